//! The arc coupling (`numerics.cable_coupling = "arc"`, `statics/pass/arc.rs`): a
//! disk's chord to the next hole points at a hole predicted by a circular arc of the
//! gap, not at the integrated one. It is a model approximation, so it is measured
//! against the condensed coupling (which solves the discrete routing of thesis 3.8.1
//! to round-off):
//!
//! * the tension-driven two-section robot of `data/scenes/tdcr_modeling.toml`
//!   (2 x 0.2 m, 10 disks a section, 20 mm gaps bending by ~0.08 rad each; tendons at
//!   4 N and 2 N): tips within 2e-4 m of the condensed solve (measured 1.22e-4 m,
//!   3e-4 of the length: the arc's truncation, `h theta^4` a gap), and falling fast
//!   with the gap: with 20 disks a section (10 mm gaps) the difference falls by more
//!   than 8x (measured 7.7e-6 m, 16x: fourth order);
//! * the stored FTDCR v4 calibration on the 443 held-out val rows, from the servo
//!   readings alone: the val tip RMSE (mean offset removed) within 0.1 mm of the
//!   condensed coupling's (measured 5.4304 against 5.4294 mm), every row converged;
//! * exact derivatives: the sweep's partials against central differences, as
//!   `tests/tendon_derivatives.rs` checks the condensed coupling's (same steps and
//!   tolerances; the pass is explicit here, so nothing settles inside it).

mod common;

use cablesense::calibrate::{
    CalibrationModel, ColumnMap, ReadingsModel, Recording, RigidTransform, TipErrors,
};
use cablesense::nalgebra::Vector3;
use cablesense::{CableCoupling, Scene, Start};
use common::Tol;
use proptest::prelude::*;

const DIR: &str = env!("CARGO_MANIFEST_DIR");

/// Tip (m) of a cold solve of `scene` with `coupling`.
fn tip(scene: &Scene, coupling: CableCoupling) -> Vector3<f64> {
    let mut scene = scene.clone();
    scene.numerics.cable_coupling = coupling;
    let mut ws = cablesense::Workspace::new(
        scene.build_robot().expect("robot"),
        scene.loads.clone(),
        scene.numerics.clone(),
    )
    .expect("workspace");
    let rep = ws.solve(Start::Cold);
    assert!(rep.status.is_converged(), "{coupling:?}: {rep:?}");
    ws.tip_position()
}

#[test]
fn arc_matches_condensed_on_a_tension_driven_robot_and_converges_with_the_gap() {
    let text = std::fs::read_to_string(format!("{DIR}/data/scenes/tdcr_modeling.toml")).unwrap();
    let coarse = Scene::from_toml_str(&text).unwrap();
    // the same robot with twice the disks: 20 a section, 10 mm apart
    let fine_text = text
        .replace("count = 10", "count = 20")
        .replace("first_offset_m = 0.02", "first_offset_m = 0.01")
        .replace("spacing_m = 0.02", "spacing_m = 0.01");
    assert_ne!(fine_text, text);
    let fine = Scene::from_toml_str(&fine_text).unwrap();
    let diff = |s: &Scene| (tip(s, CableCoupling::Arc) - tip(s, CableCoupling::Condensed)).norm();
    let (d10, d20) = (diff(&coarse), diff(&fine));
    println!("arc - condensed tip: 10 disks {d10:.3e} m, 20 disks {d20:.3e} m");
    assert!(d10 < 2e-4, "10 disks: {d10:e} m");
    assert!(
        d20 < d10 / 8.0,
        "20 disks {d20:e} m against 10 disks {d10:e} m"
    );
}

/// Val RMSE (mean offset removed, m) of the stored calibration with `coupling`, and
/// the rows that failed.
fn val_rmse(coupling: CableCoupling) -> (f64, usize) {
    let mut scene =
        Scene::load(format!("{DIR}/data/calibration/ftdcr_v4_calibrated.toml")).unwrap();
    scene.numerics.cable_coupling = coupling;
    let spec = scene.calibration.clone().unwrap();
    let val = Recording::load(
        format!("{DIR}/data/hardware/ftdcr_v4/val.csv"),
        &ColumnMap::from_spec(&spec),
    )
    .unwrap();
    let frame = RigidTransform::from_vector(
        &Vector3::from(spec.capture_to_base.rotation_vector),
        &Vector3::from(spec.capture_to_base.translation_m),
    );
    let offset = Vector3::from(spec.marker_offset_m);
    let mut model = ReadingsModel::new(&scene, &[], &val.input_names, spec.marker_s_m).unwrap();
    let (mut predicted, mut measured, mut failed) = (Vec::new(), Vec::new(), 0);
    for row in &val.rows {
        match model.predict(row) {
            Ok(pose) => {
                predicted.push(pose.position + pose.rotation * offset);
                measured.push(frame.apply(&row.marker_m));
            }
            Err(_) => {
                failed += 1;
                model.restart();
            }
        }
    }
    (
        TipErrors::of(&predicted, &measured).mean_removed.rmse_m,
        failed,
    )
}

#[test]
fn arc_keeps_the_ftdcr_val_error_of_the_stored_calibration() {
    let (arc, arc_failed) = val_rmse(CableCoupling::Arc);
    let (condensed, condensed_failed) = val_rmse(CableCoupling::Condensed);
    println!(
        "val RMSE (mean offset removed): arc {:.4} mm, condensed {:.4} mm",
        arc * 1e3,
        condensed * 1e3
    );
    assert_eq!((arc_failed, condensed_failed), (0, 0));
    assert!(
        (arc - condensed).abs() < 1e-4,
        "arc {arc:e} m against condensed {condensed:e} m"
    );
}

const H: f64 = 1e-4;

proptest! {
    #![proptest_config(ProptestConfig { cases: 3, ..ProptestConfig::default() })]

    /// The arc coupling's sweep partials `[R_x R_T]`, `[dl/dx dl/dT]` at a point off
    /// the equilibrium of an FTDCR v4 val row, against central differences.
    #[test]
    fn arc_sweep_partials_match_central_differences(row in 0usize..443, seed in 0u64..1000) {
        let mut scene = Scene::load(format!("{DIR}/data/scenes/ftdcr_v4.toml")).unwrap();
        scene.numerics.cable_coupling = CableCoupling::Arc;
        let mut tw = scene.tendon_workspace().expect("tendon workspace");
        let mut parser = scene.readings_parser(&tw);
        let text = std::fs::read_to_string(format!("{DIR}/data/hardware/ftdcr_v4/val.csv")).unwrap();
        let all: Vec<Vec<f64>> = text
            .lines()
            .enumerate()
            .filter_map(|(i, l)| parser.line(i + 1, l).ok().flatten())
            .map(|r| r.readings_m)
            .collect();
        let rep = tw.solve_readings(&all[row % all.len()]).expect("valid readings");
        prop_assert!(rep.status.is_converged(), "{rep:?}");
        let theta: Vec<f64> = tw.tensions().to_vec();
        let ws = tw.workspace_mut();
        let (n, p, c) = (ws.unknowns(), theta.len(), ws.robot().cables().len());
        let w = n + p;
        let x: Vec<f64> = ws
            .unknowns_vector()
            .iter()
            .enumerate()
            .map(|(i, x)| x + 1e-3 * (((seed as usize + 7 * i) % 11) as f64 - 5.0) / 5.0)
            .collect();
        ws.set_theta(&theta);
        let (mut js, mut jm) = (vec![0.0; n * w], vec![0.0; c * w]);
        prop_assert!(ws.joint_jacobians(&x, &mut js, &mut jm));
        let (mut rp, mut rm) = (vec![0.0; n], vec![0.0; n]);
        let (mut lp, mut lm) = (vec![0.0; c], vec![0.0; c]);
        let (tol_r, tol_l) = (Tol::both(1e-5, 1e-5), Tol::both(1e-9, 1e-5));
        for col in 0..w {
            for (sign, r, l) in [(1.0, &mut rp, &mut lp), (-1.0, &mut rm, &mut lm)] {
                let (mut xs, mut th) = (x.clone(), theta.clone());
                if col < n {
                    xs[col] += sign * H;
                } else {
                    th[col - n] += sign * H;
                }
                ws.set_theta(&th);
                prop_assert!(ws.adopt_unknowns(&xs, true).is_finite());
                r.copy_from_slice(ws.residual_vector());
                ws.cable_lengths_into(l);
            }
            for k in 0..n {
                let (fd, exact) = ((rp[k] - rm[k]) / (2.0 * H), js[k * w + col]);
                prop_assert!(tol_r.ok(fd, exact), "dr[{k}]/dz[{col}]: exact {exact:e}, fd {fd:e}");
            }
            for j in 0..c {
                let (fd, exact) = ((lp[j] - lm[j]) / (2.0 * H), jm[j * w + col]);
                prop_assert!(tol_l.ok(fd, exact), "dl[{j}]/dz[{col}]: exact {exact:e}, fd {fd:e}");
            }
        }
    }
}
