//! Solver settings: plain structs with documented units and defaults.

use crate::error::ModelError;
use serde::{Deserialize, Serialize};

/// Which rod theory the backbone obeys.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RodModel {
    /// Full Cosserat rod: shear, extension, bending, torsion (thesis eqs. 2.3-2.13).
    #[default]
    Cosserat,
    /// Kirchhoff rod: inextensible and unshearable, `v = e3`.
    Kirchhoff,
}

/// How a tensioned cable's pull on a disk, which points along the chord to the *next*
/// disk (not yet integrated when the pass reaches this disk), is resolved.
///
/// `condensed` and `exact` solve the same equations to the same tolerance and differ
/// in cost; `arc` replaces the not-yet-integrated next disk by a prediction (a model
/// approximation, cheaper still).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CableCoupling {
    /// Each disk-to-disk segment is solved for its next hole positions inside the pass
    /// (a local Newton whose matrix comes from the last Jacobian sweep), so Newton
    /// shoots only for the base wrench (6 unknowns); the sweep carries 3 extra dual
    /// directions per tensioned cable over one segment at a time and folds them in
    /// exactly (implicit function theorem per segment). Falls back to `exact` when more
    /// than six tensioned cables pass one disk.
    #[default]
    Condensed,
    /// The hole positions of every tensioned cable on route disks 1..K-1 are shooting
    /// unknowns beside the base wrench (3 per hole), with matching residuals.
    Exact,
    /// The next hole is predicted from the state at the disk, not solved for: the gap
    /// to the next disk is taken as a circular arc (constant curvature and strain
    /// from the internal moment and force at the gap's midpoint, rigid-body
    /// exponential map), and the disk's chord forces and that prediction are iterated
    /// a fixed number of times (`statics::pass::arc`). No local iteration, no hole
    /// unknowns, no jump directions in the sweep: the pass is explicit, and cheaper.
    /// An approximation of the discrete routing of thesis 3.8.1: its error is the
    /// arc's miss of the integrated next disk, second order in the gap; cable
    /// lengths still use the integrated holes. Measured against `condensed` in
    /// `tests/arc_coupling.rs`.
    Arc,
}

/// How the guide disks' mass enters the model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GuideMass {
    /// Disks are massless.
    None,
    /// Thesis 3.7: disk mass spread evenly over its section, `rho_avg = (m_r + m_cg) / r_l`.
    #[default]
    Average,
    /// Thesis 3.8: piecewise density, disk mass spread over its own thickness
    /// (`rho_e A_cg = m_cg / h_cg + m_r / r_l`, table 3.2).
    Accurate,
    /// Each disk a point mass at its centre: a jump `n+ = n- - m g` in the internal force.
    Point,
}

/// ODE integrator along arc length.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Integrator {
    /// Classical fixed-step RK4; steps are spread over each section in proportion to
    /// length, aligned with guides, disk edges and point loads (>= 1 per interval).
    Rk4 {
        /// Steps per section (default 24).
        steps_per_section: usize,
    },
    /// Dormand-Prince 5(4) with step-size control, steps landing on every event.
    Adaptive {
        /// Relative/absolute tolerance on the scaled state (default 1e-8).
        tol: f64,
        /// Step limit over the whole rod (default 100000); exceeding it fails the pass.
        max_steps: usize,
    },
}

impl Default for Integrator {
    fn default() -> Self {
        Self::Rk4 {
            steps_per_section: 24,
        }
    }
}

/// Settings of the tendon iteration of a solve from readings
/// (`crate::tendons::TendonWorkspace`; the shooting solve inside has the rest of
/// [`SolverSettings`]). Scene form: `[numerics.tendons]`, each key optional.
///
/// The two tolerances (this `tolerance_m` and [`SolverSettings::tolerance`]) are the
/// user's accuracy choice. The defaults solve to round-off; a control loop can loosen
/// both: what each pair costs and how far it moves the tips on the FTDCR v4 recording
/// is in the paragraph on the two tolerances of docs/tendons.md (measured with
/// `examples/tendon_profile`, asserted in `tests/tendon_tolerance.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TendonSettings {
    /// Newton iterations on the tensions (default 30).
    pub max_iterations: usize,
    /// Tolerance on `max_i |G_i|` (m), the mismatch between each taut tendon's path
    /// and the length it covers at its tension (default 1e-12 m).
    pub tolerance_m: f64,
    /// Warm solves first try Newton on the shooting unknowns and the tensions
    /// together (`tendons::solve::joint`), handing back to the nested method when it does
    /// not converge (default true; false runs the nested method only).
    pub joint_newton: bool,
    /// Nested shooting solves one row may run
    /// ([`crate::tendons::TendonReport::shooting_solves`]:
    /// each a full Newton solve of the rod at fixed tensions, with continuation and
    /// branch checks when it needs them; line-search trials included; default 200).
    /// A row that reaches it ends with `max_iterations`, so a row the solver cannot
    /// reach costs a bounded amount of work (a control loop's worst tick; the fuzz
    /// targets set 12). The joint path's single passes are bounded by its own
    /// iteration and substep limits and not counted. Measured: an unreachable 82 mm
    /// pull on the two-segment TDCR's 0.1 m segments ran 108 shooting solves in 2.5 s
    /// before stalling.
    pub max_shooting_solves: usize,
    /// Work budget of one solve call, in rod evaluations
    /// ([`crate::tendons::TendonReport::forward_solves`]: the joint path's `f64`
    /// passes of the whole rod, line-search trials included). Checked before each
    /// evaluation: a call that has run `max_passes` returns at once with status
    /// `budget_exhausted` and the state where it stopped (rolled back before the
    /// next call when the rollback is on). A budgeted call runs the joint path
    /// only: the warm predictor and Newton from the last converged row, then, when
    /// they do not reach the row, the cold joint path from the reference
    /// equilibrium with what is left; when that hands back too, the call ends with
    /// the same status instead of running the nested fallback (one of whose
    /// shooting solves costs milliseconds). Default none (unbounded, the nested
    /// fallback included). Sizes and overshoot: docs/control-loop-budget.md.
    pub max_passes: Option<usize>,
    /// Wall-time budget of one solve call (s), checked where `max_passes` is (before
    /// each rod evaluation), with the same status and the same rule for the nested
    /// fallback. Default none. Results then depend on the machine's speed (use
    /// `max_passes` for reproducible streams).
    pub time_budget_s: Option<f64>,
}

impl Default for TendonSettings {
    fn default() -> Self {
        Self {
            max_iterations: 30,
            tolerance_m: 1e-12,
            joint_newton: true,
            max_shooting_solves: 200,
            max_passes: None,
            time_budget_s: None,
        }
    }
}

impl TendonSettings {
    /// Every field at its default (a scene then leaves `[numerics.tendons]` out).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// Check every field (names them as `numerics.tendons.*`).
    pub fn validate(&self) -> Result<(), ModelError> {
        ModelError::positive("numerics.tendons.tolerance_m", self.tolerance_m)?;
        if let Some(t) = self.time_budget_s {
            ModelError::positive("numerics.tendons.time_budget_s", t)?;
        }
        for (field, v) in [
            ("numerics.tendons.max_iterations", self.max_iterations),
            (
                "numerics.tendons.max_shooting_solves",
                self.max_shooting_solves,
            ),
            ("numerics.tendons.max_passes", self.max_passes.unwrap_or(1)),
        ] {
            if v == 0 || v > 100_000 {
                return Err(ModelError::OutOfRange {
                    field: field.into(),
                    value: v as f64,
                    why: "between 1 and 100000".into(),
                });
            }
        }
        Ok(())
    }
}

/// Everything that controls a forward solve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverSettings {
    /// Rod theory (default `cosserat`).
    pub rod_model: RodModel,
    /// Guide-mass model (default `average`, the thesis's recommendation in 4.7.3).
    pub guide_mass: GuideMass,
    /// Integrator (default RK4, 24 steps per section).
    pub integrator: Integrator,
    /// Newton iteration limit per solve (default 50).
    pub max_iterations: usize,
    /// Convergence threshold on the scaled boundary residual's max-norm (default 1e-10).
    /// Forces are scaled by `EI/L^2`, moments by `EI/L`, positions by `L`. A solve
    /// raises it to the residual's round-off floor for its robot, integrator and loads
    /// (`Workspace::residual_floor`, reported as `SolveReport::tolerance`).
    pub tolerance: f64,
    /// Retry a failed cold start by load continuation (default true).
    pub continuation: bool,
    /// Largest number of continuation steps (default 32).
    pub max_continuation_steps: usize,
    /// How tensioned cables' next-chord directions are resolved (default `condensed`).
    pub cable_coupling: CableCoupling,
    /// Rounds of the `arc` coupling's next-hole prediction at a disk (default 3;
    /// between 1 and 100; read only under `cable_coupling = "arc"`). Each round is
    /// about a tenth of a warm FTDCR v4 row's instructions; the rounds start from
    /// the mirrored chords corrected as the disks just before were, and converge to
    /// the arc's fixed point by about `sum T (h^2/6 + rho h/2) / EI` a round. On the
    /// 443 FTDCR v4 val rows, tips from the fixed point's: 1 round 39 um mean (max
    /// 0.27 mm; 17 % fewer instructions a warm row than 2), 2 rounds 6.7 um (max 60
    /// um), 3 rounds 0.66 um (max 5.3 um); the fixed point is 3.3 um from
    /// `condensed` (`statics::pass::arc`, `tests/arc_coupling.rs`).
    #[serde(skip_serializing_if = "is_default_arc_rounds")]
    pub arc_rounds: usize,
    /// Keep solves on the branch reached by loading the rod from rest (default true):
    /// - world-fixed loads without tensioned cables: a cold solve's equilibrium that
    ///   fails Jacobi's condition is `unstable` (one extra dual sweep per cold solve);
    /// - other loads (tensioned cables, body-frame loads) of load intensity above 3
    ///   (`Workspace::load_intensity`): a cold solve is a branch-checked load
    ///   continuation (tangent predictor, corrector/predictor ratio, sign of the
    ///   shooting Jacobian's determinant); past a fold it fails `stalled`;
    /// - warm solves: one whose Newton path left its first (tangent) step's direction,
    ///   a large one under world-fixed loads above intensity 3 with a conjugate point,
    ///   or one changing the intensity by more than 0.25 under other loads above 3, is
    ///   solved cold.
    ///   Small control-loop steps pay nothing extra.
    pub branch_guard: bool,
    /// The tendon iteration of a solve from readings (`[numerics.tendons]`; defaults
    /// on [`TendonSettings`]). Read by `crate::tendons::TendonWorkspace` only.
    #[serde(skip_serializing_if = "TendonSettings::is_default")]
    pub tendons: TendonSettings,
}

/// Default rounds of "predict the next holes from the jump of the last round" at a
/// disk ([`SolverSettings::arc_rounds`], read by the arc coupling of
/// `statics::pass::arc`; the carried start gives the first jump). On
/// the 443 FTDCR v4 val rows, solved warm, tips against those of the rounds' fixed
/// point (40 rounds): from the mirrored chords alone (the predictor the carried start replaced) 2 rounds 32
/// um mean (max 0.34 mm), 3 rounds 7.0 um (max 91 um); from the carried start 1
/// round 39 um (max 0.27 mm; the last correction alone: extrapolating one round's
/// unconverged corrections gave 215 um), 2 rounds 6.7 um (max 60 um), 3 rounds 0.66
/// um (max 5.3 um). The fixed point is 3.3 um (max 25 um) from the condensed
/// coupling: the arc's own error. Callgrind instructions of those warm rows
/// (`examples/tendon_profile`): 3 rounds mirrored 0.932e9, carried 2 rounds 0.836e9,
/// 1 round 0.693e9.
pub(crate) const ARC_ROUNDS: usize = 3;

/// `arc_rounds` at its default (a scene then leaves it out).
fn is_default_arc_rounds(n: &usize) -> bool {
    *n == ARC_ROUNDS
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            rod_model: RodModel::default(),
            guide_mass: GuideMass::default(),
            integrator: Integrator::default(),
            max_iterations: 50,
            tolerance: 1e-10,
            continuation: true,
            max_continuation_steps: 32,
            cable_coupling: CableCoupling::default(),
            arc_rounds: ARC_ROUNDS,
            branch_guard: true,
            tendons: TendonSettings::default(),
        }
    }
}

impl SolverSettings {
    /// Check every field.
    pub fn validate(&self) -> Result<(), ModelError> {
        match self.integrator {
            Integrator::Rk4 { steps_per_section } => {
                if steps_per_section == 0 || steps_per_section > 1_000_000 {
                    return Err(ModelError::OutOfRange {
                        field: "numerics.integrator.rk4.steps_per_section".into(),
                        value: steps_per_section as f64,
                        why: "between 1 and 1000000".into(),
                    });
                }
            }
            Integrator::Adaptive { tol, max_steps } => {
                ModelError::positive("numerics.integrator.adaptive.tol", tol)?;
                if max_steps == 0 || max_steps > 10_000_000 {
                    return Err(ModelError::OutOfRange {
                        field: "numerics.integrator.adaptive.max_steps".into(),
                        value: max_steps as f64,
                        why: "between 1 and 10000000".into(),
                    });
                }
            }
        }
        ModelError::positive("numerics.tolerance", self.tolerance)?;
        if self.max_iterations == 0 || self.max_iterations > 10_000 {
            return Err(ModelError::OutOfRange {
                field: "numerics.max_iterations".into(),
                value: self.max_iterations as f64,
                why: "between 1 and 10000".into(),
            });
        }
        if self.arc_rounds == 0 || self.arc_rounds > 100 {
            return Err(ModelError::OutOfRange {
                field: "numerics.arc_rounds".into(),
                value: self.arc_rounds as f64,
                why: "between 1 and 100".into(),
            });
        }
        if self.max_continuation_steps > 10_000 {
            return Err(ModelError::OutOfRange {
                field: "numerics.max_continuation_steps".into(),
                value: self.max_continuation_steps as f64,
                why: "at most 10000".into(),
            });
        }
        self.tendons.validate()
    }
}
