//! The joint path's semi-smooth Newton iteration (module docs of `joint`): fresh
//! and chord steps on `[x; T]`, the line search on the merit, and the chord retry
//! with a Broyden-updated inverse. Not `math::newton::chord_newton`: a failed chord
//! step gives way to a fresh Jacobian within the same iteration (there, at the next
//! one), is first retried with the Broyden-updated inverse, a fresh step's line
//! search may switch the active set and restart at the full step, and the limit is
//! on iterations, not fresh Jacobians; it shares the Armijo constant.

use super::super::TendonWorkspace;
use super::JointBufs;
use super::{ChordPolicy, CHORD_PROBE, JOINT_MAX_ITERATIONS};
use crate::math::newton::ARMIJO_SLOPE;
use crate::settings::SolverSettings;
use crate::statics::{SolveStatus, LOCAL_TOL};

impl TendonWorkspace {
    /// Newton iterations of the joint path from `(joint.x, t)` until the merit is at
    /// most `merit_tol` (1: converged). `Err` with the largest component of the first
    /// fresh Newton step in the scaled shooting unknowns (infinite when unknown)
    /// when it stopped without converging; the iterate is then unspecified.
    pub(super) fn joint_newton(
        &mut self,
        merit_tol: f64,
        evaluated: Option<f64>,
    ) -> Result<(), f64> {
        let n = self.ws.unknowns();
        let p = self.tendons.driven.len();
        let mut first_step = f64::INFINITY;
        let Some(mut merit) = evaluated.or_else(|| self.joint_evaluate()) else {
            return Err(first_step);
        };
        self.joint.rj.check(&self.ws, &self.iter);
        let policy = ChordPolicy::of(self.ws.settings().cable_coupling, self.joint.cold);
        for it in 0..JOINT_MAX_ITERATIONS {
            self.status.report.iterations = it;
            if merit <= merit_tol {
                if merit_tol <= 1.0 && self.joint.inner_tol > LOCAL_TOL {
                    // the point was evaluated with loosely settled next holes: confirm
                    // it with fully settled ones (what every reported point has)
                    self.joint_inner_tolerance(0.0);
                    match self.joint_evaluate() {
                        Some(m) => merit = m,
                        None => return Err(first_step),
                    }
                    if merit > merit_tol {
                        continue;
                    }
                }
                if merit_tol <= 1.0 && self.iter.zero_slack_tensions() {
                    // a slack tendon carries exactly nothing (see the nested loop)
                    match self.joint_evaluate() {
                        Some(m) if m <= 1.0 => {}
                        _ => return Err(first_step),
                    }
                }
                self.status.set(SolveStatus::Converged);
                return Ok(());
            }
            // a quasi-Newton step with the last Jacobian's inverse, Broyden-updated
            // since, when the active set is the same (a "chord" step below); a fresh
            // Jacobian when there is none or the chord step does not
            // contract the merit enough (`ChordPolicy`)
            // (at a row's start under the arc rules, an inverse made for another active
            // set is carried over to the iterate's: `carry`)
            let carry = policy.carry && it == 0;
            let mut chord = self.joint.lu_valid
                && (self.joint.lu_taut == self.iter.taut
                    || (carry && self.joint.carry_to_iterate(&self.tendons, &self.iter)));
            // (a row started from an extrapolated point always tries the chord: on
            // the 443 FTDCR v4 val rows 2 026 -> 2 403 `f64` and 139.2 -> 117.6 dual
            // right-hand sides a row, 12.86 -> 12.76 M instructions; on 5 000 ticks
            // of the 1 kHz control loop dual 4.1 -> 0.5 a tick)
            if it == 0
                && chord
                && policy.skip_after_failure
                && !self.joint.first_chord_ok
                && !self.joint.predicted
            {
                self.joint.rows_fresh += 1;
                chord = self.joint.rows_fresh % CHORD_PROBE == 0;
            }
            let l2_before = self.joint.l2;
            self.joint.xs.copy_from_slice(&self.joint.x);
            self.joint.ts.copy_from_slice(&self.iter.t);
            self.joint.keep(&self.iter);
            let mut accepted = None;
            for fresh in [false, true] {
                if !fresh && !chord {
                    continue;
                }
                if it == 0 && chord {
                    self.joint.first_chord_ok = !fresh;
                }
                if fresh && chord {
                    // back from the failed chord trial to the iterate (its kept
                    // evaluation, `keep`)
                    self.joint.x.copy_from_slice(&self.joint.xs);
                    self.iter.t.copy_from_slice(&self.joint.ts);
                    if !self.joint.restore(&mut self.ws, &mut self.iter)
                        && self.joint_evaluate().is_none()
                    {
                        return Err(first_step);
                    }
                }
                if fresh
                    && !self
                        .joint
                        .fresh_jacobian(&mut self.ws, &self.tendons, &self.iter)
                {
                    return Err(first_step);
                }
                self.joint.newton_step(n, &self.iter.t);
                if fresh {
                    // the step's active set from its own linearisation (`active_set`)
                    self.joint.save_branches(&self.tendons, &self.iter);
                    self.joint.linear_active_set(&self.tendons, &self.iter);
                }
                let dx_max = self.joint.step_max(n);
                if fresh && first_step.is_infinite() {
                    first_step = dx_max;
                }
                if !dx_max.is_finite() || dx_max > self.joint.max_step {
                    if fresh {
                        return Err(first_step);
                    }
                    continue;
                }
                // inexact inner solves while far away (as the shooting Newton does):
                // the trial's next holes settle to 1e-7 of the iterate's residual
                let settle = self
                    .joint
                    .norms(self.ws.report().tolerance, self.ws.settings())
                    .1;
                self.joint_inner_tolerance(settle);
                // 0: the step's own active set, 1: trying the full step's, 2: tried
                let mut switched = 0u8;
                let mut alpha = 1.0;
                for _ in 0..if fresh { 8 } else { policy.trials } {
                    for i in 0..n {
                        self.joint.x[i] = self.joint.xs[i] + alpha * self.joint.dz[i];
                    }
                    for i in 0..p {
                        self.iter.t[i] = (self.joint.ts[i] + alpha * self.joint.dz[n + i]).max(0.0);
                    }
                    let mut evaluated = false;
                    if let Some(m) = self.joint_evaluate() {
                        evaluated = true;
                        let enough = if fresh || alpha < 1.0 {
                            (1.0 - ARMIJO_SLOPE * alpha) * l2_before
                        } else {
                            policy.contraction * l2_before
                        };
                        if self.joint.l2 < enough || m <= merit_tol {
                            accepted = Some(m);
                            break;
                        }
                    }
                    if !fresh && evaluated {
                        // a failed chord trial is still a secant pair: Broyden's update
                        // from it, then the new quasi-Newton step from the iterate
                        // (`JointBufs::chord_retry`); a hopeless one gives way to a fresh
                        // Jacobian at once
                        if self.joint.l2 > policy.hopeless * l2_before
                            || !self.joint.chord_retry(&self.iter.t, self.ws.settings())
                        {
                            break;
                        }
                        continue;
                    }
                    if fresh && switched == 0 && self.iter.taut != self.joint.lu_taut {
                        // the full step crossed a kink of G (a tendon went slack or
                        // taut): Newton's step from the iterate with the active set
                        // found there, before any backtracking (`JointBufs::switch_step`)
                        switched = 2;
                        if self.joint.switch_step(&self.tendons, &self.iter) {
                            switched = 1;
                            continue;
                        }
                    } else if switched == 1 {
                        // it did not help: back to the step's own set, backtracking
                        switched = 2;
                        self.joint.unswitch(&self.tendons, &self.iter);
                        alpha = 1.0;
                    }
                    alpha *= 0.5;
                }
                if accepted.is_some() {
                    if it == 0 && chord && !fresh {
                        self.joint.first_chord_ok = true;
                    }
                    break;
                }
                self.joint.lu_valid = false;
            }
            match accepted {
                Some(m) => {
                    merit = m;
                    self.joint.broyden(n, &self.iter.t, self.ws.settings());
                }
                None => return Err(first_step),
            }
        }
        Err(first_step)
    }
}

impl JointBufs {
    /// After a chord trial that failed (evaluated, not hopeless): Broyden's update
    /// from the trial's secant pair (the trial point against the iterate, whose
    /// residual is `f_prev`), then the step from the iterate with the updated
    /// inverse, to be tried whole. `false` when that step leaves the step limit.
    ///
    /// Why not halve the old step: the trial saw how the
    /// residual bends along the step, and halving throws that away. On the FTDCR v4
    /// recordings warm (`f64` / dual RHS a row, and in pass units, `f64` / 120 + 9.4
    /// x dual / 120): val rows 611 / 39.7 -> 558 / 37.5 (8.20 -> 7.59), train 549 /
    /// 29.6 -> 521 / 27.0 (6.89 -> 6.46), at the library's default tolerances 1 147 /
    /// 54.0 -> 1 096 / 50.0 (13.79 -> 13.05), the calibrated scene's val rows 10.06 ->
    /// 9.53; cold rows and 1 kHz ticks unchanged. A hopeless trial (merit up more than
    /// [`ChordPolicy::hopeless`]) still goes to a fresh Jacobian: updating from it too
    /// gave 7.33 on the val rows but 14.45 at the default tolerances.
    fn chord_retry(&mut self, t: &[f64], settings: &SolverSettings) -> bool {
        let n = self.x.len();
        self.broyden(n, t, settings);
        self.f_now.copy_from_slice(&self.f_prev);
        self.newton_step(n, t);
        let dx_max = self.step_max(n);
        dx_max.is_finite() && dx_max <= self.max_step
    }
}
