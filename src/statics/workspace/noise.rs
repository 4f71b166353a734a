//! The condensed coupling's settle noise, measured: the tolerance of a solve is raised
//! to what two evaluations of the same unknowns disagree by.
//!
//! Under the condensed coupling a pass settles each segment's next holes by a local
//! iteration that starts from where the last pass left them and stops at
//! [`LOCAL_TOL`] of the rod length, or earlier where it stagnates (up to 100x that,
//! `pass/condensed.rs`, `LOCAL_FLOOR`). The residual of one set of unknowns therefore
//! depends on the passes before it. `statics::floor` estimates that dependence from
//! `LOCAL_TOL`, but near the end of the documented region it is larger: on the track
//! demo at cable tension `T r L / EI` = 6.52 (tests/stability.rs's reference tracker)
//! the same unknowns evaluated 2.04e-10, 1.08e-10 and 2.54e-10 against an estimated
//! floor of 1.48e-10, so a fresh exact Newton step could no longer lower the residual
//! and the solve ended `Stalled` at a residual no re-evaluation can certify either way.
//!
//! Newton re-evaluates its current point anyway (before a condensed sweep whose last
//! pass was a rejected trial, after a failed line search, to confirm settled holes).
//! When both evaluations settled to `LOCAL_TOL` at the same load scale, their largest
//! difference is a measured lower bound of the noise, and the solve's tolerance becomes
//! at least [`FLOOR_SAFETY`] times it (reported in `SolveReport::tolerance`): the
//! definition "`Converged` exactly when a re-evaluation of the same state agrees" of
//! `Iterate::status`, with the noise measured instead of estimated. The arc and exact
//! couplings' passes are functions of the unknowns alone and are not measured.

use super::super::floor::FLOOR_SAFETY;
use super::super::pass::LOCAL_TOL;

/// The unknowns the workspace's residual `res` belongs to, when it was a settled
/// (`LOCAL_TOL`) pass of this solve at load scale `lam`.
#[derive(Clone, Debug)]
pub(super) struct SettleNoise {
    /// Whether the plan settles next holes (the condensed coupling): else the record
    /// is never kept or read, and a pass costs no copy of the unknowns.
    active: bool,
    x: Vec<f64>,
    lam: Option<f64>,
}

impl SettleNoise {
    /// For `n` unknowns; `active` when the plan settles next holes.
    pub(super) fn new(n: usize, active: bool) -> Self {
        Self {
            active,
            x: vec![0.0; if active { n } else { 0 }],
            lam: None,
        }
    }

    /// The residual no longer belongs to a recorded point (a new solve, new loads or
    /// load parameters, a failed pass).
    pub(super) fn forget(&mut self) {
        self.lam = None;
    }

    /// `res` now belongs to `x` at `lam`, evaluated with settle tolerance `local_tol`.
    pub(super) fn record(&mut self, x: &[f64], lam: f64, local_tol: f64) {
        if self.active && local_tol <= LOCAL_TOL && self.x.len() == x.len() {
            self.x.copy_from_slice(x);
            self.lam = Some(lam);
        } else {
            self.lam = None;
        }
    }

    /// The tolerance `tol` raised to the noise a new settled evaluation `new` of `x` at
    /// `lam` shows against the recorded one `old` (unchanged when `old` is not of the
    /// same point, or either is not finite).
    pub(super) fn raised(
        &self,
        tol: f64,
        x: &[f64],
        lam: f64,
        local_tol: f64,
        old: &[f64],
        new: &[f64],
    ) -> f64 {
        if !self.active || self.lam != Some(lam) || local_tol > LOCAL_TOL || self.x != x {
            return tol;
        }
        let d = old
            .iter()
            .zip(new)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        if d.is_finite() {
            tol.max(FLOOR_SAFETY * d)
        } else {
            tol
        }
    }
}

impl crate::math::warm::WarmCopy for SettleNoise {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src, copy: [active, x, lam], keep: []);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Only a settled re-evaluation of the recorded point at the same load scale
    /// raises the tolerance, by `FLOOR_SAFETY` times the largest difference.
    #[test]
    fn only_the_same_settled_point_raises_the_tolerance() {
        let mut n = SettleNoise::new(2, true);
        let (old, new) = ([1e-10, -2e-10], [2e-10, -1e-10]);
        let x = [0.5, 0.25];
        // nothing recorded yet
        assert_eq!(n.raised(1e-10, &x, 1.0, LOCAL_TOL, &old, &new), 1e-10);
        n.record(&x, 1.0, LOCAL_TOL);
        let t = n.raised(1e-10, &x, 1.0, LOCAL_TOL, &old, &new);
        assert!((t - FLOOR_SAFETY * 1e-10).abs() < 1e-24, "{t}");
        // another point, another load scale, a loose settle, a non-finite residual
        assert_eq!(
            n.raised(1e-10, &[0.5, 0.3], 1.0, LOCAL_TOL, &old, &new),
            1e-10
        );
        assert_eq!(n.raised(1e-10, &x, 0.5, LOCAL_TOL, &old, &new), 1e-10);
        assert_eq!(n.raised(1e-10, &x, 1.0, 1e-12, &old, &new), 1e-10);
        let inf = [f64::INFINITY, 0.0];
        assert_eq!(n.raised(1e-10, &x, 1.0, LOCAL_TOL, &inf, &new), 1e-10);
        // a loose evaluation is not recorded; forget drops the record
        n.record(&x, 1.0, 1e-12);
        assert_eq!(n.raised(1e-10, &x, 1.0, LOCAL_TOL, &old, &new), 1e-10);
        n.record(&x, 1.0, LOCAL_TOL);
        n.forget();
        assert_eq!(n.raised(1e-10, &x, 1.0, LOCAL_TOL, &old, &new), 1e-10);
        // never lowers
        n.record(&x, 1.0, LOCAL_TOL);
        assert_eq!(n.raised(1.0, &x, 1.0, LOCAL_TOL, &old, &new), 1.0);
        // a plan without settled holes keeps nothing and raises nothing
        let mut off = SettleNoise::new(2, false);
        off.record(&x, 1.0, LOCAL_TOL);
        assert_eq!(off.raised(1e-10, &x, 1.0, LOCAL_TOL, &old, &new), 1e-10);
    }
}
