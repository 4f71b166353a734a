//! Arbitrary bytes as a TOML scene file: parse, validate, round-trip, small-budget
//! solve. Body in `shared.rs` (also replayed by `tests/fuzz_regressions.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "shared.rs"]
mod shared;

fuzz_target!(|data: &[u8]| shared::scene_toml(data));
