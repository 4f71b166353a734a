//! Fuzz target: arbitrary bytes as a calibration recording or a pull recording with
//! a column map from the first bytes (checks in `shared_recording.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

mod shared_recording;

fuzz_target!(|data: &[u8]| {
    shared_recording::check_recording(data);
});
