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

/// Directions of the arc coupling's sweep buffer (`b_arc`): the shooting unknowns and
/// up to nine tensions, a three-segment, nine-tendon robot's `[x; T]`.
const ARC_SWEEP: usize = 15;

// Joint-estimator methods (linearisation at any point): a child module, so it reads
// the buffers above without widening their visibility.
pub(super) mod joint;

// Tendon mechanics: hole positions and per-chord tension factors.
mod chords;

// Dual-number sweeps: the Jacobian passes and the condensed coupling's buffers.
mod sweep;
use sweep::{sweep, Wide};

mod broyden;
use broyden::Broyden;

mod predict;
use predict::Secant;

mod continuation;
mod multi;
mod newton;
mod noise;
use noise::SettleNoise;
mod output;
mod sens;
// The solve entry: warm Newton, the cold path, the report.
mod solve;

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
    /// The point `res` belongs to, for measuring the condensed coupling's settle noise.
    noise: SettleNoise,
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
    /// Tip axis `R(L) e_z` of the last evaluated point (unit, world frame).
    tip_axis: Vector3<f64>,
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
            noise: SettleNoise::new(n, plan.condensed),
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
            tip_axis: Vector3::z(),
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
    /// Replace [`SolverSettings::tendons`] alone: the shooting solve never reads
    /// them (only the owning [`crate::tendons::TendonWorkspace`] does), so nothing is
    /// rebuilt. The caller has validated them.
    pub(crate) fn set_tendon_settings(&mut self, tendons: crate::settings::TendonSettings) {
        self.settings.tendons = tendons;
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
            self.noise.forget();
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
                self.noise.forget();
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

    /// The plan its passes run (tests of the pass itself).
    #[cfg(test)]
    pub(crate) fn plan_mut(&mut self) -> &mut Plan {
        &mut self.plan
    }

    /// Current load parameters.
    pub fn theta(&self) -> &[f64] {
        &self.b64.theta
    }

    /// Replace the settings (rebuilds the plan; allocates). The load parameters and
    /// their values `theta` are kept, as in [`Workspace::set_loads`]: a workspace
    /// owned by a [`crate::tendons::TendonWorkspace`] carries the tensions there, and
    /// dropping them would make its next solve panic on a length mismatch. The
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
        // the round-off floor overflowed (loads near the range of f64, e.g. a force
        // of 1e300 N): every residual would be within it, so none certifies a solution
        _ if tolerance == f64::INFINITY => SolveStatus::NonFinite,
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

impl crate::math::warm::WarmCopy for Workspace {
    /// Everything a solve changes; the robot, loads, settings and plan are
    /// configuration (changed only by the caller) and stay as they are.
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src, copy: [
            x, x_trial, x_best, best_res, x_ok, x_prev, x_start, x_first, first_taken, x_tan,
            tip_ok, tip_tan, tip_start, tip_first, last_intensity, tol, noise, branch_verdict,
            dx, res, lu, broyden, use_broyden, secant, holes_aux, wide,
            last_pass, has_solution, sens_s, sens_m, sens_col, dxdtheta, dxdtheta_valid,
            lu_valid, tip, tip_axis, report, jac_evals, multi, multi_active,
        ], keep: [robot, loads, settings, plan, multi_supported, b64, b3, b6, b_arc]);
        // the pass buffers: whole under the condensed coupling (its next holes and
        // matrices are carried from pass to pass), else what a later pass reads
        // (`PassBuf::warm_copy_uncondensed`)
        if self.plan.condensed || src.plan.condensed {
            crate::math::warm::WarmCopy::warm_copy_from(&mut self.b64, &src.b64);
            crate::math::warm::WarmCopy::warm_copy_from(&mut self.b3, &src.b3);
            crate::math::warm::WarmCopy::warm_copy_from(&mut self.b6, &src.b6);
            crate::math::warm::WarmCopy::warm_copy_from(&mut self.b_arc, &src.b_arc);
        } else {
            self.b64.warm_copy_uncondensed(&src.b64, true);
            self.b3.warm_copy_uncondensed(&src.b3, false);
            self.b6.warm_copy_uncondensed(&src.b6, false);
            if let (Some(a), Some(b)) = (self.b_arc.as_mut(), src.b_arc.as_ref()) {
                a.warm_copy_uncondensed(b, false);
            }
        }
        // the plan is configuration but for the friction's capstan factors per
        // chord, which a tendon solve updates (`set_chord_factors`)
        for (a, b) in self.plan.cables.iter_mut().zip(&src.plan.cables) {
            crate::math::warm::WarmCopy::warm_copy_from(&mut a.factor, &b.factor);
        }
    }
}

impl Workspace {
    /// Debug builds, after a rollback: the pass buffers' state the rollback does
    /// not copy set to NaN ([`crate::statics::pass::PassBuf::poison_uncopied`]).
    pub(crate) fn poison_uncopied(&mut self) {
        if !self.plan.condensed {
            self.b64.poison_uncopied(true);
            self.b3.poison_uncopied(false);
            self.b6.poison_uncopied(false);
            if let Some(b) = self.b_arc.as_mut() {
                b.poison_uncopied(false);
            }
        }
    }
}
