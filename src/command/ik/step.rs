//! The model of one step: the merit `phi`, the QP of the linearised problem
//! (mm), the first-order measure, the model's value of a step.

use super::{IkObjective, IkTarget, IkWorkspace, DAMPING, LM_FACTOR, MM, ON_BOUND_M};
use nalgebra::{Matrix6, Vector3, Vector6};

impl IkWorkspace {
    /// `phi` in mm^2 at tip, axis, readings and tensions (module docs).
    pub(super) fn merit(
        &self,
        target: &IkTarget,
        tip: &Vector3<f64>,
        axis: &Vector3<f64>,
        q: &[f64],
        t: &[f64],
    ) -> f64 {
        let e = (target.position_m - tip) * MM;
        let mut phi = e.norm_squared();
        if let Some(d) = &target.direction {
            let ld = self.settings.direction_weight_m * MM;
            phi += ld * ld * (d.normalize() - axis).norm_squared();
        }
        let w = self.settings.secondary_weight;
        phi += match self.settings.objective {
            IkObjective::Closest => {
                w * q
                    .iter()
                    .zip(&self.q0)
                    .map(|(a, b)| ((a - b) * MM).powi(2))
                    .sum::<f64>()
            }
            IkObjective::LeastPull => w * q.iter().map(|v| v * MM).sum::<f64>(),
            IkObjective::LeastTension => w * t.iter().map(|v| v * v).sum::<f64>(),
        };
        phi
    }

    /// Fill the QP (mm) at the accepted point within trust radius `delta` (m).
    pub(super) fn build_qp(&mut self, target: &IkTarget, delta: f64) {
        let p = self.p;
        self.h.fill(0.0);
        self.g.fill(0.0);
        // position rows: |J u - e|^2 (J dimensionless: mm/mm)
        let e = (target.position_m - self.tip) * MM;
        let rows = |jac: &[f64], e: &Vector3<f64>, scale: f64, h: &mut [f64], g: &mut [f64]| {
            for r in 0..3 {
                for a in 0..p {
                    let ja = jac[r * p + a] * scale;
                    g[a] -= 2.0 * ja * e[r];
                    for b in 0..p {
                        h[a * p + b] += 2.0 * ja * jac[r * p + b] * scale;
                    }
                }
            }
        };
        rows(&self.jp, &e, 1.0, &mut self.h, &mut self.g);
        // squared residual (mm^2) and |J|_F^2 of the least-squares rows
        let mut r2 = e.norm_squared();
        let mut j2: f64 = self.jp.iter().map(|v| v * v).sum();
        if let Some(d) = &target.direction {
            // l_d (Ja u) in mm with l_d in m and Ja in 1/m; target l_d e_a in mm
            let ld = self.settings.direction_weight_m;
            let ea = (d.normalize() - self.axis) * (ld * MM);
            rows(&self.ja, &ea, ld, &mut self.h, &mut self.g);
            r2 += ea.norm_squared();
            j2 += ld * ld * self.ja.iter().map(|v| v * v).sum::<f64>();
        }
        // the first-order measure from the least-squares gradient (before the
        // secondary's, which only picks among solutions)
        self.first_order = self.projected_gradient_norm() / (2.0 * (r2 * j2).sqrt()).max(1e-300);
        let w = self.settings.secondary_weight;
        // Levenberg-Marquardt damping mu = c |r|^2 (Yamashita & Fukushima 2001),
        // at most c |J|_F^2: a large residual (a target far outside) does not
        // freeze the step
        let mu = DAMPING + LM_FACTOR * r2.min(j2);
        for a in 0..p {
            self.h[a * p + a] += 2.0 * mu;
        }
        match self.settings.objective {
            IkObjective::Closest => {
                for a in 0..p {
                    self.h[a * p + a] += 2.0 * w;
                    self.g[a] += 2.0 * w * (self.q_lin[a] - self.q0[a]) * MM;
                }
            }
            IkObjective::LeastPull => {
                for a in 0..p {
                    self.g[a] += w;
                }
            }
            IkObjective::LeastTension => {
                // w sum_k (T_k + (dT_k/dq / MM) u)^2
                for k in 0..p {
                    for a in 0..p {
                        let ka = self.jt[k * p + a] / MM;
                        self.g[a] += 2.0 * w * ka * self.t[k];
                        for b in 0..p {
                            self.h[a * p + b] += 2.0 * w * ka * self.jt[k * p + b] / MM;
                        }
                    }
                }
            }
        }
        let wr = self.settings.rest_weight;
        if wr > 0.0 && self.null_space(target) {
            // the rest term wr |N (q_lin + u)|^2 (mm), N the projector on the
            // null space of the least-squares rows (module docs, "Rest term")
            for a in 0..p {
                let mut nq = 0.0;
                for b in 0..p {
                    let nab = self.null[a * p + b];
                    self.h[a * p + b] += 2.0 * wr * nab;
                    nq += nab * self.q_lin[b] * MM;
                }
                self.null_q[a] = nq;
                self.g[a] += 2.0 * wr * nq;
            }
        } else {
            self.null.fill(0.0);
            self.null_q.fill(0.0);
        }
        for i in 0..p {
            // from the linearisation point (an engaged tendon's engagement point)
            let hi = (self.limits.max_m[i].min(self.q_phys[i]) - self.q_lin[i]).min(delta);
            let lo = (self.limits.min_m[i] - self.q_lin[i]).max(-delta);
            self.qp.hi[i] = (hi * MM).max(0.0);
            self.qp.lo[i] = (lo * MM).min(0.0);
            let row = &mut self.qp.rows[i * p..(i + 1) * p];
            if self.slack[i] {
                // a slack tendon stays slack in this step: its linearised slack
                // `gap - (dl/dq + e_i) u >= 0`; the step is cut where it would
                // engage, and the next linearisation is on its taut side
                self.qp.rhs[i] = self.gap[i] * MM;
                row.copy_from_slice(&self.jg[i * p..(i + 1) * p]);
                row[i] += 1.0;
            } else {
                // the linearised tension stays >= 0: the model of the taut side
                // holds only up to where the tendon goes slack
                self.qp.rhs[i] = self.t[i].max(0.0);
                for (a, j) in row.iter_mut().zip(&self.jt[i * p..(i + 1) * p]) {
                    *a = -j / MM;
                }
            }
        }
    }

    /// Norm of the projected gradient `g` (mm): per reading, the part of `-g` that
    /// the limits allow (a reading on its lower limit, or an engaged tendon's,
    /// whose derivative is the pull beyond its engagement point, paying out only
    /// slackens it, only increases; one on its upper limit only decreases; a slack
    /// tendon's gradient is 0).
    pub(super) fn projected_gradient_norm(&self) -> f64 {
        let mut n2 = 0.0;
        for i in 0..self.p {
            let gi = self.g[i];
            let lo = self.engaged[i] || self.q[i] <= self.limits.min_m[i] + ON_BOUND_M;
            let hi = self.q_lin[i] >= self.limits.max_m[i].min(self.q_phys[i]) - ON_BOUND_M;
            let v = match (lo, hi) {
                (true, true) => 0.0,
                (true, false) => gi.min(0.0),
                (false, true) => gi.max(0.0),
                (false, false) => gi,
            };
            n2 += v * v;
        }
        n2.sqrt()
    }

    /// Model value of the step `u` (mm^2): `0.5 u^T H u + g^T u`, less the rest
    /// term's part (`wr (u^T N u + 2 (N q_lin)^T u)`): the rest term steers the
    /// step within the null space and is not part of the merit.
    pub(super) fn model(&self) -> f64 {
        let p = self.p;
        let wr = self.settings.rest_weight;
        let mut v = 0.0;
        for a in 0..p {
            let (mut hu, mut nu) = (0.0, 0.0);
            for b in 0..p {
                hu += self.h[a * p + b] * self.u[b];
                nu += self.null[a * p + b] * self.u[b];
            }
            v += self.u[a] * (0.5 * hu + self.g[a]) - wr * self.u[a] * (nu + 2.0 * self.null_q[a]);
        }
        v
    }

    /// The projector `N = I - A^T (A A^T + eps I)^-1 A` on the null space of the
    /// least-squares rows `A` (the tip's Jacobian, and the direction's scaled by
    /// `l_d` when there is a direction target; mm/mm), into `self.null` (p x p).
    /// `eps` = 1e-10 of the trace of `A A^T`. Rows and columns of slack tendons
    /// (zero columns of `A`) are left out. False (and `N` unset) when the
    /// Gram matrix cannot be factored (all rows zero).
    fn null_space(&mut self, target: &IkTarget) -> bool {
        let p = self.p;
        let ld = self.settings.direction_weight_m;
        let m = if target.direction.is_some() { 6 } else { 3 };
        let row = |r: usize, a: usize| -> f64 {
            if r < 3 {
                self.jp[r * p + a]
            } else {
                ld * self.ja[(r - 3) * p + a]
            }
        };
        let mut gram = Matrix6::<f64>::identity();
        for r in 0..m {
            for c in 0..m {
                gram[(r, c)] = (0..p).map(|a| row(r, a) * row(c, a)).sum();
            }
        }
        let eps = 1e-10 * (0..m).map(|r| gram[(r, r)]).sum::<f64>();
        if eps <= 0.0 || !eps.is_finite() {
            return false;
        }
        for r in 0..m {
            gram[(r, r)] += eps;
        }
        let Some(chol) = gram.cholesky() else {
            return false;
        };
        // Y = (A A^T + eps I)^-1 A, column by column; N = I - A^T Y
        for b in 0..p {
            let mut col = Vector6::<f64>::zeros();
            for r in 0..m {
                col[r] = row(r, b);
            }
            let y = chol.solve(&col);
            for a in 0..p {
                let ay: f64 = (0..m).map(|r| row(r, a) * y[r]).sum();
                // a slack tendon's reading moves nothing: the rest term leaves it
                // (pulling it toward zero would only engage it)
                let both = !self.slack[a] && !self.slack[b];
                self.null[a * p + b] = if both {
                    f64::from(u8::from(a == b)) - ay
                } else {
                    0.0
                };
            }
        }
        true
    }
}
