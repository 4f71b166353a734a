//! Check of the `readings_stream` fuzz target, shared with `tests/fuzz_regressions.rs`:
//! arbitrary bytes as a readings file of the shipped two-segment TDCR
//! (`data/scenes/tdcr_two_segment.toml`, six displacement-driven tendons), every parsed
//! row solved warm-started (at most 4 per input, so one input stays cheap).
//!
//! The scene and its workspace (whose construction runs the reference solve at the
//! pretensions) are built once per process and cloned per input: a clone of the
//! freshly built workspace is the state `tendon_workspace()` returns, so every input
//! starts from the same state as before, without re-running the reference solve.
//!
//! Invariants: no panic; a parsed row's readings are finite; a solve either returns a
//! named error or a report, and a converged report has finite tensions >= 0, a
//! finite tip, and every tendon with positive tension flagged taut.

#![allow(dead_code)]

use cablesense::tendons::TendonWorkspace;
use cablesense::Scene;
use std::sync::OnceLock;

const SCENE: &str = include_str!("../../data/scenes/tdcr_two_segment.toml");

/// Budget of one input: the scene's forward solves are capped at this many Newton
/// iterations and [`MAX_CONTINUATION_STEPS`] continuation steps (as `shared.rs` caps
/// the `scene_*` targets' solves). A row whose solve stalls ran 44-97 forward solves
/// of 20-60 ms each at the scene's own limits (50 and 32): 2-7 s per row, most of
/// it in load continuation. The integrator's resolution is the scene's.
const MAX_ITERATIONS: usize = 10;
/// See [`MAX_ITERATIONS`].
const MAX_CONTINUATION_STEPS: usize = 4;

/// The shipped scene (numerics capped) and its freshly built workspace (built once per process).
fn template() -> &'static (Scene, TendonWorkspace) {
    static TEMPLATE: OnceLock<(Scene, TendonWorkspace)> = OnceLock::new();
    TEMPLATE.get_or_init(|| {
        let mut scene = Scene::from_toml_str(SCENE).expect("shipped scene parses");
        let n = &mut scene.numerics;
        n.max_iterations = n.max_iterations.min(MAX_ITERATIONS);
        n.max_continuation_steps = n.max_continuation_steps.min(MAX_CONTINUATION_STEPS);
        let ws = scene.tendon_workspace().expect("shipped scene builds");
        (scene, ws)
    })
}

/// Run the check; panics on a broken invariant.
pub fn check_readings(data: &[u8]) {
    let (scene, fresh) = template();
    let mut ws = fresh.clone();
    let mut parser = scene.readings_parser(&ws);
    let text = String::from_utf8_lossy(data);
    let mut solved = 0;
    for (i, line) in text.lines().enumerate() {
        let Ok(Some(row)) = parser.line(i + 1, line) else {
            continue;
        };
        assert!(
            row.readings_m.iter().all(|q| q.is_finite()),
            "line {}: non-finite reading passed the parser: {:?}",
            row.line,
            row.readings_m
        );
        if solved >= 4 {
            continue;
        }
        solved += 1;
        let Ok(rep) = ws.solve_readings(&row.readings_m) else {
            continue;
        };
        if rep.status.is_converged() {
            let tip = ws.tip_position();
            assert!(tip.iter().all(|x| x.is_finite()), "non-finite tip {tip}");
            for (t, taut) in ws.tensions().iter().zip(ws.taut()) {
                assert!(t.is_finite() && *t >= 0.0, "tension {t}");
                assert!(*t == 0.0 || *taut, "tension {t} on a tendon flagged slack");
            }
        }
    }
}
