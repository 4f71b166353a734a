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

use crate::common;

use cablesense::calibrate::Recording;
use cablesense::nalgebra::Vector3;
use cablesense::validation;
use cablesense::{CableCoupling, Scene, Start};
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

/// Val RMSE (mean offset removed, m) of the stored calibration with `coupling`
/// (`validate`'s hardware benchmark on val.csv alone), and the rows that failed.
fn val_rmse(coupling: CableCoupling) -> (f64, usize) {
    let mut scene = Scene::parse_validated(
        validation::CALIBRATED_SCENE,
        std::path::Path::new("ftdcr_v4_calibrated.toml"),
        false,
    )
    .unwrap();
    scene.numerics.cable_coupling = coupling;
    let stored = validation::parse_summary("summary", validation::SUMMARY_JSON).unwrap();
    let map = validation::column_map(&scene).unwrap();
    let val = Recording::parse_str("val.csv", validation::VAL_CSV, &map).unwrap();
    let settings = validation::HardwareSettings {
        train_stride: 0,
        track: false,
        ..Default::default()
    };
    let b = validation::hardware_benchmark(&scene, &stored, None, &val, &settings).unwrap();
    (b.val.mean_removed.rmse_m, b.failed_rows.len())
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

/// The readings ladder (`cablesense pareto`, `solve --model auto`) offers the arc
/// coupling on a robot with disks: one `/arc` twin of each fixed-step rod rung, none
/// of the adaptive one. Solved as readings models over the first 40 FTDCR v4 val
/// rows (warm, in order), a twin's tips stay within 1e-4 m of its condensed rung's
/// (the largest difference over all 443 rows with the scene's settings was 84 um;
/// measured here 13 um).
#[test]
fn the_readings_ladder_offers_arc_twins_of_the_fixed_step_rod_rungs() {
    use cablesense::ladder::{readings_ladder, Rung};
    use cablesense::{Integrator, Start};
    let scene = Scene::load(format!("{DIR}/data/scenes/ftdcr_v4.toml")).unwrap();
    let robot = scene.build_robot().unwrap();
    let ladder = readings_ladder(&robot);
    let rk4 = |r: &Rung| matches!(r.solver_settings(), Some(s) if matches!(s.integrator, Integrator::Rk4 { .. }));
    let arcs: Vec<&Rung> = ladder
        .iter()
        .filter(|r| r.label().ends_with("/arc"))
        .collect();
    let fixed = ladder
        .iter()
        .filter(|r| rk4(r) && !r.label().ends_with("/arc"));
    assert_eq!(arcs.len(), fixed.count());
    assert!(arcs
        .iter()
        .all(|r| rk4(r) && r.solver_settings().unwrap().cable_coupling == CableCoupling::Arc));
    // a twin against its condensed rung
    let arc = arcs
        .iter()
        .find(|r| r.label() == "cosserat/point/rk4-8/arc")
        .expect("the twin of cosserat/point/rk4-8");
    let cond = ladder
        .iter()
        .find(|r| r.label() == "cosserat/point/rk4-8")
        .unwrap();
    let mut a = arc.build_readings(&robot, &scene.loads).unwrap();
    let mut c = cond.build_readings(&robot, &scene.loads).unwrap();
    let tw = scene.tendon_workspace().unwrap();
    let mut parser = scene.readings_parser(&tw);
    let text = std::fs::read_to_string(format!("{DIR}/data/hardware/ftdcr_v4/val.csv")).unwrap();
    let rows = text
        .lines()
        .enumerate()
        .filter_map(|(i, l)| parser.line(i + 1, l).ok().flatten())
        .take(40);
    let mut worst = 0.0f64;
    for row in rows {
        for m in [&mut a, &mut c] {
            let rep = m.solve_readings(&row.readings_m, Start::Warm).unwrap();
            assert!(rep.status.is_converged(), "{rep:?}");
        }
        worst = worst.max((a.tip_position() - c.tip_position()).norm());
    }
    println!("arc twin against condensed, 40 val rows: {worst:.3e} m at most");
    assert!(worst < 1e-4, "{worst:e} m");
}

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
        let check = common::joint_partials_against_central_differences(&mut tw, seed);
        prop_assert!(check.is_ok(), "{}", check.unwrap_err());
    }
}
