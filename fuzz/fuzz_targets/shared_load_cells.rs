//! Check of the `load_cells_stream` fuzz target, shared with
//! `tests/fuzz_regressions.rs`: arbitrary bytes as a readings file with load-cell
//! columns (`tension_<cable>`) of the shipped load-cell demo
//! (`data/load_cells/tdcr_load_cells.toml`: six displacement-driven tendons, unknown tip
//! force x, y and payload mass), every parsed row through the load estimator (at most
//! 3 per input, so one input stays cheap).
//!
//! The scene and its estimator (whose construction runs the tendon workspace's
//! reference solve) are built once per process and cloned per input: every input
//! starts from the state `load_cells::estimator` returns, without re-building it.
//!
//! Invariants: no panic; a parsed row's load-cell tensions are missing (NaN) or
//! finite and >= 0; a tick either returns a named error or a status, and the
//! estimate then has values within the unknowns' bounds (finite), standard
//! deviations >= 0 (infinite allowed: unobservable), finite tensions >= 0, and a
//! tension residual only where the row has a load cell.

#![allow(dead_code)]

use cablesense::estimate::EstimateStatus;
use cablesense::estimate::TendonLoadEstimator;
use cablesense::files::load_cells;
use cablesense::Scene;
use std::sync::OnceLock;

const SCENE: &str = include_str!("../../data/load_cells/tdcr_load_cells.toml");

/// Budget of one input: the scene's forward solves are capped at this many Newton
/// iterations and [`MAX_CONTINUATION_STEPS`] continuation steps (as `shared.rs` caps
/// the `scene_*` targets' solves). A row whose solve stalls ran 44-97 forward solves
/// of 20-60 ms each at the scene's own limits (50 and 32): 2-7 s per row, most of
/// it in load continuation. The integrator's resolution is the scene's.
const MAX_ITERATIONS: usize = 10;
/// See [`MAX_ITERATIONS`].
const MAX_CONTINUATION_STEPS: usize = 4;

/// The shipped scene (numerics capped) and its freshly built estimator (built once per process).
fn template() -> &'static (Scene, TendonLoadEstimator) {
    static TEMPLATE: OnceLock<(Scene, TendonLoadEstimator)> = OnceLock::new();
    TEMPLATE.get_or_init(|| {
        let mut scene = Scene::from_toml_str(SCENE).expect("shipped scene parses");
        let n = &mut scene.numerics;
        n.max_iterations = n.max_iterations.min(MAX_ITERATIONS);
        n.max_continuation_steps = n.max_continuation_steps.min(MAX_CONTINUATION_STEPS);
        let est = load_cells::estimator(&scene).expect("shipped scene builds");
        (scene, est)
    })
}

/// Run the check; panics on a broken invariant.
pub fn check_load_cells(data: &[u8]) {
    let (scene, fresh) = template();
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
        if ticked >= 3 {
            continue;
        }
        ticked += 1;
        if est.tick(&row.readings_m, &row.tensions_n, None).is_err() {
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
