//! The trust-region Gauss-Newton iteration and its conclusions.

use super::qp::QpSolver;
use super::{Counts, IkObjective, IkStatus, IkTarget, IkWorkspace, FIRST_ORDER_TOL, MM};

impl IkWorkspace {
    /// The trust-region iteration towards `target` from the accepted readings,
    /// counting into `n` against the call's budget (module docs); the status.
    pub(super) fn iterate(&mut self, target: &IkTarget, n: &mut Counts) -> IkStatus {
        let st = self.settings.clone();
        let mut delta = st.trust_radius_m;
        let mut stalls = 0usize;
        let mut phi = self.merit(target, &self.tip, &self.axis, &self.q, &self.t);
        self.first_order = f64::NAN;
        self.flip_tried = false;
        self.engage_override = None;
        self.reset_radius = false;
        loop {
            let reached = self.is_reached(target);
            if reached && st.objective == IkObjective::Closest {
                return IkStatus::Reached;
            }
            if n.iterations >= st.max_iterations || n.solves >= st.max_forward_solves {
                return self.final_status(reached, true);
            }
            n.iterations += 1;
            if !self.jac_valid {
                self.first_order = f64::NAN;
                if std::mem::take(&mut self.reset_radius) {
                    delta = st.trust_radius_m;
                    stalls = 0;
                }
                self.engage_tol_m = self
                    .engage_override
                    .take()
                    .unwrap_or(super::ENGAGE_FRACTION * delta);
                match self.compute_jacobian() {
                    Some(k) => {
                        n.solves += k;
                        n.passes += self.fd_passes.0;
                        n.peak_passes = n.peak_passes.max(self.fd_passes.1);
                    }
                    None => return self.final_status(reached, false),
                }
                n.jacobians += 1;
                self.jac_valid = true;
                self.jac_exact = true;
            }
            // trust-region trials at this Jacobian
            let mut outcome = None;
            let mut first = true;
            while outcome.is_none() {
                self.build_qp(target, delta);
                if std::mem::take(&mut first) && stalls >= 2 {
                    // slow progress: judged on the exact Jacobian
                    if !self.jac_exact {
                        self.jac_valid = false;
                        outcome = Some(None);
                        break;
                    }
                    if reached || self.first_order <= FIRST_ORDER_TOL {
                        // reached (a secondary objective no longer improving), or
                        // at a stationary point: the closest tip (after the other
                        // side of a tendon at its boundary)
                        outcome = Some(self.conclude(reached));
                        break;
                    }
                }
                let solver = self.qp.solve(&self.h, &self.g, &mut self.u);
                n.qp_solves += 1;
                if solver == Some(QpSolver::Clarabel) {
                    n.qp_fallbacks += 1;
                }
                if solver.is_none() {
                    outcome = Some(self.conclude(reached));
                    break;
                }
                let step_m = self.u.iter().fold(0.0f64, |m, v| m.max(v.abs())) / MM;
                let pred = -self.model();
                if step_m < st.step_tolerance_m || pred <= 1e-15 * phi.max(1e-300) {
                    outcome = Some(self.conclude(reached));
                    break;
                }
                if n.solves >= st.max_forward_solves {
                    outcome = Some(Some(self.final_status(reached, true)));
                    break;
                }
                for i in 0..self.p {
                    let (lo, hi) = (self.limits.min_m[i], self.limits.max_m[i]);
                    let v = if self.slack[i]
                        && st.objective == IkObjective::LeastPull
                        && lo.is_finite()
                    {
                        // stays slack: least pull pays it out to its limit
                        lo
                    } else {
                        self.q_lin[i] + self.u[i] / MM
                    };
                    self.q_trial[i] = v.clamp(lo, hi);
                }
                let rr = self.tw.solve_readings(&self.q_trial);
                n.solve(rr.as_ref().map_or(0, |r| r.forward_solves));
                let converged = rr.is_ok_and(|r| r.status.is_converged());
                let (rho, phi_new) = if converged {
                    let tip = self.tw.tip_position();
                    let axis = self.tw.workspace().tip_axis();
                    let phi_new =
                        self.merit(target, &tip, &axis, &self.q_trial, self.tw.tensions());
                    ((phi - phi_new) / pred, phi_new)
                } else {
                    (f64::NEG_INFINITY, phi)
                };
                if rho > 1e-4 && phi_new < phi {
                    let on_boundary = step_m > 0.99 * delta;
                    if rho > 0.75 && on_boundary {
                        delta *= 2.0;
                    } else if rho < 0.25 {
                        delta = 0.25 * step_m;
                    }
                    let updated = self.broyden_update();
                    std::mem::swap(&mut self.q, &mut self.q_trial);
                    self.accept_state();
                    // the update is trusted while the model predicts well
                    self.jac_valid = updated && rho > 0.75;
                    self.jac_exact = false;
                    if updated {
                        // all taut: the linearisation point is the readings
                        self.q_lin.copy_from_slice(&self.q);
                    }
                    let gain = phi - phi_new;
                    phi = phi_new;
                    if gain < 1e-4 * (phi + gain) {
                        stalls += 1;
                    } else {
                        stalls = 0;
                    }
                    outcome = Some(None);
                } else if !self.jac_exact {
                    // the updated Jacobian's step failed: the exact one, same radius
                    self.restore_state();
                    self.jac_valid = false;
                    outcome = Some(None);
                } else {
                    self.restore_state();
                    delta = 0.25 * step_m;
                    if delta < st.step_tolerance_m {
                        outcome = Some(self.conclude(reached));
                    }
                }
            }
            if let Some(Some(s)) = outcome {
                return s;
            }
        }
    }

    /// The iteration stops here: the final status at an exact Jacobian (`Some`);
    /// at an updated one, `None` and the next iteration evaluates the exact one
    /// (conclusions, `Unreachable` above all, rest on the exact Jacobian).
    /// Not reached with a tendon at its taut/slack boundary: the other side's
    /// linearisation is tried first (once per attempt), from the trust radius of
    /// the settings.
    pub(super) fn conclude(&mut self, reached: bool) -> Option<IkStatus> {
        if !self.jac_exact {
            self.jac_valid = false;
            return None;
        }
        if !reached && self.try_other_side() {
            return None;
        }
        Some(self.final_status(reached, false))
    }

    /// Schedule the other side's linearisation for a tendon at its taut/slack
    /// boundary (module docs, "Taut/slack boundary"): engaged tendons taken as
    /// slack (engagement tolerance 0), or, with none engaged, slack tendons within
    /// the settings' trust radius of their engagement point taken as engaged;
    /// `false` when there is none or it was tried in this attempt.
    fn try_other_side(&mut self) -> bool {
        if self.flip_tried {
            return false;
        }
        let engaged = self.engaged.iter().any(|e| *e);
        let wide = self.settings.trust_radius_m;
        let near = (0..self.p).any(|i| self.slack[i] && self.gap[i] <= wide);
        if !engaged && !near {
            return false;
        }
        self.flip_tried = true;
        self.engage_override = Some(if engaged { 0.0 } else { wide });
        self.reset_radius = true;
        self.jac_valid = false;
        true
    }

    pub(super) fn is_reached(&self, target: &IkTarget) -> bool {
        let d = (target.position_m - self.tip).norm();
        let angle_ok = target.direction.is_none_or(|t| {
            t.normalize().dot(&self.axis).clamp(-1.0, 1.0).acos()
                <= self.settings.angle_tolerance_rad
        });
        d <= self.settings.tolerance_m && angle_ok
    }

    /// The status when the iteration ends: reached; else unreachable at a
    /// constrained stationary point (first-order measure of the last linearisation
    /// below [`FIRST_ORDER_TOL`]); else out of budget.
    pub(super) fn final_status(&self, reached: bool, budget: bool) -> IkStatus {
        if reached {
            IkStatus::Reached
        } else if budget || self.first_order.is_nan() || self.first_order > FIRST_ORDER_TOL {
            IkStatus::BudgetExhausted
        } else {
            IkStatus::Unreachable {
                closest_tip_m: self.tip,
                distance_m: f64::NAN,
            }
        }
    }
}
