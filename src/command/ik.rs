//! Inverse kinematics from actuator readings: the readings `q` (m, one per
//! displacement-driven tendon) that put the tip at a target position (optionally
//! pointing along a target direction), inside the actuator limits.
//!
//! **Problem.** With `p(q)` the tip and `a(q)` the tip axis of the readings solve
//! (`crate::tendons`), minimise
//!
//! ```text
//! phi(q) = |p* - p(q)|^2 + l_d^2 |a* - a(q)|^2 + S(q)      s.t.  q_min <= q <= q_max
//! ```
//!
//! (`l_d` = [`IkSettings::direction_weight_m`], 0 without a direction target; `S` the
//! secondary objective below). Nine tendons for a 3-D target leave a redundancy of
//! six: `S` picks one solution, with a small user weight `w`
//! ([`IkSettings::secondary_weight`]) so that the position term dominates (a weight
//! `w` shifts the reached tip by about `w` times the secondary's gradient over the
//! Jacobian's singular values squared; the default 1e-6 keeps it well inside the
//! tolerance on the FTDCR v4, where 1e-4 left some val targets out of reach):
//!
//! * [`IkObjective::Closest`]: `w |q - q_prev|^2`, readings closest to those the call
//!   started from (the previous tick): smooth servo motion;
//! * [`IkObjective::LeastPull`]: `w l_r sum_i q_i` (`l_r` = 1 mm), least total pull;
//!   readings go to their lower limits where the target allows (tendons go slack);
//! * [`IkObjective::LeastTension`]: `w l_r^2 sum_i (T_i / 1 N)^2`, the sum of squared
//!   tensions: a smooth proxy of the peak tension (the 2-norm bounds the max-norm,
//!   `max T <= |T|_2`), with `dT/dq` from the same implicit-function solve as the
//!   tip's Jacobian.
//!
//! **Step.** Trust-region Gauss-Newton (Nocedal & Wright, *Numerical Optimization*,
//! 2nd ed., ch. 4 and 10.3): at the current readings the linearised `phi` plus a
//! Levenberg-Marquardt damping `mu |dq|^2` (mm^2), `mu = 1e-6 + 0.1 |r|^2` with `r`
//! the position (and direction) residual in mm (Yamashita & Fukushima, "On the rate
//! of convergence of the Levenberg-Marquardt method", Computing Suppl. 15, 2001:
//! `mu ~ |r|^2` keeps quadratic convergence, also to a non-isolated solution, as a
//! redundant robot's are), is minimised over `dq` subject to the limits,
//! `|dq_i| <= Delta` and the linearised tensions staying non-negative
//! (`T + dT/dq dq >= 0`: the model of the current active set holds only up to where
//! a taut tendon goes slack), a box-constrained convex QP solved by clarabel (interior point,
//! built once and updated in place, `update_P/q/b`). The step is taken when the
//! forward solve at `q + dq` converges and the actual decrease of `phi` is at least
//! 1e-4 of the model's (`rho`), and `Delta` grows (x2, `rho > 0.75` with the step on
//! the trust region) or shrinks (to a quarter of the step, `rho < 0.25`) as in
//! Nocedal & Wright algorithm 4.1. The QP works in millimetres (readings and tip)
//! so that its tolerances are meaningful.
//!
//! The damping keeps a step out of the Jacobian's near-null directions while the
//! residual is large. Without it (the fixed `1e-6` alone), a step whose residual
//! is mostly curvature (the tip's drop as the robot bends) is explained by such a
//! direction: on the daru robot, pulling all three cables together moves the tip
//! 0.09 mm per mm against 5-7 mm per mm for bending, and an undamped first step
//! pulled all three by 1.45 mm (tensions 10 -> 17 N), to a tip 0.07 mm from the
//! target where the tip's derivative along that direction changes sign within
//! 1e-6 m of reading (differences of converged solves at 1e-5, 1e-6, 1e-7 m:
//! dx/dq_1 = 4.8, 3.4, 110). There no trial step was accepted, the trust region
//! shrank to nothing, and the target was called unreachable.
//!
//! **Continuation.** A gradient method finds a local minimum of `phi`, and the
//! readings model has some that are not the target: on the daru robot at high
//! common-mode tension (about 20 N per cable) a start 0.8 mm of one reading away
//! from a reachable target's readings ends, from the first step on, in a valley
//! whose floor lies 10.2 um from the target, stationary to 1e-4 (forward solves to
//! 1e-11 m), with the readings 0.2 mm from the target's. When the first attempt does
//! not reach and budget is left, the call starts over from its start readings and
//! solves [`CONTINUATION_STEPS`] intermediate targets on the segment from the start
//! tip to the target, each warm from the last (a homotopy in the target; Allgower &
//! Georg, *Numerical Continuation Methods*, 1990, ch. 1), within the same budget;
//! its end is kept when it is closer (lower `phi`) than the first attempt's (a
//! creeping first attempt then goes on with the budget left). On that case it
//! reaches; the control loop's small steps rarely need it.
//!
//! **Jacobian.** At a converged solve, `F(z; q) = 0` with `z = [x; T]` (scaled
//! shooting unknowns, tensions): by the implicit function theorem
//! `dz/dq_i = F_z^-1 e_{n+i} (1 + T_i/EA_t)` for a taut tendon (`crate::tendons::ift`,
//! shared with the calibration's sensitivities, `calibrate::readings_sens`). A slack
//! tendon's reading moves nothing until its slack is taken up: its column is the
//! one-sided derivative beyond its engagement point (the reading at which its free
//! length equals its path length, where it is taut at `T = 0`; `F_z` factored again
//! with that tendon taut), and the step for it is a pull beyond that point or none
//! (the reading is then kept, or paid out to its lower limit under `least_pull`). `F_z` is exact, from one dual
//! sweep (`Workspace::joint_jacobians`); the tip's derivative along each tangent is a
//! central difference of the tip at fixed `(z +- h dz/dq_i)` (two `f64` passes, a smooth
//! function: truncation `h^2`, no solver tolerance in it), as the calibration does.
//! `dT/dq` are the tension rows of `dz/dq`. With capstan friction (`mu > 0`) the state
//! depends on the direction memory, not on `z` alone: the Jacobian is then a central
//! difference of converged forward solves (`2p` solves).
//!
//! **Jacobian updates.** After an accepted step with every tendon taut before and
//! after (and no friction), the Jacobians are not evaluated again: Broyden's
//! rank-one update along the step (Broyden, "A class of methods for solving
//! nonlinear simultaneous equations", Math. Comp. 19, 1965; Nocedal & Wright eq.
//! 11.24) carries them to the new readings, and into the next call (the next
//! tick starts where this one ended), as long as the model predicted the step well
//! (`rho > 0.75`). The exact Jacobian is evaluated again after a poorer step, when
//! a step from an updated one is rejected (same trust radius), when the active set
//! changes, and before any conclusion other than `Reached` (a stationary point is
//! judged on the exact Jacobian only). [`IkReport::jacobians`] counts the
//! evaluations. On the FTDCR v4's warm ticks an evaluation (dual sweep, `F_z`
//! factored, 18 tangent passes) costs about 3.4 forward solves.
//!
//! **Outcomes** ([`IkStatus`]): `Reached` (tip within [`IkSettings::tolerance_m`], and
//! the direction within [`IkSettings::angle_tolerance_rad`] when one is given);
//! `Unreachable` only at a constrained stationary point with the tip still farther
//! than the tolerance: the first-order condition of the bounded least squares
//! (Nocedal & Wright eq. 12.34, with the limits as the only constraints) holds to
//! 1e-2, i.e. the gradient `g = -2 J^T r` projected on the directions the limits
//! allow (a reading on its lower limit or a slack tendon only pulls, one on its
//! upper limit only pays out) is below 1e-2 of `2 |J|_F |r|` ([`IkReport::first_order`]),
//! and the iteration has stopped there (no step, steps below
//! [`IkSettings::step_tolerance_m`], or two steps in a row improving `phi` by less
//! than 1e-4 of itself): the closest tip found and its distance are returned.
//! `BudgetExhausted` when the iterations or forward solves of [`IkSettings`] run out
//! first, or when the iteration stops at a point that is not stationary (the best
//! readings found are kept). The
//! readings are always within the limits, and the workspace stays at the returned
//! readings (the next call's warm start).

use crate::error::ModelError;
use crate::math::warm::WarmCopy;
use crate::math::DenseLu;
use crate::robot::ActuatorLimits;
use crate::scene::Scene;
use crate::statics::Start;
use crate::tendons::ift::{assemble_joint_jacobian, reading_gain};
use crate::tendons::TendonWorkspace;
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus,
};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Millimetres per metre: the QP's units.
const MM: f64 = 1e3;
/// Reading step of the tangent differences (m).
const TANGENT_STEP_M: f64 = 1e-6;
/// Reading step of the friction fallback's differences of solves (m).
const FD_STEP_M: f64 = 1e-5;
/// Damping of the step in the QP (per mm^2 of step).
const DAMPING: f64 = 1e-6;
/// Levenberg-Marquardt factor `c` of the damping `mu = c |r|^2` (`r` the
/// position and direction residual in mm; module docs).
const LM_FACTOR: f64 = 0.1;
/// First-order tolerance: a point whose projected gradient of `phi` is below this
/// fraction of `2 |J| |r|` is a constrained stationary point (module docs).
const FIRST_ORDER_TOL: f64 = 1e-2;
/// Intermediate targets of the continuation after a first attempt that did not
/// reach (module docs).
const CONTINUATION_STEPS: usize = 4;
/// A reading within this of a limit is on it (m).
const ON_BOUND_M: f64 = 1e-12;

/// The secondary objective that resolves the redundancy (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IkObjective {
    /// Readings closest to the previous ones (the call's start). Default.
    #[default]
    Closest,
    /// Least total pull `sum q_i`.
    LeastPull,
    /// Least tension: the sum of squared tensions, a smooth proxy of the peak.
    LeastTension,
}

impl IkObjective {
    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Closest => "closest",
            Self::LeastPull => "least_pull",
            Self::LeastTension => "least_tension",
        }
    }
}

/// Settings of an inverse solve (plain numbers; defaults below).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IkSettings {
    /// A tip within this distance of the target is reached (m, > 0). Default 1e-5.
    pub tolerance_m: f64,
    /// A direction within this angle of the target's is reached (rad, > 0). Default 1e-3.
    pub angle_tolerance_rad: f64,
    /// Gauss-Newton iterations per call (>= 1). Default 30.
    pub max_iterations: usize,
    /// Forward (readings) solves per call, trial steps and the friction fallback's
    /// differences included (>= 1). Default 100.
    pub max_forward_solves: usize,
    /// Initial trust region: largest change of any reading in the first step (m, > 0).
    /// Default 0.002.
    pub trust_radius_m: f64,
    /// Smallest step: a step below it (m, max-norm) ends the iteration. Default 1e-10.
    pub step_tolerance_m: f64,
    /// Secondary objective. Default `closest`.
    pub objective: IkObjective,
    /// Weight `w` of the secondary objective (>= 0, dimensionless; module docs).
    /// Default 1e-6.
    pub secondary_weight: f64,
    /// A direction error of 1 rad counts as this much position error (m, > 0).
    /// Default 0.01.
    pub direction_weight_m: f64,
}

impl Default for IkSettings {
    fn default() -> Self {
        Self {
            tolerance_m: 1e-5,
            angle_tolerance_rad: 1e-3,
            max_iterations: 30,
            max_forward_solves: 100,
            trust_radius_m: 0.002,
            step_tolerance_m: 1e-10,
            objective: IkObjective::Closest,
            secondary_weight: 1e-6,
            direction_weight_m: 0.01,
        }
    }
}

impl IkSettings {
    /// Check every number; the error names the field.
    pub fn validate(&self) -> Result<(), ModelError> {
        ModelError::positive("ik.tolerance_m", self.tolerance_m)?;
        ModelError::positive("ik.angle_tolerance_rad", self.angle_tolerance_rad)?;
        ModelError::positive("ik.trust_radius_m", self.trust_radius_m)?;
        ModelError::positive("ik.step_tolerance_m", self.step_tolerance_m)?;
        ModelError::non_negative("ik.secondary_weight", self.secondary_weight)?;
        ModelError::positive("ik.direction_weight_m", self.direction_weight_m)?;
        for (f, v) in [
            ("ik.max_iterations", self.max_iterations),
            ("ik.max_forward_solves", self.max_forward_solves),
        ] {
            if v == 0 {
                return Err(ModelError::OutOfRange {
                    field: f.into(),
                    value: 0.0,
                    why: "at least 1".into(),
                });
            }
        }
        Ok(())
    }
}

/// What to reach: a tip position (m, world frame) and optionally a tip direction
/// (the tip's axis `R(L) e_z`, any non-zero length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkTarget {
    /// Tip position (m).
    pub position_m: Vector3<f64>,
    /// Tip direction (normalised here; `None`: position only).
    pub direction: Option<Vector3<f64>>,
}

impl IkTarget {
    /// A position-only target.
    pub fn position(p: Vector3<f64>) -> Self {
        Self {
            position_m: p,
            direction: None,
        }
    }

    /// Check: finite position, finite non-zero direction (no allocation on success).
    pub fn validate(&self) -> Result<(), ModelError> {
        for k in 0..3 {
            if !self.position_m[k].is_finite() {
                return Err(ModelError::NonFinite {
                    field: format!("target.position_m[{k}]"),
                    value: self.position_m[k],
                });
            }
        }
        if let Some(d) = &self.direction {
            for k in 0..3 {
                if !d[k].is_finite() {
                    return Err(ModelError::NonFinite {
                        field: format!("target.direction[{k}]"),
                        value: d[k],
                    });
                }
            }
            if d.norm() < 1e-12 {
                return Err(ModelError::Invalid {
                    field: "target.direction".into(),
                    why: "has zero length: give a non-zero tip direction, or none".into(),
                });
            }
        }
        Ok(())
    }
}

/// How an inverse solve ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IkStatus {
    /// The tip is within the tolerance of the target (and the direction within its
    /// tolerance when one was given).
    Reached,
    /// The tip is farther than the tolerance at a constrained stationary point of
    /// `phi` (first-order condition with the limits, [`IkReport::first_order`]):
    /// the closest tip found (m) and its distance to the target (m).
    Unreachable {
        /// Closest tip found (m).
        closest_tip_m: Vector3<f64>,
        /// Its distance to the target (m).
        distance_m: f64,
    },
    /// The iterations or forward solves of the budget ran out first, or the
    /// trust region shrank to nothing at a point that is not stationary (the
    /// model of the step is not good there at any radius, e.g. where the forward
    /// solves' tolerance hides the descent): the best readings found are kept.
    BudgetExhausted,
}

impl IkStatus {
    /// `reached`, `unreachable` or `budget_exhausted`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Reached => "reached",
            Self::Unreachable { .. } => "unreachable",
            Self::BudgetExhausted => "budget_exhausted",
        }
    }
}

/// Outcome of one inverse solve; the readings are [`IkWorkspace::readings`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkReport {
    /// How it ended.
    pub status: IkStatus,
    /// Tip at the returned readings (m).
    pub tip_m: Vector3<f64>,
    /// Distance of that tip to the target (m).
    pub distance_m: f64,
    /// Angle between the tip axis and the target direction (rad; 0 without one).
    pub angle_rad: f64,
    /// Gauss-Newton iterations (QP models built from an evaluated or an updated
    /// Jacobian).
    pub iterations: usize,
    /// Jacobians evaluated (the exact one, or the friction fallback's differences);
    /// the other iterations use Broyden's update along the last step.
    pub jacobians: usize,
    /// Forward solves (trial steps, friction differences).
    pub forward_solves: usize,
    /// Bounded least-squares steps solved (clarabel).
    pub qp_solves: usize,
    /// The secondary objective that chose among the solutions.
    pub objective: IkObjective,
    /// Tendons slack at the returned readings.
    pub slack: usize,
    /// First-order measure at the last linearisation: the norm of the projected
    /// gradient of `phi` over `2 |J|_F |r|` (dimensionless; 0 at a constrained
    /// stationary point, `Unreachable` only below 1e-2; NaN when none was built).
    pub first_order: f64,
}

/// Work of one call: Gauss-Newton iterations (Jacobians), forward solves, QPs.
#[derive(Default)]
struct Counts {
    iterations: usize,
    jacobians: usize,
    solves: usize,
    qp_solves: usize,
}

/// The bounded least-squares step: a clarabel solver built once (dense upper
/// triangle of `P`, `A = [I; -I; -dT/du]`) and updated in place for every step.
struct StepQp {
    solver: DefaultSolver<f64>,
    /// Upper triangle of `P`, column by column (the CSC order).
    p_vals: Vec<f64>,
    /// `A` column by column: `[1, -1, -dT_0/du_col, .., -dT_{p-1}/du_col]`.
    a_vals: Vec<f64>,
    q_vals: Vec<f64>,
    b_vals: Vec<f64>,
}

impl StepQp {
    fn new(p: usize) -> Result<Self, ModelError> {
        let (mut colptr, mut rowval, mut nzval) = (vec![0usize], Vec::new(), Vec::new());
        for col in 0..p {
            for row in 0..=col {
                rowval.push(row);
                nzval.push(if row == col { 1.0 } else { 0.0 });
            }
            colptr.push(rowval.len());
        }
        let pm = CscMatrix::new(p, p, colptr, rowval, nzval.clone());
        // rows: u <= hi, -u <= -lo, then -dT/du u <= T (tensions stay >= 0)
        let (mut colptr, mut rowval, mut aval) = (vec![0usize], Vec::new(), Vec::new());
        for col in 0..p {
            rowval.push(col);
            aval.push(1.0);
            rowval.push(p + col);
            aval.push(-1.0);
            for k in 0..p {
                rowval.push(2 * p + k);
                aval.push(0.0);
            }
            colptr.push(rowval.len());
        }
        let am = CscMatrix::new(3 * p, p, colptr, rowval, aval.clone());
        let q = vec![0.0; p];
        let b = vec![1.0; 3 * p];
        let settings = DefaultSettingsBuilder::default()
            .verbose(false)
            .max_iter(60)
            .presolve_enable(false)
            .equilibrate_enable(false)
            .input_sparse_dropzeros(false)
            .build()
            .map_err(|e| ModelError::Invalid {
                field: "ik.qp".into(),
                why: format!("clarabel settings: {e:?}"),
            })?;
        let cones = [NonnegativeConeT(3 * p)];
        let solver = DefaultSolver::new(&pm, &q, &am, &b, &cones, settings).map_err(|e| {
            ModelError::Invalid {
                field: "ik.qp".into(),
                why: format!("clarabel: {e:?}"),
            }
        })?;
        Ok(Self {
            solver,
            p_vals: nzval,
            a_vals: aval,
            q_vals: q,
            b_vals: b,
        })
    }

    /// Solve with the current `p_vals`, `q_vals`, `b_vals`; the step into `out`.
    fn solve(&mut self, out: &mut [f64]) -> bool {
        let s = &mut self.solver;
        if s.update_P(&self.p_vals).is_err()
            || s.update_A(&self.a_vals).is_err()
            || s.update_q(&self.q_vals).is_err()
            || s.update_b(&self.b_vals).is_err()
        {
            return false;
        }
        s.solve();
        match s.solution.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => {
                out.copy_from_slice(&s.solution.x);
                out.iter().all(|v| v.is_finite())
            }
            _ => false,
        }
    }
}

/// Inverse kinematics on a readings model: allocate once, solve every tick.
pub struct IkWorkspace {
    /// The forward model, at the accepted readings between calls.
    tw: TendonWorkspace,
    /// The state at the accepted readings during a call (to return to after a
    /// rejected trial step).
    best: Box<TendonWorkspace>,
    /// The state at the call's start and at the end of its first attempt (the
    /// continuation starts from the one and falls back to the other).
    start_ws: Box<TendonWorkspace>,
    end_ws: Box<TendonWorkspace>,
    q_end: Vec<f64>,
    limits: ActuatorLimits,
    settings: IkSettings,
    /// Largest reading that leaves a tendon 1 % of its rest free length (m).
    q_phys: Vec<f64>,
    p: usize,
    nx: usize,
    /// Accepted readings, the call's start, the trial.
    q: Vec<f64>,
    q0: Vec<f64>,
    q_trial: Vec<f64>,
    /// Tip, axis and tensions at the accepted readings.
    tip: Vector3<f64>,
    axis: Vector3<f64>,
    t: Vec<f64>,
    // Jacobian buffers
    jac_s: Vec<f64>,
    jac_m: Vec<f64>,
    lu: DenseLu,
    col: Vec<f64>,
    xs: Vec<f64>,
    ts: Vec<f64>,
    x_acc: Vec<f64>,
    /// Taut flags at the accepted readings, and the active set of one column.
    taut_cur: Vec<bool>,
    taut_tmp: Vec<bool>,
    /// Slack at the accepted readings, and the linearisation point: the reading
    /// itself for a taut tendon, the reading that just takes up the slack (its
    /// engagement point) for a slack one.
    slack: Vec<bool>,
    q_lin: Vec<f64>,
    /// `dp/dq`, `da/dq` (3 x p, row-major) and `dT/dq` (p x p).
    jp: Vec<f64>,
    ja: Vec<f64>,
    jt: Vec<f64>,
    /// QP: full `P` (p x p), its gradient and the step (mm).
    h: Vec<f64>,
    g: Vec<f64>,
    u: Vec<f64>,
    qp: StepQp,
    has_state: bool,
    /// First-order measure at the last `build_qp` (see [`IkReport::first_order`]).
    first_order: f64,
    /// `jp`, `ja`, `jt`, `slack`, `q_lin` hold at the accepted readings, and were
    /// evaluated there (not updated along a step).
    jac_valid: bool,
    jac_exact: bool,
    /// The last accepted step (m), for the Broyden update.
    step_m: Vec<f64>,
}

impl IkWorkspace {
    /// An inverse solver on a readings model with actuator limits (m, in
    /// `tw.driven()` order). The rollback of `tw` is turned off (this workspace
    /// keeps its own accepted state); starts at zero readings (the reference).
    pub fn new(
        tw: TendonWorkspace,
        limits: ActuatorLimits,
        settings: IkSettings,
    ) -> Result<Self, ModelError> {
        settings.validate()?;
        limits.validate(tw.columns())?;
        let tw = tw.without_rollback();
        let p = tw.driven().len();
        let nx = tw.workspace().unknowns();
        let np = tw.workspace().params().len();
        let nc = tw.workspace().robot().cables().len();
        let w = nx + np;
        let m = nx + p;
        let q_phys = tw
            .rest_free_lengths()
            .iter()
            .zip(tw.mechanics())
            .map(|(l0, mech)| 0.99 * l0 + mech.zero_offset_m)
            .collect();
        let best = Box::new(tw.clone());
        let mut me = Self {
            start_ws: best.clone(),
            end_ws: best.clone(),
            q_end: vec![0.0; p],
            best,
            limits,
            settings,
            q_phys,
            p,
            nx,
            q: vec![0.0; p],
            q0: vec![0.0; p],
            q_trial: vec![0.0; p],
            tip: Vector3::zeros(),
            axis: Vector3::z(),
            t: vec![0.0; p],
            jac_s: vec![0.0; nx * w],
            jac_m: vec![0.0; nc * w],
            lu: DenseLu::new(m),
            col: vec![0.0; m],
            xs: vec![0.0; nx],
            ts: vec![0.0; np],
            x_acc: vec![0.0; nx],
            taut_cur: vec![true; p],
            taut_tmp: vec![true; p],
            slack: vec![false; p],
            q_lin: vec![0.0; p],
            jp: vec![0.0; 3 * p],
            ja: vec![0.0; 3 * p],
            jt: vec![0.0; p * p],
            h: vec![0.0; p * p],
            g: vec![0.0; p],
            u: vec![0.0; p],
            qp: StepQp::new(p)?,
            has_state: false,
            first_order: f64::NAN,
            jac_valid: false,
            jac_exact: false,
            step_m: vec![0.0; p],
            tw,
        };
        let zero = vec![0.0; p];
        me.set_readings(&zero)?;
        Ok(me)
    }

    /// From a scene: its readings model, `[robot.limits]` (unbounded without) and
    /// `settings`.
    pub fn from_scene(scene: &Scene, settings: IkSettings) -> Result<Self, ModelError> {
        Self::new(
            scene.tendon_workspace()?,
            scene.actuator_limits()?,
            settings,
        )
    }

    /// Move to readings `q` (m, within the limits): a forward solve, warm (then cold
    /// if that fails). The next [`IkWorkspace::solve`] starts there.
    pub fn set_readings(&mut self, q: &[f64]) -> Result<(), ModelError> {
        if q.len() != self.p {
            return Err(ModelError::Invalid {
                field: "readings".into(),
                why: format!("{} readings for {} driven tendons", q.len(), self.p),
            });
        }
        for (i, &v) in q.iter().enumerate() {
            let (lo, hi) = (self.limits.min_m[i], self.limits.max_m[i]);
            if v.is_nan() || v < lo || v > hi {
                return Err(ModelError::OutOfRange {
                    field: format!("readings[{i}] ({})", self.tw.columns()[i]),
                    value: v,
                    why: format!("outside the actuator limits [{lo}, {hi}] m"),
                });
            }
        }
        let mut r = self.tw.solve_readings(q)?;
        if !r.status.is_converged() {
            r = self.tw.solve_readings_from(q, Start::Cold)?;
        }
        if !r.status.is_converged() {
            self.has_state = false;
            return Err(ModelError::Invalid {
                field: "readings".into(),
                why: format!("the forward solve at the start readings did not converge ({r:?})"),
            });
        }
        self.q.copy_from_slice(q);
        self.accept_state();
        self.has_state = true;
        self.jac_valid = false;
        Ok(())
    }

    /// Readings of the last solve (m, `driven` order).
    pub fn readings(&self) -> &[f64] {
        &self.q
    }
    /// Tip at [`IkWorkspace::readings`] (m).
    pub fn tip_position(&self) -> Vector3<f64> {
        self.tip
    }
    /// Tip axis at [`IkWorkspace::readings`] (unit).
    pub fn tip_axis(&self) -> Vector3<f64> {
        self.axis
    }
    /// The forward model, at [`IkWorkspace::readings`].
    pub fn tendon_workspace(&self) -> &TendonWorkspace {
        &self.tw
    }
    /// The actuator limits (m).
    pub fn limits(&self) -> &ActuatorLimits {
        &self.limits
    }
    /// The settings in effect.
    pub fn settings(&self) -> &IkSettings {
        &self.settings
    }
    /// Replace the settings (checked; the ones in effect stay on error).
    pub fn set_settings(&mut self, s: IkSettings) -> Result<(), ModelError> {
        s.validate()?;
        self.settings = s;
        Ok(())
    }
    /// `dp/dq` at the readings of the last Jacobian (3 x p row-major, m/m).
    pub fn tip_jacobian(&self) -> &[f64] {
        &self.jp
    }
    /// `dT/dq` at the readings of the last Jacobian (p x p row-major, N/m).
    pub fn tension_jacobian(&self) -> &[f64] {
        &self.jt
    }

    /// The tendon workspace's converged state becomes the accepted one.
    fn accept_state(&mut self) {
        WarmCopy::warm_copy_from(&mut *self.best, &self.tw);
        self.tip = self.tw.tip_position();
        self.axis = self.tw.workspace().tip_axis();
        self.t.copy_from_slice(self.tw.tensions());
    }

    /// Back to the accepted state (after a rejected trial or the Jacobian's passes).
    fn restore_state(&mut self) {
        self.tw.warm_copy_from(&self.best);
    }

    /// The Jacobians `jp`, `ja`, `jt` at the accepted readings (module docs); the
    /// number of forward solves used (0 for the exact one). `false` on failure.
    pub fn compute_jacobian(&mut self) -> Option<usize> {
        if !self.has_state {
            return None;
        }
        let ok = if self.tw.workspace().robot().friction_mu() > 0.0 {
            return self.fd_jacobian();
        } else {
            self.exact_jacobian()
        };
        self.restore_state();
        ok.then_some(0)
    }

    fn exact_jacobian(&mut self) -> bool {
        let p = self.p;
        self.x_acc
            .copy_from_slice(self.tw.workspace().unknowns_vector());
        self.taut_cur.copy_from_slice(self.best.taut());
        // engagement points of the slack tendons: the reading at which the free
        // length equals the path length (T = 0 on the taut branch)
        for i in 0..p {
            self.slack[i] = !self.taut_cur[i];
            self.q_lin[i] = self.q[i];
            if self.slack[i] {
                let l = self.best.lengths()[self.best.driven()[i]];
                let off = self.best.mechanics()[i].zero_offset_m;
                let free = self.best.rest_free_lengths()[i] - (self.q[i] - off);
                self.q_lin[i] = self.q[i] + (free - l).max(0.0);
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
        // taut tendons' columns with the actual active set
        if !self.factor_fz(None) {
            return false;
        }
        for i in 0..p {
            if self.slack[i] {
                continue;
            }
            let gain = reading_gain(&self.best.mechanics()[i], self.t[i], true);
            self.taut_tmp.copy_from_slice(&self.taut_cur);
            if !self.tangent(i, gain) {
                return false;
            }
        }
        // a slack tendon's column: pulled beyond its engagement point it is taut
        // from T = 0 (one-sided derivative; the others keep their active set)
        for i in 0..p {
            if !self.slack[i] {
                continue;
            }
            if !self.factor_fz(Some(i)) || !self.tangent(i, 1.0) {
                return false;
            }
        }
        true
    }

    /// Factor `F_z` at the accepted point; with `engaged = Some(i)` slack tendon `i`
    /// is taut at its engagement point (free length = path length). Sets `taut_tmp`.
    fn factor_fz(&mut self, engaged: Option<usize>) -> bool {
        let nx = self.nx;
        let w = nx + self.ts.len();
        self.taut_tmp.copy_from_slice(&self.taut_cur);
        if let Some(i) = engaged {
            self.taut_tmp[i] = true;
        }
        let free0 = self.best.rest_free_lengths();
        let mech = self.best.mechanics();
        let driven = self.best.driven();
        let lengths = self.best.lengths();
        let q = &self.q;
        assemble_joint_jacobian(
            nx,
            w,
            &self.jac_s,
            &self.jac_m,
            driven,
            mech,
            |k| {
                if Some(k) == engaged {
                    lengths[driven[k]]
                } else {
                    free0[k] - (q[k] - mech[k].zero_offset_m)
                }
            },
            &self.t,
            &self.taut_tmp,
            self.lu.matrix_mut(),
        );
        matches!(self.lu.factor(), Some(rc) if rc > 1e-14)
    }

    /// Column `i` of `dp/dq`, `da/dq`, `dT/dq` from the factored `F_z` (active set
    /// `taut_tmp`) and the reading gain: `dz = F_z^-1 e_{n+i} gain`, the tip along
    /// `z +- h dz` (two passes).
    fn tangent(&mut self, i: usize, gain: f64) -> bool {
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
    fn fd_jacobian(&mut self) -> Option<usize> {
        let p = self.p;
        self.slack.fill(false);
        self.q_lin.copy_from_slice(&self.q);
        let h = FD_STEP_M;
        let mut solves = 0;
        for i in 0..p {
            let mut tips = [Vector3::zeros(); 2];
            let mut axes = [Vector3::zeros(); 2];
            for (s, sign) in [1.0, -1.0].into_iter().enumerate() {
                self.restore_state();
                self.q_trial.copy_from_slice(&self.q);
                self.q_trial[i] += sign * h;
                solves += 1;
                let r = self.tw.solve_readings(&self.q_trial).ok()?;
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

    /// `phi` in mm^2 at tip, axis, readings and tensions (module docs).
    fn merit(
        &self,
        target: &IkTarget,
        tip: &Vector3<f64>,
        axis: &Vector3<f64>,
        q: &[f64],
        t: &[f64],
    ) -> f64 {
        let e = (target.position_m - tip) * MM;
        let mut phi = e.norm_squared();
        if let Some(d) = &target.direction {
            let ld = self.settings.direction_weight_m * MM;
            phi += ld * ld * (d.normalize() - axis).norm_squared();
        }
        let w = self.settings.secondary_weight;
        phi += match self.settings.objective {
            IkObjective::Closest => {
                w * q
                    .iter()
                    .zip(&self.q0)
                    .map(|(a, b)| ((a - b) * MM).powi(2))
                    .sum::<f64>()
            }
            IkObjective::LeastPull => w * q.iter().map(|v| v * MM).sum::<f64>(),
            IkObjective::LeastTension => w * t.iter().map(|v| v * v).sum::<f64>(),
        };
        phi
    }

    /// Fill the QP (mm) at the accepted point within trust radius `delta` (m).
    fn build_qp(&mut self, target: &IkTarget, delta: f64) {
        let p = self.p;
        self.h.fill(0.0);
        self.g.fill(0.0);
        // position rows: |J u - e|^2 (J dimensionless: mm/mm)
        let e = (target.position_m - self.tip) * MM;
        let rows = |jac: &[f64], e: &Vector3<f64>, scale: f64, h: &mut [f64], g: &mut [f64]| {
            for r in 0..3 {
                for a in 0..p {
                    let ja = jac[r * p + a] * scale;
                    g[a] -= 2.0 * ja * e[r];
                    for b in 0..p {
                        h[a * p + b] += 2.0 * ja * jac[r * p + b] * scale;
                    }
                }
            }
        };
        rows(&self.jp, &e, 1.0, &mut self.h, &mut self.g);
        // squared residual (mm^2) and |J|_F^2 of the least-squares rows
        let mut r2 = e.norm_squared();
        let mut j2: f64 = self.jp.iter().map(|v| v * v).sum();
        if let Some(d) = &target.direction {
            // l_d (Ja u) in mm with l_d in m and Ja in 1/m; target l_d e_a in mm
            let ld = self.settings.direction_weight_m;
            let ea = (d.normalize() - self.axis) * (ld * MM);
            rows(&self.ja, &ea, ld, &mut self.h, &mut self.g);
            r2 += ea.norm_squared();
            j2 += ld * ld * self.ja.iter().map(|v| v * v).sum::<f64>();
        }
        // the first-order measure from the least-squares gradient (before the
        // secondary's, which only picks among solutions)
        self.first_order = self.projected_gradient_norm() / (2.0 * (r2 * j2).sqrt()).max(1e-300);
        let w = self.settings.secondary_weight;
        // Levenberg-Marquardt damping mu = c |r|^2 (Yamashita & Fukushima 2001),
        // at most c |J|_F^2: a large residual (a target far outside) does not
        // freeze the step
        let mu = DAMPING + LM_FACTOR * r2.min(j2);
        for a in 0..p {
            self.h[a * p + a] += 2.0 * mu;
        }
        match self.settings.objective {
            IkObjective::Closest => {
                for a in 0..p {
                    self.h[a * p + a] += 2.0 * w;
                    self.g[a] += 2.0 * w * (self.q_lin[a] - self.q0[a]) * MM;
                }
            }
            IkObjective::LeastPull => {
                for a in 0..p {
                    self.g[a] += w;
                }
            }
            IkObjective::LeastTension => {
                // w sum_k (T_k + (dT_k/dq / MM) u)^2
                for k in 0..p {
                    for a in 0..p {
                        let ka = self.jt[k * p + a] / MM;
                        self.g[a] += 2.0 * w * ka * self.t[k];
                        for b in 0..p {
                            self.h[a * p + b] += 2.0 * w * ka * self.jt[k * p + b] / MM;
                        }
                    }
                }
            }
        }
        // upper triangle, column by column
        let mut n = 0;
        for col in 0..p {
            for row in 0..=col {
                self.qp.p_vals[n] = self.h[row * p + col];
                n += 1;
            }
        }
        self.qp.q_vals.copy_from_slice(&self.g);
        for i in 0..p {
            // from the linearisation point; a slack tendon's step only pulls beyond
            // its engagement point (its reading is kept when the step is 0)
            let hi = (self.limits.max_m[i].min(self.q_phys[i]) - self.q_lin[i]).min(delta);
            let lo = if self.slack[i] {
                0.0
            } else {
                (self.limits.min_m[i] - self.q_lin[i]).max(-delta)
            };
            self.qp.b_vals[i] = (hi * MM).max(0.0);
            self.qp.b_vals[p + i] = (-lo * MM).max(0.0);
            // the linearised tension of each tendon stays >= 0: the model of the
            // active set holds only up to where a taut tendon goes slack
            self.qp.b_vals[2 * p + i] = self.t[i].max(0.0);
            let col = i * (p + 2);
            for k in 0..p {
                self.qp.a_vals[col + 2 + k] = -self.jt[k * p + i] / MM;
            }
        }
    }

    /// Norm of the projected gradient `g` (mm): per reading, the part of `-g` that
    /// the limits allow (a reading on its lower limit, or a slack tendon's, whose
    /// derivative is the pull beyond its engagement point, only increases; one on
    /// its upper limit only decreases).
    fn projected_gradient_norm(&self) -> f64 {
        let mut n2 = 0.0;
        for i in 0..self.p {
            let gi = self.g[i];
            let lo = self.slack[i] || self.q[i] <= self.limits.min_m[i] + ON_BOUND_M;
            let hi = self.q_lin[i] >= self.limits.max_m[i].min(self.q_phys[i]) - ON_BOUND_M;
            let v = match (lo, hi) {
                (true, true) => 0.0,
                (true, false) => gi.min(0.0),
                (false, true) => gi.max(0.0),
                (false, false) => gi,
            };
            n2 += v * v;
        }
        n2.sqrt()
    }

    /// Model value of the step `u` (mm^2): `0.5 u^T H u + g^T u`.
    fn model(&self) -> f64 {
        let p = self.p;
        let mut v = 0.0;
        for a in 0..p {
            let mut hu = 0.0;
            for b in 0..p {
                hu += self.h[a * p + b] * self.u[b];
            }
            v += self.u[a] * (0.5 * hu + self.g[a]);
        }
        v
    }

    /// Solve for readings that reach `target`, warm from the last readings
    /// (module docs). Errors: an invalid target; otherwise the outcome is the
    /// report's status and the readings are within the limits.
    pub fn solve(&mut self, target: &IkTarget) -> Result<IkReport, ModelError> {
        target.validate()?;
        if !self.has_state {
            let zero = vec![0.0; self.p];
            self.set_readings(&zero)?;
        }
        self.q0.copy_from_slice(&self.q);
        WarmCopy::warm_copy_from(&mut *self.start_ws, &self.tw);
        let mut n = Counts::default();
        let mut status = self.iterate(target, &mut n);
        let st = &self.settings;
        let left = n.iterations < st.max_iterations && n.solves < st.max_forward_solves;
        if !matches!(status, IkStatus::Reached) && left {
            // continuation: from the call's start through intermediate targets on
            // the segment from the start tip to the target, each solved warm from
            // the last; kept when it ends closer (module docs)
            let (first_status, first_fo) = (status, self.first_order);
            let phi_first = self.merit(target, &self.tip, &self.axis, &self.q, &self.t);
            WarmCopy::warm_copy_from(&mut *self.end_ws, &self.tw);
            self.q_end.copy_from_slice(&self.q);
            self.tw.warm_copy_from(&self.start_ws);
            self.q.copy_from_slice(&self.q0);
            self.accept_state();
            self.jac_valid = false;
            let tip0 = self.tip;
            for k in 1..=CONTINUATION_STEPS {
                let f = k as f64 / CONTINUATION_STEPS as f64;
                let sub = IkTarget {
                    position_m: tip0 + (target.position_m - tip0) * f,
                    direction: target.direction,
                };
                status = self.iterate(&sub, &mut n);
                if matches!(status, IkStatus::BudgetExhausted)
                    && (n.iterations >= self.settings.max_iterations
                        || n.solves >= self.settings.max_forward_solves)
                {
                    break;
                }
            }
            if self.merit(target, &self.tip, &self.axis, &self.q, &self.t) >= phi_first {
                self.tw.warm_copy_from(&self.end_ws);
                self.q.copy_from_slice(&self.q_end);
                self.accept_state();
                self.jac_valid = false;
                status = first_status;
                self.first_order = first_fo;
            } else if !matches!(status, IkStatus::Reached) && self.is_reached(target) {
                status = IkStatus::Reached;
            }
        }
        let st = self.settings.clone();
        let (iterations, solves, qp_solves) = (n.iterations, n.solves, n.qp_solves);
        let distance = (target.position_m - self.tip).norm();
        let status = match status {
            IkStatus::Unreachable { .. } => IkStatus::Unreachable {
                closest_tip_m: self.tip,
                distance_m: distance,
            },
            s => s,
        };
        Ok(IkReport {
            status,
            tip_m: self.tip,
            distance_m: distance,
            angle_rad: target.direction.map_or(0.0, |d| {
                d.normalize().dot(&self.axis).clamp(-1.0, 1.0).acos()
            }),
            iterations,
            jacobians: n.jacobians,
            forward_solves: solves,
            qp_solves,
            objective: st.objective,
            slack: self.best.taut().iter().filter(|t| !**t).count(),
            first_order: self.first_order,
        })
    }

    /// The trust-region iteration towards `target` from the accepted readings,
    /// counting into `n` against the call's budget (module docs); the status.
    fn iterate(&mut self, target: &IkTarget, n: &mut Counts) -> IkStatus {
        let st = self.settings.clone();
        let mut delta = st.trust_radius_m;
        let mut stalls = 0usize;
        let mut phi = self.merit(target, &self.tip, &self.axis, &self.q, &self.t);
        self.first_order = f64::NAN;
        loop {
            let reached = self.is_reached(target);
            if reached && st.objective == IkObjective::Closest {
                return IkStatus::Reached;
            }
            if n.iterations >= st.max_iterations || n.solves >= st.max_forward_solves {
                return self.final_status(reached, true);
            }
            n.iterations += 1;
            if !self.jac_valid {
                self.first_order = f64::NAN;
                match self.compute_jacobian() {
                    Some(k) => n.solves += k,
                    None => return self.final_status(reached, false),
                }
                n.jacobians += 1;
                self.jac_valid = true;
                self.jac_exact = true;
            }
            // trust-region trials at this Jacobian
            let mut outcome = None;
            let mut first = true;
            while outcome.is_none() {
                self.build_qp(target, delta);
                if std::mem::take(&mut first) && stalls >= 2 {
                    // slow progress: judged on the exact Jacobian
                    if !self.jac_exact {
                        self.jac_valid = false;
                        outcome = Some(None);
                        break;
                    }
                    if reached || self.first_order <= FIRST_ORDER_TOL {
                        // reached (a secondary objective no longer improving), or
                        // at a stationary point: the closest tip
                        outcome = Some(Some(self.final_status(reached, false)));
                        break;
                    }
                }
                let mut u = std::mem::take(&mut self.u);
                let ok = self.qp.solve(&mut u);
                n.qp_solves += 1;
                self.u = u;
                if !ok {
                    outcome = Some(self.conclude(reached));
                    break;
                }
                let step_m = self.u.iter().fold(0.0f64, |m, v| m.max(v.abs())) / MM;
                let pred = -self.model();
                if step_m < st.step_tolerance_m || pred <= 1e-15 * phi.max(1e-300) {
                    outcome = Some(self.conclude(reached));
                    break;
                }
                if n.solves >= st.max_forward_solves {
                    outcome = Some(Some(self.final_status(reached, true)));
                    break;
                }
                for i in 0..self.p {
                    let (lo, hi) = (self.limits.min_m[i], self.limits.max_m[i]);
                    let v = if !self.slack[i] {
                        self.q[i] + self.u[i] / MM
                    } else if self.u[i] > 1e-9 {
                        self.q_lin[i] + self.u[i] / MM
                    } else if st.objective == IkObjective::LeastPull && lo.is_finite() {
                        // stays slack: least pull pays it out to its limit
                        lo
                    } else {
                        self.q[i]
                    };
                    self.q_trial[i] = v.clamp(lo, hi);
                }
                n.solves += 1;
                let converged = self
                    .tw
                    .solve_readings(&self.q_trial)
                    .is_ok_and(|r| r.status.is_converged());
                let (rho, phi_new) = if converged {
                    let tip = self.tw.tip_position();
                    let axis = self.tw.workspace().tip_axis();
                    let phi_new =
                        self.merit(target, &tip, &axis, &self.q_trial, self.tw.tensions());
                    ((phi - phi_new) / pred, phi_new)
                } else {
                    (f64::NEG_INFINITY, phi)
                };
                if rho > 1e-4 && phi_new < phi {
                    let on_boundary = step_m > 0.99 * delta;
                    if rho > 0.75 && on_boundary {
                        delta *= 2.0;
                    } else if rho < 0.25 {
                        delta = 0.25 * step_m;
                    }
                    let updated = self.broyden_update();
                    std::mem::swap(&mut self.q, &mut self.q_trial);
                    self.accept_state();
                    // the update is trusted while the model predicts well
                    self.jac_valid = updated && rho > 0.75;
                    self.jac_exact = false;
                    if updated {
                        // all taut: the linearisation point is the readings
                        self.q_lin.copy_from_slice(&self.q);
                    }
                    let gain = phi - phi_new;
                    phi = phi_new;
                    if gain < 1e-4 * (phi + gain) {
                        stalls += 1;
                    } else {
                        stalls = 0;
                    }
                    outcome = Some(None);
                } else if !self.jac_exact {
                    // the updated Jacobian's step failed: the exact one, same radius
                    self.restore_state();
                    self.jac_valid = false;
                    outcome = Some(None);
                } else {
                    self.restore_state();
                    delta = 0.25 * step_m;
                    if delta < st.step_tolerance_m {
                        outcome = Some(self.conclude(reached));
                    }
                }
            }
            if let Some(Some(s)) = outcome {
                return s;
            }
        }
    }

    /// The iteration stops here: the final status at an exact Jacobian (`Some`);
    /// at an updated one, `None` and the next iteration evaluates the exact one
    /// (conclusions, `Unreachable` above all, rest on the exact Jacobian).
    fn conclude(&mut self, reached: bool) -> Option<IkStatus> {
        if self.jac_exact {
            Some(self.final_status(reached, false))
        } else {
            self.jac_valid = false;
            None
        }
    }

    /// Broyden's rank-one update of `jp`, `ja`, `jt` along the accepted step
    /// `s = q_trial - q` with the tip, axis and tension changes `y` it made
    /// (`J += (y - J s) s^T / s^T s`; Broyden, Math. Comp. 19, 1965; Nocedal &
    /// Wright eq. 11.24): the Jacobian at the new readings without evaluating it.
    /// Only with every tendon taut before and after (the active set, and so the
    /// columns' meaning, unchanged) and without friction; `false` otherwise.
    fn broyden_update(&mut self) -> bool {
        let p = self.p;
        if self.tw.workspace().robot().friction_mu() > 0.0
            || self.slack.iter().any(|s| *s)
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
        let update = |row: &mut [f64], y: f64| {
            let js: f64 = row.iter().zip(s).map(|(j, v)| j * v).sum();
            let c = (y - js) / ss;
            for (j, v) in row.iter_mut().zip(s) {
                *j += c * v;
            }
        };
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

    fn is_reached(&self, target: &IkTarget) -> bool {
        let d = (target.position_m - self.tip).norm();
        let angle_ok = target.direction.is_none_or(|t| {
            t.normalize().dot(&self.axis).clamp(-1.0, 1.0).acos()
                <= self.settings.angle_tolerance_rad
        });
        d <= self.settings.tolerance_m && angle_ok
    }

    /// The status when the iteration ends: reached; else unreachable at a
    /// constrained stationary point (first-order measure of the last linearisation
    /// below [`FIRST_ORDER_TOL`]); else out of budget.
    fn final_status(&self, reached: bool, budget: bool) -> IkStatus {
        if reached {
            IkStatus::Reached
        } else if budget || self.first_order.is_nan() || self.first_order > FIRST_ORDER_TOL {
            IkStatus::BudgetExhausted
        } else {
            IkStatus::Unreachable {
                closest_tip_m: self.tip,
                distance_m: f64::NAN,
            }
        }
    }
}
