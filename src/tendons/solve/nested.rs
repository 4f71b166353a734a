//! The nested method of a solve from readings: semi-smooth Newton on the tensions
//! alone, with a converged shooting solve at every tension iterate and a sweep for
//! `dl/dT` (the parent module's residual `G` and generalized Jacobian). The fallback of
//! the joint path (`joint` submodule), and the only method when
//! [`super::TendonSettings::joint_newton`] is off.

use super::{Iterate, TendonWorkspace, Tendons};
use crate::math::newton::{halve, CHORD_CONTRACTION};
use crate::math::DenseLu;
use crate::statics::{SolveStatus, Start};

/// The nested method's Newton on the tensions: the sensitivities, the factorised
/// generalized Jacobian, the step and the line search's start.
#[derive(Clone)]
pub(super) struct NestedBufs {
    /// `dl/dtheta` (`c x (p + extra)`).
    pub(super) sens: Vec<f64>,
    /// `sens` is from the current point (else from an earlier one: chord steps).
    pub(super) sens_fresh: bool,
    pub(super) lu: DenseLu,
    /// Newton step, and the tensions and taut flags before it (an active-set change
    /// needs a fresh Jacobian).
    pub(super) step: Vec<f64>,
    t_trial: Vec<f64>,
    taut_before: Vec<bool>,
}

impl TendonWorkspace {
    /// The nested method from the current tensions (`Cold`: the shooting solve from
    /// the straight rod). Ends with [`TendonWorkspace::finish`]'s report.
    pub(super) fn solve_nested(&mut self, mut start: Start) -> super::TendonReport {
        let p = self.tendons.driven.len();
        self.status.set(SolveStatus::MaxIterations);
        // the point T: shooting solve, factors, lengths, sensitivities, residual
        if !self.evaluate(start, true) {
            start = Start::Cold;
            if !self.evaluate(start, true) {
                return self.finish();
            }
        }
        let mut merit = self.iter.merit();
        // a fresh Jacobian (sweep at the current point) for the first step, after a
        // failed step, a step that contracted |G| by less than 10x
        // (`CHORD_CONTRACTION`), or a change of the active set; otherwise a chord
        // step reuses the last factorisation. Not `math::newton::chord_newton`: a
        // chord step that decreases |G| at all is taken (there it is rejected unless
        // it contracts), chord steps are not capped, the limit is on passes (there on
        // fresh Jacobians), and the merit is max |G|, not ||G||_2
        let mut need_fresh = true;
        for it in 0..self.tendon_settings().max_iterations {
            self.status.report.iterations = it;
            let friction_settled = self.refresh_factors();
            if !friction_settled {
                // the factors moved (lagged friction coupling): re-solve at the same
                // tensions so that G belongs to the new factors
                if !self.evaluate(Start::Warm, false) {
                    return self.finish();
                }
                merit = self.iter.merit();
            }
            if merit <= self.tendon_settings().tolerance_m && friction_settled {
                // a slack tendon carries exactly nothing: a damped step can leave a
                // tension below tolerance / a_i on the slack branch; drop it and check
                if !self.iter.zero_slack_tensions() {
                    self.status.set(SolveStatus::Converged);
                    return self.finish();
                }
                if !self.evaluate(Start::Warm, false) {
                    return self.finish();
                }
                merit = self.iter.merit();
                need_fresh = true;
                continue;
            }
            let fresh = need_fresh;
            if fresh {
                if !self.nested.sens_fresh && !self.evaluate(Start::Warm, true) {
                    return self.finish();
                }
                if !self.nested.newton_step(&self.tendons, &self.iter) {
                    self.status.set(SolveStatus::IllConditioned);
                    return self.finish();
                }
            } else {
                self.nested.chord_step(&self.iter);
            }
            let merit_before = merit;
            let nb = &mut self.nested;
            nb.taut_before.copy_from_slice(&self.iter.taut);
            // projected backtracking line search on max |G| (a chord step gets one
            // trial: if it needs damping, the step is redone with a fresh Jacobian)
            nb.t_trial.copy_from_slice(&self.iter.t);
            let accepted = halve(if fresh { 12 } else { 1 }, |alpha| {
                for i in 0..p {
                    let nb = &self.nested;
                    self.iter.t[i] = (nb.t_trial[i] + alpha * nb.step[i]).max(0.0);
                }
                if !self.evaluate(Start::Warm, false) {
                    return false;
                }
                let m = self.iter.merit();
                let decrease = m < merit || m <= self.tendon_settings().tolerance_m;
                if decrease {
                    merit = m;
                }
                decrease
            })
            .is_some();
            need_fresh = !accepted
                || merit > CHORD_CONTRACTION * merit_before
                || self.iter.taut != self.nested.taut_before;
            if !accepted {
                // back to the last point; a failed chord step retries with a fresh
                // Jacobian there, a failed Newton step has nowhere to go
                self.iter.t.copy_from_slice(&self.nested.t_trial);
                if !self.evaluate(Start::Warm, !fresh) {
                    return self.finish();
                }
                merit = self.iter.merit();
                if fresh {
                    self.status.set(SolveStatus::Stalled);
                    return self.finish();
                }
            }
        }
        self.status.report.iterations = self.tendon_settings().max_iterations;
        if self.iter.merit() <= self.tendon_settings().tolerance_m && self.refresh_factors() {
            self.status.set(SolveStatus::Converged);
        }
        self.finish()
    }

    /// Shooting solve at the current tensions, then lengths, sensitivities and `G`.
    /// `false` when the shooting solve or the sweep failed.
    fn evaluate(&mut self, start: Start, sweep: bool) -> bool {
        let p = self.tendons.driven.len();
        let report = &mut self.status.report;
        if report.shooting_solves >= self.ws.settings().tendons.max_shooting_solves {
            report.status = SolveStatus::MaxIterations;
            return false;
        }
        if !self.within_budget() {
            return false;
        }
        let iter = &mut self.iter;
        iter.theta[..p].copy_from_slice(&iter.t);
        // first-order predictor of the shooting unknowns from the last sweep
        self.ws.set_theta_predicted(&iter.theta);
        self.status.report.forward_solves += 1;
        self.status.report.shooting_solves += 1;
        let rep = self.ws.solve(start);
        if !rep.status.is_converged() {
            self.status.set(rep.status);
            return false;
        }
        if sweep {
            let nb = &mut self.nested;
            if !self
                .ws
                .length_sensitivities(&mut nb.sens, &mut iter.lengths)
            {
                self.status.set(SolveStatus::IllConditioned);
                return false;
            }
            nb.sens_fresh = true;
        } else {
            self.ws.cable_lengths_into(&mut iter.lengths);
            self.nested.sens_fresh = false;
        }
        iter.update_g(&self.tendons);
        true
    }
}

impl NestedBufs {
    pub(super) fn new(p: usize, np: usize, cables: usize) -> Self {
        Self {
            sens: vec![0.0; cables * np],
            sens_fresh: false,
            lu: DenseLu::new(p),
            step: vec![0.0; p],
            t_trial: vec![0.0; p],
            taut_before: vec![true; p],
        }
    }

    /// A slack row of the generalized Jacobian is `a_i e_i` and its residual
    /// `a_i T_i`: its step is exactly `-T_i` (the LU solve leaves round-off, e.g. a
    /// tension of 1e-24 N on a tendon reported slack).
    fn exact_slack_steps(&mut self, iter: &Iterate) {
        for ((s, t), taut) in self.step.iter_mut().zip(&iter.t).zip(&iter.taut) {
            if !taut {
                *s = -t;
            }
        }
    }

    /// Step with the factorised Jacobian of an earlier point (chord Newton; the
    /// active set is the one it was factorised with, else a fresh step is taken).
    fn chord_step(&mut self, iter: &Iterate) {
        for (s, g) in self.step.iter_mut().zip(&iter.g) {
            *s = -g;
        }
        self.lu.solve_in_place(&mut self.step);
        self.exact_slack_steps(iter);
    }

    /// Semi-smooth Newton step `J step = -G` with the generalized Jacobian.
    fn newton_step(&mut self, tendons: &Tendons, iter: &Iterate) -> bool {
        if !self.factor_tension_jacobian(tendons, iter) {
            return false;
        }
        for (s, g) in self.step.iter_mut().zip(&iter.g) {
            *s = -g;
        }
        self.lu.solve_in_place(&mut self.step);
        self.exact_slack_steps(iter);
        self.step.iter().all(|s| s.is_finite())
    }

    /// Assemble and factorise the generalized Jacobian of `G` in the tensions from
    /// `sens` (`dl/dtheta` at the current point) and the taut flags: row `i` is
    /// `c_i e_i - dl_i/dT` when taut, `(c_i + a_i) e_i` when slack (module docs of
    /// the parent). `false` when it is singular. Also the load-estimation
    /// sensitivities' matrix (`loads` submodule).
    pub(super) fn factor_tension_jacobian(&mut self, tendons: &Tendons, iter: &Iterate) -> bool {
        let p = tendons.driven.len();
        let np = iter.theta.len();
        let a = self.lu.matrix_mut();
        for i in 0..p {
            let j = tendons.driven[i];
            let c = tendons.compliance(
                i,
                iter.taut[i],
                iter.free[i],
                iter.t[i],
                iter.mean_factor[i],
            );
            for k in 0..p {
                a[i * p + k] = if iter.taut[i] {
                    -self.sens[j * np + k] + if i == k { c } else { 0.0 }
                } else if i == k {
                    c + tendons.geo[i]
                } else {
                    0.0
                };
            }
        }
        self.lu.factor().is_some()
    }
}

impl crate::math::warm::WarmCopy for NestedBufs {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src,
            copy: [sens, sens_fresh, lu, step, t_trial, taut_before], keep: []);
    }
}
