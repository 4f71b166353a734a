//! Fuzz target: arbitrary bytes as a readings file through the tendon model
//! (checks in `shared_readings.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

mod shared_readings;
mod shared_tdcr;

fuzz_target!(|data: &[u8]| {
    shared_readings::check_readings(data);
});
