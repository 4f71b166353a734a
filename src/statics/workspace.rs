//! The reusable solver workspace: buffers sized once per plan, Newton with an exact
//! dual-number Jacobian, backtracking line search, warm starts, load continuation.

use super::floor::residual_floor;
use super::intensity::load_intensity;
use super::pass::{pass, PassBuf, Recording, LOCAL_TOL};
use super::plan::{ParamSite, Plan};
use super::{GuidePose, Solution, SolveReport, SolveStatus};
use crate::cables::{path_length, segments, CableLength};
use crate::error::ModelError;
use crate::loads::Loads;
use crate::math::{DenseLu, Dual};
use crate::robot::Robot;
use crate::settings::SolverSettings;
use nalgebra::Vector3;

/// Newton iterations a cold start gets before continuation takes over.
const COLD_BUDGET: usize = 4;
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
#[path = "joint.rs"]
pub(super) mod joint;

// Tendon mechanics: hole positions and per-chord tension factors.
#[path = "chords.rs"]
mod chords;

// Dual-number sweeps: the Jacobian passes and the condensed coupling's buffers.
#[path = "sweep.rs"]
mod sweep;
use sweep::{sweep, Wide};

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
    b64: PassBuf<f64>,
    b3: PassBuf<Dual<3>>,
    b6: PassBuf<Dual<6>>,
    /// Condensed coupling: the sweep buffer with the plan's local directions.
    wide: Option<Wide>,
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

    /// Exact sensitivities of the cable lengths to `theta` at the current (converged)
    /// point, by implicit differentiation of the shooting problem:
    /// `dl/dtheta = dl/dtheta|x - dl/dx J_x^-1 dr/dtheta` (all partials from one
    /// dual-number sweep over `[x; theta]`). Writes `c x p` row-major into `out`,
    /// the lengths into `lengths`. No allocation. `false` if the sweep failed or
    /// `J_x` is singular.
    pub fn length_sensitivities(&mut self, out: &mut [f64], lengths: &mut [f64]) -> bool {
        let n = self.plan.n_unknowns;
        let p = self.plan.params.len();
        let c = self.plan.cables.len();
        let w = n + p;
        self.jac_evals += 1;
        let ok = if self.plan.condensed {
            self.condensed_sweeps(w, true, 1.0)
        } else if w <= 3 {
            sweep::<3>(
                &self.plan,
                &self.x,
                0,
                true,
                &mut self.b3,
                &mut self.sens_s,
                &mut self.sens_m,
                1.0,
            )
        } else {
            (0..w).step_by(6).all(|c0| {
                sweep::<6>(
                    &self.plan,
                    &self.x,
                    c0,
                    true,
                    &mut self.b6,
                    &mut self.sens_s,
                    &mut self.sens_m,
                    1.0,
                )
            })
        };
        // theta back to constants
        for k in 0..p {
            let v = self.b64.theta[k];
            self.b3.theta[k] = Dual::constant(v);
            self.b6.theta[k] = Dual::constant(v);
        }
        if !ok {
            return false;
        }
        let a = self.lu.matrix_mut();
        for r in 0..n {
            a[r * n..(r + 1) * n].copy_from_slice(&self.sens_s[r * w..r * w + n]);
        }
        match self.lu.factor() {
            Some(rc) if rc > 1e-14 => self.lu_valid = true,
            _ => {
                self.lu_valid = false;
                return false;
            }
        }
        for j in 0..c {
            let len = path_length(&self.plan.cables[j].base_hole, &self.b64.holes[j]);
            if let Some(l) = lengths.get_mut(j) {
                *l = len;
            }
        }
        for k in 0..p {
            for r in 0..n {
                self.sens_col[r] = self.sens_s[r * w + n + k];
            }
            self.lu.solve_in_place(&mut self.sens_col);
            for r in 0..n {
                self.dxdtheta[r * p + k] = -self.sens_col[r];
            }
            for j in 0..c {
                let mut g = self.sens_m[j * w + n + k];
                for r in 0..n {
                    g -= self.sens_m[j * w + r] * self.sens_col[r];
                }
                out[j * p + k] = g;
            }
        }
        self.dxdtheta_valid = true;
        true
    }

    /// Replace the settings (rebuilds the plan; allocates).
    pub fn set_settings(&mut self, settings: SolverSettings) -> Result<(), ModelError> {
        *self = Self::new(self.robot.clone(), self.loads.clone(), settings)?;
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
        if warm {
            self.x_start.copy_from_slice(&self.x);
            self.b64.local_tol = LOCAL_TOL;
            (status, iterations) = self.newton(1.0, self.settings.max_iterations);
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
        self.has_solution = status.is_converged();
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

    /// Cold solve: Newton from the straight rod (with Jacobi's test and continuation
    /// as fallback), or, for loads outside Jacobi's test above [`CERTIFY_INTENSITY`],
    /// the branch-checked continuation directly.
    fn solve_cold(&mut self) -> (SolveStatus, usize, usize) {
        self.cold_guess(1.0);
        self.lu_valid = false;
        self.b64.local_tol = 1e-9;
        if self.settings.branch_guard
            && !self.guarded()
            && self.load_intensity() > CERTIFY_INTENSITY
        {
            return self.checked_continuation();
        }
        // A cold Newton from the straight rod is cut short (heavy damping means it is
        // far from the basin); continuation with a secant predictor is then cheaper.
        let budget = if self.settings.continuation {
            COLD_BUDGET.min(self.settings.max_iterations)
        } else {
            self.settings.max_iterations
        };
        let (mut status, mut iterations) = self.newton(1.0, budget);
        let mut steps = 0;
        // branch guard: a cold Newton can land on an unstable equilibrium (looped or
        // inverted rod, seen from PL^2/EI ~ 5 on); continuation may still reach the
        // stable one from the unloaded rod
        if status.is_converged() && self.guarded() && self.conjugate_point().is_some() {
            status = SolveStatus::Unstable;
            // never hand back the unstable equilibrium as the best full-load iterate
            self.best_res = f64::INFINITY;
        }
        if !status.is_converged() && self.settings.continuation {
            let (st, it, s) = self.continuation();
            status = st;
            iterations += it;
            steps = s;
            if status.is_converged() && self.guarded() && self.conjugate_point().is_some() {
                status = SolveStatus::Unstable;
            }
        }
        (status, iterations, steps)
    }

    /// Warm solve left its branch: after the first accepted step `d1`, Newton moved
    /// the unknowns by more than `WARM_JUMP_RATIO |d1| + WARM_JUMP_FLOOR` (max norm).
    fn left_branch(&self) -> bool {
        if !self.first_taken {
            return false;
        }
        let d1 = max_abs_diff(&self.x_first, &self.x_start);
        let rest = max_abs_diff(&self.x, &self.x_first);
        let t1 = (self.tip_first - self.tip_start).norm() / self.plan.length;
        let trest = (self.tip - self.tip_first).norm() / self.plan.length;
        rest > WARM_JUMP_RATIO * d1 + WARM_JUMP_FLOOR
            || trest > WARM_JUMP_RATIO * t1 + WARM_JUMP_FLOOR
    }

    /// [`Workspace::left_branch`], and for a large step under world-fixed loads of
    /// intensity above [`CERTIFY_INTENSITY`] also Jacobi's test (one `Dual<3>` sweep,
    /// only then: the control loop's small steps, and mild loads, do not pay for it).
    fn left_branch_checked(&mut self, intensity: f64) -> bool {
        if self.left_branch() {
            return true;
        }
        let step = max_abs_diff(&self.x, &self.x_start);
        let moved = (self.tip - self.tip_start).norm() / self.plan.length;
        self.guarded()
            && intensity > CERTIFY_INTENSITY
            && (step > WARM_CHECK_STEP || moved > WARM_CHECK_STEP)
            && self.conjugate_point().is_some()
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
    }

    /// Condensed coupling: sweeps over `[x (; theta)]` in chunks of six outer
    /// directions with the plan's local directions, after making sure the assumed
    /// next holes belong to `x` at load scale `lam` (an `f64` pass if not).
    fn condensed_sweeps(&mut self, w: usize, with_theta: bool, lam: f64) -> bool {
        if self.last_pass != Some(lam) || self.b64.x != self.x {
            self.eval_at(false, lam);
            if self.last_pass != Some(lam) {
                return false;
            }
        }
        let (plan, x, b64) = (&self.plan, &self.x, &mut self.b64);
        let (jac_s, jac_m) = if with_theta {
            (&mut self.sens_s[..], &mut self.sens_m[..])
        } else {
            (self.lu.matrix_mut(), &mut [][..])
        };
        self.wide
            .as_mut()
            .is_some_and(|b| b.sweeps(plan, x, w, with_theta, b64, jac_s, jac_m, lam))
    }

    /// Straight-rod reactions as the starting point, loads scaled by `lam`.
    fn cold_guess(&mut self, lam: f64) {
        let p = &self.plan;
        let (f, m) = p.straight_wrench(lam);
        let off = if p.closed_form {
            0
        } else {
            for i in 0..3 {
                self.x[i] = f[i] / p.force_scale;
            }
            3
        };
        for i in 0..3 {
            self.x[off + i] = m[i] / p.moment_scale;
        }
        let axis = p.base_rot * Vector3::z();
        if p.condensed {
            // straight-rod next holes; a cold start does not reuse an old segment map
            self.b64.mlin_valid = false;
            for (j, c) in p.cables.iter().enumerate() {
                let route = &self.robot.cables()[j].route;
                for k in 0..c.len.saturating_sub(1) {
                    let s = self.robot.guides()[route[k + 1]].s;
                    self.b64.next[j][k] = p.base_r + axis * s + p.base_rot * c.hole_local[k + 1];
                }
            }
            for (g, a) in self.b64.anchor.iter_mut().enumerate() {
                *a = (p.base_r + axis * self.robot.guides()[g].s, p.base_rot);
            }
        }
        for (j, c) in p.cables.iter().enumerate() {
            if let Some(u) = c.unknowns {
                let route = &self.robot.cables()[j].route;
                for (k, &g) in route.iter().enumerate().skip(1) {
                    let s = self.robot.guides()[g].s;
                    let q = p.base_r + axis * s + p.base_rot * c.hole_local[k];
                    for a in 0..3 {
                        self.x[u + 3 * (k - 1) + a] = q[a] / p.length;
                    }
                }
            }
        }
    }

    /// Residual at `x` (f64 pass) into `res`; `false` when the pass failed.
    fn eval_at(&mut self, trial: bool, lam: f64) -> bool {
        let src = if trial { &self.x_trial } else { &self.x };
        self.b64.x.copy_from_slice(src);
        let out = pass(&self.plan, &mut self.b64, lam, None);
        self.last_pass = out.is_ok().then_some(lam);
        match out {
            Ok(y) => {
                self.tip = y.r;
                self.res.copy_from_slice(&self.b64.res);
                true
            }
            Err(_) => {
                // no residual at `x`: never leave an older one to decide a status
                self.res.fill(f64::INFINITY);
                false
            }
        }
    }

    /// Jacobian at `x` into the LU buffer.
    fn jacobian(&mut self, lam: f64) -> bool {
        let n = self.plan.n_unknowns;
        self.jac_evals += 1;
        if self.plan.condensed {
            return self.condensed_sweeps(n, false, lam);
        }
        let jac = self.lu.matrix_mut();
        if n <= 3 {
            sweep::<3>(
                &self.plan,
                &self.x,
                0,
                false,
                &mut self.b3,
                jac,
                &mut [],
                lam,
            )
        } else {
            (0..n).step_by(6).all(|c0| {
                sweep::<6>(
                    &self.plan,
                    &self.x,
                    c0,
                    false,
                    &mut self.b6,
                    jac,
                    &mut [],
                    lam,
                )
            })
        }
    }

    /// Newton at load scale `lam` from the current `x`.
    ///
    /// The Jacobian is exact (dual numbers) where it is evaluated, and is reused for
    /// further full steps while they contract the residual by at least
    /// [`CHORD_CONTRACTION`] (the chord method; warm starts reuse the previous solve's
    /// factorisation). A fresh Jacobian's step gets a backtracking line search on
    /// `||r||_2`; a stale one that does not contract is discarded and refreshed.
    fn newton(&mut self, lam: f64, max_iterations: usize) -> (SolveStatus, usize) {
        let n = self.plan.n_unknowns;
        self.first_taken = false;
        if !self.eval_at(false, lam) {
            self.res.iter_mut().for_each(|r| *r = f64::INFINITY);
            return (SolveStatus::NonFinite, 0);
        }
        self.tip_start = self.tip;
        let mut it = 0;
        let mut jacobians = 0;
        let mut chord_steps = 0;
        loop {
            if lam == 1.0 && max_abs(&self.res) < self.best_res {
                self.best_res = max_abs(&self.res);
                self.x_best.copy_from_slice(&self.x);
            }
            if self.status_here(SolveStatus::Converged).is_converged() {
                if self.b64.local_tol <= LOCAL_TOL {
                    return (self.status_here(SolveStatus::Converged), it);
                }
                // confirm with fully settled segments (condensed coupling)
                self.b64.local_tol = LOCAL_TOL;
                if !self.eval_at(false, lam) {
                    return (self.status_here(SolveStatus::NonFinite), it);
                }
                continue;
            }
            if chord_steps >= MAX_CHORD_STEPS {
                self.lu_valid = false;
            }
            // inexact inner solves while far away: 1e-10 of the outer residual,
            // between LOCAL_TOL and 1e-9 (full accuracy once res < 1e-3)
            self.b64.local_tol = (1e-10 * max_abs(&self.res)).clamp(LOCAL_TOL, 1e-9);
            let fresh = !self.lu_valid;
            if fresh && jacobians >= max_iterations {
                return (self.status_here(SolveStatus::MaxIterations), it);
            }
            it += 1;
            if fresh {
                jacobians += 1;
                chord_steps = 0;
                if !self.jacobian(lam) {
                    return (self.status_here(SolveStatus::NonFinite), it);
                }
                match self.lu.factor() {
                    Some(rc) if rc > 1e-14 => self.lu_valid = true,
                    _ => return (self.status_here(SolveStatus::IllConditioned), it),
                }
            }
            for i in 0..n {
                self.dx[i] = -self.res[i];
            }
            self.lu.solve_in_place(&mut self.dx);
            let f0 = norm2(&self.res);
            if !fresh {
                for i in 0..n {
                    self.x_trial[i] = self.x[i] + self.dx[i];
                }
                chord_steps += 1;
                if self.eval_trial(lam) && norm2(&self.b64.res) < CHORD_CONTRACTION * f0 {
                    std::mem::swap(&mut self.x, &mut self.x_trial);
                    self.res.copy_from_slice(&self.b64.res);
                    self.note_first_step();
                } else {
                    self.lu_valid = false;
                }
                continue;
            }
            let mut alpha = 1.0;
            let mut accepted = false;
            for _ in 0..30 {
                for i in 0..n {
                    self.x_trial[i] = self.x[i] + alpha * self.dx[i];
                }
                if self.eval_trial(lam) && norm2(&self.b64.res) < (1.0 - 1e-4 * alpha) * f0 {
                    accepted = true;
                    break;
                }
                alpha *= 0.5;
            }
            if !accepted {
                self.eval_at(false, lam);
                self.lu_valid = false;
                return (self.status_here(SolveStatus::Stalled), it);
            }
            std::mem::swap(&mut self.x, &mut self.x_trial);
            self.res.copy_from_slice(&self.b64.res);
            self.note_first_step();
            if alpha < 1.0 {
                // far from the solution: the Jacobian changes quickly, do not reuse it
                self.lu_valid = false;
            }
        }
    }

    /// Residual at `x_trial` into `b64.res`; `false` when the pass failed.
    fn eval_trial(&mut self, lam: f64) -> bool {
        self.b64.x.copy_from_slice(&self.x_trial);
        let out = pass(&self.plan, &mut self.b64, lam, None);
        self.last_pass = out.is_ok().then_some(lam);
        match out {
            Ok(y) => {
                self.tip = y.r;
                true
            }
            Err(_) => false,
        }
    }

    /// Remember the point after the first accepted Newton step (warm branch check).
    fn note_first_step(&mut self) {
        if !self.first_taken {
            self.first_taken = true;
            self.x_first.copy_from_slice(&self.x);
            self.tip_first = self.tip;
        }
    }

    /// Natural-parameter continuation in the load scale from the unloaded rod, with a
    /// secant predictor from the last two converged load levels.
    fn continuation(&mut self) -> (SolveStatus, usize, usize) {
        let mut lam: f64 = 0.0;
        let mut step: f64 = 0.25;
        let mut iterations = 0;
        let mut steps = 0;
        self.cold_guess(0.0);
        self.lu_valid = false;
        self.x_ok.copy_from_slice(&self.x);
        self.x_prev.copy_from_slice(&self.x);
        let mut lam_prev: f64 = 0.0;
        let per_step = self.settings.max_iterations.min(CONTINUATION_BUDGET);
        while steps < self.settings.max_continuation_steps {
            let target = (lam + step).min(1.0);
            if lam > lam_prev {
                let k = (target - lam) / (lam - lam_prev);
                for i in 0..self.x.len() {
                    self.x[i] = self.x_ok[i] + k * (self.x_ok[i] - self.x_prev[i]);
                }
            }
            let (st, it) = self.newton(target, per_step);
            iterations += it;
            steps += 1;
            if st.is_converged() {
                self.x_prev.copy_from_slice(&self.x_ok);
                lam_prev = lam;
                lam = target;
                self.x_ok.copy_from_slice(&self.x);
                if lam >= 1.0 {
                    return (self.status_here(st), iterations, steps);
                }
                if it <= 4 {
                    step *= 2.0;
                }
            } else {
                self.x.copy_from_slice(&self.x_ok);
                step *= 0.5;
                if step < 1e-4 {
                    self.eval_at(false, 1.0);
                    return (st, iterations, steps);
                }
            }
        }
        self.x.copy_from_slice(&self.x_ok);
        let (st, it) = self.newton(1.0, self.settings.max_iterations);
        (st, iterations + it, steps)
    }

    /// Branch-checked continuation (the branch guard for loads outside Jacobi's test):
    /// tangent predictor, steps capped at [`CERTIFY_STEP`] of load intensity, and a
    /// converged step is accepted only if
    /// - the corrector moved the unknowns by at most [`CORRECTOR_RATIO`] of the
    ///   predictor's own move (else it likely converged onto another branch), and
    /// - the shooting Jacobian's determinant kept the sign it has at the unloaded rod
    ///   (a sign change means the path passed a fold or bifurcation: past a fold the
    ///   equilibrium is the unstable sibling of the branch).
    ///
    /// A rejected step is halved; below `1e-4` of the load scale (a fold of the
    /// branch) the status is `stalled`, and running out of steps is `max_iterations`:
    /// never a full-load Newton from a partial load.
    fn checked_continuation(&mut self) -> (SolveStatus, usize, usize) {
        let max_step = (CERTIFY_STEP / self.load_intensity()).min(1.0);
        let mut step = max_step.min(0.25);
        let (mut lam, mut iterations, mut steps) = (0.0f64, 0, 0);
        let per_step = self.settings.max_iterations.min(CONTINUATION_BUDGET);
        self.cold_guess(0.0);
        let sign0 = match self.tangent(0.0) {
            Ok(sign) => sign,
            Err(st) => return (st, 0, 0),
        };
        self.x_ok.copy_from_slice(&self.x);
        self.x_prev.copy_from_slice(&self.x_tan);
        let mut last = SolveStatus::MaxIterations;
        while steps < self.settings.max_continuation_steps {
            let target = (lam + step).min(1.0);
            let h = target - lam;
            for i in 0..self.x.len() {
                self.x[i] = self.x_ok[i] + h * self.x_prev[i];
            }
            let (st, it) = self.newton(target, per_step);
            iterations += it;
            steps += 1;
            // corrector move over predictor move: O(h) on a smooth branch, O(1) after a
            // jump to another one
            let ratio = if st.is_converged() {
                self.corrector_ratio(h)
            } else {
                f64::INFINITY
            };
            let accept = ratio <= CORRECTOR_RATIO && self.tangent(target) == Ok(sign0);
            // next step from the ratio's linear growth in h, within [h/4, 2h]
            let grow = (0.8 * CORRECTOR_RATIO / ratio).clamp(0.25, 2.0);
            if accept {
                lam = target;
                self.x_ok.copy_from_slice(&self.x);
                self.x_prev.copy_from_slice(&self.x_tan);
                if lam >= 1.0 {
                    // the tangent's passes re-settled the chords from another start
                    // (residual 1.3e-12 against 1.0e-12 seen by the fuzzer): confirm
                    let (st, it) = self.newton(1.0, per_step);
                    return (st, iterations + it, steps);
                }
                step = (h * grow).min(max_step);
                continue;
            }
            last = if st.is_converged() {
                SolveStatus::Stalled
            } else {
                st
            };
            self.x.copy_from_slice(&self.x_ok);
            self.lu_valid = false;
            step = h * grow.min(0.5);
            if step < 1e-4 {
                break;
            }
        }
        self.x.copy_from_slice(&self.x_ok);
        self.eval_at(false, 1.0);
        // a branch verdict: the guard could not follow the branch to full load, so no
        // state of this solve counts as on it, whatever its residual (the partial-load
        // point evaluated at full load, or the best full-load iterate)
        self.best_res = f64::INFINITY;
        self.branch_verdict = true;
        let st = if step < 1e-4 {
            last
        } else {
            SolveStatus::MaxIterations
        };
        (st, iterations, steps)
    }

    /// How far the corrector of a checked continuation step of size `h` (from `x_ok`
    /// along the tangent in `x_prev`) moved, relative to the predictor's own move: the
    /// larger of the ratios for the unknowns and for the tip.
    fn corrector_ratio(&self, h: f64) -> f64 {
        let (mut dp, mut dc) = (0.0f64, 0.0f64);
        for i in 0..self.x.len() {
            let d = h * self.x_prev[i];
            dp = dp.max(d.abs());
            dc = dc.max((self.x[i] - self.x_ok[i] - d).abs());
        }
        let tip_pred = self.tip_ok + self.tip_tan * h;
        let (tp, tc) = ((self.tip_tan * h).norm(), (self.tip - tip_pred).norm());
        (dc / (dp + 1e-9)).max(tc / (tp + 1e-9 * self.plan.length))
    }

    /// Tangent `dx/dlam = -J^-1 dr/dlam` of the equilibrium path at `x` (converged at
    /// load scale `lam`) into `x_tan`, and the sign of `det J`: a fresh exact Jacobian
    /// and a forward difference of the residual in `lam`. Leaves that Jacobian
    /// factorised for the next corrector.
    fn tangent(&mut self, lam: f64) -> Result<f64, SolveStatus> {
        let n = self.plan.n_unknowns;
        self.jac_evals += 1;
        if !self.eval_at(false, lam) || !self.jacobian(lam) {
            return Err(SolveStatus::NonFinite);
        }
        match self.lu.factor() {
            Some(rc) if rc > 1e-14 => self.lu_valid = true,
            _ => return Err(SolveStatus::IllConditioned),
        }
        self.dx.copy_from_slice(&self.res);
        let eps = 1e-6;
        if !self.eval_at(false, lam + eps) {
            return Err(SolveStatus::NonFinite);
        }
        for i in 0..n {
            self.x_tan[i] = -(self.res[i] - self.dx[i]) / eps;
        }
        self.lu.solve_in_place(&mut self.x_tan);
        // the tip's tangent, by a pass from this point's settled chords
        if !self.eval_at(false, lam) {
            return Err(SolveStatus::NonFinite);
        }
        self.tip_ok = self.tip;
        for i in 0..n {
            self.x_trial[i] = self.x[i] + eps * self.x_tan[i];
        }
        if !self.eval_at(true, lam + eps) {
            return Err(SolveStatus::NonFinite);
        }
        self.tip_tan = (self.tip - self.tip_ok) / eps;
        // leave the pass state at `lam`
        self.eval_at(false, lam);
        Ok(self.lu.det_sign())
    }

    /// Whether cold solves get the branch guard: world-fixed (dead) loads and no
    /// tensioned cable, where `n(0)` is in closed form and Jacobi's condition on
    /// `dm(s)/dm0` is the stability test of the clamped-free rod.
    fn guarded(&self) -> bool {
        self.settings.branch_guard && self.plan.closed_form
    }

    /// Jacobi's condition at the current solution: the first arc length (m) where
    /// `det d(n, m)(s)/d(n0, m0)` (or `det dm(s)/dm0` with `n(0)` in closed form)
    /// changes sign, i.e. a conjugate point, or `None` when it keeps its sign on
    /// `(0, L]`. One dual sweep along the base wrench. With the exact cable coupling the
    /// hole unknowns are held fixed in that sweep, so the test is not defined there:
    /// `None`.
    pub fn conjugate_point(&mut self) -> Option<f64> {
        let n = self.plan.n_unknowns;
        let (plan, x) = (&self.plan, &self.x);
        let mut scratch_s = [0.0; 36];
        let jac_s = &mut scratch_s[..];
        if plan.condensed {
            if self.last_pass != Some(1.0) || self.b64.x != *x {
                self.eval_at(false, 1.0);
            }
            let (plan, x, b64) = (&self.plan, &self.x, &self.b64);
            let b = &mut self.wide.as_mut()?.narrow;
            b.next.clone_from(&b64.next);
            b.watch = true;
            b.conjugate_at = None;
            let ok = sweep(plan, x, 0, false, b, jac_s, &mut [], 1.0);
            b.watch = false;
            return if ok { b.conjugate_at } else { None };
        }
        if n == 3 {
            self.b3.watch = true;
            self.b3.conjugate_at = None;
            let ok = sweep::<3>(plan, x, 0, false, &mut self.b3, jac_s, &mut [], 1.0);
            self.b3.watch = false;
            ok.then_some(self.b3.conjugate_at).flatten()
        } else if n == 6 {
            self.b6.watch = true;
            self.b6.conjugate_at = None;
            let ok = sweep::<6>(plan, x, 0, false, &mut self.b6, jac_s, &mut [], 1.0);
            self.b6.watch = false;
            ok.then_some(self.b6.conjugate_at).flatten()
        } else {
            None
        }
    }

    /// Current scaled shooting unknowns (layout in the `statics` module docs).
    pub fn unknowns_vector(&self) -> &[f64] {
        &self.x
    }

    /// Scaled shooting residual at the current unknowns (after a solve or
    /// [`Workspace::adopt_unknowns`]); its max-norm is `report().residual`.
    pub fn residual_vector(&self) -> &[f64] {
        &self.res
    }

    /// Scaled shooting residual at scaled unknowns `x` into `out` (diagnostics and
    /// tests); `false` when the integration failed.
    pub fn shooting_residual(&mut self, x: &[f64], out: &mut [f64]) -> bool {
        self.x_trial.copy_from_slice(x);
        let ok = self.eval_trial(1.0);
        out.copy_from_slice(&self.b64.res);
        ok
    }

    /// Exact (dual-number) shooting Jacobian at `x`, row-major `n x n`.
    pub fn shooting_jacobian(&mut self, x: &[f64]) -> Option<Vec<f64>> {
        let saved = std::mem::replace(&mut self.x, x.to_vec());
        let ok = self.jacobian(1.0);
        self.lu_valid = false;
        self.x = saved;
        let n = self.plan.n_unknowns;
        ok.then(|| self.lu.matrix_mut()[..n * n].to_vec())
    }

    /// Cable lengths of the last evaluated point (m), indexed like `robot.cables`.
    /// No allocation.
    pub fn cable_lengths_into(&self, out: &mut [f64]) {
        for (j, (c, o)) in self.plan.cables.iter().zip(out.iter_mut()).enumerate() {
            *o = path_length(&c.base_hole, &self.b64.holes[j]);
        }
    }

    /// Base internal force and moment of the current solution `(n(0), m(0))`.
    pub fn base_wrench(&self) -> (Vector3<f64>, Vector3<f64>) {
        let p = &self.plan;
        if p.closed_form {
            let m = Vector3::new(self.x[0], self.x[1], self.x[2]) * p.moment_scale;
            (p.closed_n0, m)
        } else {
            (
                Vector3::new(self.x[0], self.x[1], self.x[2]) * p.force_scale,
                Vector3::new(self.x[3], self.x[4], self.x[5]) * p.moment_scale,
            )
        }
    }

    /// Tip position of the last evaluated point (m).
    pub fn tip_position(&self) -> Vector3<f64> {
        self.tip
    }

    /// Full solution of the current point (allocates: samples, poses, lengths).
    pub fn solution(&mut self) -> Solution {
        let mut rec = Recording::default();
        self.b64.x.copy_from_slice(&self.x);
        let _ = pass(&self.plan, &mut self.b64, 1.0, Some(&mut rec));
        let guides = self
            .robot
            .guides()
            .iter()
            .zip(&rec.guides)
            .map(|(g, pose)| GuidePose {
                section: g.section,
                index: g.index,
                s: g.s,
                pose: *pose,
            })
            .collect();
        let cables = self
            .robot
            .cables()
            .iter()
            .zip(&self.plan.cables)
            .enumerate()
            .map(|(j, (c, pc))| CableLength {
                name: c.name.clone(),
                total_m: path_length(&pc.base_hole, &self.b64.holes[j]),
                segments_m: segments(&pc.base_hole, &self.b64.holes[j]),
            })
            .collect();
        let (base_force, base_moment) = self.base_wrench();
        Solution {
            report: self.report,
            samples: rec.samples,
            section_tips: rec.section_tips,
            guides,
            cables,
            base_force,
            base_moment,
        }
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
