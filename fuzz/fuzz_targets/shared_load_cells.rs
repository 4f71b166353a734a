//! Check of the `load_cells_stream` fuzz target, shared with
//! `tests/fuzz_regressions.rs`: arbitrary bytes as a readings file with load-cell
//! columns (`tension_<cable>`) and a measuring cable's length change (`length_m1`,
//! a passive cable added to the shipped scene) of a two-segment TDCR with six
//! displacement-driven tendons and an unknown tip load (force x, y and payload mass),
//! every parsed row through the load estimator.
//!
//! Three robots with the same columns: the shipped load-cell demo
//! (`data/load_cells/tdcr_load_cells.toml`) and a small copy of it with either cable
//! coupling (`shared_tdcr.rs`, [`Robot`], [`robot_for`]).
//!
//! Budget of one input (every robot): at most [`MAX_ROWS`] rows ticked, forward
//! solves capped at `shared_tdcr::MAX_ITERATIONS` Newton iterations and
//! `shared_tdcr::MAX_CONTINUATION_STEPS` continuation steps (`shared.rs` caps the `scene_*`
//! targets' solves at 6 and 4), at most [`MAX_ESTIMATE_ITERATIONS`] estimator
//! iterations per row, and inside each forward solve the tendon iteration's budget of
//! `shared_tdcr::tendon_settings` (`TendonLoadEstimator::set_tendon_settings`). A row
//! that runs out of this budget ends with a non-converged status, which the checks
//! accept (its estimate is checked like any other).
//!
//! The scene and its estimator (whose construction runs the tendon workspace's
//! reference solve) are built once per process and cloned per input: every input
//! starts from the state `load_cells::estimator` returns, without re-building it.
//!
//! Invariants: no panic; a parsed row's load-cell tensions are missing (NaN) or
//! finite and >= 0, its length changes missing (NaN) or finite; a tick either returns a named error or a status, and the
//! estimate then has values within the unknowns' bounds (finite), standard
//! deviations >= 0 (infinite allowed: unobservable), finite tensions >= 0, and a
//! tension residual only where the row has a load cell.

#![allow(dead_code)]

use cablesense::estimate::EstimateStatus;
use cablesense::estimate::TendonLoadEstimator;
use cablesense::files::load_cells;
use cablesense::Scene;
use std::sync::OnceLock;

// the crate root (the fuzz target, or tests/fuzz_regressions.rs) includes it once
use super::shared_tdcr;
pub use shared_tdcr::{robot_for, Robot};

const SCENE: &str = include_str!("../../data/load_cells/tdcr_load_cells.toml");
/// A passive measuring cable added to the shipped scene (its own hole, to the tip), so
/// that `length_m1` columns are measurements of the estimator (`files::readings`).
const MEASURING_CABLE: &str = "\n[[robot.cables]]\nname = \"m1\"\nrouting = { radius_m = 0.006, angle_deg = 30.0 }\nend_section = 1\nactuation = \"passive\"\n";

/// Estimator iterations per row (the scene's default is 20).
pub const MAX_ESTIMATE_ITERATIONS: usize = 8;
/// Rows ticked per input (every row is parsed and checked).
pub const MAX_ROWS: usize = 3;

/// The shipped scene with the measuring cable for `robot` (`shared_tdcr::scene`),
/// estimator iterations capped.
pub fn scene(robot: Robot) -> Scene {
    let mut scene = shared_tdcr::scene(&format!("{SCENE}{MEASURING_CABLE}"), robot);
    let e = scene.estimate.as_mut().expect("shipped scene estimates");
    e.max_iterations = e.max_iterations.min(MAX_ESTIMATE_ITERATIONS);
    scene
}

/// The robot's scene (capped) and its freshly built estimator (built once per process).
fn template(robot: Robot) -> &'static (Scene, TendonLoadEstimator) {
    static SMALL: OnceLock<(Scene, TendonLoadEstimator)> = OnceLock::new();
    static SMALL_ARC: OnceLock<(Scene, TendonLoadEstimator)> = OnceLock::new();
    static SHIPPED: OnceLock<(Scene, TendonLoadEstimator)> = OnceLock::new();
    let cell = match robot {
        Robot::Small => &SMALL,
        Robot::SmallArc => &SMALL_ARC,
        Robot::Shipped => &SHIPPED,
    };
    cell.get_or_init(|| {
        let scene = scene(robot);
        let mut est = load_cells::estimator(&scene).expect("scene builds");
        est.set_tendon_settings(shared_tdcr::tendon_settings())
            .expect("the fuzz budget is valid");
        (scene, est)
    })
}

/// Run the check on the robot [`robot_for`] picks; panics on a broken invariant.
pub fn check_load_cells(data: &[u8]) {
    check_load_cells_on(robot_for(data), data);
}

/// Run the check on `robot`; panics on a broken invariant.
pub fn check_load_cells_on(robot: Robot, data: &[u8]) {
    let (scene, fresh) = template(robot);
    let mut est = fresh.clone();
    let mut parser = load_cells::parser(scene, &mut est);
    let text = String::from_utf8_lossy(data);
    let mut ticked = 0;
    for (i, line) in text.lines().enumerate() {
        let Ok(Some(row)) = parser.line(i + 1, line) else {
            continue;
        };
        assert!(
            row.tensions_n
                .iter()
                .all(|t| t.is_nan() || (t.is_finite() && *t >= 0.0)),
            "line {}: a bad load-cell tension passed the parser: {:?}",
            row.line,
            row.tensions_n
        );
        assert!(
            row.length_changes_m
                .iter()
                .all(|l| l.is_nan() || l.is_finite()),
            "line {}: a bad length change passed the parser: {:?}",
            row.line,
            row.length_changes_m
        );
        if ticked >= MAX_ROWS {
            continue;
        }
        ticked += 1;
        if est
            .tick(&row.readings_m, &row.tensions_n, row.length_changes())
            .is_err()
        {
            continue;
        }
        let e = est.estimate();
        let spec = est.estimator().spec().clone();
        for (k, v) in e.estimate.values.iter().enumerate() {
            let u = &spec.unknowns[k];
            assert!(
                v.is_finite() && *v >= u.lower() && *v <= u.upper(),
                "{k}: {v}"
            );
        }
        assert!(e.estimate.std_dev.iter().all(|s| *s >= 0.0), "{e:?}");
        if matches!(
            e.estimate.status,
            EstimateStatus::Converged | EstimateStatus::Unobservable
        ) {
            assert!(
                e.tensions_n.iter().all(|t| t.is_finite() && *t >= 0.0),
                "{e:?}"
            );
        }
        for (m, r) in e.measured_tension_n.iter().zip(&e.tension_residual_n) {
            assert!(m.is_some() || r.is_none(), "{e:?}");
        }
    }
}
