//! The exact sensitivities of the readings model (`ServoModel::sensitivities`:
//! implicit function theorem on the joint tendon residual at each row's converged
//! state, `src/calibrate/readings_sens.rs`) against the checked central
//! differences of the rows' converged poses (`calibrate::finite_differences`, the
//! model's sensitivities before), on the stored FTDCR v4 calibration: nine
//! displacement-driven tendons, its eight parameters (series stiffness,
//! pretension, the rod's modulus, the guide mass, two components of gravity, and the
//! readings conditioning's time offset and backlash, whose `dq/dp` both methods take from the same central difference
//! of the conditioned readings), on rows of `train.csv` solved warm in sequence.
//!
//! Tolerance per parameter: `max_i |exact_i - fd_i| <= 1e-4 max_i |fd_i|` for the
//! position and the rotation derivatives. Sources of disagreement: the central
//! differences' truncation (`h^2 f'''/6`, h = 1e-5 of the parameter's scale: ~1e-10
//! relative) and the solves' residual noise over the step (tendon tolerance 1e-12 m,
//! shooting 1e-10 scaled, over a 1e-5 relative step: up to ~1e-5 relative); the
//! exact side differentiates smooth functions at a fixed state. Seen: at most
//! 4.1e-6 (pretension, rotation, rows 300..316). A missing term (the pretension's and stiffness's
//! change of the rest free lengths, the compliance's dependence on the reading, the
//! scene's change of the boundary residual) is O(1) relative and fails.

use cablesense::calibrate::{
    finite_differences, CalibrationModel, CalibrationSettings, ColumnMap, FitParam, Recording,
    SceneModel, Sensitivities,
};
use cablesense::scene::calibration::ParamSpec;
use cablesense::validation::ParamPath;
use cablesense::Scene;

fn dir() -> &'static str {
    env!("CARGO_MANIFEST_DIR")
}

/// The stored FTDCR v4 calibration, solved to round-off: the central differences'
/// noise is the solves' tolerance (the stored scene's own 1e-4 / 1e-7 m would
/// swamp them).
fn stored() -> Scene {
    crate::common::default_tolerances(
        Scene::load(format!(
            "{}/data/calibration/ftdcr_v4_calibrated.toml",
            dir()
        ))
        .unwrap(),
    )
}

#[test]
fn exact_sensitivities_equal_central_differences_on_ftdcr_v4() {
    check(stored(), 8);
}

/// The same with the series spring's second-order term (`e(T) = T/k_s + b T^2`,
/// `TendonMechanics::covered`) set and freed: its tangent compliance enters `F_z`
/// (the exact side) and both sides' residuals. Seen (b = 4e-5 m/N^2, about 30 % of
/// the spring's extension at 3 N, and its negative, a toe region).
#[test]
fn exact_sensitivities_with_a_nonlinear_series_spring() {
    for b in [4e-5, -4e-5] {
        let mut scene = stored();
        scene
            .robot
            .tendons
            .as_mut()
            .unwrap()
            .series_quadratic_m_per_n2 = Some(b);
        let cal = scene.calibration.as_mut().unwrap();
        cal.params.push(ParamSpec {
            path: "robot/tendons/series_quadratic_m_per_n2".into(),
            min: Some(-1e-3),
            max: Some(1e-3),
            scale: Some(1e-4),
            ..ParamSpec::default()
        });
        println!("b = {b:e} m/N^2");
        check(scene, 9);
    }
}

fn check(scene: Scene, expected_params: usize) {
    let spec = scene.calibration.clone().unwrap();
    let map = ColumnMap::from_spec(&spec);
    let all = Recording::load(format!("{}/data/hardware/ftdcr_v4/train.csv", dir()), &map).unwrap();
    // rows of a one-segment bending pattern and a circle (reversals: the backlash acts)
    let (rec, _) = all.split_rows(300..316);
    let paths: Vec<ParamPath> = spec
        .params
        .iter()
        .map(|p| p.path.parse().unwrap())
        .collect();
    let mut model = SceneModel::new(&scene, &paths, &rec.input_names, spec.marker_s_m).unwrap();
    assert!(matches!(model, SceneModel::Readings(_)));
    let params = FitParam::all_from_spec(&spec, model.values());
    let settings = CalibrationSettings::from_spec(&spec, 1);
    let values = model.values().to_vec();
    let steps: Vec<f64> = params.iter().map(|p| settings.fd_step * p.scale).collect();
    let n = values.len();
    assert_eq!(n, expected_params);

    let mut exact = Sensitivities::default();
    model
        .sensitivities(&values, &steps, &rec.rows, &mut exact)
        .unwrap();
    let mut fd = Sensitivities::default();
    finite_differences(&mut model, &values, &steps, &rec.rows, &mut fd).unwrap();
    assert!(exact.failed.is_empty() && fd.failed.is_empty());
    for (i, (a, b)) in exact.poses.iter().zip(&fd.poses).enumerate() {
        assert!(
            (a.position - b.position).norm() < 1e-9,
            "row {i}: pose {} vs {}",
            a.position,
            b.position
        );
    }
    for k in 0..n {
        // the exact path checks only the readings' differences: 0 for a scene value
        if !params[k].name.starts_with("readings/") {
            assert_eq!(exact.fd_disagreement[k], 0.0, "{}", params[k].name);
        }
        for (what, e, f) in [
            ("position", &exact.d_position, &fd.d_position),
            ("rotation", &exact.d_rotation, &fd.d_rotation),
        ] {
            let (mut worst, mut size, mut at) = (0.0f64, 0.0f64, 0);
            for i in 0..rec.rows.len() {
                let d = (e[i * n + k] - f[i * n + k]).norm();
                if d > worst {
                    (worst, at) = (d, i);
                }
                size = size.max(f[i * n + k].norm());
            }
            println!(
                "{} {what}: max |fd| {size:.3e}, max |exact - fd| {worst:.3e} (row {at})",
                params[k].name
            );
            assert!(size > 0.0, "{} does not move the {what}s", params[k].name);
            assert!(
                worst <= 1e-4 * size,
                "{} {what}: row {at}: exact {} fd {}",
                params[k].name,
                e[at * n + k],
                f[at * n + k]
            );
        }
    }
}

/// The scene's checks of the second-order term: a negative one (a toe region) needs
/// the linear series spring, a non-finite one is refused; each error names the key.
#[test]
fn a_negative_second_order_term_needs_the_linear_series_spring() {
    let text = std::fs::read_to_string(format!(
        "{}/data/calibration/ftdcr_v4_calibrated.toml",
        dir()
    ))
    .unwrap();
    let spring = "series_stiffness_n_per_m = 2676.9397954155406\n";
    assert!(text.contains(spring), "the stored series spring moved");
    let with = |b: &str, keep_spring: bool| {
        let line = format!("{spring}series_quadratic_m_per_n2 = {b}\n");
        let t = text.replace(spring, &line);
        let t = if keep_spring {
            t
        } else {
            t.replace(spring, "")
        };
        let scene = Scene::from_toml_str(&t).expect("parses");
        scene.validate()
    };
    assert!(with("-2e-5", true).is_ok());
    assert!(with("3e-5", false).is_ok());
    for (b, keep) in [("-2e-5", false), ("nan", true), ("inf", true)] {
        let e = match with(b, keep) {
            Ok(_) => panic!("b = {b} (spring kept: {keep}) was accepted"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains("series_quadratic_m_per_n2"), "b = {b}: {e}");
    }
}
