//! The generalized Jacobian of the joint path (module docs of `joint`): one sweep's
//! partials assembled with the active set, factorised and inverted, the
//! semi-smooth Newton step, and Broyden's update of the inverse after every accepted
//! step.

use super::super::TendonWorkspace;

impl TendonWorkspace {
    /// Exact generalized Jacobian at the current point, factorised.
    pub(super) fn joint_factor(&mut self) -> bool {
        let jb = &mut self.joint;
        if !self.ws.joint_jacobians(&jb.x, &mut jb.jac_s, &mut jb.jac_m) {
            jb.lu_valid = false;
            return false;
        }
        jb.lu_taut.copy_from_slice(&self.taut);
        self.joint_assemble()
    }

    /// Assemble and factorise the generalized Jacobian from the last sweep's
    /// `jac_s`, `jac_m` with the active set `joint.lu_taut`.
    pub(super) fn joint_assemble(&mut self) -> bool {
        let n = self.ws.unknowns();
        let p = self.driven.len();
        let w = n + self.theta.len();
        let jb = &mut self.joint;
        let m = n + p;
        let a = jb.lu.matrix_mut();
        for r in 0..n {
            a[r * m..r * m + n].copy_from_slice(&jb.jac_s[r * w..r * w + n]);
            a[r * m + n..(r + 1) * m].copy_from_slice(&jb.jac_s[r * w + n..r * w + n + p]);
        }
        for i in 0..p {
            let row = &mut a[(n + i) * m..(n + i + 1) * m];
            let mech = &self.mech[i];
            let c = mech.compliance(self.free[i], self.mean_factor[i]);
            if jb.lu_taut[i] {
                let j = self.driven[i];
                for (col, v) in row[..n].iter_mut().enumerate() {
                    *v = -jb.jac_m[j * w + col];
                }
                for k in 0..p {
                    row[n + k] = -jb.jac_m[j * w + n + k] + if k == i { c } else { 0.0 };
                }
            } else {
                row.fill(0.0);
                row[n + i] = c + self.geo[i];
            }
        }
        jb.lu_valid = matches!(jb.lu.factor(), Some(rc) if rc > 1e-14);
        if jb.lu_valid {
            // explicit inverse (m solves; m = n + p is ~15, far below a pass's cost)
            jb.h.fill(0.0);
            for k in 0..m {
                jb.hy.fill(0.0);
                jb.hy[k] = 1.0;
                jb.lu.solve_in_place(&mut jb.hy);
                for r in 0..m {
                    jb.h[r * m + k] = jb.hy[r];
                }
            }
        }
        jb.lu_valid
    }

    /// `dz = -J^-1 [r; G]` with the factorised Jacobian; a slack row's step is
    /// exactly `-T_i` (see the nested method's `exact_slack_steps`).
    pub(super) fn joint_step(&mut self, n: usize, p: usize) {
        let jb = &mut self.joint;
        let m = n + p;
        jb.f_prev.copy_from_slice(&jb.f_now);
        for (d, row) in jb.dz.iter_mut().zip(jb.h.chunks_exact(m)) {
            *d = -row.iter().zip(&jb.f_now).map(|(a, b)| a * b).sum::<f64>();
        }
        for i in 0..p {
            if !jb.lu_taut[i] {
                jb.dz[n + i] = -self.t[i];
            }
        }
    }

    /// Broyden's ("good") update of the inverse Jacobian from the accepted step
    /// `s = z_new - z_old` and the residual change `y = F_new - F_old`:
    /// `H <- H + (s - H y) s^T H / (s^T H y)` (Dennis & Schnabel, *Numerical Methods
    /// for Unconstrained Optimization*, eq. 8.3.1 in inverse form). Skipped when the
    /// denominator is tiny (the update would be ill-defined).
    pub(super) fn joint_broyden(&mut self, n: usize, p: usize) {
        let jb = &mut self.joint;
        let m = n + p;
        for i in 0..n {
            jb.step[i] = jb.x[i] - jb.xs[i];
        }
        for i in 0..p {
            jb.step[n + i] = self.t[i] - jb.ts[i];
        }
        // hy = H y
        for r in 0..m {
            let row = &jb.h[r * m..(r + 1) * m];
            jb.hy[r] = (0..m).map(|c| row[c] * (jb.f_now[c] - jb.f_prev[c])).sum();
        }
        let den: f64 = jb.step.iter().zip(&jb.hy).map(|(a, b)| a * b).sum();
        let ss: f64 = jb.step.iter().map(|a| a * a).sum();
        if den.abs() <= 1e-12 * ss.max(f64::MIN_POSITIVE) || !den.is_finite() {
            return;
        }
        for (c, wc) in jb.sth.iter_mut().enumerate() {
            *wc = (0..m).map(|r| jb.step[r] * jb.h[r * m + c]).sum();
        }
        for (r, row) in jb.h.chunks_exact_mut(m).enumerate() {
            let u = (jb.step[r] - jb.hy[r]) / den;
            for (hc, wc) in row.iter_mut().zip(&jb.sth) {
                *hc += u * wc;
            }
        }
    }
}
