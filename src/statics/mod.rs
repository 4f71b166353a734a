//! Statics layer: the shooting method for the boundary-value problem of the rod.
//!
//! Known at the base: `r(0)`, `R(0)` (thesis table 2.1). Unknown: `m(0)` (equivalently
//! `u(0) = C^-1 R(0)^T m(0) + u*`, the thesis's "initial bending found iteratively"),
//! plus `n(0)` when it is not known in closed form, plus assumed hole positions of
//! tensioned cables. Newton's method with an exact Jacobian from forward-mode dual
//! numbers, a backtracking line search, warm starts and load continuation.

mod diagnosis;
mod floor;
mod intensity;
mod multiple;
mod pass;
mod plan;
mod workspace;

pub(crate) use diagnosis::diagnose_named;
pub use diagnosis::{diagnose, Diagnosis, LoadShare, COMPRESSION_BLAMED_ABOVE, LOADS_BLAMED_ABOVE};
pub(crate) use pass::LOCAL_TOL;
pub use pass::{Pose, Sample};
pub use plan::ParamSite;
pub use workspace::joint::RhsCounts;
pub use workspace::{Start, Workspace};

use crate::cables::CableLength;
use crate::error::ModelError;
use crate::loads::Loads;
use crate::robot::Robot;
use crate::settings::SolverSettings;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// How a solve ended. Non-convergence is a status, never a panic.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SolveStatus {
    /// Scaled boundary residual below `tolerance`: the shape is an equilibrium. Usable.
    Converged,
    /// Iteration limit hit; the output is the best iterate, with `residual` telling
    /// how far from equilibrium. Usable only if that residual is acceptable to you.
    MaxIterations,
    /// The line search could not reduce the residual: a local minimum of the residual
    /// norm or a turning point. Not an equilibrium; do not use the shape.
    Stalled,
    /// The shooting Jacobian is singular to working precision (e.g. at buckling).
    /// Not an equilibrium; do not use the shape.
    IllConditioned,
    /// The integration produced NaN/infinity from the start point (loads far beyond
    /// what the rod can carry, or a wildly wrong warm start). Nothing is usable.
    NonFinite,
    /// A cold solve converged, but on an equilibrium that fails Jacobi's condition
    /// (a conjugate point, [`Workspace::conjugate_point`]): not a minimum of the
    /// potential energy, e.g. a looped or inverted rod under a large tip force, not the
    /// shape the robot takes. Checked for cold solves under world-fixed loads without
    /// tensioned cables (where `n(0)` is in closed form); do not use the shape.
    Unstable,
    /// The call's budget ended it before convergence (tendon solves from readings:
    /// [`crate::settings::TendonSettings::max_passes`] or `time_budget_s` ran out,
    /// or the joint paths handed back and the nested fallback, which a budgeted
    /// call does not run, was all that was left): the last iterate, not an
    /// equilibrium; do not use the shape. With the rollback on
    /// ([`crate::tendons::TendonWorkspace::set_rollback`]) the next solve starts as
    /// if this one had not run.
    BudgetExhausted,
}

impl SolveStatus {
    /// `true` only for `Converged`.
    pub fn is_converged(self) -> bool {
        self == Self::Converged
    }
}

impl From<crate::math::newton::End> for SolveStatus {
    /// The status of a chord-Newton run's end (a failed evaluation: `NonFinite`).
    fn from(end: crate::math::newton::End) -> Self {
        use crate::math::newton::End;
        match end {
            End::Converged => Self::Converged,
            End::Failed => Self::NonFinite,
            End::MaxJacobians => Self::MaxIterations,
            End::Singular => Self::IllConditioned,
            End::Stalled => Self::Stalled,
        }
    }
}

/// Counts and outcome of one solve (diffsol-style statistics).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SolveReport {
    /// How the solve ended.
    pub status: SolveStatus,
    /// Newton iterations (all continuation steps together).
    pub iterations: usize,
    /// Max-norm of the scaled boundary residual at the returned point (-).
    pub residual: f64,
    /// Tolerance the solve used (-): `settings.tolerance`, raised to the round-off
    /// floor of the residual for this robot, integrator and load when it is below it,
    /// and (condensed coupling) to 3 times the settle noise measured between two
    /// evaluations of the same unknowns (docs/scene-format.md, `[numerics]`, "Tolerance floor").
    /// `Converged` exactly when `residual <= tolerance`.
    pub tolerance: f64,
    /// ODE right-hand-side evaluations, counting each dual pass once per evaluation.
    pub rhs_evals: u64,
    /// Jacobian evaluations (dual-number passes of up to 6 directions each).
    pub jacobian_evals: u64,
    /// Load-continuation steps taken (0 when the direct solve converged).
    pub continuation_steps: usize,
    /// Number of shooting unknowns.
    pub unknowns: usize,
}

/// A solved forward problem: shape, poses, cable lengths and the solve report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Solution {
    /// Outcome and counts.
    pub report: SolveReport,
    /// Backbone samples base to tip (every integration step).
    pub samples: Vec<Sample>,
    /// Pose of each section's end, base to tip (the last is the tip).
    pub section_tips: Vec<Pose>,
    /// Pose of each guide disk centre, base to tip: `T(s_i)` of thesis 3.8.1.
    pub guides: Vec<GuidePose>,
    /// Cable lengths, indexed like `robot.cables`.
    pub cables: Vec<CableLength>,
    /// Internal force at the base `n(0)` (N): minus the reaction of the clamp.
    pub base_force: Vector3<f64>,
    /// Internal moment at the base `m(0)` (N m).
    pub base_moment: Vector3<f64>,
}

/// A guide disk's pose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GuidePose {
    /// Section index.
    pub section: usize,
    /// Index within the section.
    pub index: usize,
    /// Arc length of the disk centre (m).
    pub s: f64,
    /// Pose of the disk centre.
    pub pose: Pose,
}

impl Solution {
    /// Tip pose (end of the last section).
    pub fn tip(&self) -> &Pose {
        self.section_tips
            .last()
            .expect("a robot has at least one section")
    }
}

/// Solve the forward statics once from a cold start (allocating convenience form of
/// [`Workspace::solve`]).
pub fn solve(
    robot: &Robot,
    loads: &Loads,
    settings: &SolverSettings,
) -> Result<Solution, ModelError> {
    let mut ws = Workspace::new(robot.clone(), loads.clone(), settings.clone())?;
    ws.solve(Start::Cold);
    Ok(ws.solution())
}

crate::math::warm::warm_by_copy!(SolveReport);
