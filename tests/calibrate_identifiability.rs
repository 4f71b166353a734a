//! Parameters the data cannot separate are reported with their direction, and get no
//! invented standard error: (a) a toy model whose marker depends on the product `a b`
//! only (exactly null direction a: +1, b: -1 in relative units); (b) the rod model
//! with E and the rod diameter, which (Kirchhoff rod, no gravity) enter only through
//! `E d^4` (direction E: +1, d: -1/4; tolerance 5 % on the ratio); (c) the statistics
//! on a hand-made Jacobian with two nearly equal columns (correlation > 0.98).

use crate::calibrate_common;
use calibrate_common::*;

use cablesense::calibrate::{
    calibrate, parameter_statistics, CalibrationError, CalibrationModel, CalibrationSettings,
    CalibrationSetup, FitParam, FrameSetup, LengthUnit, ParamSpec, RecordingRow, RigidTransform,
    TensionModel, Unidentifiable,
};
use cablesense::nalgebra::{DMatrix, Matrix3, Vector3};
use cablesense::Pose;

#[derive(Clone)]
struct Product {
    ab: f64,
}

impl CalibrationModel for Product {
    fn set_params(&mut self, v: &[f64]) -> Result<(), CalibrationError> {
        self.ab = v[0] * v[1];
        Ok(())
    }
    fn predict(&mut self, row: &RecordingRow) -> Result<Pose, CalibrationError> {
        let u = row.inputs[0];
        Ok(Pose {
            position: Vector3::new(self.ab * u, self.ab * u * u, u),
            rotation: Matrix3::identity(),
        })
    }
}

fn direction(u: &[Unidentifiable]) -> Vec<(String, f64)> {
    u.iter()
        .find_map(|x| match x {
            Unidentifiable::NullDirection { direction, .. } => Some(direction.clone()),
            _ => None,
        })
        .unwrap_or_else(|| panic!("no null direction in {u:?}"))
}

#[test]
fn product_of_two_parameters_is_reported_as_a_null_direction() {
    let mut text = String::from("u,tip_x,tip_y,tip_z\n");
    for i in 0..20 {
        let u = i as f64 * 0.05;
        let ab = 6.0;
        text.push_str(&format!(
            "{u},{},{},{u}\n",
            ab * u + 1e-4 * ((i * 7 % 5) as f64 - 2.0),
            ab * u * u
        ));
    }
    let mut map = map(LengthUnit::M);
    map.inputs = vec!["u".into()];
    let rec = cablesense::calibrate::Recording::parse_str("toy.csv", &text, &map).unwrap();
    let model = Product { ab: 4.0 };
    let setup = CalibrationSetup {
        model: &model,
        params: vec![
            FitParam::from_spec(&ParamSpec::new("a"), 2.0),
            FitParam::from_spec(&ParamSpec::new("b"), 2.0),
        ],
        frame: FrameSetup {
            capture_to_base: RigidTransform::default(),
            marker_offset_m: Vector3::zeros(),
            fit_capture_frame: false,
            fit_marker_offset: false,
        },
        train: &rec,
        val: None,
        robot_length_m: 1.0,
    };
    let settings = CalibrationSettings {
        capture_noise_m: 1e-4,
        ..CalibrationSettings::default()
    };
    let report = calibrate(&setup, &settings, &mut |_| {}).unwrap();
    // the product is fitted (1e-4 relative) ...
    let ab = report.scene_values[0] * report.scene_values[1];
    assert!((ab - 6.0).abs() < 6e-4, "{ab}");
    // ... the split between a and b is not: a null direction naming both, +1 / -1
    let d = direction(&report.statistics.unidentifiable);
    assert_eq!(d.len(), 2, "{d:?}");
    assert_eq!((d[0].0.as_str(), d[1].0.as_str()), ("a", "b"));
    assert!((d[0].1 * d[1].1 + 1.0).abs() < 1e-3, "{d:?}");
    assert!(
        report.params.iter().all(|p| p.std_error.is_nan()),
        "{:?}",
        report.params
    );
    assert!(report
        .warnings
        .iter()
        .any(|w| w.contains("not identifiable")));
}

#[test]
fn modulus_and_diameter_of_a_kirchhoff_rod_are_reported_with_their_direction() {
    let mut sc = scene();
    sc.loads.gravity_m_s2 = [0.0; 3];
    sc.numerics.rod_model = cablesense::RodModel::Kirchhoff;
    let params = vec![
        path("robot/sections/*/youngs_modulus_pa"),
        path("robot/sections/*/shape/solid/diameter_m"),
    ];
    let names: Vec<String> = ["tension_a", "tension_b", "tension_c"]
        .map(String::from)
        .to_vec();
    // synthesise at E = 55 GPa with this scene
    let mut truth_model = TensionModel::new(&sc, &params, &names, None).unwrap();
    truth_model.set_params(&[55e9, 1.5e-3]).unwrap();
    let mut rng = Rng::new(7);
    let mut text = String::from("tension_a,tension_b,tension_c,tip_x,tip_y,tip_z\n");
    for (i, t) in tensions(12).iter().enumerate() {
        let row = RecordingRow {
            line: i + 2,
            t_s: None,
            marker_m: Vector3::zeros(),
            inputs: t.to_vec(),
            history: None,
        };
        let p = truth_model.predict(&row).unwrap().position;
        let n = Vector3::new(rng.gauss(), rng.gauss(), rng.gauss()) * 1e-4;
        let m = p + n;
        text.push_str(&format!(
            "{},{},{},{},{},{}\n",
            t[0], t[1], t[2], m.x, m.y, m.z
        ));
    }
    let rec = parse("ed.csv", &text, LengthUnit::M);
    let model = TensionModel::new(&sc, &params, &rec.input_names, None).unwrap();
    let setup = CalibrationSetup {
        model: &model,
        params: vec![
            FitParam::from_spec(&ParamSpec::new(params[0].as_str()), 60e9),
            FitParam::from_spec(&ParamSpec::new(params[1].as_str()), 1.5e-3),
        ],
        frame: FrameSetup {
            capture_to_base: RigidTransform::default(),
            marker_offset_m: Vector3::zeros(),
            fit_capture_frame: false,
            fit_marker_offset: false,
        },
        train: &rec,
        val: None,
        robot_length_m: 0.2,
    };
    let settings = CalibrationSettings {
        capture_noise_m: 1e-4,
        ..CalibrationSettings::default()
    };
    let report = calibrate(&setup, &settings, &mut |_| {}).unwrap();
    let d = direction(&report.statistics.unidentifiable);
    println!("{:?}", report.statistics.unidentifiable);
    let e = d
        .iter()
        .find(|(n, _)| n.contains("youngs"))
        .expect("E in the direction")
        .1;
    let dia = d
        .iter()
        .find(|(n, _)| n.contains("diameter"))
        .expect("d in the direction")
        .1;
    // E d^4 = const: dE/E = -4 dd/d, so the ratio d/E components is -1/4 (5 %)
    assert!((dia / e + 0.25).abs() < 0.0125, "{d:?}");
    assert!(report.params.iter().all(|p| p.std_error.is_nan()));
    // the combination itself is fitted: E d^4 within 1e-3 of the truth's
    let ed4 = report.scene_values[0] * report.scene_values[1].powi(4);
    let want = 55e9 * 1.5e-3f64.powi(4);
    assert!((ed4 / want - 1.0).abs() < 1e-3, "{ed4} vs {want}");
}

#[test]
fn nearly_equal_columns_are_flagged_as_correlated() {
    let m = 30;
    let j = DMatrix::from_fn(m, 3, |i, k| {
        let t = i as f64 / m as f64;
        match k {
            0 => t,
            1 => t + 0.02 * (7.0 * t).sin(),
            _ => (3.0 * t).cos(),
        }
    });
    let names: Vec<String> = ["p", "q", "r"].map(String::from).to_vec();
    let st = parameter_statistics(&j, m as f64, m, &names, &[1.0, 1.0, 1.0]);
    assert!(
        st.unidentifiable.iter().any(|u| matches!(u,
            Unidentifiable::Correlated { a, b, correlation } if a == "p" && b == "q" && correlation.abs() > 0.98)),
        "{:?}",
        st.unidentifiable
    );
    // r is independent: finite standard error, no flag on it
    assert!(st.std_errors[2].is_finite());
    assert!(!st
        .unidentifiable
        .iter()
        .any(|u| u.to_string().contains(" r ")));
}

/// (d) The same path given twice: the later write wins, so the first copy has no
/// effect; it is named in a warning and in a null direction, with no standard error,
/// while the second copy is fitted with a finite one.
#[test]
fn the_same_path_twice_is_reported() {
    let e = path("robot/sections/*/youngs_modulus_pa");
    let t = Truth {
        values: vec![58e9],
        ..truth()
    };
    let text = synthesise(std::slice::from_ref(&e), &t, 10, 1e-4, 11, LengthUnit::M);
    let rec = parse("twice.csv", &text, LengthUnit::M);
    let params = vec![e.clone(), e.clone()];
    let model = TensionModel::new(&scene(), &params, &rec.input_names, None).unwrap();
    let setup = CalibrationSetup {
        model: &model,
        params: vec![
            FitParam::from_spec(&ParamSpec::new(e.as_str()), 60e9),
            FitParam::from_spec(&ParamSpec::new(e.as_str()), 60e9),
        ],
        frame: FrameSetup {
            capture_to_base: t.frame,
            marker_offset_m: t.offset,
            fit_capture_frame: false,
            fit_marker_offset: false,
        },
        train: &rec,
        val: None,
        robot_length_m: 0.2,
    };
    let settings = CalibrationSettings {
        capture_noise_m: 1e-4,
        ..CalibrationSettings::default()
    };
    let report = calibrate(&setup, &settings, &mut |_| {}).unwrap();
    assert!(
        report.warnings.iter().any(|w| w.contains("given twice")),
        "{:?}",
        report.warnings
    );
    let d = direction(&report.statistics.unidentifiable);
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(d[0].0, e.as_str());
    assert!(report.params[0].std_error.is_nan());
    // the effective copy: 58 GPa within 4 reported standard errors
    let p = &report.params[1];
    assert!(p.std_error.is_finite(), "{p:?}");
    assert!((p.value - 58e9).abs() < 4.0 * p.std_error, "{p:?}");
}
