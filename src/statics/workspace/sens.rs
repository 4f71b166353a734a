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
        let n = self.plan.n_unknowns;
        let p = self.plan.params.len();
        let c = self.plan.cables.len();
        let w = n + p;
        self.jac_evals += 1;
        let ok = if self.plan.condensed {
            self.condensed_sweeps(w, true, 1.0)
        } else if w <= 3 {
            sweep::<3>(
                &self.plan,
                &self.x,
                0,
                true,
                &mut self.b3,
                &mut self.sens_s,
                &mut self.sens_m,
                1.0,
            )
        } else if let Some(b) = self.b_arc.as_mut().filter(|_| w > 6 && w <= ARC_SWEEP) {
            let ok = sweep(
                &self.plan,
                &self.x,
                0,
                true,
                b,
                &mut self.sens_s,
                &mut self.sens_m,
                1.0,
            );
            for k in 0..p {
                b.theta[k] = Dual::constant(self.b64.theta[k]);
            }
            ok
        } else {
            (0..w).step_by(6).all(|c0| {
                sweep::<6>(
                    &self.plan,
                    &self.x,
                    c0,
                    true,
                    &mut self.b6,
                    &mut self.sens_s,
                    &mut self.sens_m,
                    1.0,
                )
            })
        };
        // theta back to constants
        for k in 0..p {
            let v = self.b64.theta[k];
            self.b3.theta[k] = Dual::constant(v);
            self.b6.theta[k] = Dual::constant(v);
        }
        if !ok {
            return false;
        }
        let a = self.lu.matrix_mut();
        for r in 0..n {
            a[r * n..(r + 1) * n].copy_from_slice(&self.sens_s[r * w..r * w + n]);
        }
        match self.lu.factor() {
            Some(rc) if rc > MIN_RCOND => self.lu_valid = true,
            _ => {
                self.lu_valid = false;
                return false;
            }
        }
        for j in 0..c {
            let len = cable_length(&self.plan, &self.b64, j);
            if let Some(l) = lengths.get_mut(j) {
                *l = len;
            }
        }
        for k in 0..p {
            for r in 0..n {
                self.sens_col[r] = self.sens_s[r * w + n + k];
            }
            self.lu.solve_in_place(&mut self.sens_col);
            for r in 0..n {
                self.dxdtheta[r * p + k] = -self.sens_col[r];
            }
            for j in 0..c {
                let mut g = self.sens_m[j * w + n + k];
                for r in 0..n {
                    g -= self.sens_m[j * w + r] * self.sens_col[r];
                }
                out[j * p + k] = g;
            }
        }
        self.dxdtheta_valid = true;
        true
    }
}
