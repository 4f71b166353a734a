//! The warm fast path of a solve from readings: one semi-smooth Newton iteration
//! on the shooting unknowns and the tensions together.
//!
//! Unknowns `z = [x; T]` (the scaled shooting unknowns of the inner [`Workspace`]
//! and the tensions of the driven tendons), residuals `F = [r(x, T); G(x, T)]`: the
//! scaled boundary residual of the shooting problem and the tendon NCP function of
//! the parent module, `G_i = min(a_i T_i, c_i T_i + L_f,i - l_i(x, T))`. The
//! generalized Jacobian is exact, from one dual sweep over `[x; T]`
//! ([`Workspace::joint_jacobians`]):
//!
//! ```text
//! [ R_x              R_T                ]   boundary rows
//! [ -dl_i/dx         c_i e_i - dl_i/dT  ]   taut tendon i
//! [ 0                a_i e_i            ]   slack tendon i
//! ```
//!
//! The nested method (a converged shooting solve per tension iterate, then a sweep
//! for `dl/dT`) pays a full warm shooting solve for every tension trial; this one
//! pays one `f64` pass per iteration and a sweep only when the Broyden-updated
//! inverse of the last one stops contracting. Why it is only the warm path:
//! from the previous row it starts within Newton's reach; a cold start needs the
//! shooting solve's continuation and branch checks, which the nested method keeps.
//! It hands back to the nested method (from the row's starting point) whenever it
//! does not converge within [`JOINT_MAX_ITERATIONS`] or a step fails, so it can
//! only make a row faster, never change which rows converge. The shooting solve's
//! warm branch guard (a check that Newton went where its tangent pointed) is not
//! run on this path: steps are limited to [`MAX_STEP`] in the scaled unknowns, and
//! a larger step hands back to the nested method.

use super::TendonWorkspace;
use crate::math::DenseLu;
use crate::settings::{CableCoupling, SolverSettings};
use crate::statics::{SolveStatus, LOCAL_TOL};

// The row's start: the previous row's residual without a pass, and a predictor.
mod predict;
use predict::RowStart;
// The cold start's first Jacobian, kept from the first cold solve.
mod reference;
// A fresh step's active set from its own linearisation.
mod active_set;
// The generalized Jacobian, its inverse and the Newton step.
mod jacobian;
// A row too far for Newton: continuation in the readings.
mod continuation;
// An evaluated iterate kept across its trials.
mod keep;
// The updated inverse carried over to another active set.
mod carry;
// The Newton iteration itself and its chord retry.
mod newton;

/// Newton iterations of the joint path before it hands back.
pub(super) const JOINT_MAX_ITERATIONS: usize = 12;
/// Largest accepted step of the scaled shooting unknowns (forces in units of
/// `EI/L^2`, moments of `EI/L`): a larger one leaves the neighbourhood the warm
/// start vouches for. On the FTDCR v4 recording consecutive rows step up to ~10
/// (base force ~0.8 N against `EI/L^2` ~0.085 N).
pub(super) const MAX_STEP: f64 = 100.0;
/// While rows' first chord steps fail, every this many rows one tries it again
/// ([`ChordPolicy::CONDENSED`]).
const CHORD_PROBE: usize = 16;

/// How far a reused (chord) Jacobian is pushed before a fresh sweep: the right
/// balance depends on what a sweep costs in `f64` passes, which the cable coupling
/// sets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ChordPolicy {
    /// After a row whose first chord step failed, the next rows start with a fresh
    /// Jacobian (one in [`CHORD_PROBE`] tries the chord again).
    skip_after_failure: bool,
    /// Trials of a chord step: the full step, then after each evaluated failure the
    /// full step of the inverse Broyden-updated from that trial
    /// (`JointBufs::chord_retry`); a trial whose pass
    /// failed is halved instead, and a halved step is accepted on Armijo's decrease
    /// (`1 - 1e-4 alpha`).
    trials: usize,
    /// A full chord step must shrink the merit by this factor.
    contraction: f64,
    /// A chord trial that raises the merit more than this factor is not retried: a
    /// fresh Jacobian follows at once.
    hopeless: f64,
    /// At a row's first iteration: when the iterate's active set differs from the
    /// one of the reused inverse, carry the inverse over to it (`carry`) and try the
    /// chord step, instead of a fresh sweep. Measured in `carry`'s module docs.
    carry: bool,
}

impl ChordPolicy {
    /// The policy of a cable coupling, for a warm or a cold row.
    pub(super) fn of(coupling: CableCoupling, cold: bool) -> Self {
        match coupling {
            CableCoupling::Arc if !cold => Self::ARC,
            _ => Self::CONDENSED,
        }
    }

    /// Couplings whose passes settle the next holes (`condensed`, `exact`): a pass
    /// costs about a fifth of a sweep, so a chord step that does not halve the merit
    /// gives way to a fresh Jacobian. Why 0.5 (was 0.1): a fresh Jacobian is one dual
    /// sweep, about 15 `f64` passes (22 `f64` right-hand sides per dual one), and a
    /// Broyden step that halves the merit costs one pass; on the 443 FTDCR v4 val
    /// rows 0.5 cut the dual RHS per row 420 -> 345 for 6039 -> 6257 `f64` ones (0.9:
    /// 338 and 6296, about the same; always trying the chord at a row's start: 311
    /// and 7286, worse). The arc policy below, measured on this coupling:
    /// 2 190 / 105.4 -> 3 020 / 68.3 `f64` / dual RHS a row (worse).
    pub(super) const CONDENSED: Self = Self {
        skip_after_failure: true,
        trials: 1,
        contraction: 0.5,
        hopeless: f64::INFINITY,
        carry: false,
    };
    /// The arc coupling: an explicit pass is cheap (120 RHS and the disks' rounds)
    /// and a `Dual<15>` sweep is worth ~12 of them, so a chord step is retried
    /// before it gives way (updated by `JointBufs::chord_retry`, not halved), and
    /// every row tries it first. On the 443 FTDCR v4 val rows warm
    /// (`examples/tendon_profile`, `COUPLING=arc`), `f64` / dual RHS a row and
    /// callgrind instructions: the condensed policy 950 / 97.2, 1.322e9; this
    /// one 1 215 / 46.3, 1.132e9 (-14 %). Neighbours, measured with a scratch build
    /// that read the rules from the environment (this one there: 1.141e9): 2 trials
    /// and 0.99, 1 131 / 54.4, 1.144e9; 3 and 0.99, 1 233 / 47.7, 1.156e9; 4 and
    /// 0.99, 1 347 / 47.4; 3 and 0.7, 1 244 / 47.9.
    ///
    /// A full step that raises the merit more than 3x is not halved: at
    /// a row's start, the halvings of such steps were accepted in 33 of 335 cases
    /// (3 laps of the val rows at the scene's tolerances; the failed full steps rose
    /// 1.4-925x, median 4.9x, those whose halving was accepted mostly below 2.8x).
    /// `f64` / dual RHS a row, 3 laps: 652 / 54.4 -> 580 / 54.9 (2.5x: 564 / 57.9, 4x:
    /// 598 / 54.4); at the library's default tolerances 1 200 / 51.2 -> 1 144 / 53.5;
    /// the train rows 560 / 35.5 -> 516 / 36.2. Tips within 0.06 um mean (max 1.9 um)
    /// of those with the halvings.
    pub(super) const ARC: Self = Self {
        skip_after_failure: false,
        trials: 3,
        contraction: 0.9,
        hopeless: 3.0,
        carry: true,
    };
}

/// The line search and the inner settle tolerance weigh a tendon mismatch `G` of
/// this many metres like a unit of the scaled shooting residual `r` (at the default
/// tolerances, 1e-10 and 1e-12 m, their ratio, so the default path is unchanged).
/// Why a fixed weight and not `tol / tol_G`: with the tolerances' ratio, loosening
/// only `TendonSettings::tolerance_m` to 1e-9 m shrank the weight of `G` 1 000-fold,
/// and the second-order growth of `r` over a full Newton step then outweighed the
/// fall of `G`: the line search cut every fresh step to 1/32-1/64, the joint path
/// handed every FTDCR v4 val row to the nested method, and a row cost ~120 ms
/// instead of ~0.7 ms. The stopping test still uses each tolerance on its own.
const MERIT_G_UNIT_M: f64 = 1e-2;
/// Buffers of the joint path, sized once.
#[derive(Clone)]
pub(super) struct JointBufs {
    /// Shooting unknowns and tensions at the row's start, at the current iterate,
    /// and the trial.
    x0: Vec<f64>,
    t0: Vec<f64>,
    xs: Vec<f64>,
    ts: Vec<f64>,
    x: Vec<f64>,
    /// The last converged continuation step's point (shooting unknowns, tensions).
    x_ok: Vec<f64>,
    t_ok: Vec<f64>,
    /// `d r / d[x; theta]` (`n x (n + np)`) and `d l / d[x; theta]` (`c x (n + np)`).
    jac_s: Vec<f64>,
    jac_m: Vec<f64>,
    /// Step `[dx; dT]` and the factorised Jacobian.
    dz: Vec<f64>,
    /// Largest accepted step now ([`MAX_STEP`], or [`continuation::MAX_STEP_RETRY`] in
    /// `joint_retry`).
    max_step: f64,
    lu: DenseLu,
    /// `lu` holds a factorisation with this active set (chord steps).
    lu_taut: Vec<bool>,
    lu_valid: bool,
    /// The last row's first iteration accepted a chord step. When it did not (rows
    /// far apart, as in a recording sampled once a second), the next row's first
    /// iteration goes straight to a fresh Jacobian: a chord trial that fails costs
    /// two `f64` passes (the trial and the return to the iterate) for nothing.
    first_chord_ok: bool,
    /// Rows started with a fresh Jacobian since the last chord trial at a row's start
    /// (every [`CHORD_PROBE`]th row tries the chord again).
    rows_fresh: usize,
    /// Inverse of the Jacobian in `lu` (`m x m` row-major, `m = n + p`), improved after
    /// every accepted step by Broyden's update, so that the steps that reuse it
    /// converge superlinearly rather than linearly; and the residual `[r; G]` and the
    /// step actually taken at the last iterate (its secant pair).
    h: Vec<f64>,
    f_now: Vec<f64>,
    f_prev: Vec<f64>,
    step: Vec<f64>,
    hy: Vec<f64>,
    /// Scratch `m x m`: the Jacobian `H^-1` while `h` is carried to another active
    /// set (`carry`).
    jinv: Vec<f64>,
    /// `s^T W H` of the Broyden update, and its residual change `y`.
    sth: Vec<f64>,
    yv: Vec<f64>,
    /// Free lengths of the driven tendons (m) at the row's starting point (the
    /// previous row's) and at the row (continuation steps go from one to the other).
    pub(super) free_prev: Vec<f64>,
    free_row: Vec<f64>,
    /// `|| [r; w G] ||_2 / tol` at the last evaluation (line-search merit; `w` from
    /// [`MERIT_G_UNIT_M`], `JointBufs::norms`).
    l2: f64,
    /// Settle tolerance of the inner passes now in effect (fraction of the length).
    inner_tol: f64,
    /// Row-to-row predictor (`predict` submodule): the solutions `[x; T]` of the
    /// last converged rows, newest first (`HISTORY x (n + p)`), their free lengths
    /// (`HISTORY x p`), how many are held, scratch.
    hist_z: Vec<f64>,
    hist_f: Vec<f64>,
    hist_len: usize,
    zp: Vec<f64>,
    /// The workspace's point, `t`, `lengths`, the taut flags and `f_now` are still
    /// those of the last converged row's final evaluation (no pass since).
    pub(super) at_solution: bool,
    /// This row's joint Newton started from a predicted point.
    predicted: bool,
    /// `l2` merit at the last predicted point over the merit at its row's start
    /// (what the next prediction expects: its settle tolerance).
    pred_ratio: f64,
    /// Active-set switch of a fresh step (`JointBufs::switch_step`): the iterate's
    /// branch values, and the step's own active set, step and residual.
    gap0: Vec<f64>,
    arm0: Vec<f64>,
    sw_taut: Vec<bool>,
    sw_dz: Vec<f64>,
    sw_f: Vec<f64>,
    /// The Jacobian at the reference equilibrium (`reference` submodule).
    pub(super) rj: reference::RefJacobian,
    /// The last evaluated iterate's evaluation (`keep` submodule).
    kept: keep::Kept,
    /// This row started cold (from the reference equilibrium; set by
    /// `solve_readings_from`): its chord steps follow [`ChordPolicy::CONDENSED`]
    /// whatever the coupling.
    pub(super) cold: bool,
}

impl JointBufs {
    /// Largest component of the step `dz` in the scaled shooting unknowns (the first
    /// `n`), what [`MAX_STEP`] limits (a NaN component is skipped by `f64::max`; the
    /// pass at such a point fails and is handled there).
    pub(super) fn step_max(&self, n: usize) -> f64 {
        self.dz[..n].iter().fold(0.0f64, |m, d| m.max(d.abs()))
    }

    /// Drop the reused Jacobian (a cold start must not depend on earlier rows).
    pub(super) fn forget_jacobian(&mut self) {
        self.lu_valid = false;
        self.at_solution = false;
        self.first_chord_ok = true;
        self.rows_fresh = 0;
    }

    pub(super) fn new(n: usize, p: usize, np: usize, cables: usize) -> Self {
        Self {
            x0: vec![0.0; n],
            t0: vec![0.0; p],
            xs: vec![0.0; n],
            ts: vec![0.0; p],
            x: vec![0.0; n],
            x_ok: vec![0.0; n],
            t_ok: vec![0.0; p],
            jac_s: vec![0.0; n * (n + np)],
            jac_m: vec![0.0; cables * (n + np)],
            dz: vec![0.0; n + p],
            max_step: MAX_STEP,
            lu: DenseLu::new(n + p),
            h: vec![0.0; (n + p) * (n + p)],
            jinv: vec![0.0; (n + p) * (n + p)],
            f_now: vec![0.0; n + p],
            f_prev: vec![0.0; n + p],
            step: vec![0.0; n + p],
            hy: vec![0.0; n + p],
            sth: vec![0.0; n + p],
            yv: vec![0.0; n + p],
            free_prev: vec![0.0; p],
            free_row: vec![0.0; p],
            lu_taut: vec![true; p],
            lu_valid: false,
            first_chord_ok: true,
            rows_fresh: 0,
            l2: f64::INFINITY,
            inner_tol: LOCAL_TOL,
            hist_z: vec![0.0; predict::HISTORY * (n + p)],
            hist_f: vec![0.0; predict::HISTORY * p],
            hist_len: 0,
            zp: vec![0.0; n + p],
            at_solution: false,
            predicted: false,
            pred_ratio: 1.0,
            gap0: vec![0.0; p],
            arm0: vec![0.0; p],
            sw_taut: vec![true; p],
            sw_dz: vec![0.0; n + p],
            sw_f: vec![0.0; n + p],
            rj: reference::RefJacobian::new(n, np, cables),
            kept: keep::Kept::new(n + p, p, cables),
            cold: true,
        }
    }
}

impl TendonWorkspace {
    /// The joint Newton from the current (warm) point. `true` when it converged
    /// (the workspace then holds the row's solution); `false` when it handed back,
    /// with the row's starting point restored.
    ///
    /// When the row's first Newton step leaves the warm start's neighbourhood
    /// (larger than [`MAX_STEP`]) or its line search fails, the row is retried by
    /// continuation in the readings: the free lengths go from those of the starting
    /// point to the row's in `continuation::joint_substeps` equal steps, each solved by the same
    /// Newton from the last (the equilibrium path parametrised by the readings, so
    /// every Newton step stays within [`MAX_STEP`]). Why: on the FTDCR v4 recording
    /// (rows ~1 s apart) 6 rows of 200 step 170-340 in the scaled unknowns; handed
    /// back, the nested method's checked solves cost them 30k-250k `f64` right-hand
    /// sides each, half of all the work of the 200 rows, where 3-5 continuation steps
    /// cost a few thousand. The nested method remains the fallback when a
    /// continuation step fails too.
    pub(super) fn solve_joint(&mut self) -> bool {
        self.joint.x0.copy_from_slice(self.ws.unknowns_vector());
        self.joint.t0.copy_from_slice(&self.iter.t);
        self.joint.x.copy_from_slice(&self.joint.x0);
        self.joint.predicted = false;
        let mut first = None;
        match self.joint_predict() {
            RowStart::Converged => {
                self.status.set(SolveStatus::Converged);
                self.status.report.iterations = 0;
                return true;
            }
            RowStart::Evaluated(m) => match self.joint_newton(1.0, Some(m)) {
                Ok(()) => return true,
                Err(f) if !self.joint.predicted => first = Some(f),
                Err(_) => {
                    // the predicted start did not converge: the row's plain start
                    self.joint_inner_tolerance(0.0);
                    self.iter.t.copy_from_slice(&self.joint.t0);
                    self.joint.x.copy_from_slice(&self.joint.x0);
                }
            },
            RowStart::Plain => {}
        }
        let first = match first {
            Some(f) => f,
            None => match self.joint_newton(1.0, None) {
                Ok(()) => return true,
                Err(first) => first,
            },
        };
        if self.budget.skips_continuation(self.joint.cold) {
            return self.joint_hand_back();
        }
        // continuation, when the first fresh step says how far the row is (from the
        // free lengths of the starting point: the previous row's); failing that, a
        // second one with a larger step limit; then the nested method
        self.joint.free_row.copy_from_slice(&self.iter.free);
        self.joint_continuation(first) || self.joint_retry(first)
    }

    /// Settle tolerance of the next passes from the residual of the current iterate
    /// (0: fully settled, `LOCAL_TOL`): `1e-7` of its residual `residual`
    /// (`max(|r|, w |G|)`, [`JointBufs::norms`]) as a fraction of the
    /// rod length (the boundary residual moves by ~100-1000 times a
    /// scaled hole error, so the inner error stays 1e-5..1e-4 of the outer residual;
    /// near convergence the clamp makes it `LOCAL_TOL`). Measured on the 443 FTDCR v4
    /// val rows (f64 / dual RHS a row): 1e-9 3354 / 192, 1e-8 3095 / 192, 1e-7 2885 /
    /// 195; before the adaptive continuation steps, 1e-10 (the shooting Newton's rule)
    /// 4449 / 246, 1e-8 4027 / 248, 1e-6 4256 / 284 (there the noise starts to fail
    /// the chord steps' contraction test, which costs sweeps).
    fn joint_inner_tolerance(&mut self, residual: f64) {
        self.joint.inner_tol = self.ws.set_local_tolerance(1e-7 * residual);
    }

    /// Shooting residual, lengths and `G` at `(joint.x, t)`; the merit
    /// `max(|r|/tol, |G|/tol_G)` (converged at <= 1), `None` if the pass failed.
    fn joint_evaluate(&mut self) -> Option<f64> {
        if !self.within_budget() {
            return None;
        }
        self.joint.rj.leave();
        let p = self.tendons.driven.len();
        self.iter.theta[..p].copy_from_slice(&self.iter.t);
        self.ws.set_theta(&self.iter.theta);
        self.status.report.forward_solves += 1;
        let res = self.ws.adopt_unknowns(&self.joint.x, true);
        if !res.is_finite() {
            return None;
        }
        self.ws.cable_lengths_into(&mut self.iter.lengths);
        self.iter.update_g(&self.tendons);
        let tol = self.ws.report().tolerance;
        let tol_g = self.tendon_settings().tolerance_m;
        let n = self.joint.x.len();
        self.joint.f_now[..n].copy_from_slice(self.ws.residual_vector());
        self.joint.f_now[n..].copy_from_slice(&self.iter.g);
        self.joint.l2 = self.joint.norms(tol, self.ws.settings()).0;
        Some((res / tol).max(self.iter.merit() / tol_g))
    }

    /// Restore the row's starting point for the nested method; `false`.
    fn joint_hand_back(&mut self) -> bool {
        if self.budget.steers() {
            // no nested method under a budget: the cold path or the end of the call
            // follows (`budget` module), which sets its own point
            return false;
        }
        self.joint_inner_tolerance(0.0);
        self.iter.t.copy_from_slice(&self.joint.t0);
        self.joint.x.copy_from_slice(&self.joint.x0);
        self.joint.lu_valid = false;
        if self.joint_evaluate().is_none() {
            // the start was a converged row: only a non-finite theta could fail it
            self.status.has_solution = false;
        }
        false
    }
}

impl JointBufs {
    /// `(l2, settle)` of the residual `[r; G]` in `f_now`: the line-search merit
    /// (`l2`) and the largest component of `[r; w G]` (what the next
    /// passes' settle tolerance follows). `G`
    /// is weighed against the settings' shooting tolerance, not this solve's `tol`
    /// (which the residual floor may raise), as the tolerances' ratio did.
    pub(super) fn norms(&self, tol: f64, settings: &SolverSettings) -> (f64, f64) {
        let n = self.x.len();
        let (r, g) = self.f_now.split_at(n);
        let w = tol / (MERIT_G_UNIT_M * settings.tolerance);
        let (mut sum, mut top) = (0.0, 0.0f64);
        for v in r.iter().copied().chain(g.iter().map(|g| g * w)) {
            sum += v * v;
            top = top.max(v.abs());
        }
        (sum.sqrt() / tol, top)
    }
}

impl crate::math::warm::WarmCopy for JointBufs {
    fn warm_copy_from(&mut self, src: &Self) {
        // `jinv`, `yv`, `hy` and `sth` are scratch, written in full before they are read
        // (the carry's inverse, Broyden's `y`, `H y` and `s^T W H`): left out of the
        // copy, ~10 % of it (debug builds poison them after a rollback: `poison_scratch`)
        crate::math::warm::warm_fields!(self, src, copy: [
            x0, t0, xs, ts, x, x_ok, t_ok, jac_s, jac_m, dz, max_step, lu, lu_taut, lu_valid,
            first_chord_ok, rows_fresh, h, f_now, f_prev, step, free_prev,
            free_row, l2, inner_tol, hist_z, hist_f, hist_len, zp, at_solution, predicted,
            pred_ratio, gap0, arm0, sw_taut, sw_dz, sw_f, rj, kept, cold,
        ], keep: [hy, jinv, sth, yv]);
    }
}

impl JointBufs {
    /// Debug builds: fill the scratch the rollback's copy leaves out with NaN, so
    /// that a result depending on it fails the bit-identical rows of
    /// `tests/rollback.rs`.
    pub(super) fn poison_scratch(&mut self) {
        for v in [&mut self.hy, &mut self.jinv, &mut self.sth, &mut self.yv] {
            v.fill(f64::NAN);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The backtracking chord rules are for warm rows under the arc coupling only:
    /// cold rows and the couplings whose passes settle the next holes keep the
    /// condensed rules (measured worse with the arc ones: see [`ChordPolicy`]).
    #[test]
    fn the_arc_chord_policy_is_for_warm_arc_rows_only() {
        assert_eq!(ChordPolicy::of(CableCoupling::Arc, false), ChordPolicy::ARC);
        assert_eq!(
            ChordPolicy::of(CableCoupling::Arc, true),
            ChordPolicy::CONDENSED
        );
        for coupling in [CableCoupling::Condensed, CableCoupling::Exact] {
            for cold in [false, true] {
                assert_eq!(ChordPolicy::of(coupling, cold), ChordPolicy::CONDENSED);
            }
        }
        assert_ne!(ChordPolicy::ARC, ChordPolicy::CONDENSED);
        // a failed trial that does not raise the merit is always retried (only one
        // that raises it past `hopeless` is not); the condensed rules never retry
        for policy in [ChordPolicy::ARC, ChordPolicy::CONDENSED] {
            assert!(policy.hopeless > 1.0, "{policy:?}");
        }
        assert_eq!(ChordPolicy::CONDENSED.trials, 1);
        // the inverse is carried across active sets only on the arc rules
        for coupling in [CableCoupling::Arc, CableCoupling::Condensed] {
            for cold in [false, true] {
                let warm_arc = coupling == CableCoupling::Arc && !cold;
                assert_eq!(ChordPolicy::of(coupling, cold).carry, warm_arc);
            }
        }
    }
}
