//! Broyden's rank-one update of the Jacobians along an accepted step.

use super::IkWorkspace;

/// Broyden's rank-one update of one Jacobian row `j` (the derivatives of one
/// output) along the step `s` (`ss = s^T s > 0`) that changed that output by `y`:
/// `j += (y - j s) s^T / s^T s` (Broyden, "A class of methods for solving
/// nonlinear simultaneous equations", Math. Comp. 19, 1965; Nocedal & Wright,
/// *Numerical Optimization*, 2nd ed., eq. 11.24), the least change of `j` that
/// reproduces the step's secant `j s = y`.
pub(crate) fn broyden_row_update(j: &mut [f64], s: &[f64], ss: f64, y: f64) {
    let js: f64 = j.iter().zip(s).map(|(a, b)| a * b).sum();
    let c = (y - js) / ss;
    for (a, b) in j.iter_mut().zip(s) {
        *a += c * b;
    }
}

impl IkWorkspace {
    /// [`broyden_row_update`] of every row of `jp`, `ja`, `jt` along the accepted
    /// step `s = q_trial - q` with the tip, axis and tension changes it made: the
    /// Jacobians at the new readings without evaluating them. Only without
    /// friction and with the active set unchanged (and so the columns' meaning):
    /// every tendon taut before and after, or slack before and after with its
    /// reading kept (its column, the derivative beyond its engagement point, is
    /// then not changed by the update, `s_i = 0`); `false` otherwise.
    pub(super) fn broyden_update(&mut self) -> bool {
        let p = self.p;
        if self.tw.workspace().robot().friction_mu() > 0.0 {
            return false;
        }
        let taut_after = self.tw.taut();
        let mut ss = 0.0;
        for i in 0..p {
            let kept = self.q_trial[i] == self.q[i];
            if self.slack[i] == taut_after[i] || (self.slack[i] && !kept) {
                return false;
            }
            self.step_m[i] = self.q_trial[i] - self.q[i];
            ss += self.step_m[i] * self.step_m[i];
        }
        if ss.is_nan() || ss <= 0.0 {
            return false;
        }
        let s = &self.step_m;
        let dp = self.tw.tip_position() - self.tip;
        let da = self.tw.workspace().tip_axis() - self.axis;
        for r in 0..3 {
            broyden_row_update(&mut self.jp[r * p..(r + 1) * p], s, ss, dp[r]);
            broyden_row_update(&mut self.ja[r * p..(r + 1) * p], s, ss, da[r]);
        }
        let tn = self.tw.tensions();
        for ((row, tk), t0) in self.jt.chunks_exact_mut(p).zip(tn).zip(&self.t) {
            broyden_row_update(row, s, ss, tk - t0);
        }
        true
    }
}
