//! The nested method of a solve from readings: semi-smooth Newton on the tensions
//! alone, with a converged shooting solve at every tension iterate and a sweep for
//! `dl/dT` (the parent module's residual `G` and generalized Jacobian). The fallback of
//! the joint path (`joint` submodule), and the only method when
//! [`super::TendonSettings::joint_newton`] is off.

use super::TendonWorkspace;
use crate::math::newton::{halve, CHORD_CONTRACTION};
use crate::statics::{SolveStatus, Start};

impl TendonWorkspace {
    /// The nested method from the current tensions (`Cold`: the shooting solve from
    /// the straight rod). Ends with [`TendonWorkspace::finish`]'s report.
    pub(super) fn solve_nested(&mut self, mut start: Start) -> super::TendonReport {
        let p = self.driven.len();
        self.report.status = SolveStatus::MaxIterations;
        // the point T: shooting solve, factors, lengths, sensitivities, residual
        if !self.evaluate(start, true) {
            start = Start::Cold;
            if !self.evaluate(start, true) {
                return self.finish();
            }
        }
        let mut merit = self.merit();
        // a fresh Jacobian (sweep at the current point) for the first step, after a
        // failed step, a step that contracted |G| by less than 10x
        // (`CHORD_CONTRACTION`), or a change of the active set; otherwise a chord
        // step reuses the last factorisation. Not `math::newton::chord_newton`: a
        // chord step that decreases |G| at all is taken (there it is rejected unless
        // it contracts), chord steps are not capped, the limit is on passes (there on
        // fresh Jacobians), and the merit is max |G|, not ||G||_2
        let mut need_fresh = true;
        for it in 0..self.tendon_settings().max_iterations {
            self.report.iterations = it;
            let friction_settled = self.refresh_factors();
            if !friction_settled {
                // the factors moved (lagged friction coupling): re-solve at the same
                // tensions so that G belongs to the new factors
                if !self.evaluate(Start::Warm, false) {
                    return self.finish();
                }
                merit = self.merit();
            }
            if merit <= self.tendon_settings().tolerance_m && friction_settled {
                // a slack tendon carries exactly nothing: a damped step can leave a
                // tension below tolerance / a_i on the slack branch; drop it and check
                if !self.zero_slack_tensions() {
                    self.report.status = SolveStatus::Converged;
                    return self.finish();
                }
                if !self.evaluate(Start::Warm, false) {
                    return self.finish();
                }
                merit = self.merit();
                need_fresh = true;
                continue;
            }
            let fresh = need_fresh;
            if fresh {
                if !self.sens_fresh && !self.evaluate(Start::Warm, true) {
                    return self.finish();
                }
                if !self.newton_step() {
                    self.report.status = SolveStatus::IllConditioned;
                    return self.finish();
                }
            } else {
                self.chord_step();
            }
            let merit_before = merit;
            self.taut_before.copy_from_slice(&self.taut);
            // projected backtracking line search on max |G| (a chord step gets one
            // trial: if it needs damping, the step is redone with a fresh Jacobian)
            self.t_trial.copy_from_slice(&self.t);
            let accepted = halve(if fresh { 12 } else { 1 }, |alpha| {
                for i in 0..p {
                    self.t[i] = (self.t_trial[i] + alpha * self.step[i]).max(0.0);
                }
                if !self.evaluate(Start::Warm, false) {
                    return false;
                }
                let m = self.merit();
                let decrease = m < merit || m <= self.tendon_settings().tolerance_m;
                if decrease {
                    merit = m;
                }
                decrease
            })
            .is_some();
            need_fresh = !accepted
                || merit > CHORD_CONTRACTION * merit_before
                || self.taut != self.taut_before;
            if !accepted {
                // back to the last point; a failed chord step retries with a fresh
                // Jacobian there, a failed Newton step has nowhere to go
                self.t.copy_from_slice(&self.t_trial);
                if !self.evaluate(Start::Warm, !fresh) {
                    return self.finish();
                }
                merit = self.merit();
                if fresh {
                    self.report.status = SolveStatus::Stalled;
                    return self.finish();
                }
            }
        }
        self.report.iterations = self.tendon_settings().max_iterations;
        if self.merit() <= self.tendon_settings().tolerance_m && self.refresh_factors() {
            self.report.status = SolveStatus::Converged;
        }
        self.finish()
    }

    /// Shooting solve at the current tensions, then lengths, sensitivities and `G`.
    /// `false` when the shooting solve or the sweep failed.
    fn evaluate(&mut self, start: Start, sweep: bool) -> bool {
        let p = self.driven.len();
        if self.report.shooting_solves >= self.tendon_settings().max_shooting_solves {
            self.report.status = SolveStatus::MaxIterations;
            return false;
        }
        if !self.within_budget() {
            return false;
        }
        self.theta[..p].copy_from_slice(&self.t);
        // first-order predictor of the shooting unknowns from the last sweep
        self.ws.set_theta_predicted(&self.theta);
        self.report.forward_solves += 1;
        self.report.shooting_solves += 1;
        let rep = self.ws.solve(start);
        if !rep.status.is_converged() {
            self.report.status = rep.status;
            return false;
        }
        if sweep {
            if !self
                .ws
                .length_sensitivities(&mut self.sens, &mut self.lengths)
            {
                self.report.status = SolveStatus::IllConditioned;
                return false;
            }
            self.sens_fresh = true;
        } else {
            self.ws.cable_lengths_into(&mut self.lengths);
            self.sens_fresh = false;
        }
        self.update_g();
        true
    }

    /// A slack row of the generalized Jacobian is `a_i e_i` and its residual
    /// `a_i T_i`: its step is exactly `-T_i` (the LU solve leaves round-off, e.g. a
    /// tension of 1e-24 N on a tendon reported slack).
    fn exact_slack_steps(&mut self) {
        for ((s, t), taut) in self.step.iter_mut().zip(&self.t).zip(&self.taut) {
            if !taut {
                *s = -t;
            }
        }
    }

    /// Step with the factorised Jacobian of an earlier point (chord Newton; the
    /// active set is the one it was factorised with, else a fresh step is taken).
    fn chord_step(&mut self) {
        for (s, g) in self.step.iter_mut().zip(&self.g) {
            *s = -g;
        }
        self.lu.solve_in_place(&mut self.step);
        self.exact_slack_steps();
    }

    /// Semi-smooth Newton step `J step = -G` with the generalized Jacobian.
    fn newton_step(&mut self) -> bool {
        if !self.factor_tension_jacobian() {
            return false;
        }
        for (s, g) in self.step.iter_mut().zip(&self.g) {
            *s = -g;
        }
        self.lu.solve_in_place(&mut self.step);
        self.exact_slack_steps();
        self.step.iter().all(|s| s.is_finite())
    }

    /// Assemble and factorise the generalized Jacobian of `G` in the tensions from
    /// `sens` (`dl/dtheta` at the current point) and the taut flags: row `i` is
    /// `c_i e_i - dl_i/dT` when taut, `(c_i + a_i) e_i` when slack (module docs of
    /// the parent). `false` when it is singular. Also the load-estimation
    /// sensitivities' matrix (`loads` submodule).
    pub(super) fn factor_tension_jacobian(&mut self) -> bool {
        let p = self.driven.len();
        let np = self.theta.len();
        let a = self.lu.matrix_mut();
        for i in 0..p {
            let j = self.driven[i];
            let (mech, f, mf) = (&self.mech[i], self.free[i], self.mean_factor[i]);
            let c = if self.taut[i] {
                mech.tangent_compliance(f, self.t[i], mf)
            } else {
                mech.compliance(f, mf)
            };
            for k in 0..p {
                a[i * p + k] = if self.taut[i] {
                    -self.sens[j * np + k] + if i == k { c } else { 0.0 }
                } else if i == k {
                    c + self.geo[i]
                } else {
                    0.0
                };
            }
        }
        self.lu.factor().is_some()
    }
}
