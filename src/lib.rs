#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

pub mod cables;
pub mod calibrate;
pub mod error;
pub mod estimate;
pub mod experiments;
pub mod files;
pub mod integrate;
pub mod ladder;
pub mod loads;
pub mod math;
pub mod robot;
pub mod rod;
pub mod scene;
pub mod settings;
pub mod statics;
pub mod tendons;
pub mod validation;

pub use nalgebra;

pub use cables::CableLength;
pub use error::ModelError;
pub use loads::{Frame, Loads, PointLoad};
pub use robot::{Robot, RobotSpec};
pub use rod::{CrossSection, Material};
pub use scene::{Scene, SceneError};
pub use settings::{CableCoupling, GuideMass, Integrator, RodModel, SolverSettings};
pub use statics::{solve, Pose, Sample, Solution, SolveReport, SolveStatus, Start, Workspace};
