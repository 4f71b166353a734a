//! The reusable solver workspace: buffers sized once per plan, Newton with an exact
//! dual-number Jacobian, backtracking line search, warm starts, load continuation.

use super::floor::residual_floor;
use super::intensity::load_intensity;
use super::multiple::Multi;
use super::pass::{pass, PassBuf, Recording, LOCAL_TOL};
use super::plan::{ParamSite, Plan};
use super::{GuidePose, Solution, SolveReport, SolveStatus};
use crate::cables::{segments, CableLength};
use crate::error::ModelError;
use crate::loads::Loads;
use crate::math::{DenseLu, Dual};
use crate::robot::Robot;
use crate::settings::SolverSettings;
use nalgebra::Vector3;

/// Newton iterations a cold start gets before continuation takes over.
const COLD_BUDGET: usize = 4;
/// Directions of the arc coupling's sweep buffer (`b_arc`): the shooting unknowns and
/// up to nine tensions, a three-segment, nine-tendon robot's `[x; T]`.
const ARC_SWEEP: usize = 15;
/// Newton iterations per continuation step.
const CONTINUATION_BUDGET: usize = 10;

/// Load intensity (see `intensity.rs`) above which a cold solve under loads outside
/// Jacobi's test (tensioned cables, body-frame loads) is a branch-checked load
/// continuation from the unloaded rod instead of a Newton from the straight rod. On the
/// track demo a cold Newton lands on the continued branch up to 6 and on other
/// equilibria from 7 (README "Where methods fail"): half of 6, for margin.
pub const CERTIFY_INTENSITY: f64 = 3.0;
/// Largest load-intensity increment of one step of the branch-checked continuation.
const CERTIFY_STEP: f64 = 2.0;
/// A branch-checked continuation step is rejected (and halved) when the corrector
/// moves the unknowns more than this fraction of the secant predictor's own move.
const CORRECTOR_RATIO: f64 = 0.5;
/// A warm solve has left its branch when, after the first step `d1`, Newton still moved
/// the unknowns by more than `WARM_JUMP_RATIO |d1| + WARM_JUMP_FLOOR` (scaled units,
/// max norm): its tangent step no longer described where it went.
const WARM_JUMP_RATIO: f64 = 1.0;
const WARM_JUMP_FLOOR: f64 = 1e-3;
/// Largest change of load intensity a warm solve under loads outside Jacobi's test
/// may take above [`CERTIFY_INTENSITY`] before it is solved as a checked cold solve.
const WARM_STEP_INTENSITY: f64 = 0.25;
/// A warm solve under world-fixed loads that moved the unknowns (scaled) or the tip
/// (in units of L) by more than this also gets Jacobi's test.
const WARM_CHECK_STEP: f64 = 0.05;

/// A reused (chord) Jacobian's full step must shrink `||r||_2` by this factor.
const CHORD_CONTRACTION: f64 = 0.1;
/// Chord steps allowed per Jacobian before it is refreshed anyway.
const MAX_CHORD_STEPS: usize = 8;

// Joint-estimator methods (linearisation at any point): a child module, so it reads
// the buffers above without widening their visibility.
pub(super) mod joint;

// Tendon mechanics: hole positions and per-chord tension factors.
mod chords;

// Dual-number sweeps: the Jacobian passes and the condensed coupling's buffers.
mod sweep;
use sweep::{sweep, Wide};

mod broyden;
/// Largest chord step (scaled unknowns) that refines a solution for the load-path
/// predictor's history (`predict.rs`): the step from a converged residual is about
/// the tolerance; a larger one means a stale or ill-conditioned Jacobian, and the
/// solution is kept as it is.
const REFINE_MAX_STEP: f64 = 1e-6;
/// Only a solution whose residual is above this fraction of the tolerance is refined:
/// below it the cubic's eightfold amplification stays under the tolerance anyway, and
/// the chord step from such a residual is mostly round-off. Why not always: with the
/// condensed coupling a pass's residual depends on where its next holes start by up to
/// ~2e-10 near the end of the documented region (`tests/stability.rs`, tension
/// intensity 6.08: the same unknowns evaluated 4.7e-11 and 2.5e-10), and refining every
/// solution there moved a warm step's start into that noise, where Newton's line
/// search stalled (`Stalled` at 2.5e-10); at 0.1 the step converges and Till's 100-disk
/// ramp keeps its gain (0.14 Newton iterations a solve, 0.12 refining every solution).
const REFINE_FROM: f64 = 0.1;
use broyden::Broyden;

mod predict;
use predict::Secant;

mod continuation;
mod multi;
mod newton;
mod output;
mod sens;

/// Where Newton starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// From the rigid straight-rod reactions; continuation if that fails.
    Cold,
    /// From the previous solution in this workspace (cold if there is none).
    Warm,
}

/// Solver state for repeated solves of one robot: allocate once, solve many times.
///
/// [`Workspace::set_loads`] with the same load structure and [`Workspace::solve`]
/// with [`Start::Warm`] do not allocate.
#[derive(Clone)]
pub struct Workspace {
    robot: Robot,
    loads: Loads,
    settings: SolverSettings,
    plan: Plan,
    x: Vec<f64>,
    x_trial: Vec<f64>,
    /// Lowest-residual iterate at full load during the current solve.
    x_best: Vec<f64>,
    best_res: f64,
    /// Continuation: the last two converged points.
    x_ok: Vec<f64>,
    x_prev: Vec<f64>,
    /// Warm solve: the start and the point after the first accepted Newton step.
    x_start: Vec<f64>,
    x_first: Vec<f64>,
    first_taken: bool,
    /// Checked continuation: tangent at the last converged point, and the tip (m) and
    /// its tangent there (the tip is checked too: with tensioned cables the base
    /// wrench alone does not fix the shape, the chords' settled state does).
    x_tan: Vec<f64>,
    tip_ok: Vector3<f64>,
    tip_tan: Vector3<f64>,
    /// Warm solve: tip at the start and after the first accepted step.
    tip_start: Vector3<f64>,
    tip_first: Vector3<f64>,
    /// Load intensity of the last solve.
    last_intensity: f64,
    /// Tolerance of the current solve: `settings.tolerance` raised to the round-off
    /// floor of the residual ([`Workspace::residual_floor`]).
    tol: f64,
    /// The current solve ended in a branch verdict (a failed checked continuation).
    branch_verdict: bool,
    dx: Vec<f64>,
    res: Vec<f64>,
    lu: DenseLu,
    /// Chord steps: the inverse of `lu`'s Jacobian with Broyden updates.
    broyden: Broyden,
    /// Chord steps use `broyden` (warm solves only: cold solves and continuation keep
    /// the plain chord steps, which served them better: `forward_cold_tensioned`
    /// took 1.6x as long with the updates).
    use_broyden: bool,
    /// Warm solves: secant predictor from the last two solutions.
    secant: Secant,
    /// The secant predictor's auxiliary values: the condensed coupling's settled next
    /// holes in their guides' frames (`pass::local_next`).
    holes_aux: Vec<f64>,
    b64: PassBuf<f64>,
    b3: PassBuf<Dual<3>>,
    b6: PassBuf<Dual<6>>,
    /// Condensed coupling: the sweep buffer with the plan's local directions.
    wide: Option<Wide>,
    /// Arc coupling: one sweep over up to [`ARC_SWEEP`] directions of `[x; theta]`
    /// (a three-segment, nine-tendon robot's `[x; T]` in one pass, not three `Dual<6>`).
    b_arc: Option<Box<PassBuf<Dual<ARC_SWEEP>>>>,
    /// Load scale and outcome of the last `f64` pass (its unknowns are `b64.x`).
    last_pass: Option<f64>,
    has_solution: bool,
    /// d(shooting residual)/d[x; theta], row-major `n x (n + p)`.
    sens_s: Vec<f64>,
    /// d(cable length)/d[x; theta], row-major `c x (n + p)`.
    sens_m: Vec<f64>,
    sens_col: Vec<f64>,
    /// `dx/dtheta` from the last sensitivity sweep, row-major `n x p` (predictor).
    dxdtheta: Vec<f64>,
    dxdtheta_valid: bool,
    /// `lu` holds a factorised Jacobian of this plan (possibly from an earlier point).
    lu_valid: bool,
    tip: Vector3<f64>,
    report: SolveReport,
    jac_evals: u64,
    /// Multiple shooting for large loads (`multi.rs`); `multi_active` when it holds
    /// the current solution.
    multi: Multi,
    multi_active: bool,
    /// `Multi::supports(&plan)`, a function of the plan's structure (fixed for a
    /// workspace: `set_loads` rebuilds it when the structure changes), so not
    /// re-derived by every solve (2 % of a warm solve on a 100-disk robot).
    multi_supported: bool,
}

impl Workspace {
    /// Validate and build the plan and buffers.
    pub fn new(robot: Robot, loads: Loads, settings: SolverSettings) -> Result<Self, ModelError> {
        Self::with_params(robot, loads, settings, &[])
    }

    /// Like [`Workspace::new`], with load parameters `theta` that add to the scene's
    /// loads (all zero initially; see [`Workspace::set_theta`]).
    pub fn with_params(
        robot: Robot,
        loads: Loads,
        settings: SolverSettings,
        params: &[ParamSite],
    ) -> Result<Self, ModelError> {
        let plan = Plan::new(&robot, &loads, &settings, params)?;
        let multi_supported = Multi::supports(&plan);
        let n = plan.n_unknowns;
        let (p, c) = (params.len(), robot.cables().len());
        let tolerance = settings.tolerance;
        Ok(Self {
            sens_s: vec![0.0; n * (n + p)],
            sens_m: vec![0.0; c * (n + p)],
            sens_col: vec![0.0; n],
            dxdtheta: vec![0.0; n * p],
            dxdtheta_valid: false,
            b64: PassBuf::new(&plan),
            b3: PassBuf::new(&plan),
            b6: PassBuf::new(&plan),
            wide: Wide::new(&plan),
            b_arc: plan.arc.then(|| Box::new(PassBuf::new(&plan))),
            last_pass: None,
            x: vec![0.0; n],
            x_trial: vec![0.0; n],
            x_best: vec![0.0; n],
            best_res: f64::INFINITY,
            x_ok: vec![0.0; n],
            x_prev: vec![0.0; n],
            x_start: vec![0.0; n],
            x_first: vec![0.0; n],
            first_taken: false,
            x_tan: vec![0.0; n],
            tip_ok: Vector3::zeros(),
            tip_tan: Vector3::zeros(),
            tip_start: Vector3::zeros(),
            tip_first: Vector3::zeros(),
            last_intensity: 0.0,
            tol: tolerance,
            branch_verdict: false,
            dx: vec![0.0; n],
            res: vec![0.0; n],
            lu: DenseLu::new(n),
            broyden: Broyden::new(n),
            use_broyden: false,
            secant: Secant::new(n, super::pass::local_next_len(&plan)),
            holes_aux: vec![0.0; super::pass::local_next_len(&plan)],
            robot,
            loads,
            settings,
            plan,
            has_solution: false,
            lu_valid: false,
            tip: Vector3::zeros(),
            report: SolveReport {
                status: SolveStatus::NonFinite,
                iterations: 0,
                residual: f64::INFINITY,
                tolerance,
                rhs_evals: 0,
                jacobian_evals: 0,
                continuation_steps: 0,
                unknowns: n,
            },
            jac_evals: 0,
            multi: Multi::new(),
            multi_active: false,
            multi_supported,
        })
    }

    /// The robot.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }
    /// The current loads.
    pub fn loads(&self) -> &Loads {
        &self.loads
    }
    /// The settings.
    pub fn settings(&self) -> &SolverSettings {
        &self.settings
    }
    /// Report of the last solve.
    pub fn report(&self) -> &SolveReport {
        &self.report
    }
    /// Number of shooting unknowns for the current loads.
    pub fn unknowns(&self) -> usize {
        self.plan.n_unknowns
    }

    /// Replace the loads. Keeps the warm start and does not allocate when the load
    /// structure (point-load sites and frames, set of tensioned cables) is unchanged.
    pub fn set_loads(&mut self, loads: &Loads) -> Result<(), ModelError> {
        loads.validate(&self.robot)?;
        if self.plan.same_structure(loads) {
            self.plan.set_load_values(loads);
            self.loads.clone_from(loads);
        } else {
            let theta = self.b64.theta.clone();
            let params = self.plan.params.clone();
            *self = Self::with_params(
                self.robot.clone(),
                loads.clone(),
                self.settings.clone(),
                &params,
            )?;
            self.set_theta(&theta);
        }
        Ok(())
    }

    /// Load parameters of this workspace.
    pub fn params(&self) -> &[ParamSite] {
        &self.plan.params
    }

    /// Set the load parameters `theta` (units per [`ParamSite`]); no allocation.
    pub fn set_theta(&mut self, theta: &[f64]) {
        for (k, v) in theta.iter().enumerate().take(self.plan.params.len()) {
            if self.b64.theta[k] != *v {
                // the last pass (and its settled next holes) belongs to the old value
                self.last_pass = None;
            }
            self.b64.theta[k] = *v;
            self.b3.theta[k] = Dual::constant(*v);
            self.b6.theta[k] = Dual::constant(*v);
            if let Some(w) = self.wide.as_mut() {
                w.set_theta(k, *v);
            }
            if let Some(b) = self.b_arc.as_mut() {
                b.theta[k] = Dual::constant(*v);
            }
        }
    }

    /// Set `theta` and move the shooting unknowns by the first-order predictor
    /// `dx = (dx/dtheta) dtheta` from the last [`Workspace::length_sensitivities`]
    /// (so the following warm solve starts O(dtheta^2) from the equilibrium).
    /// No allocation.
    pub fn set_theta_predicted(&mut self, theta: &[f64]) {
        let (n, p) = (self.plan.n_unknowns, self.plan.params.len());
        if self.dxdtheta_valid && self.has_solution {
            for r in 0..n {
                let row = &self.dxdtheta[r * p..(r + 1) * p];
                let dx: f64 = row
                    .iter()
                    .zip(theta)
                    .zip(&self.b64.theta)
                    .map(|((d, t), t0)| d * (t - t0))
                    .sum();
                self.x[r] += dx;
            }
        }
        self.set_theta(theta);
    }

    /// Current load parameters.
    pub fn theta(&self) -> &[f64] {
        &self.b64.theta
    }

    /// Replace the settings (rebuilds the plan; allocates). The load parameters and
    /// their values `theta` are kept, as in [`Workspace::set_loads`]: a workspace
    /// owned by a [`crate::tendons::TendonWorkspace`] carries the tensions there, and
    /// dropping them made its next solve panic on a length mismatch (found in
    /// session 14 by changing the tolerance of the FTDCR v4 scene's workspace). The
    /// unknowns are kept too when their number is unchanged, as a starting point for
    /// [`Workspace::adopt_unknowns`] callers; the workspace holds no solution (a
    /// `Start::Warm` solve starts cold).
    pub fn set_settings(&mut self, settings: SolverSettings) -> Result<(), ModelError> {
        let theta = self.b64.theta.clone();
        let params = self.plan.params.clone();
        let x = std::mem::take(&mut self.x);
        *self = Self::with_params(self.robot.clone(), self.loads.clone(), settings, &params)?;
        self.set_theta(&theta);
        if x.len() == self.x.len() {
            self.x = x;
        }
        Ok(())
    }

    /// Solve in place. Never panics; the status says whether the result is usable.
    ///
    /// With `branch_guard` (default) a `converged` status also means "on the branch
    /// reached by loading the unloaded rod quasi-statically" (cold) or "on the branch
    /// of the previous solution" (warm), as far as the guard can tell: Jacobi's
    /// condition for world-fixed loads, a branch-checked load continuation for other
    /// loads above a load intensity of 3 (`CERTIFY_INTENSITY`), and for warm solves a
    /// check that Newton went where its first (tangent) step pointed, else a checked
    /// cold solve.
    pub fn solve(&mut self, start: Start) -> SolveReport {
        let rhs0 = self.rhs_count();
        self.jac_evals = 0;
        self.best_res = f64::INFINITY;
        let mut warm = start == Start::Warm && self.has_solution;
        // branch guard, warm: under loads outside Jacobi's test above the certify
        // intensity, a step of more than WARM_STEP_INTENSITY can land on another
        // equilibrium already in its first pass (the chords settle elsewhere), which no
        // check on the Newton path sees: such a step is solved as a checked cold solve
        let intensity = self.load_intensity();
        self.tol = self.settings.tolerance.max(self.residual_floor());
        self.branch_verdict = false;
        if let Some(rep) = self.multi_first(start, intensity) {
            return rep;
        }
        if warm
            && self.settings.branch_guard
            && !self.guarded()
            && intensity > CERTIFY_INTENSITY
            && (intensity - self.last_intensity).abs() > WARM_STEP_INTENSITY
        {
            warm = false;
        }
        let (mut status, mut iterations, mut continuation_steps) = (SolveStatus::NonFinite, 0, 0);
        let mut cold = !warm;
        // the secant predictor moves a warm start along the load path, except where
        // the branch guard's step check of large moves is in force
        // Not with load parameters: the estimators' inner solves keep their old paths
        // (with both on, tests/estimate_joint.rs's nested LM moved by 2.5e-7 relative
        // and an unobservable case changed status).
        let plain = self.plan.params.is_empty();
        let predict = plain && !(self.guarded() && intensity > CERTIFY_INTENSITY);
        let predicted = self.secant.start(
            &mut self.x,
            &mut self.holes_aux,
            &self.loads,
            &self.b64.theta,
            warm && predict,
        );
        if predicted {
            super::pass::set_local_next(&self.plan, &mut self.b64, &self.holes_aux, &self.x);
        }
        if warm {
            self.x_start.copy_from_slice(&self.x);
            self.b64.local_tol = LOCAL_TOL;
            self.use_broyden = plain;
            (status, iterations) = self.newton(1.0, self.settings.max_iterations);
            self.use_broyden = false;
            // branch guard, warm: a solve its tangent step did not describe may have
            // jumped to another equilibrium; answer as a cold (checked) solve would
            if status.is_converged()
                && self.settings.branch_guard
                && self.left_branch_checked(intensity)
            {
                cold = true;
                self.best_res = f64::INFINITY;
            }
            // a failed warm start falls back like a failed cold one
            cold |= !status.is_converged() && self.settings.continuation;
        }
        if cold {
            let (st, it, steps) = self.solve_cold();
            status = st;
            iterations += it;
            continuation_steps = steps;
        }
        if !status.is_converged() && self.best_res < max_abs(&self.res) {
            // hand back the best full-load iterate, not a partial-load point
            self.x.copy_from_slice(&self.x_best);
            self.eval_at(false, 1.0);
        }
        if self.b64.local_tol > LOCAL_TOL {
            // a failed solve's last point was evaluated with a loose inner tolerance
            self.b64.local_tol = LOCAL_TOL;
            self.eval_at(false, 1.0);
        }
        // the status of the state handed back, decided like every other one, unless
        // the branch guard gave its verdict on this solve
        let status = if self.branch_verdict {
            status
        } else {
            self.status_here(status)
        };
        if let Some(rep) = self.multi_fallback(status, intensity) {
            return rep;
        }
        self.has_solution = status.is_converged();
        if self.has_solution {
            super::pass::local_next(&self.plan, &self.b64, &mut self.holes_aux);
        }
        // the point the predictor extrapolates from: the solution with one more
        // chord step, no pass (`predict.rs`, "refined solutions")
        self.x_trial.copy_from_slice(&self.x);
        if self.has_solution
            && predict
            && self.lu_valid
            && max_abs(&self.res) > REFINE_FROM * self.tol
        {
            self.broyden.sync(&self.lu);
            self.broyden.step(&self.res, &mut self.dx);
            if self.dx.iter().all(|d| d.abs() <= REFINE_MAX_STEP) {
                for (x, d) in self.x_trial.iter_mut().zip(&self.dx) {
                    *x += d;
                }
                let (plan, b64) = (&self.plan, &self.b64);
                super::pass::refine_local_next(plan, b64, &self.dx, &mut self.holes_aux);
            }
        }
        self.secant.finish(
            self.has_solution,
            &self.x,
            &self.x_trial,
            &self.holes_aux,
            &self.loads,
            &self.b64.theta,
        );
        self.last_intensity = intensity;
        self.report = SolveReport {
            status,
            iterations,
            residual: max_abs(&self.res),
            tolerance: self.tol,
            rhs_evals: self.rhs_count() - rhs0,
            jacobian_evals: self.jac_evals,
            continuation_steps,
            unknowns: self.plan.n_unknowns,
        };
        self.report
    }

    /// Non-dimensional intensity of the current loads and load parameters (the sum of
    /// the bending angles each would cause alone: `P s^2/EI`, `M s/EI`, `T r s/EI`,
    /// weights like forces; see the `intensity` module).
    pub fn load_intensity(&self) -> f64 {
        load_intensity(&self.robot, &self.loads, &self.plan.params, &self.b64.theta)
    }

    /// Round-off floor of the scaled residual for the current loads and load
    /// parameters (see the `floor` module): the smallest tolerance a solve uses.
    pub fn residual_floor(&self) -> f64 {
        let intensity = self.load_intensity();
        residual_floor(
            &self.robot,
            &self.loads,
            &self.settings,
            &self.plan.params,
            &self.b64.theta,
            intensity,
        )
    }

    /// [`status_of`] the current state (`res`) with this solve's tolerance.
    fn status_here(&self, stop: SolveStatus) -> SolveStatus {
        status_of(max_abs(&self.res), self.tol, stop)
    }

    fn rhs_count(&self) -> u64 {
        self.b64.rhs_evals
            + self.b3.rhs_evals
            + self.b6.rhs_evals
            + self.wide.as_ref().map_or(0, Wide::rhs_evals)
            + self.b_arc.as_ref().map_or(0, |b| b.rhs_evals)
    }
}

/// The status of a solve (or of a Newton run inside one) that stops at a state with
/// max-norm scaled residual `residual`; `stop` is why the iteration stopped. Every
/// status of this file is decided here, so it is a function of the state handed back:
/// - `Unstable` (a branch verdict on a converged state: Jacobi's test) stays, and so
///   does a failed checked continuation's status (`Workspace::solve` skips this then);
/// - otherwise `Converged` exactly when `residual <= tolerance` (the solve's tolerance,
///   at least the round-off floor, so a re-evaluation of the same state agrees);
/// - a path that believed it converged but whose returned state misses the tolerance
///   (it was re-evaluated after settling) is `Stalled`; any other `stop` stays.
fn status_of(residual: f64, tolerance: f64, stop: SolveStatus) -> SolveStatus {
    match stop {
        SolveStatus::Unstable => stop,
        _ if residual <= tolerance => SolveStatus::Converged,
        SolveStatus::Converged => SolveStatus::Stalled,
        _ => stop,
    }
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |a, x| {
        if x.is_nan() {
            f64::INFINITY
        } else {
            a.max(x.abs())
        }
    })
}

fn norm2(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}
