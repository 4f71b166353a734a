//! Broyden's rank-one update of the Jacobians along an accepted step.

use super::IkWorkspace;
use crate::math::broyden::secant_row_update;

impl IkWorkspace {
    /// Broyden's rank-one update of `jp`, `ja`, `jt` along the accepted step
    /// `s = q_trial - q` with the tip, axis and tension changes `y` it made
    /// (`J += (y - J s) s^T / s^T s`, [`secant_row_update`]; Broyden, Math. Comp.
    /// 19, 1965; Nocedal & Wright eq. 11.24): the Jacobian at the new readings without evaluating it.
    /// Only with every tendon taut before (none engaged) and after (the active set, and so the
    /// columns' meaning, unchanged) and without friction; `false` otherwise.
    pub(super) fn broyden_update(&mut self) -> bool {
        let p = self.p;
        if !self.tw.workspace().robot().friction().is_frictionless()
            || self.slack.iter().chain(&self.engaged).any(|s| *s)
            || self.tw.taut().iter().any(|t| !*t)
        {
            return false;
        }
        let mut ss = 0.0;
        for i in 0..p {
            self.step_m[i] = self.q_trial[i] - self.q[i];
            ss += self.step_m[i] * self.step_m[i];
        }
        if ss.is_nan() || ss <= 0.0 {
            return false;
        }
        let s = &self.step_m;
        let dp = self.tw.tip_position() - self.tip;
        let da = self.tw.workspace().tip_axis() - self.axis;
        let update = |row: &mut [f64], y: f64| secant_row_update(row, s, ss, y);
        for r in 0..3 {
            update(&mut self.jp[r * p..(r + 1) * p], dp[r]);
            update(&mut self.ja[r * p..(r + 1) * p], da[r]);
        }
        let tn = self.tw.tensions();
        for ((row, tk), t0) in self.jt.chunks_exact_mut(p).zip(tn).zip(&self.t) {
            update(row, tk - t0);
        }
        true
    }
}
