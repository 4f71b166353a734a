//! How an inverse solve ended and what it cost.

use super::IkObjective;
use nalgebra::Vector3;

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

/// Outcome of one inverse solve; the readings are [`IkWorkspace::readings`](super::IkWorkspace::readings).
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
    /// Rod passes of those forward solves, summed
    /// ([`TendonReport::forward_solves`](crate::tendons::TendonReport::forward_solves)
    /// of each; the Jacobians' sweeps and tangent passes not included).
    pub passes: usize,
    /// The most passes one of those forward solves ran (at most
    /// [`IkSettings::max_solve_passes`](super::IkSettings::max_solve_passes) when
    /// set).
    pub peak_passes: usize,
    /// Bounded least-squares steps solved.
    pub qp_solves: usize,
    /// Of those, the ones the allocation-free active-set method gave up on
    /// (numerically dependent constraints, cycling) and clarabel solved: these
    /// allocate (0 on the FTDCR v4's warm ticks, `tests/ik_alloc.rs`).
    pub qp_fallbacks: usize,
    /// The secondary objective that chose among the solutions.
    pub objective: IkObjective,
    /// Tendons slack at the returned readings.
    pub slack: usize,
    /// First-order measure at the last linearisation: the norm of the projected
    /// gradient of `phi` over `2 |J|_F |r|` (dimensionless; 0 at a constrained
    /// stationary point, `Unreachable` only below 1e-2; NaN when none was built).
    pub first_order: f64,
}

/// Work of one call: Gauss-Newton iterations (Jacobians), forward solves and
/// their passes, QPs.
#[derive(Default)]
pub(super) struct Counts {
    pub(super) iterations: usize,
    pub(super) jacobians: usize,
    pub(super) solves: usize,
    pub(super) passes: usize,
    pub(super) peak_passes: usize,
    pub(super) qp_solves: usize,
    pub(super) qp_fallbacks: usize,
}

impl Counts {
    /// Count one forward solve that ran `passes` rod passes.
    pub(super) fn solve(&mut self, passes: usize) {
        self.solves += 1;
        self.passes += passes;
        self.peak_passes = self.peak_passes.max(passes);
    }
}
