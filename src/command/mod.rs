//! Commanding the robot: which actuator readings put the tip at a target (inverse
//! kinematics of a tendon robot with stretch, slack tendons and actuator limits).
//!
//! The forward model is the readings solve of [`crate::tendons::TendonWorkspace`];
//! [`IkWorkspace`] inverts it by a trust-region Gauss-Newton iteration whose steps
//! are bounded least-squares problems (an active-set QP, clarabel as the fallback), with the exact Jacobian of the
//! tip with respect to the readings (implicit function theorem, [`ik`] module docs),
//! warm-started from the previous tick and bounded by a per-call budget.
//! [`workspace`] samples the actuator box for the reachable tips, their convex hull
//! and volume.
//! Layering: this module uses `tendons`, `statics` and `robot`, never the CLI.

pub mod ik;

pub use ik::{IkObjective, IkReport, IkSettings, IkStatus, IkTarget, IkWorkspace};
pub mod workspace;

pub use workspace::{sample_workspace, Hull, SampleStatus, WorkspaceCloud, WorkspaceSettings};
