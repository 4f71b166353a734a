//! Fuzz target: arbitrary bytes as scene text and numbers through the C ABI's entry
//! points (checks in `shared_capi.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

mod shared_capi;

fuzz_target!(|data: &[u8]| {
    shared_capi::check_capi(data);
});
