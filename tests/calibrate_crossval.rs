//! Grouped cross-validation (`cablesense::calibrate::cross_validate`) chooses the
//! candidate with the right physics. A recording synthesised by the shipped
//! two-segment TDCR (`data/scenes/tdcr_two_segment.toml`, Young's modulus set to a
//! known 55 GPa) plus Gaussian capture noise (0.05 mm) holds two pattern families:
//! pulls of segment 1's tendons and pulls of segment 2's. Candidate A frees the modulus
//! (start 90 GPa); candidate B keeps it at the wrong 90 GPa and frees the tendons'
//! pretension instead. Held out, each family is predicted from a fit on the other.
//! Tolerances: A's modulus within 10 % of the truth from either family (16 rows);
//! A's pooled held-out RMSE below 3 noise sigmas per coordinate (`3 sqrt(3) sigma`,
//! the model is exact); B's at least twice A's (measured: 0.078 and 0.162 mm).

use cablesense::calibrate::{
    cross_validate, CalibrationSettings, ColumnMap, FitParam, Folds, FrameSetup, ParamSpec,
    Recording, RigidTransform, SceneModel, ServoModel,
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

/// 32 rows: even rows pull one tendon of segment 1, odd rows one of segment 2 (by up
/// to 1.5 mm, the others paid out by half as much); labels name the family.
fn readings() -> Vec<(String, [f64; 6])> {
    (0..32)
        .map(|i| {
            let a = 1.5e-3 * ((i as f64) * 0.7).sin().abs().max(0.2);
            let mut q = [-0.5 * a; 6];
            let (seg, k) = (i % 2, (i / 2) % 3);
            q[3 * seg + k] = a;
            (format!("rep1_seg{}_pull", seg + 1), q)
        })
        .collect()
}

fn fit_params(model: &SceneModel, paths: &[ParamPath]) -> Vec<FitParam> {
    paths
        .iter()
        .zip(model.values())
        .map(|(path, v)| {
            let mut spec = ParamSpec::new(path.as_str());
            spec.min = Some(1.0);
            FitParam::from_spec(&spec, *v)
        })
        .collect()
}

#[test]
fn cross_validation_prefers_the_candidate_with_the_right_physics() {
    let sc = scene();
    let e: Vec<ParamPath> = vec!["robot/sections/*/youngs_modulus_pa".parse().unwrap()];
    let truth = set_values(&sc, &e, &[55e9]).unwrap();
    let columns = ServoModel::reading_columns(&sc);
    let mut ws = truth.tendon_workspace().unwrap();
    let mut rng = crate::calibrate_common::Rng::new(46);
    let mut gauss = || rng.gauss();
    let mut csv = format!("label,{},tip_x,tip_y,tip_z\n", columns.join(","));
    let mut labels = Vec::new();
    for (label, q) in readings() {
        assert!(ws.solve_readings(&q).unwrap().status.is_converged());
        let tip = ws.tip_position() + Vector3::new(gauss(), gauss(), gauss()) * NOISE;
        let cells: Vec<String> = q.iter().map(|v| format!("{v:.12e}")).collect();
        csv += &format!(
            "{label},{},{:.12e},{:.12e},{:.12e}\n",
            cells.join(","),
            tip.x,
            tip.y,
            tip.z
        );
        labels.push(label);
    }
    let map = ColumnMap {
        inputs: columns.clone(),
        ..ColumnMap::default()
    };
    let rec = Recording::parse_str("synthetic.csv", &csv, &map).unwrap();
    // the labels as the CLI reads them, from the file's text by line
    assert_eq!(
        cablesense::calibrate::row_labels(&csv, "label", &rec).unwrap(),
        labels
    );
    let families = cablesense::calibrate::parse_families("seg1=seg1;seg2=seg2").unwrap();
    let folds = Folds::from_labels(&labels, &families).unwrap();
    let frame = FrameSetup {
        capture_to_base: RigidTransform::default(),
        marker_offset_m: Vector3::zeros(),
        fit_capture_frame: false,
        fit_marker_offset: false,
    };
    let settings = CalibrationSettings {
        capture_noise_m: NOISE,
        ..CalibrationSettings::default()
    };
    let wrong = set_values(&sc, &e, &[90e9]).unwrap();
    let run = |paths: Vec<ParamPath>| {
        let model = SceneModel::new(&wrong, &paths, &rec.input_names, None).unwrap();
        let params = fit_params(&model, &paths);
        cross_validate(
            &model,
            &params,
            frame,
            &rec,
            &folds,
            &settings,
            model.robot_length(),
            &mut |_, _| {},
        )
        .unwrap()
    };
    let a = run(e.clone());
    let b = run(vec!["robot/tendons/pretension_n".parse().unwrap()]);
    for cv in [&a, &b] {
        assert_eq!(cv.held_out.len(), 2);
        for h in &cv.held_out {
            assert_eq!((h.rows, h.fit_rows, h.unsolved), (16, 16, 0), "{h:?}");
            assert_eq!(h.errors.mean_removed.count, 16);
        }
    }
    // A recovers the modulus from either half (16 rows of one family: within 10 %)
    // and predicts the other at the noise
    for h in &a.held_out {
        assert!(
            (h.values[0] - 55e9).abs() < 5.5e9,
            "{} {:e}",
            h.group,
            h.values[0]
        );
    }
    let limit = 3.0 * 3f64.sqrt() * NOISE;
    assert!(a.pooled_rmse_m < limit, "{} m", a.pooled_rmse_m);
    assert!(
        b.pooled_rmse_m > 2.0 * a.pooled_rmse_m,
        "{} {}",
        b.pooled_rmse_m,
        a.pooled_rmse_m
    );
}
