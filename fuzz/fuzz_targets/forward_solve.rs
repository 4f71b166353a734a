//! Typed, physically bounded robot + loads + settings: cold solve, perturbed warm
//! solve, warm re-solve, under each cable coupling; `Converged` must mean finite tip,
//! samples and cable lengths.
//! Body in `shared.rs` (also replayed by `tests/fuzz_regressions.rs`).
#![no_main]

use arbitrary::{Arbitrary, Result, Unstructured};
use libfuzzer_sys::fuzz_target;

#[path = "shared.rs"]
mod shared;

use shared::{ForwardInput, FORWARD_SOLVE_BYTES};

/// Delegates to the fixed layout of `ForwardInput::from_bytes` (zero-padded like
/// `fill_buffer`), so a crasher's raw bytes replay to the same input in
/// `tests/fuzz_regressions.rs`, which cannot depend on `arbitrary`.
impl<'a> Arbitrary<'a> for ForwardInput {
    fn arbitrary(u: &mut Unstructured<'a>) -> Result<Self> {
        let mut buf = [0u8; FORWARD_SOLVE_BYTES];
        u.fill_buffer(&mut buf)?;
        Ok(ForwardInput::from_solve_bytes(&buf))
    }
    fn size_hint(_depth: usize) -> (usize, Option<usize>) {
        (FORWARD_SOLVE_BYTES, Some(FORWARD_SOLVE_BYTES))
    }
}

fuzz_target!(|input: ForwardInput| shared::check_forward(&input));
