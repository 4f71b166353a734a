//! The workspace's state in typed parts (the way Clarabel's `Solver` holds `data`,
//! `variables`, `residuals`, `kktsystem`, `info`, `settings`): each impl file works on
//! the parts it names, and a solve's status is decided in one place,
//! [`Iterate::status`]. Which file reads and writes which part: docs/architecture.md,
//! "The shooting workspace in parts".

use super::super::multiple::Multi;
use super::super::pass::PassBuf;
use super::super::plan::Plan;
use super::super::{SolveReport, SolveStatus};
use super::broyden::Broyden;
use super::noise::SettleNoise;
use super::predict::Secant;
use super::sweep::Wide;
use super::{max_abs, ARC_SWEEP};
use crate::loads::Loads;
use crate::math::warm::{warm_fields, WarmCopy};
use crate::math::{DenseLu, Dual};
use crate::robot::Robot;
use crate::settings::SolverSettings;
use nalgebra::Vector3;

/// The problem: configuration, changed only by the caller (never by a solve, and
/// never copied by a rollback).
#[derive(Clone)]
pub(super) struct Problem {
    pub robot: Robot,
    pub loads: Loads,
    pub settings: SolverSettings,
    pub plan: Plan,
    /// `Multi::supports(&plan)`, a function of the plan's structure (fixed for a
    /// workspace: `set_loads` rebuilds it when the structure changes), so not
    /// re-derived by every solve (2 % of a warm solve on a 100-disk robot).
    pub multi_supported: bool,
}

/// The Newton iterate and what certifies it: the residual, the solve's tolerance, the
/// settle noise that raises it and the branch guard's verdict.
#[derive(Clone)]
pub(super) struct Iterate {
    pub x: Vec<f64>,
    pub x_trial: Vec<f64>,
    pub dx: Vec<f64>,
    pub res: Vec<f64>,
    /// Lowest-residual iterate at full load during the current solve.
    pub x_best: Vec<f64>,
    pub best_res: f64,
    /// Tolerance of the current solve: `settings.tolerance` raised to the round-off
    /// floor of the residual (`Workspace::residual_floor`) and to the measured settle
    /// noise.
    pub tol: f64,
    /// The point `res` belongs to, for measuring the condensed coupling's settle noise.
    pub noise: SettleNoise,
    /// The current solve ended in a branch verdict (a failed checked continuation).
    pub verdict: bool,
}

impl Iterate {
    /// The status of a solve (or of a Newton run inside one) that stops at the current
    /// state (max-norm scaled residual of `res`); `stop` is why the iteration stopped.
    /// Every status of the shooting solve is decided here, so it is a function of the
    /// state handed back:
    /// - after a branch verdict (a failed checked continuation) `stop` stays, and so
    ///   does `Unstable` (a branch verdict on a converged state: Jacobi's test);
    /// - otherwise `Converged` exactly when the residual is within `tol` (the solve's
    ///   tolerance, at least the round-off floor, so a re-evaluation of the same state
    ///   agrees);
    /// - a path that believed it converged but whose returned state misses the
    ///   tolerance (it was re-evaluated after settling) is `Stalled`; any other `stop`
    ///   stays.
    pub fn status(&self, stop: SolveStatus) -> SolveStatus {
        match stop {
            _ if self.verdict => stop,
            SolveStatus::Unstable => stop,
            // the round-off floor overflowed (loads near the range of f64, e.g. a force
            // of 1e300 N): every residual would be within it, so none certifies a solution
            _ if self.tol == f64::INFINITY => SolveStatus::NonFinite,
            _ if max_abs(&self.res) <= self.tol => SolveStatus::Converged,
            SolveStatus::Converged => SolveStatus::Stalled,
            _ => stop,
        }
    }
}

/// The load path: continuation's last converged points and tangent, the warm solve's
/// start and first step (the branch checks), and the secant predictor's history.
#[derive(Clone)]
pub(super) struct Path {
    /// Continuation: the last two converged points.
    pub x_ok: Vec<f64>,
    pub x_prev: Vec<f64>,
    /// Warm solve: the start and the point after the first accepted Newton step.
    pub x_start: Vec<f64>,
    pub x_first: Vec<f64>,
    pub first_taken: bool,
    /// Checked continuation: tangent at the last converged point, and the tip (m) and
    /// its tangent there (the tip is checked too: with tensioned cables the base
    /// wrench alone does not fix the shape, the chords' settled state does).
    pub x_tan: Vec<f64>,
    pub tip_ok: Vector3<f64>,
    pub tip_tan: Vector3<f64>,
    /// Warm solve: tip at the start and after the first accepted step.
    pub tip_start: Vector3<f64>,
    pub tip_first: Vector3<f64>,
    /// Warm solves: secant predictor from the last solutions.
    pub secant: Secant,
    /// The secant predictor's auxiliary values: the condensed coupling's settled next
    /// holes in their guides' frames (`pass::local_next`).
    pub holes_aux: Vec<f64>,
    /// Load intensity of the last solve.
    pub last_intensity: f64,
}

impl Path {
    /// Remember the point `x` (tip `tip`) after the first accepted Newton step.
    pub fn note_first_step(&mut self, x: &[f64], tip: Vector3<f64>) {
        if !self.first_taken {
            self.first_taken = true;
            self.x_first.copy_from_slice(x);
            self.tip_first = tip;
        }
    }
}

/// The Jacobian: its factorisation, the Broyden inverse of the chord steps and the
/// count of evaluations in the current solve.
#[derive(Clone)]
pub(super) struct Jacobian {
    pub lu: DenseLu,
    /// `lu` holds a factorised Jacobian of this plan (possibly from an earlier point).
    pub lu_valid: bool,
    /// Chord steps: the inverse of `lu`'s Jacobian with Broyden updates.
    pub broyden: Broyden,
    /// Chord steps use `broyden` (warm solves only: cold solves and continuation keep
    /// the plain chord steps, which served them better: `forward_cold_tensioned`
    /// took 1.6x as long with the updates).
    pub use_broyden: bool,
    pub evals: u64,
}

impl Jacobian {
    /// The Newton step `dx = -J^-1 res`: from the factors when `fresh` or without
    /// `use_broyden`, else from their inverse with the Broyden updates so far.
    pub fn step(&mut self, fresh: bool, res: &[f64], dx: &mut [f64]) {
        if fresh || !self.use_broyden {
            for (d, r) in dx.iter_mut().zip(res) {
                *d = -r;
            }
            self.lu.solve_in_place(dx);
        } else {
            self.inverse_step(res, dx);
        }
    }

    /// `dx = -H res` with `H` the factors' inverse and its Broyden updates.
    pub fn inverse_step(&mut self, res: &[f64], dx: &mut [f64]) {
        self.broyden.sync(&self.lu);
        self.broyden.step(res, dx);
    }
}

/// The pass buffers: one per number type (`f64`, `Dual<3>`, `Dual<6>`, the condensed
/// coupling's sweeps, the arc coupling's wide sweep), and what the last `f64` pass was.
#[derive(Clone)]
pub(super) struct Passes {
    pub b64: PassBuf<f64>,
    pub b3: PassBuf<Dual<3>>,
    pub b6: PassBuf<Dual<6>>,
    /// Condensed coupling: the sweep buffer with the plan's local directions.
    pub wide: Option<Wide>,
    /// Arc coupling: one sweep over up to [`ARC_SWEEP`] directions of `[x; theta]`
    /// (a three-segment, nine-tendon robot's `[x; T]` in one pass, not three `Dual<6>`).
    pub b_arc: Option<Box<PassBuf<Dual<ARC_SWEEP>>>>,
    /// Load scale and outcome of the last `f64` pass (its unknowns are `b64.x`).
    pub last_pass: Option<f64>,
}

impl Passes {
    /// Set load parameter `k` to `v` in every buffer; `true` when it changed (the
    /// last pass, and its settled next holes, then belong to the old value).
    pub fn set_theta(&mut self, k: usize, v: f64) -> bool {
        let changed = self.b64.theta[k] != v;
        if changed {
            self.last_pass = None;
        }
        self.b64.theta[k] = v;
        self.b3.theta[k] = Dual::constant(v);
        self.b6.theta[k] = Dual::constant(v);
        if let Some(w) = self.wide.as_mut() {
            w.set_theta(k, v);
        }
        if let Some(b) = self.b_arc.as_mut() {
            b.theta[k] = Dual::constant(v);
        }
        changed
    }

    /// The first `p` load parameters of the dual buffers back to constants (a sweep
    /// over `[x; theta]` seeded them).
    pub fn unseed_theta(&mut self, p: usize) {
        for k in 0..p {
            let v = self.b64.theta[k];
            self.b3.theta[k] = Dual::constant(v);
            self.b6.theta[k] = Dual::constant(v);
        }
    }

    /// Right-hand-side evaluations in dual-number passes.
    pub fn dual_rhs(&self) -> u64 {
        self.b3.rhs_evals
            + self.b6.rhs_evals
            + self.wide.as_ref().map_or(0, Wide::rhs_evals)
            + self.b_arc.as_ref().map_or(0, |b| b.rhs_evals)
    }

    /// Right-hand-side evaluations in all passes.
    pub fn rhs_count(&self) -> u64 {
        self.b64.rhs_evals + self.dual_rhs()
    }

    /// The rollback's copy: `wide` and `last_pass` always; the other buffers whole
    /// under the condensed coupling (its next holes and matrices are carried from pass
    /// to pass: `condensed`, of either side), else what a later pass reads
    /// (`PassBuf::warm_copy_uncondensed`).
    pub fn warm_copy_from(&mut self, src: &Self, condensed: bool) {
        warm_fields!(self, src, copy: [wide, last_pass], keep: [b64, b3, b6, b_arc]);
        if condensed {
            self.b64.warm_copy_from(&src.b64);
            self.b3.warm_copy_from(&src.b3);
            self.b6.warm_copy_from(&src.b6);
            self.b_arc.warm_copy_from(&src.b_arc);
        } else {
            self.b64.warm_copy_uncondensed(&src.b64, true);
            self.b3.warm_copy_uncondensed(&src.b3, false);
            self.b6.warm_copy_uncondensed(&src.b6, false);
            if let (Some(a), Some(b)) = (self.b_arc.as_mut(), src.b_arc.as_ref()) {
                a.warm_copy_uncondensed(b, false);
            }
        }
    }

    /// Debug builds, after a rollback: the state the rollback does not copy set to NaN
    /// (uncondensed plans only: `PassBuf::poison_uncopied`).
    pub fn poison_uncopied(&mut self, condensed: bool) {
        if !condensed {
            self.b64.poison_uncopied(true);
            self.b3.poison_uncopied(false);
            self.b6.poison_uncopied(false);
            if let Some(b) = self.b_arc.as_mut() {
                b.poison_uncopied(false);
            }
        }
    }
}

/// Sensitivities to the load parameters from the last sweep over `[x; theta]`.
#[derive(Clone)]
pub(super) struct Sensitivities {
    /// d(shooting residual)/d[x; theta], row-major `n x (n + p)`.
    pub dres: Vec<f64>,
    /// d(cable length)/d[x; theta], row-major `c x (n + p)`.
    pub dlen: Vec<f64>,
    pub col: Vec<f64>,
    /// `dx/dtheta` from the last sensitivity sweep, row-major `n x p` (predictor).
    pub dxdtheta: Vec<f64>,
    pub dxdtheta_valid: bool,
}

impl Sensitivities {
    /// Implicit differentiation with `lu` factorising `R_x` (`n x n`): `dx/dtheta =
    /// -R_x^-1 R_theta` into `dxdtheta`, and `dl/dtheta = C_theta + C_x dx/dtheta`
    /// (`c x p`, row-major) into `out`.
    pub fn eliminate(&mut self, lu: &DenseLu, n: usize, p: usize, c: usize, out: &mut [f64]) {
        let w = n + p;
        for k in 0..p {
            for r in 0..n {
                self.col[r] = self.dres[r * w + n + k];
            }
            lu.solve_in_place(&mut self.col);
            for r in 0..n {
                self.dxdtheta[r * p + k] = -self.col[r];
            }
            for j in 0..c {
                let mut g = self.dlen[j * w + n + k];
                for r in 0..n {
                    g -= self.dlen[j * w + r] * self.col[r];
                }
                out[j * p + k] = g;
            }
        }
        self.dxdtheta_valid = true;
    }
}

/// What the last evaluation or solve hands out (single shooting).
#[derive(Clone)]
pub(super) struct Outcome {
    pub tip: Vector3<f64>,
    /// Tip axis `R(L) e_z` of the last evaluated point (unit, world frame).
    pub tip_axis: Vector3<f64>,
    pub report: SolveReport,
    pub has_solution: bool,
}

/// Multiple shooting for large loads (`multi.rs`); `active` when it holds the current
/// solution.
#[derive(Clone)]
pub(super) struct Multiple {
    pub solver: Multi,
    pub active: bool,
}

/// `WarmCopy` of the parts a rollback copies whole: every field listed.
macro_rules! warm_parts {
    ($($t:ident: [$($f:ident),* $(,)?]),* $(,)?) => {$(
        impl WarmCopy for $t {
            fn warm_copy_from(&mut self, src: &Self) {
                warm_fields!(self, src, copy: [$($f),*], keep: []);
            }
        }
    )*};
}

warm_parts!(
    Iterate: [x, x_trial, dx, res, x_best, best_res, tol, noise, verdict],
    Path: [
        x_ok, x_prev, x_start, x_first, first_taken, x_tan, tip_ok, tip_tan, tip_start,
        tip_first, secant, holes_aux, last_intensity,
    ],
    Jacobian: [lu, lu_valid, broyden, use_broyden, evals],
    Sensitivities: [dres, dlen, col, dxdtheta, dxdtheta_valid],
    Outcome: [tip, tip_axis, report, has_solution],
    Multiple: [solver, active],
);
