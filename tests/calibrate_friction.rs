//! Calibration sensitivities of a robot with capstan friction (`robot.friction`),
//! which fall back to finite differences of converged solves
//! (`calibrate::readings_sens`).
//!
//! One segment, three displacement-driven tendons, `mu = 0.1`, readings that turn
//! the bending direction row by row (each tendon pulled in and paid out in turn, so
//! the friction's direction memory changes along the chain).
//!
//! * `a_chain_does_not_inherit_the_last_sweeps_direction_memory`: the poses of a
//!   sensitivity sweep that follows another sweep equal those of a fresh model
//!   (to 1e-12 m). Before the chain began with `CalibrationModel::begin_chain`, the
//!   base sweep started from the direction memory where the previous sweep ended and
//!   the finite-difference sweeps from a fresh one: on FTDCR v4 their central and
//!   forward differences disagreed by 50-120 %.
//! * the same sweep's central and forward differences agree within 2 % of each
//!   column's size (the step is 1e-3 of each parameter's scale for differences of
//!   solves; the forward difference's own truncation error is of that order).

use cablesense::calibrate::{CalibrationModel, ColumnMap, Recording, Sensitivities, ServoModel};
use cablesense::validation::{set_values, ParamPath};
use cablesense::Scene;

fn scene() -> Scene {
    let mut text = String::from(
        r#"
[[robot.sections]]
length_m = 0.06
shape = { solid = { diameter_m = 1.0e-3 } }
youngs_modulus_pa = 60.0e9
poisson_ratio = 0.3
density_kg_m3 = 6450.0
[robot.sections.guides]
count = 4
first_offset_m = 0.015
spacing_m = 0.015
thickness_m = 0.0
diameter_m = 0.011
mass_kg = 1.0e-3
holes = { radius_m = 0.0045 }
[robot.tendons]
stiffness_n = 5000.0
pretension_n = 2.0
[robot.friction]
mu = 0.1
"#,
    );
    for j in 0..3 {
        text += &format!(
            "[[robot.cables]]\nname = \"t{j}\"\nrouting = {{ radius_m = 0.0045, angle_deg = {} }}\nend_section = 0\nactuation = \"displacement\"\n",
            120.0 * j as f64
        );
    }
    text += r#"
[loads]
gravity_m_s2 = [0.0, 0.0, -9.81]
[numerics]
guide_mass = "point"
integrator = { rk4 = { steps_per_section = 8 } }
"#;
    Scene::from_toml_str(&text).unwrap()
}

/// A recording whose bending direction turns 0.7 rad a row by 0.3 mm of pull (every
/// tendon stays taut at a pretension of 2 N); the markers are not used here.
fn recording(rows: usize) -> Recording {
    let mut s = "t0,t1,t2,tip_x,tip_y,tip_z\n".to_string();
    for i in 0..rows {
        let phi = 0.7 * i as f64;
        let q: Vec<String> = (0..3)
            .map(|j| {
                let v = 3e-4 * (phi - 2.0 * std::f64::consts::PI / 3.0 * j as f64).cos();
                format!("{v:.12e}")
            })
            .collect();
        s += &format!("{},0,0,0.06\n", q.join(","));
    }
    let map = ColumnMap {
        inputs: vec!["t0".into(), "t1".into(), "t2".into()],
        ..ColumnMap::default()
    };
    Recording::parse_str("friction.csv", &s, &map).unwrap()
}

#[test]
fn a_chain_does_not_inherit_the_last_sweeps_direction_memory() {
    let paths: Vec<ParamPath> = ["robot/friction/mu", "robot/sections/*/youngs_modulus_pa"]
        .iter()
        .map(|p| p.parse().unwrap())
        .collect();
    let values = [0.1, 60e9];
    let scales = [0.1, 60e9];
    let steps: Vec<f64> = scales.iter().map(|s| 1e-5 * s).collect();
    let sc = set_values(&scene(), &paths, &values).unwrap();
    let rec = recording(12);

    let mut fresh = ServoModel::new(&sc, &paths, &rec.input_names, None).unwrap();
    let mut reference = Sensitivities::default();
    fresh
        .sensitivities(&values, &steps, &rec.rows, &mut reference)
        .unwrap();
    assert!(reference.failed.is_empty(), "{:?}", reference.failed);

    // a model that has just predicted the rows in reverse order (its direction
    // memory ends where the reversed chain left it)
    let mut used = ServoModel::new(&sc, &paths, &rec.input_names, None).unwrap();
    used.set_params(&values).unwrap();
    used.begin_chain();
    for row in rec.rows.iter().rev() {
        used.predict(row).unwrap();
    }
    let mut again = Sensitivities::default();
    used.sensitivities(&values, &steps, &rec.rows, &mut again)
        .unwrap();
    for (i, (a, b)) in reference.poses.iter().zip(&again.poses).enumerate() {
        let d = (a.position - b.position).norm();
        assert!(d <= 1e-12, "row {i}: poses differ by {d:e} m");
    }
    // central and forward differences of the solves agree
    for (k, d) in again.fd_disagreement.iter().enumerate() {
        assert!(*d < 0.02, "parameter {k}: disagreement {d}");
    }
    // friction moves the tip: the mu column is not zero
    let size = (0..rec.rows.len())
        .map(|i| again.d_position[i * 2].norm())
        .fold(0.0f64, f64::max);
    assert!(size > 1e-4, "d tip / d mu {size:e} m");
}
