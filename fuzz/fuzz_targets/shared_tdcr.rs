//! The two robots of the tendon fuzz targets (`readings_stream`, `load_cells_stream`),
//! included by `shared_readings.rs` and `shared_load_cells.rs` (and through them by
//! `tests/fuzz_regressions.rs`).
//!
//! Each target runs a shipped scene and a small copy of it (five disks per segment
//! instead of ten, RK4 with 10 steps per section instead of 20) whose forward solves
//! are cheaper (converged rows on replay: 0.9 ms per forward solve against 2.6 ms on
//! the shipped scene), the small copy both with the scene's cable coupling and with
//! the arc coupling (`numerics.cable_coupling = "arc"`, the FTDCR v4 scenes' since
//! session 20, whose warm rows follow their own chord policy). The fuzz target runs
//! a small robot on most inputs (either coupling, by the input's length) and the
//! shipped one on about one in 32 ([`robot_for`]); `tests/fuzz_regressions.rs` replays
//! every committed input on all three.

#![allow(dead_code)]

use cablesense::tendons::TendonSettings;
use cablesense::{CableCoupling, Integrator, Scene};

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
/// Nested shooting solves per row (`TendonSettings::max_shooting_solves`, default
/// 200): a row the solver cannot reach (an 80 mm pull on the shipped scene) ran 108 of them in
/// 2.5 s, most of an input's time.
pub const MAX_SHOOTING_SOLVES: usize = 12;

/// The tendon iteration's budget in both targets: [`MAX_TENDON_ITERATIONS`],
/// [`MAX_SHOOTING_SOLVES`], the rest the library's defaults.
pub fn tendon_settings() -> TendonSettings {
    TendonSettings {
        max_iterations: MAX_TENDON_ITERATIONS,
        max_shooting_solves: MAX_SHOOTING_SOLVES,
        ..TendonSettings::default()
    }
}

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
    /// [`Robot::Small`] with the arc coupling.
    SmallArc,
    /// The target's shipped scene (ten disks per segment, RK4 with 20 steps).
    Shipped,
}

/// The robot the fuzz target uses for `data`: the shipped scene when the input's
/// length is 31 modulo 32 (about one input in 32), else the small one, with the arc
/// coupling when the length is even. The choice consumes no byte, so an input's rows
/// are the same on every robot.
pub fn robot_for(data: &[u8]) -> Robot {
    if data.len() % 32 == 31 {
        Robot::Shipped
    } else if data.len() % 2 == 0 {
        Robot::SmallArc
    } else {
        Robot::Small
    }
}

/// The scene `text` for `robot`: with the small robot's disks and integrator when it
/// is [`Robot::Small`], and the forward solve's numerics capped.
pub fn scene(text: &str, robot: Robot) -> Scene {
    let mut scene = Scene::from_toml_str(text).expect("shipped scene parses");
    if robot != Robot::Shipped {
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
    if robot == Robot::SmallArc {
        scene.numerics.cable_coupling = CableCoupling::Arc;
    }
    let n = &mut scene.numerics;
    n.max_iterations = n.max_iterations.min(MAX_ITERATIONS);
    n.max_continuation_steps = n.max_continuation_steps.min(MAX_CONTINUATION_STEPS);
    scene
}
