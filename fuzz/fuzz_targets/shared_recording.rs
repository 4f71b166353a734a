//! Check of the `recording` fuzz target, shared with `tests/fuzz_regressions.rs`:
//! arbitrary bytes as a calibration recording (`calibrate::Recording`, CSV or JSON
//! lines with a column map) or a pull recording of the identification
//! (`calibrate::PullRecording`, CSV, then its patterns and evidence rows). Parsing
//! only: no model, no solve.
//!
//! Input layout ([`HEADER_BYTES`] bytes, then the text, read as lossy UTF-8):
//! * byte 0, flags: bit 0 pull recording (else recording); bit 1 marker unit `mm`
//!   (recording) or tip scale 1e-3 (pull); bit 2 time column named (recording);
//!   bit 3 servo scale 1e-3 (pull); bit 4 `min_pull_m = 0` (pull);
//! * bytes 1-3: the marker (tip) columns x, y, z, each an index into [`NAMES`];
//! * byte 4: the time column (recording) or the pattern column (pull), in [`NAMES`];
//! * byte 5: how many input columns the map names (0-3, recording; 0 = the default
//!   `tension_*`, `force_*`, `mass_*`) or the servo prefix (pull, in [`PREFIXES`]);
//! * bytes 6-8: the input columns, in [`NAMES`];
//! * bytes 9-10: a row range `a..b` for `Recording::split_rows`.
//!
//! Invariants: no panic. A recording parses all or nothing: `Ok` has one row per
//! data line (every non-blank line that is not a `#` comment, less the CSV header),
//! at the lines of those data lines, with finite values, as many inputs per row as
//! input names (the map's, or default input names), a time stamp on every row or on
//! none (every row when the map names a time column), and the map's marker columns
//! and unit; an error is a `Recording` or `MissingColumn` error naming the file and
//! a line of the text. `split_rows` partitions the rows. A pull recording: `Ok` has
//! one row per data line, servo columns with the prefix, finite readings and tips,
//! non-empty labels; its patterns cover the rows in order with a pulled servo whose
//! range is at least `min_pull_m`; the evidence rows have matching lengths (>= 3).
//! `parse_row_range` on the text's first line returns an empty-free range or an error.

#![allow(dead_code)]

use cablesense::calibrate::{
    is_default_input, linear_response, parse_row_range, servo_rows, CalibrationError, ColumnMap,
    IdentifySettings, LengthUnit, PullRecording, Recording,
};
use cablesense::nalgebra::{Matrix3, Vector3};

/// Bytes before the text.
pub const HEADER_BYTES: usize = 11;
/// Column names the map can use (index = byte modulo the length).
pub const NAMES: [&str; 19] = [
    "tip_x",
    "tip_y",
    "tip_z",
    "t_s",
    "tension_a",
    "tension_b",
    "tension_c",
    "force_x",
    "mass_1",
    "pattern_label",
    "servo_1_mm",
    "timestamp",
    "x",
    "",
    " tip_x",
    "a,b",
    "\"q\"",
    "tip_x\r",
    "\u{e9}",
];
/// Servo prefixes of a pull recording.
pub const PREFIXES: [&str; 5] = ["servo_", "", "tip_", "s", "servo_1"];
/// File name given to the parsers.
const FILE: &str = "fuzz.csv";

fn name(b: u8) -> String {
    NAMES[usize::from(b) % NAMES.len()].to_string()
}

/// Run the check; panics on a broken invariant.
pub fn check_recording(data: &[u8]) {
    let mut head = [0u8; HEADER_BYTES];
    let n = data.len().min(HEADER_BYTES);
    head[..n].copy_from_slice(&data[..n]);
    let text = String::from_utf8_lossy(&data[n..]);
    range_check(&text);
    if head[0] & 1 == 0 {
        recording(&head, &text);
    } else {
        pull(&head, &text);
    }
}

/// `parse_row_range` on the first line of the text.
fn range_check(text: &str) {
    let first: String = text.lines().next().unwrap_or("").chars().take(64).collect();
    if let Ok(r) = parse_row_range(&first) {
        assert!(r.start < r.end, "`{first}` gave the empty range {r:?}");
    }
}

/// Lines (1-based) of `Recording::parse_str`'s data lines: after a leading BOM,
/// split at `\n`, `\r` trimmed at the end, blank and `#` lines skipped.
/// The lines the one row reader (`files::rows`) reads: each without its leading BOMs
/// and surrounding white space, blank and `#` lines skipped.
fn recording_lines(text: &str) -> Vec<(usize, &str)> {
    text.split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_start_matches('\u{feff}').trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
        .collect()
}

fn recording(head: &[u8; HEADER_BYTES], text: &str) {
    let map = ColumnMap {
        marker_columns: [name(head[1]), name(head[2]), name(head[3])],
        unit: if head[0] & 2 != 0 {
            LengthUnit::Mm
        } else {
            LengthUnit::M
        },
        time_column: (head[0] & 4 != 0).then(|| name(head[4])),
        inputs: head[6..6 + usize::from(head[5] % 4)]
            .iter()
            .map(|&b| name(b))
            .collect(),
        header: Vec::new(),
    };
    let total_lines = text.split('\n').count();
    let rec = match Recording::parse_str(FILE, text, &map) {
        Ok(rec) => rec,
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.starts_with(FILE), "error without the file: {msg}");
            match e {
                CalibrationError::Recording { line, .. }
                | CalibrationError::MissingColumn { line, .. } => {
                    assert!(
                        (1..=total_lines).contains(&line),
                        "line {line} of {total_lines}: {msg}"
                    );
                }
                other => panic!("unexpected error kind: {other:?}"),
            }
            return;
        }
    };
    assert_eq!(rec.file, FILE);
    assert_eq!(rec.marker_columns, map.marker_columns);
    assert_eq!(rec.unit, map.unit);
    if map.inputs.is_empty() {
        assert!(
            rec.input_names.iter().all(|n| is_default_input(n)),
            "{:?}",
            rec.input_names
        );
    } else {
        assert_eq!(rec.input_names, map.inputs);
    }
    // all or nothing: every data line is a row
    let lines = recording_lines(text);
    let json = lines
        .first()
        .is_some_and(|(_, l)| l.trim_start().starts_with('{'));
    let data_lines: Vec<usize> = lines
        .iter()
        .skip(usize::from(!json))
        .map(|(i, _)| *i)
        .collect();
    let row_lines: Vec<usize> = rec.rows.iter().map(|r| r.line).collect();
    assert_eq!(row_lines, data_lines, "rows are not the data lines");
    assert!(!rec.rows.is_empty());
    let timed = rec.rows[0].t_s.is_some();
    assert!(timed || map.time_column.is_none());
    for r in &rec.rows {
        assert!(r.marker_m.iter().all(|x| x.is_finite()), "{r:?}");
        assert_eq!(r.inputs.len(), rec.input_names.len(), "{r:?}");
        assert!(r.inputs.iter().all(|x| x.is_finite()), "{r:?}");
        assert_eq!(r.t_s.is_some(), timed, "{r:?}");
        assert!(r.t_s.is_none_or(|t| t.is_finite()), "{r:?}");
    }
    let (a, b) = (usize::from(head[9] % 16), usize::from(head[10] % 16));
    let (inside, rest) = rec.split_rows(a..b);
    assert_eq!(inside.rows.len() + rest.rows.len(), rec.rows.len());
    let lo = a.min(rec.rows.len());
    let hi = b.min(rec.rows.len()).max(lo);
    assert_eq!(inside.rows, rec.rows[lo..hi]);
    let mut merged = rest.rows.clone();
    merged.splice(lo..lo, inside.rows.iter().cloned());
    assert_eq!(merged, rec.rows, "split_rows lost the order");
}

fn pull(head: &[u8; HEADER_BYTES], text: &str) {
    let settings = IdentifySettings {
        pattern_column: name(head[4]),
        servo_prefix: PREFIXES[usize::from(head[5]) % PREFIXES.len()].to_string(),
        min_pull_m: if head[0] & 16 != 0 { 0.0 } else { 0.5e-3 },
        ..IdentifySettings::default()
    };
    let tips = [name(head[1]), name(head[2]), name(head[3])];
    let tip_scale = if head[0] & 2 != 0 { 1e-3 } else { 1.0 };
    let servo_scale = if head[0] & 8 != 0 { 1e-3 } else { 1.0 };
    let rec = match PullRecording::parse_str(FILE, text, &settings, &tips, servo_scale, tip_scale) {
        Ok(rec) => rec,
        Err(e) => {
            assert!(!e.to_string().is_empty());
            return;
        }
    };
    // the parser's data lines (the one row reader, `files::rows`): each line without
    // its leading BOMs and surrounding white space, blank and `#` lines skipped, the
    // first one the header
    let data_lines: Vec<usize> = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_start_matches('\u{feff}').trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
        .skip(1)
        .map(|(i, _)| i)
        .collect();
    let row_lines: Vec<usize> = rec.rows.iter().map(|r| r.line).collect();
    assert_eq!(row_lines, data_lines, "rows are not the data lines");
    assert!(!rec.servos.is_empty());
    assert!(rec
        .servos
        .iter()
        .all(|s| s.starts_with(&settings.servo_prefix)));
    for r in &rec.rows {
        assert!(!r.label.is_empty(), "{r:?}");
        assert_eq!(r.servo_m.len(), rec.servos.len(), "{r:?}");
        assert!(r.servo_m.iter().all(|x| x.is_finite()), "{r:?}");
        assert!(r.tip_m.iter().all(|x| x.is_finite()), "{r:?}");
    }
    let Ok(patterns) = rec.patterns(&settings) else {
        return;
    };
    let mut next = 0;
    for p in &patterns {
        assert_eq!(p.rows.start, next, "{p:?}");
        assert!(p.rows.end > p.rows.start, "{p:?}");
        assert!(p.servo < rec.servos.len(), "{p:?}");
        assert!(p.range_m >= settings.min_pull_m, "{p:?}");
        assert!(p.runner_up_gap_m >= 0.0, "{p:?}");
        next = p.rows.end;
    }
    assert_eq!(next, rec.rows.len(), "patterns do not cover the rows");
    let Ok(per_servo) = servo_rows(
        &rec,
        &patterns,
        &settings,
        &Matrix3::identity(),
        &Vector3::zeros(),
    ) else {
        return;
    };
    assert_eq!(per_servo.len(), rec.servos.len());
    for s in &per_servo {
        assert!(s.q.len() >= 3);
        assert_eq!(s.q.len(), s.tip.len());
        assert_eq!(s.q.len(), s.lines.len());
        let _ = linear_response(s);
    }
}
