//! `cablesense calibrate` end to end on the shipped demo (`data/calibration/`,
//! synthesised with section moduli 52 and 68 GPa, marker (1.5, -1, 6) mm, 0.1 mm
//! noise): the recording mode fits the first 40 rows, validates on the other 20 and
//! writes a calibrated scene (moduli within 1 % of the truth, marker offset within
//! 0.5 mm), a residual CSV (one line per row) and an SVG with the three views and a
//! dot per row in each panel; the same data read in the wrong unit fails as a unit
//! mismatch; the thesis mode still fits table 4.1.

use cablesense::Scene;
use std::path::PathBuf;
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn run(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_cablesense"))
        .current_dir(root())
        .args(args)
        .output()
        .expect("runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn recording_mode_writes_a_calibrated_scene_residuals_and_report() {
    let out = std::env::temp_dir().join(format!("cablesense_calibrate_cli_{}", std::process::id()));
    let out_s = out.to_string_lossy().into_owned();
    let (code, stdout, stderr) = run(&[
        "calibrate",
        "data/calibration/demo.toml",
        "--data",
        "data/calibration/train.csv",
        "--train-rows",
        "0..40",
        "--quiet",
        "--out",
        &out_s,
    ]);
    assert_eq!(code, 0, "{stdout}\n{stderr}");
    assert!(stdout.contains("train tip error, raw"), "{stdout}");
    assert!(
        stdout.contains("val tip error, mean offset removed (upstream convention)"),
        "{stdout}"
    );
    let scene = Scene::load(out.join("calibrated.toml")).expect("calibrated scene loads");
    let e: Vec<f64> = scene
        .robot
        .sections
        .iter()
        .map(|s| s.material.youngs_modulus_pa)
        .collect();
    assert!(
        (e[0] / 52e9 - 1.0).abs() < 0.01 && (e[1] / 68e9 - 1.0).abs() < 0.01,
        "{e:?}"
    );
    let cal = scene.calibration.expect("calibration table written");
    let want = [1.5e-3, -1e-3, 6e-3];
    for (got, want) in cal.marker_offset_m.iter().zip(want) {
        assert!((got - want).abs() < 5e-4, "{:?}", cal.marker_offset_m);
    }
    let csv = std::fs::read_to_string(out.join("residuals.csv")).unwrap();
    assert_eq!(csv.lines().count(), 61, "header + 60 rows");
    assert_eq!(csv.lines().filter(|l| l.starts_with("val,")).count(), 20);
    let svg = std::fs::read_to_string(out.join("report.svg")).unwrap();
    for v in [
        "xy view",
        "xz view",
        "yz view",
        "error histogram",
        "error over time",
        "error against tension_a",
    ] {
        assert!(svg.contains(v), "{v}");
    }
    // a dot per row in each of the three views and the two error panels, one model
    // line per split in each view, no NaN
    let doc = roxmltree::Document::parse(&svg).expect("well-formed SVG");
    let count = |tag: &str| doc.descendants().filter(|n| n.has_tag_name(tag)).count();
    assert_eq!((count("circle"), count("path")), (60 * 5, 3 * 2));
    assert!(!svg.contains("NaN"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(json["params"].as_array().unwrap().len(), 11);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn wrong_unit_is_reported_as_a_unit_mismatch() {
    let out =
        std::env::temp_dir().join(format!("cablesense_calibrate_unit_{}", std::process::id()));
    let (code, stdout, stderr) = run(&[
        "calibrate",
        "data/calibration/demo.toml",
        "--data",
        "data/calibration/val.csv",
        "--unit",
        "m",
        "--quiet",
        "--out",
        &out.to_string_lossy(),
    ]);
    assert_eq!(code, 2, "{stdout}\n{stderr}");
    assert!(
        stderr.contains("data/calibration/val.csv:")
            && stderr.contains("tip_x,tip_y,tip_z")
            && stderr.contains("mm read as m"),
        "{stderr}"
    );
}

#[test]
fn thesis_table_mode_still_fits() {
    let (code, stdout, stderr) = run(&[
        "calibrate",
        "--table",
        "4.1",
        "--param",
        "robot/sections/*/youngs_modulus_pa",
    ]);
    assert_eq!(code, 0, "{stdout}\n{stderr}");
    assert!(stdout.contains("Converged"), "{stdout}");
}
