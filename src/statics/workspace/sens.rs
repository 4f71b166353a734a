//! Implicit-differentiation sensitivities of the cable lengths to the load
//! parameters `theta` at a converged point.

use super::super::pass::cable_length;
use super::*;
use crate::math::newton::MIN_RCOND;

impl Workspace {
    /// Exact sensitivities of the cable lengths to `theta` at the current (converged)
    /// point, by implicit differentiation of the shooting problem:
    /// `dl/dtheta = dl/dtheta|x - dl/dx J_x^-1 dr/dtheta` (all partials from one
    /// dual-number sweep over `[x; theta]`). Writes `c x p` row-major into `out`,
    /// the lengths into `lengths`. No allocation. `false` if the sweep failed or
    /// `J_x` is singular.
    pub fn length_sensitivities(&mut self, out: &mut [f64], lengths: &mut [f64]) -> bool {
        let n = self.prob.plan.n_unknowns;
        let p = self.prob.plan.params.len();
        let c = self.prob.plan.cables.len();
        let w = n + p;
        self.jac.evals += 1;
        let ok = if self.prob.plan.condensed {
            self.condensed_sweeps(w, true, 1.0)
        } else if w <= 3 {
            sweep::<3>(
                &self.prob.plan,
                &self.it.x,
                0,
                true,
                &mut self.bufs.b3,
                &mut self.sens.dres,
                &mut self.sens.dlen,
                1.0,
            )
        } else if let Some(b) = self.bufs.b_arc.as_mut().filter(|_| w > 6 && w <= ARC_SWEEP) {
            let ok = sweep(
                &self.prob.plan,
                &self.it.x,
                0,
                true,
                b,
                &mut self.sens.dres,
                &mut self.sens.dlen,
                1.0,
            );
            for k in 0..p {
                b.theta[k] = Dual::constant(self.bufs.b64.theta[k]);
            }
            ok
        } else {
            (0..w).step_by(6).all(|c0| {
                sweep::<6>(
                    &self.prob.plan,
                    &self.it.x,
                    c0,
                    true,
                    &mut self.bufs.b6,
                    &mut self.sens.dres,
                    &mut self.sens.dlen,
                    1.0,
                )
            })
        };
        self.bufs.unseed_theta(p);
        if !ok {
            return false;
        }
        let a = self.jac.lu.matrix_mut();
        for r in 0..n {
            a[r * n..(r + 1) * n].copy_from_slice(&self.sens.dres[r * w..r * w + n]);
        }
        match self.jac.lu.factor() {
            Some(rc) if rc > MIN_RCOND => self.jac.lu_valid = true,
            _ => {
                self.jac.lu_valid = false;
                return false;
            }
        }
        for j in 0..c {
            let len = cable_length(&self.prob.plan, &self.bufs.b64, j);
            if let Some(l) = lengths.get_mut(j) {
                *l = len;
            }
        }
        self.sens.eliminate(&self.jac.lu, n, p, c, out);
        true
    }
}
