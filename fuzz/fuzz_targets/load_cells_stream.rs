//! Fuzz target: arbitrary bytes as a readings file with load-cell columns through
//! the load estimator of a tendon robot (checks in `shared_load_cells.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

mod shared_load_cells;
mod shared_tdcr;

fuzz_target!(|data: &[u8]| {
    shared_load_cells::check_load_cells(data);
});
