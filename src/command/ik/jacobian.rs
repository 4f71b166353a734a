//! The Jacobians of the tip, its axis and the tensions with respect to the
//! readings: exact (implicit function theorem), or differences of solves under
//! friction (module docs of [`super`]).

use super::{IkWorkspace, FD_STEP_M, TANGENT_STEP_M};
use crate::tendons::ift::{assemble_joint_jacobian, reading_gain};
use nalgebra::Vector3;

impl IkWorkspace {
    /// The Jacobians `jp`, `ja`, `jt` at the accepted readings (module docs); the
    /// number of forward solves used (0 for the exact one). `false` on failure.
    pub fn compute_jacobian(&mut self) -> Option<usize> {
        if !self.has_state {
            return None;
        }
        self.fd_passes = (0, 0);
        let ok = if !self.tw.workspace().robot().friction().is_frictionless() {
            return self.fd_jacobian();
        } else {
            self.exact_jacobian()
        };
        self.restore_state();
        ok.then_some(0)
    }

    pub(super) fn exact_jacobian(&mut self) -> bool {
        let p = self.p;
        self.x_acc
            .copy_from_slice(self.tw.workspace().unknowns_vector());
        self.taut_cur.copy_from_slice(self.best.taut());
        // each tendon's piece of the piecewise-smooth map (module docs, "Taut/slack
        // boundary"): taut; slack within `engage_tol_m` of its engagement point (the
        // reading at which the free length equals the path length, T = 0 on the
        // taut branch): linearised there on the taut side; else slack, its slack
        // kept >= 0 by a linearised row
        for i in 0..p {
            self.q_lin[i] = self.q[i];
            self.slack[i] = false;
            self.engaged[i] = false;
            self.gap[i] = 0.0;
            if !self.taut_cur[i] {
                let l = self.best.lengths()[self.best.driven()[i]];
                let off = self.best.mechanics()[i].zero_offset_m;
                let free = self.best.rest_free_lengths()[i] - (self.q[i] - off);
                let gap = (free - l).max(0.0);
                let top = self.limits.max_m[i].min(self.q_phys[i]);
                if gap <= self.engage_tol_m && self.q[i] + gap <= top {
                    self.engaged[i] = true;
                    self.taut_cur[i] = true;
                    self.q_lin[i] = self.q[i] + gap;
                } else {
                    self.slack[i] = true;
                    self.gap[i] = gap;
                }
            }
        }
        // the dual sweep at the converged point
        {
            let np = self.ts.len();
            let ws = self.tw.workspace_mut();
            self.ts[..p].copy_from_slice(&self.t);
            for v in &mut self.ts[p..np] {
                *v = 0.0;
            }
            ws.set_theta(&self.ts);
            if !ws.adopt_unknowns(&self.x_acc, true).is_finite()
                || !ws.joint_jacobians(&self.x_acc, &mut self.jac_s, &mut self.jac_m)
            {
                return false;
            }
        }
        // the columns of the taut and engaged tendons (an engaged one at its
        // engagement point, T = 0: the one-sided derivative of the pull)
        if !self.factor_fz() {
            return false;
        }
        for i in 0..p {
            if self.slack[i] {
                // a slack tendon's reading moves nothing while it stays slack
                for r in 0..3 {
                    self.jp[r * p + i] = 0.0;
                    self.ja[r * p + i] = 0.0;
                }
                for k in 0..p {
                    self.jt[k * p + i] = 0.0;
                    self.jg[k * p + i] = 0.0;
                }
                continue;
            }
            let gain = reading_gain(&self.best.mechanics()[i], self.t[i], true);
            if !self.tangent(i, gain) {
                return false;
            }
        }
        true
    }

    /// Factor `F_z` at the accepted point with the active set `taut_cur` (an
    /// engaged tendon taut at its engagement point: free length = path length,
    /// `q_lin`). Sets `taut_tmp`.
    pub(super) fn factor_fz(&mut self) -> bool {
        let nx = self.nx;
        let w = nx + self.ts.len();
        self.taut_tmp.copy_from_slice(&self.taut_cur);
        let free0 = self.best.rest_free_lengths();
        let mech = self.best.mechanics();
        let driven = self.best.driven();
        let q = &self.q_lin;
        assemble_joint_jacobian(
            nx,
            w,
            &self.jac_s,
            &self.jac_m,
            driven,
            mech,
            |k| free0[k] - (q[k] - mech[k].zero_offset_m),
            &self.t,
            &self.taut_tmp,
            self.lu.matrix_mut(),
        );
        matches!(self.lu.factor(), Some(rc) if rc > 1e-14)
    }

    /// Column `i` of `dp/dq`, `da/dq`, `dT/dq` from the factored `F_z` (active set
    /// `taut_tmp`) and the reading gain: `dz = F_z^-1 e_{n+i} gain`, the tip along
    /// `z +- h dz` (two passes).
    pub(super) fn tangent(&mut self, i: usize, gain: f64) -> bool {
        let (p, nx) = (self.p, self.nx);
        let h = TANGENT_STEP_M;
        self.col.fill(0.0);
        self.col[nx + i] = gain;
        self.lu.solve_in_place(&mut self.col);
        for k in 0..p {
            if !self.taut_tmp[k] {
                self.col[nx + k] = 0.0;
            }
            self.jt[k * p + i] = self.col[nx + k];
        }
        // a slack tendon's path length along the column: `dl_k/dq_i = dl_k/dz dz`
        let (w, m) = (nx + self.ts.len(), nx + p);
        for k in 0..p {
            if self.slack[k] {
                let j = self.best.driven()[k];
                let row = &self.jac_m[j * w..j * w + m];
                self.jg[k * p + i] = row.iter().zip(&self.col[..m]).map(|(a, b)| a * b).sum();
            }
        }
        let mut tips = [Vector3::zeros(); 2];
        let mut axes = [Vector3::zeros(); 2];
        for (s, sign) in [1.0, -1.0].into_iter().enumerate() {
            for (v, (a, d)) in self.xs.iter_mut().zip(self.x_acc.iter().zip(&self.col)) {
                *v = a + sign * h * d;
            }
            for k in 0..p {
                self.ts[k] = self.t[k] + sign * h * self.col[nx + k];
            }
            let ws = self.tw.workspace_mut();
            ws.set_theta(&self.ts);
            if !ws.adopt_unknowns(&self.xs, true).is_finite() {
                return false;
            }
            tips[s] = ws.tip_position();
            axes[s] = ws.tip_axis();
        }
        let dp = (tips[0] - tips[1]) / (2.0 * h);
        let da = (axes[0] - axes[1]) / (2.0 * h);
        for r in 0..3 {
            self.jp[r * p + i] = dp[r];
            self.ja[r * p + i] = da[r];
        }
        true
    }

    /// The Jacobians by central differences of converged forward solves (what
    /// [`IkWorkspace::compute_jacobian`] does under friction; a check of the exact
    /// one otherwise); the number of solves used, `None` when one failed.
    pub fn finite_difference_jacobian(&mut self) -> Option<usize> {
        if !self.has_state {
            return None;
        }
        self.jac_valid = false;
        self.fd_jacobian()
    }

    /// Central differences of converged forward solves (friction); the solves used.
    pub(super) fn fd_jacobian(&mut self) -> Option<usize> {
        let p = self.p;
        self.slack.fill(false);
        self.engaged.fill(false);
        self.q_lin.copy_from_slice(&self.q);
        let h = FD_STEP_M;
        let mut solves = 0;
        self.fd_passes = (0, 0);
        for i in 0..p {
            let mut tips = [Vector3::zeros(); 2];
            let mut axes = [Vector3::zeros(); 2];
            for (s, sign) in [1.0, -1.0].into_iter().enumerate() {
                self.restore_state();
                self.q_trial.copy_from_slice(&self.q);
                self.q_trial[i] += sign * h;
                solves += 1;
                let r = self.tw.solve_readings(&self.q_trial).ok()?;
                self.fd_passes.0 += r.forward_solves;
                self.fd_passes.1 = self.fd_passes.1.max(r.forward_solves);
                if !r.status.is_converged() {
                    self.restore_state();
                    return None;
                }
                tips[s] = self.tw.tip_position();
                axes[s] = self.tw.workspace().tip_axis();
                let t = self.tw.tensions();
                for (k, tk) in t.iter().enumerate() {
                    let v = tk / (2.0 * h);
                    if s == 0 {
                        self.jt[k * p + i] = v;
                    } else {
                        self.jt[k * p + i] -= v;
                    }
                }
            }
            let dp = (tips[0] - tips[1]) / (2.0 * h);
            let da = (axes[0] - axes[1]) / (2.0 * h);
            for r in 0..3 {
                self.jp[r * p + i] = dp[r];
                self.ja[r * p + i] = da[r];
            }
        }
        self.restore_state();
        Some(solves)
    }
}
