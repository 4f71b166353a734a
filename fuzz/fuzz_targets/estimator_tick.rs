//! Typed, bounded robot + estimation spec (unknowns, bounds, priors, method, small
//! budgets; sometimes one field poisoned) and ticks with NaN, infinite, huge, missing
//! values: construction errors are `Err`, a usable status means finite values, tip
//! pose and predicted lengths. Body in `shared_estimate.rs` (also replayed by
//! `tests/fuzz_regressions.rs`).
#![no_main]

use arbitrary::{Arbitrary, Result, Unstructured};
use libfuzzer_sys::fuzz_target;

#[path = "shared.rs"]
mod shared;
#[path = "shared_estimate.rs"]
mod shared_estimate;

use shared_estimate::{EstimatorInput, MAX_TICKS, TICKS_START, TICK_BYTES};

/// Delegates to the fixed layout of `EstimatorInput::from_bytes` (all remaining
/// bytes), so a crasher's raw bytes replay to the same input in
/// `tests/fuzz_regressions.rs`, which cannot depend on `arbitrary`.
impl<'a> Arbitrary<'a> for EstimatorInput {
    fn arbitrary(u: &mut Unstructured<'a>) -> Result<Self> {
        let len = u.len().min(TICKS_START + MAX_TICKS * TICK_BYTES);
        Ok(EstimatorInput::from_bytes(u.bytes(len)?))
    }
    fn arbitrary_take_rest(u: Unstructured<'a>) -> Result<Self> {
        Ok(EstimatorInput::from_bytes(u.take_rest()))
    }
    fn size_hint(_depth: usize) -> (usize, Option<usize>) {
        (TICKS_START, Some(TICKS_START + MAX_TICKS * TICK_BYTES))
    }
}

fuzz_target!(|input: EstimatorInput| shared_estimate::check_estimator(&input));
