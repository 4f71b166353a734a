//! Body of the `encoder_stream` fuzz target, shared by `fuzz/fuzz_targets/encoder_stream.rs`
//! and `tests/fuzz_regressions.rs` (through `#[path]`, like `shared.rs`).
//!
//! Input: one configuration byte, then the stream text (split into lines the way
//! `BufRead::lines` does for `cablesense track`: on `\n`, a trailing `\r` dropped;
//! invalid UTF-8 is replaced, U+FFFD, so the parser sees every line).
//!
//! * bits 0-1: cable count - 1 (names from [`CABLE_NAMES`]; the fourth, `sigma_top`,
//!   clashes with the noise column of `top`);
//! * bits 2-3: format: 0 and 3 detect (`None`), 1 CSV, 2 JSON lines.
//!
//! What counts as a bug: a panic, or any of
//! 1. a sample whose line number is not its line's, whose `changes_m` has not one
//!    entry per cable, or whose present values (time stamp, changes, noise) are not
//!    finite (noise also > 0);
//! 2. an error that does not name its line (field, number, message prefix) or has an
//!    empty field;
//! 3. a non-blank, non-comment line consumed silently (`Ok(None)`) other than the one
//!    CSV header;
//! 4. a bad line changing what later lines give (a bad CSV header stops the stream:
//!    every later non-blank line is then an error too): replaying the stream with every
//!    erroring line removed (same line numbers) must give the same result for every
//!    other line, with the format fixed to the one the first run detected (detection
//!    from the first non-blank line is documented, even when that line errors).

use cablesense::files::measure::{Format, LineError, Sample, StreamParser};

/// Cable names the parser is built with (the first 1..=4 of them).
pub const CABLE_NAMES: [&str; 4] = ["top", "left", "right", "sigma_top"];
/// Lines past this are ignored (keeps one run fast; libFuzzer inputs are <= 4 KiB
/// by default anyway).
const MAX_LINES: usize = 256;

type LineResult = Result<Option<Sample>, LineError>;

/// `encoder_stream` target on raw bytes.
pub fn encoder_stream(data: &[u8]) {
    let Some((&config, text)) = data.split_first() else {
        return;
    };
    let n = usize::from(config & 3) + 1;
    let cables: Vec<String> = CABLE_NAMES[..n].iter().map(|s| s.to_string()).collect();
    let format = match (config >> 2) & 3 {
        1 => Some(Format::Csv),
        2 => Some(Format::JsonLines),
        _ => None,
    };
    let lines = split_lines(text);

    let results = run(&cables, format, &lines, |_| true);
    let mut headers = 0;
    for ((no, line), result) in lines.iter().zip(&results) {
        check_line(*no, line, result, n);
        if matches!(result, Ok(None)) && !is_blank(line) {
            headers += 1;
        }
    }
    assert!(
        headers <= 1,
        "{headers} non-blank lines consumed silently; only one CSV header may be"
    );
    // The format the parser settled on: given, or detected from the first non-blank line.
    let detected = format.or_else(|| {
        lines
            .iter()
            .map(|(_, l)| l.trim_start_matches('\u{feff}').trim())
            .find(|t| !is_blank(t))
            .map(|t| {
                if t.starts_with('{') {
                    Format::JsonLines
                } else {
                    Format::Csv
                }
            })
    });
    if headers == 1 {
        assert_eq!(
            detected,
            Some(Format::Csv),
            "a line was consumed as a header of a JSON-lines stream"
        );
    }
    let Some(detected) = detected else {
        return;
    };
    // Property 4: errors are local to their line.
    let bad: Vec<usize> = results
        .iter()
        .enumerate()
        .filter_map(|(i, r)| r.is_err().then_some(i))
        .collect();
    let kept = run(&cables, Some(detected), &lines, |i| !bad.contains(&i));
    let mut k = 0;
    for (i, result) in results.iter().enumerate() {
        if bad.contains(&i) {
            continue;
        }
        // compared by `Debug` text, which is exact for f64 and equates NaN with NaN
        // (a missing value), unlike `PartialEq`
        let (before, after) = (format!("{result:?}"), format!("{:?}", kept[k]));
        assert_eq!(
            before,
            after,
            "line {}: result changed when the {} erroring lines were removed: {:?}",
            lines[i].0,
            bad.len(),
            lines[i].1
        );
        k += 1;
    }
}

/// `(1-based line number, text)`, as `BufRead::lines` would give them.
fn split_lines(text: &[u8]) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut rest = text;
    while !rest.is_empty() && out.len() < MAX_LINES {
        let (line, next) = match rest.iter().position(|&b| b == b'\n') {
            Some(i) => (&rest[..i], &rest[i + 1..]),
            None => (rest, &rest[rest.len()..]),
        };
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        out.push((out.len() + 1, String::from_utf8_lossy(line).into_owned()));
        rest = next;
    }
    out
}

/// Blank or comment: the parser must skip these (a byte-order mark is ignored).
fn is_blank(line: &str) -> bool {
    let t = line.trim_start_matches('\u{feff}').trim();
    t.is_empty() || t.starts_with('#')
}

/// Feed the lines with index `keep(i)` to a fresh parser.
fn run(
    cables: &[String],
    format: Option<Format>,
    lines: &[(usize, String)],
    keep: impl Fn(usize) -> bool,
) -> Vec<LineResult> {
    let mut parser = StreamParser::new(cables.to_vec(), format);
    lines
        .iter()
        .enumerate()
        .filter(|(i, _)| keep(*i))
        .map(|(_, (no, line))| parser.line(*no, line))
        .collect()
}

/// Properties 1-3 for one line.
fn check_line(no: usize, line: &str, result: &LineResult, n: usize) {
    match result {
        Ok(None) => {}
        Ok(Some(s)) => {
            assert!(!is_blank(line), "line {no}: blank line gave a sample {s:?}");
            assert_eq!(s.line, no, "sample of line {no} says line {}", s.line);
            assert_eq!(s.changes_m.len(), n, "line {no}: {s:?} for {n} cables");
            if let Some(t) = s.t_s {
                assert!(t.is_finite(), "line {no}: time stamp {t} in {s:?}");
            }
            for v in &s.changes_m {
                assert!(
                    v.is_nan() || v.is_finite(),
                    "line {no}: change {v} in {s:?}"
                );
            }
            if let Some(sigma) = &s.sigma_m {
                assert_eq!(sigma.len(), n, "line {no}: {s:?} for {n} cables");
                for v in sigma {
                    assert!(
                        v.is_nan() || (v.is_finite() && *v > 0.0),
                        "line {no}: noise {v} in {s:?}"
                    );
                }
            }
        }
        Err(e) => {
            assert!(!is_blank(line), "line {no}: blank line gave an error {e}");
            assert_eq!(e.line, no, "error of line {no} says line {}: {e}", e.line);
            assert!(!e.field.is_empty(), "line {no}: error without field: {e}");
            let msg = e.to_string();
            assert!(
                msg.starts_with(&format!("line {no}: ")),
                "line {no}: message does not name the line: {msg}"
            );
        }
    }
}
