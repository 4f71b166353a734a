#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

pub mod cables;
pub mod calibrate;
pub mod command;
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

/// The reference pages under `docs/`, compiled for doctests only: their Rust examples
/// run with `cargo test` as the README's did before the reference moved there.
#[cfg(doctest)]
mod docs {
    #[doc = include_str!("../docs/conventions.md")]
    struct Conventions;
    #[doc = include_str!("../docs/scene-format.md")]
    struct SceneFormat;
    #[doc = include_str!("../docs/tendons.md")]
    struct Tendons;
    #[doc = include_str!("../docs/routing.md")]
    struct Routing;
    #[doc = include_str!("../docs/load-cells.md")]
    struct LoadCells;
    #[doc = include_str!("../docs/output-schema.md")]
    struct OutputSchema;
    #[doc = include_str!("../docs/library.md")]
    struct Library;
    #[doc = include_str!("../docs/calibration.md")]
    struct Calibration;
    #[doc = include_str!("../docs/c-abi.md")]
    struct CAbi;
    #[doc = include_str!("../docs/python.md")]
    struct Python;
    #[doc = include_str!("../docs/fuzzing.md")]
    struct Fuzzing;
    #[doc = include_str!("../docs/ladder.md")]
    struct Ladder;
    #[doc = include_str!("../docs/where-methods-fail.md")]
    struct WhereMethodsFail;
    #[doc = include_str!("../docs/settings-matrix.md")]
    struct SettingsMatrix;
    #[doc = include_str!("../docs/architecture.md")]
    struct Architecture;
    #[doc = include_str!("../docs/history.md")]
    struct History;
}
