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
//! **Rest term.** Each of these objectives is a fixed function of the readings
//! except `closest`, whose reference moves with every call: over a long warm chain
//! the readings then wander along the redundancy (the classic non-repeatability of
//! a redundancy resolution tied to the previous joint state: Klein & Huang,
//! "Review of pseudoinverse control for use with kinematically redundant
//! manipulators", IEEE Trans. SMC 13, 1983), here along the co-contraction (all
//! tendons pulled together), where the tensions grow and the forward solves slow
//! down. [`IkSettings::rest_weight`] adds `w_r |N (q / 1 mm)|^2` to the step's QP,
//! with `N = I - A^T (A A^T + eps I)^-1 A` the projector on the null space of the
//! least-squares rows `A` (tip Jacobian, and the direction rows) over the taut
//! tendons: a fixed point (zero readings) that each step's null-space part is drawn
//! toward by a fraction `w_r / (w_r + w + mu)`, a contraction instead of a random
//! walk (the gradient projection of Liegeois, "Automatic supervisory control of the
//! configuration and behavior of multibody mechanisms", IEEE Trans. SMC 7, 1977).
//! Projected, it leaves the tip's least squares alone: a robot without redundancy
//! (the three-cable daru robot, `A` square) is unchanged, where an unprojected
//! `w_r |q|^2` of 1e-4 left a property case 10.2 um away (tolerance 10 um). It
//! steers the step only: the merit `phi` and the model's predicted decrease leave it
//! out. Slack tendons are left out too (their readings move nothing; pulling them
//! toward zero would only engage them).
//!
//! The default 1e-3 was chosen on the FTDCR v4 *train* rows (the model's tips at
//! 1 618 train readings walked forward and back, `examples/ik_tick_profile.rs 2 -
//! data/hardware/ftdcr_v4/train.csv W`, 3 237 ticks, all figures deterministic but
//! the times): without the term (`w_r` = 0) the first walk took 24 min of CPU and
//! ended with the readings' sum at 23.6 mm (stopped there); `w_r` = 1e-6 (an
//! unprojected first version): 22 ticks out of budget, at most 18 488 rod passes in
//! a call, the spread of the readings' sum at one target between the walks p99
//! 17.8 mm. Projected, `w_r` = 1e-4, 3e-4, 1e-3, 1e-2: out of budget 0, 5, 0, 0;
//! most passes in a call 124, 14 555, 119, 162; spread p99 5.4, 4.1, 2.8, 3.2 mm;
//! exact Jacobians per tick 1.42, 1.50, 1.56, 1.71 (0.92 at 1e-6). 1e-3 is the
//! smallest weight from which every run stayed bounded (3e-3, measured before
//! slack tendons were left out: 0, 110, 4.2 mm; 1e-3 gave the same figures both ways).
//! It keeps a chain out of co-contraction; it does not draw one out that is already
//! deep in it: from the co-contracted readings of `tests/ik_budget.rs` (sum 24.0 mm),
//! val rows 171-185 end with 12 of 15 reached and the sum at 14.9 mm with it,
//! 13 reached and 4.7 mm without it.
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
//! a taut tendon goes slack), a bounded convex QP solved without allocation by a
//! primal active-set method on the Cholesky factor of its normal matrix
//! (`active_set`, Nocedal & Wright algorithm 16.3), with clarabel (interior point,
//! built once and updated in place) as the fallback when that gives up (counted in
//! [`IkReport::qp_fallbacks`]) and as the reference of its tests. The step is taken when the
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
//! its end is kept when it reaches, or is closer than the first attempt's by more
//! than 1e-4 of `phi` (an end as far as the first attempt's, e.g. a target far
//! outside, does not replace that attempt's `Unreachable` with the continuation's
//! `BudgetExhausted`; a creeping first attempt then goes on with the budget left). On that case it
//! reaches; the control loop's small steps rarely need it.
//!
//! **Jacobian.** At a converged solve, `F(z; q) = 0` with `z = [x; T]` (scaled
//! shooting unknowns, tensions): by the implicit function theorem
//! `dz/dq_i = F_z^-1 e_{n+i} (1 + T_i/EA_t)` for a taut tendon (`crate::tendons::ift`,
//! shared with the calibration's sensitivities, `calibrate::readings_sens`). A slack
//! tendon's reading moves nothing while it stays slack: its column is zero (see
//! "Taut/slack boundary" for one at that boundary). `F_z` is exact, from one dual
//! sweep (`Workspace::joint_jacobians`); the tip's derivative along each tangent is a
//! central difference of the tip at fixed `(z +- h dz/dq_i)` (two `f64` passes, a smooth
//! function: truncation `h^2`, no solver tolerance in it), as the calibration does.
//! `dT/dq` are the tension rows of `dz/dq`. With capstan friction (`mu > 0`) the state
//! depends on the direction memory, not on `z` alone: the Jacobian is then a central
//! difference of converged forward solves (`2p` solves).
//!
//! **Taut/slack boundary.** Each tendon's taut/slack switch makes `p(q)` a
//! piecewise-smooth map: smooth on each side, with a kink where a tendon engages
//! (free length = path length, `T = 0`). A linearisation is valid on one side only,
//! so each tendon's side is chosen where the Jacobian is evaluated and the step is
//! kept on it, as for a piecewise-smooth equation whose Newton model is built from
//! one element of the B-subdifferential (the one-sided Jacobian of the piece the
//! point lies on; Qi & Sun, "A nonsmooth version of Newton's method", Math. Prog.
//! 58, 1993; Qi, "Convergence analysis of some algorithms for solving nonsmooth
//! equations", Math. Oper. Res. 18, 1993), within the trust region of Nocedal &
//! Wright ch. 4:
//!
//! * a taut tendon: taut columns, and its linearised tension kept `>= 0` (the step
//!   is cut where it would go slack);
//! * a slack tendon within [`ENGAGE_FRACTION`] of the trust radius of its
//!   engagement point (the reading that just takes up its slack): *engaged*,
//!   linearised on its taut side at that point (`F_z` with it taut at `T = 0`,
//!   free length = path length, its reading from that point, its tension kept
//!   `>= 0`). The taut side's face `T = 0` gives every tip the slack side gives
//!   (a slack tendon's reading moves nothing), so nothing is lost, and the model no
//!   longer flips between the sides from one iteration to the next;
//! * a slack tendon farther from engagement: zero column, and its linearised slack
//!   `l_f - l(z) - (dl/dq + e_i) dq >= 0` kept (`dl/dq = dl/dz dz/dq` from the same
//!   `F_z` solves): the step is cut where the others' motion or its own pull would
//!   engage it (a breakpoint), and the next linearisation is on its taut side.
//!
//! When the iteration would stop short of the target with a tendon at its
//! boundary (an engaged tendon, or a slack one within the settings' trust radius
//! of engagement), the other side's linearisation is tried first, once per attempt,
//! from the settings' trust radius: engaged tendons taken as slack, or slack ones
//! within that radius taken as engaged. Before this, a slack tendon's column was
//! the engaged one while the others' columns took it as slack: on FTDCR v4 val row
//! 19 (`tests/ik_boundary.rs`) steps from such a model were rejected with trust
//! ratios down to -533, the trust radius collapsed to about 1e-6 m and the tick
//! ended 14 um away as `unreachable` after 30 iterations; now it is reached in 8.
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
//! **Budget.** Every forward solve of a call runs under a pass budget,
//! [`IkSettings::max_solve_passes`] (the tendon solve's `max_passes` with its
//! cap-only policy, `TendonWorkspace::set_budget_cap_only`: the unbudgeted path,
//! the warm joint path with its continuation then the nested fallback, cut where
//! the budget runs out); a trial that runs out is a failed trial, the step shrinks
//! as after any other. A call then costs at most [`IkSettings::max_forward_solves`]
//! times that many passes besides its Jacobians ([`IkReport::passes`],
//! [`IkReport::peak_passes`]). Why: over a long warm chain
//! (`examples/ik_tick_profile.rs 20`: the FTDCR v4 val rows walked forward and back
//! 20 times, 8 839 ticks, 25 673 forward solves) the readings, which the objectives
//! pin only relative to the call's start, drift along the co-contraction (all
//! tendons pulled together): at the same target their sum ranged 1.7-24.1 mm from
//! one walk to another, the largest tension up to 13.5 N. There warm forward solves
//! of 0.2-0.5 mm trial steps ran the joint path's continuation for up to 968 passes
//! and then the nested fallback (51 solves of 129-973 passes, up to 80 shooting
//! solves), 4 077 passes (4.8 s) in one call; the other 25 622 solves took at most
//! 76 passes (p99 8, p99.9 22): 128, above that maximum, bounds the chain's
//! solves and cuts those 51 (docs/command.md). It is not the default (the default
//! is no budget, as before): 128 turns slow but reached ticks in the
//! co-contraction into `budget_exhausted` ones (`tests/ik_budget.rs`: from row
//! 170's co-contracted readings, 14 of 15 ticks, up to 18 mm away) and leaves a
//! daru property case of `tests/ik.rs` (a 10 % start, trial steps of millimetres)
//! 10.2 um away. Those figures are without the rest term (above), which removes
//! the drift: the same 20 walks then stay within 125 rod passes a call (below 128).
//! With the rest term, 128 still cuts that daru property case (tested: it ends out
//! of budget), so the budget stays off by default.
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

mod active_set;
mod broyden;
mod chain;
mod continuation;
mod iterate;
mod jacobian;
mod qp;
mod report;
mod settings;
mod step;

pub use chain::{IkChain, IkChainRow, IkStart};
pub use report::{IkReport, IkStatus};
pub use settings::{IkObjective, IkSettings, IkTarget};

use crate::error::ModelError;
use crate::math::warm::WarmCopy;
use crate::math::DenseLu;
use crate::robot::ActuatorLimits;
use crate::scene::Scene;
use crate::statics::Start;
use crate::tendons::TendonWorkspace;
use nalgebra::Vector3;
use qp::StepQp;
use report::Counts;

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
/// A slack tendon whose slack is below this fraction of the trust radius is
/// linearised on its taut side (module docs, "Taut/slack boundary").
const ENGAGE_FRACTION: f64 = 0.1;
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
    /// Slack (and not engaged) at the accepted readings, and the linearisation
    /// point: the reading itself, the reading that just takes up the slack (its
    /// engagement point) for an engaged one.
    slack: Vec<bool>,
    q_lin: Vec<f64>,
    /// Slack at the accepted readings but within [`IkWorkspace::engage_tol_m`] of
    /// its engagement point: linearised on the taut side, at that point (module
    /// docs, "Taut/slack boundary").
    engaged: Vec<bool>,
    /// A slack tendon's slack (free length less path length, m) and the rows of
    /// its linearised change `dl/dq` (p x p, row `k` for slack tendon `k`).
    gap: Vec<f64>,
    jg: Vec<f64>,
    /// A slack tendon within this of its engagement point is linearised as
    /// engaged (m): a fraction [`ENGAGE_FRACTION`] of the trust radius when the
    /// Jacobian is evaluated.
    engage_tol_m: f64,
    /// The other side's linearisation (module docs, "Taut/slack boundary"):
    /// tried in this attempt; the engagement tolerance and the trust radius
    /// reset for the next Jacobian.
    flip_tried: bool,
    engage_override: Option<f64>,
    reset_radius: bool,
    /// `dp/dq`, `da/dq` (3 x p, row-major) and `dT/dq` (p x p).
    jp: Vec<f64>,
    ja: Vec<f64>,
    jt: Vec<f64>,
    /// QP: full `P` (p x p), its gradient and the step (mm).
    h: Vec<f64>,
    g: Vec<f64>,
    u: Vec<f64>,
    /// The rest term's null-space projector (p x p) and `N q_lin` (mm) at the
    /// last `build_qp` (module docs, "Rest term").
    null: Vec<f64>,
    null_q: Vec<f64>,
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
    /// The scene's own `TendonSettings::max_passes` (the forward solves run with
    /// the smaller of it and [`IkSettings::max_solve_passes`]).
    scene_passes: Option<usize>,
    /// Passes of the friction fallback's differences at the last Jacobian: the
    /// sum and the most of one solve.
    fd_passes: (usize, usize),
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
        let mut tw = tw.without_rollback();
        tw.set_budget_cap_only(true);
        let scene_passes = tw.tendon_settings().max_passes;
        Self::budget_solves(&mut tw, scene_passes, &settings)?;
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
        let engage_tol_m = ENGAGE_FRACTION * settings.trust_radius_m;
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
            engaged: vec![false; p],
            gap: vec![0.0; p],
            jg: vec![0.0; p * p],
            engage_tol_m,
            flip_tried: false,
            engage_override: None,
            reset_radius: false,
            jp: vec![0.0; 3 * p],
            ja: vec![0.0; 3 * p],
            jt: vec![0.0; p * p],
            h: vec![0.0; p * p],
            g: vec![0.0; p],
            u: vec![0.0; p],
            null: vec![0.0; p * p],
            null_q: vec![0.0; p],
            qp: StepQp::new(p)?,
            has_state: false,
            first_order: f64::NAN,
            jac_valid: false,
            jac_exact: false,
            step_m: vec![0.0; p],
            scene_passes,
            fd_passes: (0, 0),
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
            // a start the budgeted warm solve did not reach: cold, with the
            // scene's own budget (its nested fallback included), since every
            // call needs a converged start
            let budgeted = *self.tw.tendon_settings();
            let mut own = budgeted;
            own.max_passes = self.scene_passes;
            self.tw.set_tendon_settings(own)?;
            let cold = self.tw.solve_readings_from(q, Start::Cold);
            self.tw.set_tendon_settings(budgeted)?;
            r = cold?;
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
        Self::budget_solves(&mut self.tw, self.scene_passes, &s)?;
        self.settings = s;
        Ok(())
    }

    /// The forward solves' pass budget: the smaller of the scene's
    /// `max_passes` and [`IkSettings::max_solve_passes`] when either is set
    /// (module docs, "Budget").
    fn budget_solves(
        tw: &mut TendonWorkspace,
        scene_passes: Option<usize>,
        s: &IkSettings,
    ) -> Result<(), ModelError> {
        let mut ts = *tw.tendon_settings();
        ts.max_passes = match (scene_passes, s.max_solve_passes) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        tw.set_tendon_settings(ts)
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
}
