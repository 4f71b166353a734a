//! `cablesense validate` runs the FTDCR v4 hardware benchmark: the stored calibration
//! recomputed on val.csv (443 rows) and on every 5th of the train rows it fitted, printed as a
//! table beside the published model (12.1 mm val, 9.7 mm train, mean offset removed,
//! robot length 186.5 mm), with an SVG report. The exit code is 0 only when its
//! checks pass; a benchmark whose stored figure is not reproduced fails them.

use cablesense::calibrate::{ColumnMap, Recording};
use cablesense::files::Scene;
use cablesense::validation::{
    column_map, hardware_benchmark, parse_summary, HardwareSettings, CALIBRATED_SCENE,
    SUMMARY_JSON, VAL_CSV,
};
use std::path::Path;
use std::process::Command;

fn scene() -> Scene {
    Scene::parse_validated(CALIBRATED_SCENE, Path::new("calibrated.toml"), false).unwrap()
}

/// The first `n` rows of val.csv (header kept).
fn val_head(map: &ColumnMap, n: usize) -> Recording {
    let text: String = VAL_CSV
        .lines()
        .take(n + 1)
        .map(|l| format!("{l}\n"))
        .collect();
    Recording::parse_str("val_head.csv", &text, map).unwrap()
}

#[test]
fn validate_prints_the_hardware_table_and_exits_zero() {
    let out = std::env::temp_dir().join(format!("cablesense_validate_hw_{}", std::process::id()));
    let run = Command::new(env!("CARGO_BIN_EXE_cablesense"))
        .args(["validate", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    println!("{stdout}");
    assert_eq!(
        run.status.code(),
        Some(0),
        "stderr: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    let row = |label: &str| -> Vec<f64> {
        let line = stdout
            .lines()
            .find(|l| l.trim_start().starts_with(label))
            .unwrap_or_else(|| panic!("no line `{label}`"));
        line[line.find(label).unwrap() + label.len()..]
            .split_whitespace()
            .filter_map(|w| w.parse().ok())
            .collect()
    };
    // rows, RMSE, median, p95, max (mm), RMSE % of length
    let val = row("val (held out), mean offset removed");
    assert_eq!(val[0], 443.0);
    // the stored figure (ftdcr_v4_summary.json: 5.730 mm) within 10 %
    let stored = parse_summary("summary.json", SUMMARY_JSON).unwrap();
    let stored_mm = stored.val.mean_removed.rmse_m * 1e3;
    assert!((stored_mm - 5.730).abs() < 5e-4, "stored {stored_mm} mm");
    assert!(
        (val[1] - stored_mm).abs() <= 0.1 * stored_mm,
        "val RMSE {} mm against stored {stored_mm} mm",
        val[1]
    );
    assert!(
        val[2] <= val[3] && val[3] <= val[4],
        "median <= p95 <= max: {val:?}"
    );
    assert!((val[5] - val[1] / 186.5 * 100.0).abs() < 0.01);
    let raw = row("val (held out), raw");
    assert!(
        raw[1] >= val[1] - 1e-9,
        "raw RMSE {} below offset-removed {}",
        raw[1],
        val[1]
    );
    let train = row("train (fit rows, 1 in 5), mean offset removed");
    assert_eq!(train[0], 324.0);
    // every 5th of the 1620 fitted rows: 4.23 mm (printed to 0.01 mm)
    assert!((train[1] - 4.23).abs() < 0.05, "train RMSE {} mm", train[1]);
    let published = row("published model, val, offset rm.");
    assert_eq!(published[1], 12.1);
    assert!((published[2] - 6.49).abs() < 0.01);
    assert_eq!(row("published model, train, offset rm.")[1], 9.7);
    assert!(stdout.contains("below the published 12.1 mm: yes"));
    // the warm-started `track` chain on val: the same figure (within 1 %, the
    // benchmark's check; the chains agree to 1e-11 m, tests/hardware_ftdcr.rs)
    let track = row("val, track chain (warm, as `track`), mean offset removed");
    assert_eq!(track[0], 443.0);
    assert!(
        (track[1] - val[1]).abs() <= 0.01 * val[1],
        "{track:?} vs {val:?}"
    );
    assert!(stdout.contains("track chain on val: 443 rows, 0 not converged"));
    let svg = std::fs::read_to_string(out.join("hardware_ftdcr_v4.svg")).unwrap();
    assert!(svg.starts_with("<svg") || svg.contains("<svg"));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_stored_figure_that_is_not_reproduced_fails_the_check() {
    let scene = scene();
    let map = column_map(&scene).unwrap();
    let val = val_head(&map, 40);
    let mut stored = parse_summary("summary.json", SUMMARY_JSON).unwrap();
    let settings = HardwareSettings {
        train_stride: 0,
        ..HardwareSettings::default()
    };
    let b = hardware_benchmark(&scene, &stored, None, &val, &settings).unwrap();
    assert_eq!(b.val.raw.count, 40);
    assert!(b.train.is_none());
    assert!(b.failed_rows.is_empty());
    // pretend the stored calibration had found half the error these rows give
    stored.val.mean_removed.rmse_m = 0.5 * b.val.mean_removed.rmse_m;
    let b = hardware_benchmark(&scene, &stored, None, &val, &settings).unwrap();
    assert!(!b.reproduces_stored());
    assert!(!b.passed());
}

#[test]
fn a_scene_without_calibration_and_a_bad_summary_are_errors() {
    let mut s = scene();
    s.calibration = None;
    let e = column_map(&s).unwrap_err().to_string();
    assert!(e.contains("[calibration]"), "{e}");
    let e = parse_summary("summary.json", "{\"status\": 3}")
        .unwrap_err()
        .to_string();
    assert!(e.contains("summary.json") && e.contains("line 1"), "{e}");
}
