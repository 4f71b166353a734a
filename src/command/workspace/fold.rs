//! The fold test of a failed sample ([`WorkspaceSettings::fold_test`]): where the
//! warm path from the chain's last converged readings to the sample stops, and
//! whether the readings solve's joint Jacobian `F_z` is singular there
//! ([`crate::tendons::FoldProbe`]).
//!
//! The straight readings path `q(l) = q_from + l (q - q_from)` is walked by
//! adaptive steps (each solve warm from the last converged point `l_lo`, under the
//! retry pass's budget of rod passes; a step that converges moves `l_lo` and
//! doubles, up to [`FOLD_MAX_STEP`], one that fails halves) until a step of
//! [`FOLD_MIN_STEP`] from `l_lo` fails (at most [`FOLD_MAX_SOLVES`] solves). If the
//! walk reaches the sample, the verdict is `reached`. Else `F_z` is evaluated at
//! the start and at every converged point (equilibrated smallest singular values
//! `s_0` at the start, `s_lo` at `l_lo`; `b` the readings' push `-F_q dq` and `u`
//! the left singular vector of `s_lo`):
//!
//! * `past_fold`: `|u^T b|/|b| >= FOLD_PUSH` and the square of the smallest
//!   singular value, extrapolated linearly from the last two converged points,
//!   reaches zero within [`FOLD_AHEAD`] of the way beyond `l_lo`: near a
//!   limit point the smallest singular value goes like the square root of the
//!   distance to it (the branch `q(s)` turns quadratically in its arclength `s`
//!   while `s_min` is linear in `s`; Allgower & Georg 2003, ch. 2 and 9), and the
//!   readings drive its singular direction, so the branch turns there. The
//!   sample, if it has an equilibrium, lies on another branch.
//! * `singular`: `s_lo <= FOLD_DROP s_0` and `|u^T b|/|b| < FOLD_PUSH`: singular in a
//!   mode the readings do not drive (a symmetric pull: a bifurcation the branch
//!   passes), the tangent stays bounded and the Newton fails on the near-singular
//!   Jacobian (the distal section's co-contraction, docs/command.md).
//! * `regular`: neither: no fold or singularity shows where the solver failed.
//! * `untested`: `F_z` could not be evaluated, or the walk ran out of solves.
//!
//! The thresholds were read off 12 failed samples of one 500-sample chain probed by
//! small steps (`examples/workspace_fold.rs chain`): at the stall the fold-like ones
//! had `s_lo/s_0` 0.007 to 0.19 and push 0.07 to 0.71, the co-contraction-like ones
//! push below 0.03.

use super::retry::{ok, solve_status};
use crate::settings::TendonSettings;
use crate::statics::Start;
use crate::tendons::{FoldPoint, FoldProbe, TendonWorkspace};

/// Largest step of the walk (fraction of the way).
pub const FOLD_MAX_STEP: f64 = 1.0 / 16.0;
/// The walk stops when a step this small (`2^-11`, ~1/2000 of the way) fails:
/// the fold's drop of the smallest singular value shows there (on FTDCR v4 within
/// the last ~0.3 % of the way, not 1 % before).
pub const FOLD_MIN_STEP: f64 = 1.0 / 2048.0;
/// Most solves of the walk (a bound on its work).
pub const FOLD_MAX_SOLVES: usize = 64;
/// Drop of the smallest singular value that marks `F_z` singular at the stall.
pub const FOLD_DROP: f64 = 0.25;
/// A fold is predicted when the square of the smallest singular value
/// extrapolates to zero within this fraction of the way beyond the last converged
/// point (1/256: eight of the smallest steps).
pub const FOLD_AHEAD: f64 = 1.0 / 256.0;
/// Least `|u^T b| / |b|` of a fold (the readings drive the singular direction).
pub const FOLD_PUSH: f64 = 0.05;

/// The fold test's verdict on a failed sample (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FoldClass {
    /// The branch turns at the stall (a limit point along the warm path).
    PastFold,
    /// `F_z` singular in a mode the readings do not drive.
    Singular,
    /// `F_z` regular at the stall: the solver failed, not the branch.
    Regular,
    /// The walk reached the sample: it has an equilibrium on the branch, which
    /// the sampling's solve did not reach from its start (a solver failure).
    Reached,
    /// `F_z` could not be evaluated, or the walk ran out of solves.
    Untested,
}

impl FoldClass {
    /// The name used in files.
    pub fn name(self) -> &'static str {
        match self {
            Self::PastFold => "past_fold",
            Self::Singular => "singular",
            Self::Regular => "regular",
            Self::Reached => "reached",
            Self::Untested => "untested",
        }
    }
    /// Every class, in the order of the summary.
    pub const ALL: [FoldClass; 5] = [
        Self::PastFold,
        Self::Singular,
        Self::Regular,
        Self::Reached,
        Self::Untested,
    ];
}

/// What [`fold_test`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FoldTest {
    /// The verdict.
    pub class: FoldClass,
    /// Fraction of the way to the sample of the last converged point `l_lo`.
    pub reached: f64,
    /// `s_0`: the smallest equilibrated singular value of `F_z` at the start
    /// (NaN when not evaluated).
    pub sigma_start: f64,
    /// `s_lo`: the same at the last converged point (NaN when not evaluated).
    pub sigma_stall: f64,
    /// `|u^T b| / |b|` at `l_lo` (NaN when not evaluated).
    pub push: f64,
    /// How far beyond the last converged point (fraction of the way) the square
    /// of the smallest singular value extrapolates to zero from the last two
    /// converged points (infinite when it does not fall).
    pub fold_beyond: f64,
    /// Rod passes of the walk's solves.
    pub passes: u32,
}

/// The fold test of the path from `from` (readings of `tw`'s last converged
/// solve, m) to `to` (m), on a clone of `tw` (whose state is left as it is; a
/// pending rollback is applied on the clone), each solve under `settings`.
pub fn fold_test(
    tw: &TendonWorkspace,
    from: &[f64],
    to: &[f64],
    settings: &TendonSettings,
) -> FoldTest {
    let mut w = tw.clone();
    w.apply_rollback();
    let mut probe = FoldProbe::new(&w);
    let dir: Vec<f64> = from.iter().zip(to).map(|(a, b)| b - a).collect();
    let mut out = FoldTest {
        class: FoldClass::Untested,
        reached: 0.0,
        sigma_start: f64::NAN,
        sigma_stall: f64::NAN,
        push: f64::NAN,
        fold_beyond: f64::INFINITY,
        passes: 0,
    };
    let Some(start) = probe.measure(&mut w, from, &dir) else {
        return out;
    };
    out.sigma_start = start.sigma_min;
    if w.set_tendon_settings(*settings).is_err() {
        return out;
    }
    // the walk: a step that converges moves `lo` and doubles (up to
    // FOLD_MAX_STEP), one that fails halves (down to FOLD_MIN_STEP); `F_z` at the
    // last two converged points
    let (mut lo, mut h) = (0.0f64, FOLD_MAX_STEP);
    let mut q = from.to_vec();
    let (mut before, mut last) = (None, (0.0, start));
    for _ in 0..FOLD_MAX_SOLVES {
        if lo >= 1.0 || h < FOLD_MIN_STEP {
            break;
        }
        let next = (lo + h).min(1.0);
        for ((x, a), b) in q.iter_mut().zip(from).zip(to) {
            *x = a + next * (b - a);
        }
        // (a failed solve is rolled back: the next one starts from `lo` again)
        if ok(solve_status(&mut w, &q, Start::Warm, &mut out.passes)) {
            lo = next;
            h = (2.0 * h).min(FOLD_MAX_STEP);
            let Some(f) = probe.measure(&mut w, &q, &dir) else {
                return out;
            };
            before = Some(std::mem::replace(&mut last, (lo, f)));
        } else {
            h *= 0.5;
        }
    }
    out.reached = lo;
    let (l_b, stall) = last;
    out.sigma_stall = stall.sigma_min;
    out.push = stall.push_on_null;
    // sigma^2 linear in the path parameter near a fold: its zero from the last two
    // points, beyond `l_b` by `d` (infinite when sigma does not fall)
    let d = before.map_or(f64::INFINITY, |(l_a, a): (f64, FoldPoint)| {
        let (sa, sb) = (a.sigma_min * a.sigma_min, stall.sigma_min * stall.sigma_min);
        if sb < sa {
            sb * (l_b - l_a) / (sa - sb)
        } else {
            f64::INFINITY
        }
    });
    out.fold_beyond = d;
    out.class = if lo >= 1.0 {
        FoldClass::Reached
    } else if h >= FOLD_MIN_STEP {
        FoldClass::Untested
    } else if stall.push_on_null >= FOLD_PUSH && d <= FOLD_AHEAD {
        FoldClass::PastFold
    } else if stall.push_on_null < FOLD_PUSH && stall.sigma_min <= FOLD_DROP * out.sigma_start {
        FoldClass::Singular
    } else {
        FoldClass::Regular
    };
    out
}
