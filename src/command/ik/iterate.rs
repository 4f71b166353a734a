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
                match self.compute_jacobian() {
                    Some(k) => n.solves += k,
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
                        // at a stationary point: the closest tip
                        outcome = Some(Some(self.final_status(reached, false)));
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
                    let v = if !self.slack[i] {
                        self.q[i] + self.u[i] / MM
                    } else if self.u[i] > 1e-9 {
                        self.q_lin[i] + self.u[i] / MM
                    } else if st.objective == IkObjective::LeastPull && lo.is_finite() {
                        // stays slack: least pull pays it out to its limit
                        lo
                    } else {
                        self.q[i]
                    };
                    self.q_trial[i] = v.clamp(lo, hi);
                }
                n.solves += 1;
                let converged = self
                    .tw
                    .solve_readings(&self.q_trial)
                    .is_ok_and(|r| r.status.is_converged());
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
    pub(super) fn conclude(&mut self, reached: bool) -> Option<IkStatus> {
        if self.jac_exact {
            Some(self.final_status(reached, false))
        } else {
            self.jac_valid = false;
            None
        }
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
