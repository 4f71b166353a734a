//! Check of the `readings_stream` fuzz target, shared with `tests/fuzz_regressions.rs`:
//! arbitrary bytes as a readings file of a two-segment TDCR with six
//! displacement-driven tendons, every parsed row solved warm-started.
//!
//! Two robots, both with the columns of the shipped scene
//! (`data/scenes/tdcr_two_segment.toml`), so every input means the same rows on both
//! ([`Robot`]): the shipped scene itself, and a small copy of it (five disks per
//! segment instead of ten, RK4 with 10 steps per section instead of 20) whose forward
//! solves are cheaper (converged rows on replay: 0.9 ms per forward solve against
//! 2.6 ms on the shipped scene). The fuzz target runs the small robot on most
//! inputs and the shipped one on about one in 32 ([`robot_for`]);
//! `tests/fuzz_regressions.rs` replays every committed input on both.
//!
//! Budget of one input (both robots): at most [`MAX_ROWS`] solved rows, forward
//! solves capped at [`MAX_ITERATIONS`] Newton iterations and
//! [`MAX_CONTINUATION_STEPS`] continuation steps (`shared.rs` caps the `scene_*`
//! targets' solves at 6 and 4), at most [`MAX_TENDON_ITERATIONS`] Newton iterations on the
//! tensions. A row that runs out of this budget ends with a non-converged status,
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

use cablesense::tendons::{TendonSettings, TendonWorkspace};
use cablesense::{Integrator, Scene};
use std::sync::OnceLock;

const SCENE: &str = include_str!("../../data/scenes/tdcr_two_segment.toml");

/// Newton iterations of one forward (shooting) solve. A row whose solve stalls ran
/// 44-97 forward solves of 20-60 ms each on the shipped scene at its own limits (50
/// and 32): 2-7 s per row, most of it in load continuation; failing rows take
/// nearly all of an input's time, so the caps are tight (a warm solve converges in
/// a few iterations).
pub const MAX_ITERATIONS: usize = 6;
/// Load-continuation steps of one forward solve (see [`MAX_ITERATIONS`]).
pub const MAX_CONTINUATION_STEPS: usize = 2;
/// Newton iterations on the tensions per row (the library's default is 30).
pub const MAX_TENDON_ITERATIONS: usize = 5;
/// Rows solved per input (every row is parsed and checked).
pub const MAX_ROWS: usize = 4;
/// Disks per segment of the small robot (every 20 mm). Two disks with 4 or 8 RK4
/// steps were as costly per input (their rows stalled three times as often).
const SMALL_DISKS: usize = 5;
/// RK4 steps per section of the small robot.
const SMALL_RK4_STEPS: usize = 10;

/// Which robot an input's rows run on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Robot {
    /// Five disks per segment, RK4 with 10 steps per section.
    Small,
    /// `data/scenes/tdcr_two_segment.toml` (ten disks per segment, RK4 with 20 steps).
    Shipped,
}

/// The robot the fuzz target uses for `data`: the shipped scene when the input's
/// length is 31 modulo 32 (about one input in 32), else the small one. The choice
/// consumes no byte, so an input's rows are the same on both robots.
pub fn robot_for(data: &[u8]) -> Robot {
    if data.len() % 32 == 31 {
        Robot::Shipped
    } else {
        Robot::Small
    }
}

/// `text`, the shipped scene, with the small robot's disks and integrator when `small`,
/// numerics capped.
pub fn scene(text: &str, small: bool) -> Scene {
    let mut scene = Scene::from_toml_str(text).expect("shipped scene parses");
    if small {
        for s in &mut scene.robot.sections {
            let g = s.guides.as_mut().expect("shipped sections have disks");
            g.count = SMALL_DISKS;
            g.spacing_m = s.length_m / SMALL_DISKS as f64;
            g.first_offset_m = g.spacing_m;
        }
        scene.numerics.integrator = Integrator::Rk4 {
            steps_per_section: SMALL_RK4_STEPS,
        };
    }
    let n = &mut scene.numerics;
    n.max_iterations = n.max_iterations.min(MAX_ITERATIONS);
    n.max_continuation_steps = n.max_continuation_steps.min(MAX_CONTINUATION_STEPS);
    scene
}

/// The robot's scene (numerics capped) and its freshly built workspace (built once
/// per process).
fn template(robot: Robot) -> &'static (Scene, TendonWorkspace) {
    static SMALL: OnceLock<(Scene, TendonWorkspace)> = OnceLock::new();
    static SHIPPED: OnceLock<(Scene, TendonWorkspace)> = OnceLock::new();
    let cell = match robot {
        Robot::Small => &SMALL,
        Robot::Shipped => &SHIPPED,
    };
    cell.get_or_init(|| {
        let scene = scene(SCENE, robot == Robot::Small);
        let mut ws = scene.tendon_workspace().expect("scene builds");
        ws.set_tendon_settings(TendonSettings {
            max_iterations: MAX_TENDON_ITERATIONS,
            ..TendonSettings::default()
        });
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
