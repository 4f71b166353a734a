//! Bad recordings are errors naming file, line and column: a missing column, a NaN
//! cell, a non-numeric cell, an empty cell, a missing JSON key; marker columns in mm
//! read as m are detected from the residual against the stated capture noise (and
//! the spread ratio, ~1000) and reported as a unit mismatch. BOM, CRLF, comments and
//! JSON lines are read. The scene's `[calibration]` table rejects unknown keys.

use crate::calibrate_common;
use calibrate_common::*;

use cablesense::calibrate::{
    calibrate, CalibrationError, CalibrationSettings, CalibrationSetup, FitParam, FrameSetup,
    LengthUnit, ParamSpec, Recording, RigidTransform, TensionModel,
};
use cablesense::nalgebra::Vector3;
use cablesense::Scene;

const GOOD: &str = "t_s,tension_a,tension_b,tension_c,tip_x,tip_y,tip_z\n\
0.0,1.0,0.0,0.0,1.0,2.0,3.0\n\
0.1,2.0,0.0,0.0,1.5,2.5,3.5\n";

fn err(text: &str) -> CalibrationError {
    Recording::parse_str("rec.csv", text, &map(LengthUnit::Mm)).unwrap_err()
}

#[test]
fn good_csv_with_bom_crlf_and_comments_is_read_in_mm() {
    let text = format!("\u{feff}# a comment\r\n{}", GOOD.replace('\n', "\r\n"));
    let rec = Recording::parse_str("rec.csv", &text, &map(LengthUnit::Mm)).unwrap();
    assert_eq!(rec.rows.len(), 2);
    assert_eq!(rec.input_names, ["tension_a", "tension_b", "tension_c"]);
    assert_eq!(rec.rows[1].line, 4);
    assert!((rec.rows[1].marker_m - Vector3::new(1.5e-3, 2.5e-3, 3.5e-3)).norm() < 1e-15);
    assert_eq!(rec.rows[1].t_s, Some(0.1));
    assert_eq!(rec.rows[1].inputs, vec![2.0, 0.0, 0.0]);
}

#[test]
fn json_lines_are_read_and_a_missing_key_names_line_and_key() {
    let text = "{\"t_s\": 0, \"tension_a\": 1.0, \"tip_x\": 1, \"tip_y\": 2, \"tip_z\": 3}\n\
                {\"t_s\": 1, \"tension_a\": 2.0, \"tip_x\": 1, \"tip_y\": 2, \"tip_z\": 4}\n";
    let rec = Recording::parse_str("rec.jsonl", text, &map(LengthUnit::M)).unwrap();
    assert_eq!(rec.rows.len(), 2);
    assert_eq!(rec.rows[1].marker_m.z, 4.0);
    let bad = "{\"tension_a\": 1.0, \"tip_x\": 1, \"tip_y\": 2, \"tip_z\": 3}\n\
               {\"tension_a\": 1.0, \"tip_x\": 1, \"tip_z\": 3}\n";
    let e = Recording::parse_str("rec.jsonl", bad, &map(LengthUnit::M)).unwrap_err();
    assert!(
        matches!(&e, CalibrationError::Recording { file, line: 2, column, .. } if file == "rec.jsonl" && column == "tip_y"),
        "{e}"
    );
}

#[test]
fn missing_column_names_file_header_line_and_column() {
    let text = GOOD
        .replace(",tip_z", "")
        .replace(",3.0\n", "\n")
        .replace(",3.5\n", "\n");
    let e = err(&text);
    assert!(
        matches!(&e, CalibrationError::MissingColumn { file, line: 1, column, .. } if file == "rec.csv" && column == "tip_z"),
        "{e}"
    );
    let msg = e.to_string();
    assert!(msg.contains("rec.csv:1") && msg.contains("tip_z"), "{msg}");
}

#[test]
fn nan_non_numeric_and_empty_cells_name_line_and_column() {
    let nan = GOOD.replace("2.0,0.0,0.0,1.5", "2.0,NaN,0.0,1.5");
    let e = err(&nan);
    assert!(
        matches!(&e, CalibrationError::Recording { line: 3, column, why, .. } if column == "tension_b" && why.contains("NaN")),
        "{e}"
    );
    assert!(
        e.to_string().starts_with("rec.csv:3: column `tension_b`"),
        "{e}"
    );
    let word = GOOD.replace("1.5,2.5,3.5", "1.5,abc,3.5");
    let e = err(&word);
    assert!(
        matches!(&e, CalibrationError::Recording { line: 3, column, why, .. } if column == "tip_y" && why.contains("`abc` is not a number")),
        "{e}"
    );
    let empty = GOOD.replace("1.0,2.0,3.0", "1.0,,3.0");
    let e = err(&empty);
    assert!(
        matches!(&e, CalibrationError::Recording { line: 2, column, .. } if column == "tip_y"),
        "{e}"
    );
    let short = GOOD.replace(",1.5,2.5,3.5", ",1.5");
    let e = err(&short);
    assert!(
        matches!(&e, CalibrationError::Recording { line: 3, column, .. } if column == "tip_y"),
        "{e}"
    );
}

fn setup_and_run(rec: &Recording) -> Result<f64, CalibrationError> {
    let params = vec![
        path("robot/sections/0/youngs_modulus_pa"),
        path("robot/sections/1/youngs_modulus_pa"),
    ];
    let model = TensionModel::new(&scene(), &params, &rec.input_names, None)?;
    let setup = CalibrationSetup {
        model: &model,
        params: params
            .iter()
            .map(|p| FitParam::from_spec(&ParamSpec::new(p.as_str()), 60e9))
            .collect(),
        frame: FrameSetup {
            capture_to_base: RigidTransform::default(),
            marker_offset_m: Vector3::new(0.0, 0.0, 5e-3),
            fit_capture_frame: true,
            fit_marker_offset: true,
        },
        train: rec,
        val: None,
        robot_length_m: 0.2,
    };
    let settings = CalibrationSettings {
        capture_noise_m: 1e-4,
        ..CalibrationSettings::default()
    };
    calibrate(&setup, &settings, &mut |_| {}).map(|r| {
        println!(
            "{:?} {} {:?} {:?}",
            r.status, r.iterations, r.params, r.warnings
        );
        r.train.raw.rmse_m
    })
}

#[test]
fn millimetres_read_as_metres_are_a_unit_mismatch() {
    let params = vec![
        path("robot/sections/0/youngs_modulus_pa"),
        path("robot/sections/1/youngs_modulus_pa"),
    ];
    let t = truth();
    let text = synthesise(&params, &t, 10, 1e-4, 3, LengthUnit::Mm);
    // read correctly (mm): the fit reaches the noise level (RMS 3-D error < 3 sigma)
    let rec = parse("tips_mm.csv", &text, LengthUnit::Mm);
    let rmse = setup_and_run(&rec).unwrap();
    assert!(rmse < 3e-4, "{rmse}");
    // read as metres: a unit mismatch naming file, line and columns
    let rec = parse("tips_mm.csv", &text, LengthUnit::M);
    let e = setup_and_run(&rec).unwrap_err();
    match &e {
        CalibrationError::UnitMismatch {
            file,
            line,
            columns,
            unit,
            spread_ratio,
            ..
        } => {
            assert_eq!(file, "tips_mm.csv");
            assert!((2..=11).contains(line), "{line}");
            assert_eq!(columns, "tip_x,tip_y,tip_z");
            assert_eq!(unit, "m");
            // the true factor is 1000 (within 20 %: the frames differ by a rotation only)
            assert!((*spread_ratio / 1e3 - 1.0).abs() < 0.2, "{spread_ratio}");
        }
        other => panic!("expected a unit mismatch, got {other}"),
    }
    assert!(e.to_string().contains("mm read as m"), "{e}");
}

#[test]
fn calibration_table_rejects_unknown_keys_and_reads_units() {
    let good = format!(
        "{SCENE}\n[calibration]\nunit = \"mm\"\ncapture_noise_m = 2e-4\n\
         [[calibration.params]]\npath = \"robot/sections/*/youngs_modulus_pa\"\nmin = 1e9\n"
    );
    let sc = Scene::from_toml_str(&good).unwrap();
    let c = sc.calibration.as_ref().unwrap();
    assert_eq!(c.unit, LengthUnit::Mm);
    assert_eq!(c.params[0].min, Some(1e9));
    sc.validate().unwrap();
    let bad = format!("{SCENE}\n[calibration]\nnoise = 1e-4\n");
    let e = Scene::from_toml_str(&bad).unwrap_err().to_string();
    assert!(e.contains("noise"), "{e}");
    let neg = format!("{SCENE}\n[calibration]\ncapture_noise_m = -1.0\n");
    let e = Scene::from_toml_str(&neg)
        .unwrap()
        .validate()
        .unwrap_err()
        .to_string();
    assert!(e.contains("calibration.capture_noise_m"), "{e}");
}
