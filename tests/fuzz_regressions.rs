//! Replays every committed fuzz input through the fuzz targets' own checks
//! (`fuzz/fuzz_targets/shared*.rs`: `shared.rs`, `shared_stream.rs`,
//! `shared_estimate.rs`, `shared_readings.rs`, `shared_load_cells.rs`,
//! `shared_recording.rs`, `shared_capi.rs`): the seed corpora in
//! `fuzz/seeds/<target>/` and the minimized crashers in
//! `fuzz/regressions/<target>/` (rust-lang/regex style).
//! A failure names the file; reproduce it with
//! `cargo fuzz run --sanitizer none <target> fuzz/regressions/<target>/<file>`.

#[path = "../fuzz/fuzz_targets/shared.rs"]
mod shared;
#[path = "../fuzz/fuzz_targets/shared_estimate.rs"]
mod shared_estimate;
#[path = "../fuzz/fuzz_targets/shared_load_cells.rs"]
mod shared_load_cells;
#[path = "../fuzz/fuzz_targets/shared_readings.rs"]
mod shared_readings;
#[path = "../fuzz/fuzz_targets/shared_recording.rs"]
mod shared_recording;
#[path = "../fuzz/fuzz_targets/shared_stream.rs"]
mod shared_stream;
#[path = "../fuzz/fuzz_targets/shared_tdcr.rs"]
mod shared_tdcr;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

/// Files of `fuzz/{seeds,regressions}/<target>/`, sorted (README files skipped).
fn inputs(target: &str) -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let mut files = Vec::new();
    for kind in ["seeds", "regressions"] {
        let Ok(dir) = std::fs::read_dir(root.join(kind).join(target)) else {
            continue;
        };
        for entry in dir {
            let path = entry.expect("readable directory entry").path();
            let is_doc = path
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("README"));
            if path.is_file() && !is_doc {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// Run `check` on every input of `target`; report all failing files at once.
fn replay(target: &str, check: fn(&[u8]), min_seeds: usize) {
    let files = inputs(target);
    assert!(
        files.len() >= min_seeds,
        "{target}: expected at least {min_seeds} committed inputs, found {}",
        files.len()
    );
    let failed: Vec<String> = files
        .iter()
        .filter_map(|path| {
            let data = std::fs::read(path).expect("readable fuzz input");
            catch_unwind(AssertUnwindSafe(|| check(&data)))
                .err()
                .map(|_| path.display().to_string())
        })
        .collect();
    assert!(failed.is_empty(), "{target}: failing inputs: {failed:#?}");
}

#[test]
fn scene_toml_inputs() {
    replay("scene_toml", shared::scene_toml, 2);
}

#[test]
fn scene_json_inputs() {
    replay("scene_json", shared::scene_json, 2);
}

#[test]
fn forward_solve_inputs() {
    replay("forward_solve", shared::forward_solve, 2);
}

#[test]
fn encoder_stream_inputs() {
    replay("encoder_stream", shared_stream::encoder_stream, 6);
}

#[test]
fn estimator_tick_inputs() {
    replay("estimator_tick", shared_estimate::estimator_tick, 6);
}

#[test]
fn readings_stream_inputs() {
    // every input on all three robots (the fuzz target picks one per input:
    // `robot_for`, which the replays below therefore cover)
    replay(
        "readings_stream",
        |d| shared_readings::check_readings_on(shared_readings::Robot::Small, d),
        2,
    );
    replay(
        "readings_stream",
        |d| shared_readings::check_readings_on(shared_readings::Robot::Shipped, d),
        2,
    );
    replay(
        "readings_stream",
        |d| shared_readings::check_readings_on(shared_readings::Robot::SmallArc, d),
        2,
    );
}

#[test]
fn load_cells_stream_inputs() {
    // every input on all three robots (the fuzz target picks one per input:
    // `robot_for`, which the replays below therefore cover)
    replay(
        "load_cells_stream",
        |d| shared_load_cells::check_load_cells_on(shared_load_cells::Robot::Small, d),
        2,
    );
    replay(
        "load_cells_stream",
        |d| shared_load_cells::check_load_cells_on(shared_load_cells::Robot::Shipped, d),
        2,
    );
    replay(
        "load_cells_stream",
        |d| shared_load_cells::check_load_cells_on(shared_load_cells::Robot::SmallArc, d),
        2,
    );
}

#[test]
fn recording_inputs() {
    replay("recording", shared_recording::check_recording, 6);
}
