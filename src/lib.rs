//! Statics of cable- and tendon-driven continuum robots: a Cosserat-rod model solved
//! by shooting, cable lengths through the guide holes, and the inverse problems on
//! top of it (readings to shape, loads from encoders, calibration on motion capture).
//! The command-line tool, the C ABI and the Python module call the same entries.
//!
//! # The four jobs
//!
//! | job | entry | returns |
//! |---|---|---|
//! | forward: robot and loads to shape and cable lengths | [`solve`] (or a [`Workspace`] for warm, allocation-free repeats) | [`Solution`] |
//! | readings to shape: servo readings of tendons to shape and tensions | [`TendonWorkspace`] ([`Scene::tendon_workspace`]) | [`TendonReport`], the tip, tensions, taut flags |
//! | estimate: cable length changes to loads, each control tick | [`Estimator`] | [`estimate::Estimate`] (values, covariance, fit) |
//! | calibrate: scene parameters from a motion-capture recording | [`calibrate_scene`] | [`SceneCalibration`] (report and calibrated scene) |
//!
//! **Forward.** A pure tip moment bends a rod into a circular arc of curvature `M / EI`:
//!
//! ```
//! use cablesense::{solve, Loads, PointLoad, Scene, SolverSettings};
//!
//! let scene = Scene::from_toml_str(r#"
//!     [[robot.sections]]
//!     length_m = 0.3
//!     shape = { solid = { diameter_m = 1.56e-3 } }
//!     youngs_modulus_pa = 62.7e9
//!     poisson_ratio = 0.3
//!     density_kg_m3 = 6800.0
//! "#)?;
//! let robot = scene.build_robot()?;
//! let mut loads = Loads::none(); // no gravity
//! loads.point.push(PointLoad { section: 0, torque_nm: [0.01, 0.0, 0.0], ..Default::default() });
//! let sol = solve(&robot, &loads, &SolverSettings::default())?;
//! assert!(sol.report.status.is_converged());
//! let k = 0.01 / robot.sections()[0].stiffness.bend_twist.x;
//! assert!((sol.tip().position.z - (k * 0.3).sin() / k).abs() < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! **Readings to shape.** The shipped three-segment FTDCR v4 scene, one servo pulled
//! 5 mm (readings in metres, in the scene's column order):
//!
//! ```
//! use cablesense::Scene;
//!
//! let scene = Scene::load("data/scenes/ftdcr_v4.toml")?;
//! let mut ws = scene.tendon_workspace()?;
//! let straight = ws.tip_position();
//! let mut q = vec![0.0; 9];
//! q[0] = 0.005;
//! let report = ws.solve_readings(&q)?;
//! assert!(report.status.is_converged());
//! assert!((ws.tip_position() - straight).norm() > 1e-3); // the tip moved
//! assert!(ws.tensions()[0] > 0.0 && ws.taut()[0]); // and the pulled tendon is taut
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! **Estimate.** The track demo's lateral tip force from the three cables' length
//! changes (here made by a forward solve under a known force):
//!
//! ```
//! use cablesense::estimate::EstimateStatus;
//! use cablesense::{Estimator, PointLoad, Scene, Start, Workspace};
//!
//! let scene = Scene::load("data/scenes/track_demo.toml")?;
//! let robot = scene.build_robot()?;
//! let spec = scene.estimate.clone().expect("the scene has an [estimate] table");
//! let mut est = Estimator::new(robot.clone(), scene.loads.clone(), scene.numerics.clone(), spec)?;
//! // the "measured" lengths: the rod under a 20 mN force along world y at its tip
//! let mut loads = scene.loads.clone();
//! loads.point.push(PointLoad { section: 0, force_n: [0.0, 0.02, 0.0], ..Default::default() });
//! let mut ws = Workspace::new(robot, loads, scene.numerics.clone())?;
//! assert!(ws.solve(Start::Cold).status.is_converged());
//! let mut lengths = vec![0.0; 3];
//! ws.cable_lengths_into(&mut lengths);
//! let changes: Vec<f64> = lengths.iter().zip(est.reference_lengths()).map(|(l, r)| l - r).collect();
//! assert_eq!(est.tick(&changes, None), EstimateStatus::Converged);
//! let e = est.estimate();
//! assert!((e.values[0] - 0.02).abs() < 1e-6 && e.values[1].abs() < 1e-6);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! **Calibrate.** The FTDCR v4 scene's `[calibration]` parameters on its train
//! recording, errors reported on the held-out val recording (compiled, not run
//! here: the fit takes minutes; `cablesense calibrate` runs the same call):
//!
//! ```no_run
//! use cablesense::calibrate::{calibrate_scene, scene_spec, ColumnMap, Recording};
//! use cablesense::Scene;
//!
//! let scene = Scene::load("data/scenes/ftdcr_v4.toml")?;
//! let spec = scene_spec(&scene);
//! let map = ColumnMap::from_spec(&spec);
//! let train = Recording::load("data/hardware/ftdcr_v4/train.csv", &map)?;
//! let val = Recording::load("data/hardware/ftdcr_v4/val.csv", &map)?;
//! let job = calibrate_scene(&scene, &spec, &train, Some(&val), 2, &mut |_| {})?;
//! if let Some(v) = &job.report.val {
//!     println!("val RMSE {:.2} mm", v.raw.rmse_m * 1e3);
//! }
//! std::fs::write("calibrated.toml", job.scene.to_toml_string())?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Where the rest lives
//!
//! The modules follow the layers, bottom to top: [`scene`] (the file schema and
//! parameter paths), [`rod`] and [`robot`] (sections, guides, tendons, friction
//! laws), [`loads`], [`statics`] (the shooting solvers), [`tendons`] (readings-driven
//! solves), [`ladder`] (the cheaper models: CC, PCC, Kirchhoff, coarser rods),
//! [`estimate`], [`calibrate`] and [`validation`], [`command`] (inverse kinematics
//! and workspace), [`files`] (readers and writers) and [`experiments`] (speed
//! against accuracy, where each method stops converging). The reference pages are
//! under `docs/` and the front page is `README.md`.

#![warn(missing_docs)]
// Every type a public signature reaches can be named by a user (and is in the docs):
// narrowing a re-export to `pub(crate)` while a public function still returns the
// type is refused (CI runs clippy with `-D warnings`).
#![warn(unnameable_types)]

pub(crate) mod cables;
pub mod calibrate;
pub mod command;
pub(crate) mod error;
pub mod estimate;
pub mod experiments;
pub mod files;
pub(crate) mod integrate;
pub mod ladder;
pub mod loads;
pub(crate) mod math;
pub mod robot;
pub mod rod;
pub mod scene;
pub(crate) mod settings;
pub mod statics;
pub mod tendons;
pub mod validation;

// the four jobs (crate docs above), then the types they take
pub use calibrate::{calibrate_scene, SceneCalibration};
pub use estimate::Estimator;
pub use statics::{solve, Pose, Sample, Solution, SolveReport, SolveStatus, Start, Workspace};
pub use tendons::{TendonReport, TendonWorkspace};

pub use nalgebra;

pub use cables::CableLength;
pub use error::{Fixed6, ModelError, Num};
pub use loads::{Frame, Loads, PointLoad};
pub use robot::{Robot, RobotSpec};
pub use rod::{CrossSection, Material};
pub use scene::{Scene, SceneError};
pub use settings::{
    CableCoupling, GuideMass, Integrator, RodModel, SolverSettings, TendonSettings,
};

/// The reference pages under `docs/`, compiled for doctests only: their Rust examples
/// run with `cargo test` as the README's did before the reference moved there.
#[cfg(doctest)]
mod docs {
    #[doc = include_str!("../README.md")]
    struct Readme;
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
    #[doc = include_str!("../docs/plots.md")]
    struct Plots;
    #[doc = include_str!("../docs/history.md")]
    struct History;
}
