//! Check of the `readings_stream` fuzz target, shared with `tests/fuzz_regressions.rs`:
//! arbitrary bytes as a readings file of a two-segment TDCR with six
//! displacement-driven tendons, every parsed row solved warm-started.
//!
//! Three robots with the columns of the shipped scene
//! (`data/scenes/tdcr_two_segment.toml`), so every input means the same rows on each:
//! the scene itself and a small copy of it with either cable coupling (`shared_tdcr.rs`,
//! [`Robot`], [`robot_for`]).
//!
//! Budget of one input (every robot): at most [`MAX_ROWS`] solved rows, forward
//! solves capped at `shared_tdcr::MAX_ITERATIONS` Newton iterations and
//! `shared_tdcr::MAX_CONTINUATION_STEPS` continuation steps (`shared.rs` caps the `scene_*`
//! targets' solves at 6 and 4), and the tendon iteration's budget of
//! `shared_tdcr::tendon_settings` (Newton iterations on the tensions, shooting solves
//! per row). A row that runs out of this budget ends with a non-converged status,
//! which the checks accept as a clean failure (the state must still be usable by the
//! next row: its converged report is checked like any other).
//!
//! The scene and its workspace (whose construction runs the reference solve at the
//! pretensions) are built once per process and cloned per input: a clone of the
//! freshly built workspace is the state `tendon_workspace()` returns, so every input
//! starts from the same state, without re-running the reference solve.
//!
//! Invariants: no panic; a parsed row's readings are finite; a solve either returns a
//! named error or a report, and a converged report has finite tensions >= 0, a
//! finite tip, and every tendon with positive tension flagged taut.

#![allow(dead_code)]

use cablesense::tendons::TendonWorkspace;
use cablesense::Scene;
use std::sync::OnceLock;

// the crate root (the fuzz target, or tests/fuzz_regressions.rs) includes it once
use super::shared_tdcr;
pub use shared_tdcr::{robot_for, Robot};

const SCENE: &str = include_str!("../../data/scenes/tdcr_two_segment.toml");

/// Rows solved per input (every row is parsed and checked).
pub const MAX_ROWS: usize = 4;
/// The robot's scene (numerics capped) and its freshly built workspace (built once
/// per process).
fn template(robot: Robot) -> &'static (Scene, TendonWorkspace) {
    static SMALL: OnceLock<(Scene, TendonWorkspace)> = OnceLock::new();
    static SMALL_ARC: OnceLock<(Scene, TendonWorkspace)> = OnceLock::new();
    static SHIPPED: OnceLock<(Scene, TendonWorkspace)> = OnceLock::new();
    let cell = match robot {
        Robot::Small => &SMALL,
        Robot::SmallArc => &SMALL_ARC,
        Robot::Shipped => &SHIPPED,
    };
    cell.get_or_init(|| {
        let scene = shared_tdcr::scene(SCENE, robot);
        let mut ws = scene.tendon_workspace().expect("scene builds");
        ws.set_tendon_settings(shared_tdcr::tendon_settings())
            .expect("the fuzz budget is valid");
        (scene, ws)
    })
}

/// Run the check on the robot [`robot_for`] picks; panics on a broken invariant.
pub fn check_readings(data: &[u8]) {
    check_readings_on(robot_for(data), data);
}

/// Run the check on `robot`; panics on a broken invariant.
pub fn check_readings_on(robot: Robot, data: &[u8]) {
    let (scene, fresh) = template(robot);
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
        if solved >= MAX_ROWS {
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
