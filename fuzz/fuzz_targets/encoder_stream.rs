//! Arbitrary bytes as an encoder stream (CSV or JSON lines, cable count and format
//! from the first byte) through `files::measure::StreamParser`: per-line results,
//! finite samples, errors naming their line, bad lines local to themselves. Body in
//! `shared_stream.rs` (also replayed by `tests/fuzz_regressions.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "shared_stream.rs"]
mod shared_stream;

fuzz_target!(|data: &[u8]| shared_stream::encoder_stream(data));
