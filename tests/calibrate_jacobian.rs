//! The finite-difference sensitivities of the tension model against a perturbation
//! check: for each parameter, re-predicting the rows at `x + d` must move the marker
//! body's position by `J d` and its rotation by `w d` up to second order (relative
//! 1e-2 at d = 1e-3 x, where the second-order term is ~1e-3); the central/forward
//! check must stay quiet there (< 1e-3) and must flag a model with a kink.

use crate::calibrate_common;
use calibrate_common::*;

use cablesense::calibrate::{
    finite_differences, CalibrationError, CalibrationModel, RecordingRow, Sensitivities,
    TensionModel,
};
use cablesense::nalgebra::{Matrix3, Rotation3, Vector3};
use cablesense::Pose;

fn rows(n: usize) -> Vec<RecordingRow> {
    tensions(n)
        .iter()
        .enumerate()
        .map(|(i, t)| RecordingRow {
            line: i + 2,
            t_s: None,
            marker_m: Vector3::zeros(),
            inputs: t.to_vec(),
            history: None,
        })
        .collect()
}

#[test]
fn tension_model_sensitivities_match_a_perturbation() {
    let params = vec![
        path("robot/sections/0/youngs_modulus_pa"),
        path("robot/sections/1/shape/solid/diameter_m"),
    ];
    let names: Vec<String> = ["tension_a", "tension_b", "tension_c"]
        .map(String::from)
        .to_vec();
    let mut m = TensionModel::new(&scene(), &params, &names, None).unwrap();
    let x = vec![60e9, 1.5e-3];
    let steps: Vec<f64> = x.iter().map(|v| 1e-5 * v).collect();
    let rows = rows(8);
    let mut s = Sensitivities::default();
    m.sensitivities(&x, &steps, &rows, &mut s).unwrap();
    assert_eq!(s.fd_disagreement.len(), 2);
    for d in &s.fd_disagreement {
        assert!(*d < 1e-3, "{:?}", s.fd_disagreement);
    }
    for k in 0..2 {
        let d = 1e-3 * x[k];
        let mut xp = x.clone();
        xp[k] += d;
        m.set_params(&xp).unwrap();
        m.restart();
        let mut moved = 0.0f64;
        for (i, row) in rows.iter().enumerate() {
            let p = m.predict(row).unwrap();
            let dp = p.position - s.poses[i].position;
            let lin = s.d_position[i * 2 + k] * d;
            moved = moved.max(dp.norm());
            assert!(
                (dp - lin).norm() <= 1e-2 * dp.norm() + 1e-12,
                "param {k} row {i}: moved {dp:?}, linear {lin:?}"
            );
            let dw = Rotation3::from_matrix_unchecked(p.rotation * s.poses[i].rotation.transpose())
                .scaled_axis();
            let wl = s.d_rotation[i * 2 + k] * d;
            assert!(
                (dw - wl).norm() <= 1e-2 * dw.norm() + 1e-12,
                "param {k} row {i}: turned {dw:?}, linear {wl:?}"
            );
        }
        // the check is meaningful: the perturbation moves the tip by micrometres
        assert!(moved > 1e-6, "param {k} moved the marker by {moved}");
    }
}

/// A marker on `|x - 1|`: a kink at the evaluation point.
#[derive(Clone)]
struct Kink(f64);

impl CalibrationModel for Kink {
    fn set_params(&mut self, v: &[f64]) -> Result<(), CalibrationError> {
        self.0 = v[0];
        Ok(())
    }
    fn predict(&mut self, row: &RecordingRow) -> Result<Pose, CalibrationError> {
        Ok(Pose {
            position: Vector3::new((self.0 - 1.0).abs() * row.inputs[0], 0.0, 0.0),
            rotation: Matrix3::identity(),
        })
    }
}

#[test]
fn the_forward_difference_check_flags_a_kink() {
    let rows = rows(3);
    let mut s = Sensitivities::default();
    finite_differences(&mut Kink(0.0), &[1.0], &[1e-5], &rows, &mut s).unwrap();
    // central difference 0, forward difference |input|: disagreement 1, far above 1e-3
    assert!(s.fd_disagreement[0] > 0.5, "{:?}", s.fd_disagreement);
    // smooth elsewhere: quiet
    finite_differences(&mut Kink(0.0), &[2.0], &[1e-5], &rows, &mut s).unwrap();
    assert!(s.fd_disagreement[0] < 1e-6, "{:?}", s.fd_disagreement);
}
