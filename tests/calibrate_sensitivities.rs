//! The Jacobian of the calibration residuals, as the fit uses it
//! (`calibrate::residuals_and_jacobian`: scene columns from the model's
//! sensitivities combined with the marker offset, frame and offset columns
//! analytic), against central differences of the residuals themselves, on a
//! tendon-driven scene: the shipped two-segment TDCR
//! (`data/scenes/tdcr_two_segment.toml`, six displacement-driven tendons) driven
//! row by row from servo readings (`ServoModel`, warm in sequence). Proptest
//! draws the scene parameters (Young's modulus, tendon stiffness, pretension), the
//! capture frame, the marker offset and the readings of three rows.
//!
//! Reference: central differences of the whole residual vector with steps `1e-4`
//! times each scene parameter's scale (the fit's own columns use `1e-5`, so the
//! two are independent quotients), `1e-6` rad and `1e-6` m for the frame and offset.
//! Columns are compared per typical size of their parameter (scene: its scale, the
//! start value; rotation: 1 rad; translation and offset: 0.2 m, the robot length,
//! as the fit scales them), in whitened residuals (sigma = 1e-4 m). Tolerance, per
//! column: `|J - CD| <= 1e-4 max|CD| + 1e-3`, and every column must move the
//! residuals (`max|CD| > 0.1`: a parameter the rows cannot see would pass
//! vacuously). Sources of disagreement: truncation `h^2 f'''/6`, about 1e-8
//! relative at h = 1e-4; the rotation columns' inner differences of `exp(w)`
//! (step 1e-7), ~1e-9 relative; the forward solves' residual noise (tendon
//! tolerance 1e-12 m, shooting 1e-10 scaled) over the fit's step (1e-5 of the
//! parameter): at most ~1e-3 whitened if every solve stopped just at its
//! tolerance, far less in practice (Newton ends well below it), hence the absolute
//! 1e-3. Seen on 12 cases: at most 1e-5 (the pretension column, 5e-6 relative),
//! below 1e-7 for the frame and offset; one case CI drew (kept in
//! `calibrate_sensitivities.proptest-regressions`) reached 5.6e-4 in the modulus
//! column on one residual, inside that noise bound (the 1e-4 it was first held to was
//! below the bound this paragraph derives). A wrong sign, a missing offset term or a derivative of the wrong
//! pose is O(1) relative (at least 0.1 here) and fails.
//!
//! The residuals are piecewise smooth: a tendon goes slack or taut at some
//! parameter value (the complementarity `T >= 0`), and the Jacobian is that of the
//! active piece. A step that straddles a switch gives a central difference of
//! neither piece (a draw CI did not make, kept in the regressions file: the stiffness
//! column 13 % off at a step of `1e-4` of its scale, equal to `J` within 1e-8
//! relative at `3e-5` and below, a switch ~`5e-5` above the value). Such a step is
//! recognised by its one-sided differences, which differ by `h f''` (about 1e-4
//! relative) on a smooth piece and by O(1) across a switch (`KINK`); the step is
//! then shrunk tenfold, up to `KINK_SHRINKS` times. A wrong column still fails: the
//! central difference converges to the true derivative as the step shrinks.

use cablesense::calibrate::{
    residuals_and_jacobian, CalibrationSettings, CalibrationSetup, ColumnMap, FitParam, FrameSetup,
    ParamSpec, Recording, RigidTransform, SceneModel, ServoModel,
};
use cablesense::nalgebra::{DMatrix, Vector3};
use cablesense::validation::ParamPath;
use cablesense::Scene;
use proptest::prelude::*;
use proptest::test_runner::FileFailurePersistence;

const NOISE: f64 = 1e-4;
/// One-sided differences further apart than this (relative to the column's size)
/// mark a taut/slack switch inside the step.
const KINK: f64 = 1e-2;
/// How many times a step is shrunk tenfold past a switch.
const KINK_SHRINKS: usize = 3;

fn scene() -> Scene {
    Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/scenes/tdcr_two_segment.toml"
    ))
    .unwrap()
}

fn paths() -> Vec<ParamPath> {
    [
        "robot/sections/*/youngs_modulus_pa",
        "robot/tendons/stiffness_n",
        "robot/tendons/pretension_n",
    ]
    .iter()
    .map(|p| p.parse().unwrap())
    .collect()
}

/// A recording of three rows: each row pulls one tendon of each segment by `amp`
/// (m) and pays the others out by half as much; the marker column is arbitrary
/// (the Jacobian does not depend on it, the residuals do linearly).
fn recording(columns: &[String], amp: [f64; 3], pick: [usize; 3]) -> Recording {
    let mut csv = format!("{},tip_x,tip_y,tip_z\n", columns.join(","));
    for (i, (a, k)) in amp.iter().zip(pick).enumerate() {
        let mut q = [-0.5 * a; 6];
        q[k % 3] = *a;
        q[3 + (k / 3) % 3] = 0.6 * a;
        let cells: Vec<String> = q.iter().map(|v| format!("{v:.12e}")).collect();
        csv += &format!(
            "{},{},{},{}\n",
            cells.join(","),
            0.01 * i as f64,
            -0.02,
            0.19
        );
    }
    let map = ColumnMap {
        inputs: columns.to_vec(),
        ..ColumnMap::default()
    };
    Recording::parse_str("rows.csv", &csv, &map).unwrap()
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 6,
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource(
            "proptest-regressions",
        ))),
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn residual_jacobian_equals_central_differences(
        e in 40e9..80e9f64,
        ea in 3e3..3e4f64,
        t0 in 0.5..3.0f64,
        w in prop::array::uniform3(-0.3..0.3f64),
        t in prop::array::uniform3(-0.05..0.05f64),
        o in prop::array::uniform3(-0.01..0.01f64),
        amp in prop::array::uniform3(2e-4..1.5e-3f64),
        pick in prop::array::uniform3(0usize..9),
    ) {
        let sc = scene();
        let p = paths();
        let columns = ServoModel::reading_columns(&sc);
        let rec = recording(&columns, amp, pick);
        let model = SceneModel::new(&sc, &p, &rec.input_names, None).unwrap();
        let params: Vec<FitParam> = p
            .iter()
            .zip(model.values())
            .map(|(path, v)| FitParam::from_spec(&ParamSpec::new(path.as_str()), *v))
            .collect();
        let scales: Vec<f64> = params.iter().map(|q| q.scale).collect();
        let setup = CalibrationSetup {
            model: &model,
            params,
            frame: FrameSetup {
                capture_to_base: RigidTransform::default(),
                marker_offset_m: Vector3::zeros(),
                fit_capture_frame: true,
                fit_marker_offset: true,
            },
            train: &rec,
            val: None,
            robot_length_m: 0.2,
        };
        let settings = CalibrationSettings {
            capture_noise_m: NOISE,
            threads: 1,
            ..CalibrationSettings::default()
        };
        let mut x = vec![e, ea, t0];
        x.extend(w);
        x.extend(t);
        x.extend(o);
        let (r, jac) = residuals_and_jacobian(&setup, &settings, &x, true).unwrap();
        let jac = jac.unwrap();
        prop_assert_eq!(jac.shape(), (9, 12));
        prop_assert!(r.iter().all(|v| v.is_finite()));
        let typical = |k: usize| match k {
            3..=5 => 1.0,
            6.. => 0.2,
            _ => scales.get(k).copied().unwrap_or(1.0),
        };
        let mut cd = DMatrix::zeros(9, 12);
        for k in 0..12 {
            let mut h = if k < 3 { 1e-4 * scales[k] } else { 1e-6 };
            // a taut/slack switch inside [x - h, x + h]: shrink the step (see the
            // module's last paragraph)
            for shrink in 0..=KINK_SHRINKS {
                let mut xp = x.clone();
                xp[k] += h;
                let (rp, _) = residuals_and_jacobian(&setup, &settings, &xp, false).unwrap();
                xp[k] = x[k] - h;
                let (rm, _) = residuals_and_jacobian(&setup, &settings, &xp, false).unwrap();
                let (mut size, mut bend) = (0.0f64, 0.0f64);
                for i in 0..9 {
                    cd[(i, k)] = (rp[i] - rm[i]) / (2.0 * h);
                    size = size.max(cd[(i, k)].abs() * typical(k));
                    // forward minus backward difference
                    bend = bend.max((rp[i] - 2.0 * r[i] + rm[i]).abs() / h * typical(k));
                }
                if bend <= KINK * size + 1e-2 {
                    break;
                }
                println!("column {k}: one-sided differences apart by {bend:.3e} (size {size:.3e}) at step {h:e}");
                prop_assert!(shrink < KINK_SHRINKS, "column {}: a kink at every step down to {:e}", k, h);
                h *= 0.1;
            }
        }
        for k in 0..12 {
            let typical = typical(k);
            let size = cd.column(k).amax() * typical;
            let worst = (jac.column(k) - cd.column(k)).amax() * typical;
            prop_assert!(size > 0.1, "column {} does not move the residuals: {}", k, size);
            println!("column {k}: max |CD| {size:.3e}, max |J - CD| {worst:.3e}");
            prop_assert!(
                worst <= 1e-4 * size + 1e-3,
                "column {}: J {:?} CD {:?}",
                k,
                jac.column(k).as_slice(),
                cd.column(k).as_slice()
            );
        }
    }
}
