//! Check of the `readings_stream` fuzz target, shared with `tests/fuzz_regressions.rs`:
//! arbitrary bytes as a readings file of the shipped two-segment TDCR
//! (`data/scenes/tdcr_two_segment.toml`, six displacement-driven tendons), every parsed
//! row solved warm-started (at most 4 per input, so one input stays cheap).
//!
//! Invariants: no panic; a parsed row's readings are finite; a solve either returns a
//! named error or a report, and a converged report has finite tensions >= 0, a
//! finite tip, and every tendon with positive tension flagged taut.

#![allow(dead_code)]

use cablesense::Scene;

const SCENE: &str = include_str!("../../data/scenes/tdcr_two_segment.toml");

/// Run the check; panics on a broken invariant.
pub fn check_readings(data: &[u8]) {
    let scene = Scene::from_toml_str(SCENE).expect("shipped scene parses");
    let mut ws = scene.tendon_workspace().expect("shipped scene builds");
    let mut parser = scene.readings_parser(&ws);
    let text = String::from_utf8_lossy(data);
    let mut solved = 0;
    for (i, line) in text.lines().enumerate() {
        let Ok(Some(row)) = parser.line(i + 1, line) else {
            continue;
        };
        assert!(
            row.readings_m.iter().all(|q| q.is_finite()),
            "line {}: non-finite reading passed the parser: {:?}",
            row.line,
            row.readings_m
        );
        if solved >= 4 {
            continue;
        }
        solved += 1;
        let Ok(rep) = ws.solve_readings(&row.readings_m) else {
            continue;
        };
        if rep.status.is_converged() {
            let tip = ws.tip_position();
            assert!(tip.iter().all(|x| x.is_finite()), "non-finite tip {tip}");
            for (t, taut) in ws.tensions().iter().zip(ws.taut()) {
                assert!(t.is_finite() && *t >= 0.0, "tension {t}");
                assert!(*t == 0.0 || *taut, "tension {t} on a tendon flagged slack");
            }
        }
    }
}
