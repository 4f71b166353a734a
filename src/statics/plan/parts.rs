//! The parts of a [`Plan`](super::Plan): the events at interval ends, the
//! intervals, point loads, load parameters and cables as the pass reads them.

use crate::robot::TendonPath;
use nalgebra::Vector3;

/// An event applied at the end of an interval.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Event {
    /// Guide disk (global index): pose record, point mass, cable forces.
    Guide(usize),
    /// Point load (index into `loads.point`).
    Point(usize),
    /// End of a section: pose record.
    SectionEnd(usize),
}

/// A stretch of rod with constant coefficients.
#[derive(Clone, Debug)]
pub(crate) struct Interval {
    pub s0: f64,
    pub s1: f64,
    pub section: usize,
    /// Linear density including distributed guide mass (kg/m).
    pub lambda: f64,
    /// RK4 steps.
    pub steps: usize,
    /// Events at `s1`.
    pub events: std::ops::Range<usize>,
}

/// Resolved point load (values updated by `set_loads`).
#[derive(Clone, Debug)]
pub(crate) struct PlanPoint {
    pub section: usize,
    pub force: Vector3<f64>,
    pub torque: Vector3<f64>,
    pub body: bool,
    pub mass: f64,
}

/// A load parameter `theta_k` the pass can differentiate with respect to (the
/// estimator's unknowns). Each adds to a load of the scene.
// Fields: `point` indexes `loads.point`, `axis` is 0/1/2 (world x/y/z), `cable`
// indexes `robot.cables`.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamSite {
    /// World-frame force component (N) added at point load `point`, axis 0/1/2.
    Force { point: usize, axis: usize },
    /// World-frame torque component (N m) added at point load `point`.
    Torque { point: usize, axis: usize },
    /// Payload mass (kg) added at point load `point`.
    Mass { point: usize },
    /// Tension (N) added to cable `cable`.
    Tension { cable: usize },
}

/// One cable as the pass sees it.
#[derive(Clone, Debug)]
pub(crate) struct PlanCable {
    pub tension: f64,
    /// Tensioned at full load (structure: decides the unknowns).
    pub tensioned: bool,
    /// Base-plate hole in world coordinates.
    pub base_hole: Vector3<f64>,
    /// Local hole vector on each route disk (each disk's own hole pattern).
    pub hole_local: Vec<Vector3<f64>>,
    /// Number of disks on the route.
    pub len: usize,
    /// Arc length of the termination disk, or a continuous tendon's end (m).
    pub end_s: f64,
    /// Local position of the cable where it ends (m): its last hole, or a continuous
    /// tendon's path there.
    pub end_hole: Vector3<f64>,
    /// Continuously routed (`crate::statics::pass::continuous`): no disks, no chords.
    pub routed: bool,
    /// Index of the first hole unknown (route disk 1) when tensioned.
    pub unknowns: Option<usize>,
    /// Tension of chord `k` (ending at route disk `k`; chord 0 starts at the base
    /// plate) relative to the actuator's: 1 without friction, the capstan factors
    /// `exp(+-mu theta)` with it ([`crate::tendons`]).
    pub factor: Vec<f64>,
    /// Shortest chord of the route (m): base plate to the first disk, then disk to
    /// disk (infinite without disks); the residual floor's coupling term
    /// (`statics::floor`), gathered once instead of at every evaluation.
    pub shortest_chord: f64,
    /// Arc coupling ([`Plan::arc`]): per chord from route disk `k` to `k + 1`, the
    /// arc length of the gap (m) and the section whose stiffness it takes (the one
    /// at the gap's midpoint). Empty otherwise.
    pub gap: Vec<(f64, usize)>,
}

/// A chord of the arc coupling from a disk on to the next disk of its cable's route
/// (`statics::pass::arc`): what the disk's rounds read, gathered once so that a
/// round touches no [`PlanCable`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct ArcChord {
    /// Cable index.
    pub cable: usize,
    /// Hole vector on this disk and on the next one, each in its own disk's frame (m).
    pub rho: Vector3<f64>,
    pub rho_next: Vector3<f64>,
    /// The gap to the next disk: arc length (m) and section ([`PlanCable::gap`]).
    pub gap: (f64, usize),
    /// The gap differs from the previous chord's in the guide's list (always for the
    /// first): the rounds predict it anew.
    pub new_gap: bool,
}

/// One continuously routed cable as the plan sees it.
#[derive(Clone, Debug)]
pub(crate) struct RoutedCable {
    /// Index into `robot.cables`.
    pub cable: usize,
    pub path: TendonPath,
    /// Arc length where it ends (m).
    pub end_s: f64,
}
