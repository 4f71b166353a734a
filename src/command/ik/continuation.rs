//! One call: the first attempt, then the continuation through intermediate
//! targets when it did not reach (module docs of [`super`]).

use super::{Counts, IkReport, IkStatus, IkTarget, IkWorkspace, CONTINUATION_STEPS};
use crate::error::ModelError;
use crate::math::warm::WarmCopy;

impl IkWorkspace {
    /// Solve for readings that reach `target`, warm from the last readings
    /// (module docs). Errors: an invalid target; otherwise the outcome is the
    /// report's status and the readings are within the limits.
    pub fn solve(&mut self, target: &IkTarget) -> Result<IkReport, ModelError> {
        target.validate()?;
        if !self.has_state {
            let zero = vec![0.0; self.p];
            self.set_readings(&zero)?;
        }
        self.q0.copy_from_slice(&self.q);
        WarmCopy::warm_copy_from(&mut *self.start_ws, &self.tw);
        let mut n = Counts::default();
        let mut status = self.iterate(target, &mut n);
        let st = &self.settings;
        let left = n.iterations < st.max_iterations && n.solves < st.max_forward_solves;
        if !matches!(status, IkStatus::Reached) && left {
            // continuation: from the call's start through intermediate targets on
            // the segment from the start tip to the target, each solved warm from
            // the last; kept when it ends closer (module docs)
            let (first_status, first_fo) = (status, self.first_order);
            let phi_first = self.merit(target, &self.tip, &self.axis, &self.q, &self.t);
            WarmCopy::warm_copy_from(&mut *self.end_ws, &self.tw);
            self.q_end.copy_from_slice(&self.q);
            self.tw.warm_copy_from(&self.start_ws);
            self.q.copy_from_slice(&self.q0);
            self.accept_state();
            self.jac_valid = false;
            let tip0 = self.tip;
            for k in 1..=CONTINUATION_STEPS {
                let f = k as f64 / CONTINUATION_STEPS as f64;
                let sub = IkTarget {
                    position_m: tip0 + (target.position_m - tip0) * f,
                    direction: target.direction,
                };
                status = self.iterate(&sub, &mut n);
                if matches!(status, IkStatus::BudgetExhausted)
                    && (n.iterations >= self.settings.max_iterations
                        || n.solves >= self.settings.max_forward_solves)
                {
                    break;
                }
            }
            // the continuation's end is kept when it reached, or when it is closer
            // by more than 1e-4 of phi (the stall threshold): an end as far as the
            // first attempt's does not replace that attempt's conclusion
            let phi_cont = self.merit(target, &self.tip, &self.axis, &self.q, &self.t);
            if !self.is_reached(target) && phi_cont >= (1.0 - 1e-4) * phi_first {
                self.tw.warm_copy_from(&self.end_ws);
                self.q.copy_from_slice(&self.q_end);
                self.accept_state();
                self.jac_valid = false;
                status = first_status;
                self.first_order = first_fo;
            } else if !matches!(status, IkStatus::Reached) && self.is_reached(target) {
                status = IkStatus::Reached;
            }
        }
        let st = self.settings.clone();
        let (iterations, solves, qp_solves) = (n.iterations, n.solves, n.qp_solves);
        let distance = (target.position_m - self.tip).norm();
        let status = match status {
            IkStatus::Unreachable { .. } => IkStatus::Unreachable {
                closest_tip_m: self.tip,
                distance_m: distance,
            },
            s => s,
        };
        Ok(IkReport {
            status,
            tip_m: self.tip,
            distance_m: distance,
            angle_rad: target.direction.map_or(0.0, |d| {
                d.normalize().dot(&self.axis).clamp(-1.0, 1.0).acos()
            }),
            iterations,
            jacobians: n.jacobians,
            forward_solves: solves,
            passes: n.passes,
            peak_passes: n.peak_passes,
            qp_solves,
            qp_fallbacks: n.qp_fallbacks,
            objective: st.objective,
            slack: self.best.taut().iter().filter(|t| !**t).count(),
            first_order: self.first_order,
        })
    }
}
