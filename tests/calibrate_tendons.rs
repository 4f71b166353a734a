//! Calibration of a tendon-driven robot from servo readings: a recording synthesised
//! by the model itself (the shipped two-segment TDCR, `data/scenes/tdcr_two_segment.toml`,
//! with the tendons' axial stiffness set to a known 4000 N and Young's modulus 55 GPa)
//! plus Gaussian capture noise (0.05 mm) is calibrated back from starting values
//! 2.0e4 N and 60 GPa. Tolerance: each value within 3 reported standard errors of the
//! truth, and the train error at the noise level (RMS of 3-D distances below 3
//! sigma). The capture frame and marker offset are held at the truth (identity,
//! zero): this test is about the tendon model, the frame fit has its own tests.
//! Its progress reports are checked too: every model evaluation reports its rows
//! at its start and end (`Progress::rows`), from the start values' solves on.

use cablesense::calibrate::{
    calibrate, CalibrationModel, CalibrationSettings, CalibrationSetup, ColumnMap, FitParam,
    FrameSetup, LmStatus, ParamSpec, Progress, Recording, RigidTransform, RowWork, SceneModel,
    ServoModel, Stage,
};
use cablesense::nalgebra::Vector3;
use cablesense::validation::{set_values, ParamPath};
use cablesense::Scene;

const NOISE: f64 = 5e-5;

fn scene() -> Scene {
    Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/scenes/tdcr_two_segment.toml"
    ))
    .unwrap()
}

fn params() -> Vec<ParamPath> {
    vec![
        "robot/sections/*/youngs_modulus_pa".parse().unwrap(),
        "robot/tendons/stiffness_n".parse().unwrap(),
    ]
}

/// Readings (m) of the six tendons: one tendon of each segment pulled in turn by up
/// to 1.5 mm, the others paid out by half as much (so some go slack).
fn readings(rows: usize) -> Vec<[f64; 6]> {
    (0..rows)
        .map(|i| {
            let a = 1.5e-3 * ((i as f64) * 0.7).sin().abs();
            let (s1, s2) = (i % 3, (i / 3) % 3);
            let mut q = [-0.5 * a; 6];
            q[s1] = a;
            q[3 + s2] = 0.6 * a;
            q
        })
        .collect()
}

#[test]
fn tendon_robot_calibrates_back_from_servo_readings() {
    let sc = scene();
    let p = params();
    let truth = [55e9, 4000.0];
    let true_scene = set_values(&sc, &p, &truth).unwrap();
    let columns = ServoModel::reading_columns(&sc);
    assert_eq!(columns.len(), 6);
    let mut ws = true_scene.tendon_workspace().unwrap();
    let mut rng = 0x2545f4914f6cdd1du64;
    let mut gauss = || {
        // Box-Muller on a xorshift stream
        let mut u = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let (a, b) = (u().max(1e-300), u());
        (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
    };
    let mut csv = format!("{},tip_x,tip_y,tip_z\n", columns.join(","));
    for q in readings(24) {
        let rep = ws.solve_readings(&q).unwrap();
        assert!(rep.status.is_converged());
        let tip = ws.tip_position() + Vector3::new(gauss(), gauss(), gauss()) * NOISE;
        let cells: Vec<String> = q.iter().map(|v| format!("{v:.12e}")).collect();
        csv += &format!(
            "{},{:.12e},{:.12e},{:.12e}\n",
            cells.join(","),
            tip.x,
            tip.y,
            tip.z
        );
    }
    let map = ColumnMap {
        inputs: columns.clone(),
        ..ColumnMap::default()
    };
    let rec = Recording::parse_str("synthetic.csv", &csv, &map).unwrap();
    let start = set_values(&sc, &p, &[60e9, 2.0e4]).unwrap();
    let model = SceneModel::new(&start, &p, &rec.input_names, None).unwrap();
    assert!(matches!(model, SceneModel::Readings(_)));
    let fit_params: Vec<FitParam> = p
        .iter()
        .zip(model.values())
        .map(|(path, v)| {
            let mut spec = ParamSpec::new(path.as_str());
            spec.min = Some(1.0);
            FitParam::from_spec(&spec, *v)
        })
        .collect();
    let setup = CalibrationSetup {
        model: &model,
        params: fit_params,
        frame: FrameSetup {
            capture_to_base: RigidTransform::default(),
            marker_offset_m: Vector3::zeros(),
            fit_capture_frame: false,
            fit_marker_offset: false,
        },
        train: &rec,
        val: None,
        robot_length_m: model.robot_length(),
    };
    let settings = CalibrationSettings {
        capture_noise_m: NOISE,
        ..CalibrationSettings::default()
    };
    let mut seen: Vec<Progress> = Vec::new();
    let report = calibrate(&setup, &settings, &mut |p| seen.push(*p)).unwrap();
    assert_eq!(report.status, LmStatus::Converged, "{:?}", report.warnings);
    // progress: the start values' solves first, rows counted up to all 24, the
    // sensitivities in the full stage, and a finished solve of every trial point
    let first = seen[0].rows.expect("a rows report first");
    assert_eq!(
        (seen[0].stage, first.work, first.total),
        (Stage::Start, RowWork::Solve, 24)
    );
    let rows: Vec<_> = seen
        .iter()
        .filter_map(|p| p.rows.map(|r| (p.stage, r)))
        .collect();
    assert!(rows.iter().all(|(_, r)| r.total == 24 && r.done <= r.total));
    assert!(rows
        .iter()
        .any(|(s, r)| *s == Stage::Full && r.work == RowWork::Sensitivities && r.done == 24));
    let solved = rows
        .iter()
        .filter(|(_, r)| r.work == RowWork::Solve && r.done == 24)
        .count();
    let trials = seen.iter().filter(|p| p.rows.is_none()).count();
    assert!(
        solved > report.iterations && solved > trials,
        "{solved} {trials}"
    );
    for (fp, want) in report.params.iter().zip(&truth) {
        let z = (fp.value - want) / fp.std_error;
        println!(
            "{} fit {:.6e} true {want:.6e} se {:.2e} z {z:+.2}",
            fp.name, fp.value, fp.std_error
        );
        assert!(
            fp.std_error.is_finite() && z.abs() <= 3.0,
            "{fp:?} vs {want}"
        );
    }
    assert!(
        report.train.raw.rmse_m < 3.0 * NOISE,
        "train RMSE {}",
        report.train.raw.rmse_m
    );
    // the model predicts through the tendon solve: a clone starts cold and agrees
    let mut a = model.clone();
    let mut b = model.clone();
    let pa = a.predict(&rec.rows[0]).unwrap();
    let pb = b.predict(&rec.rows[0]).unwrap();
    assert_eq!(pa.position, pb.position);
}
