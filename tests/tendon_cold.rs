//! A cold solve from readings (issue 9: "cold at most 2 ms") starts the joint path
//! from the reference equilibrium (zero readings, the pretensions) and continues in
//! the readings, handing back to the nested cold solve only when that fails. What
//! must hold whatever path a row takes:
//! - a cold solve reaches the equilibrium the warm chain reaches (every 20th row of
//!   the FTDCR v4 val recording: tip within 1e-9 m, same taut flags);
//! - it does not depend on earlier rows: the same row solved cold after two
//!   different rows gives the same tip within 1e-12 m (the settled holes' starting
//!   guesses differ, so round-off may);
//! - the path from the reference is cheaper than the nested method alone
//!   (`joint_newton = false`) on the same rows: fewer right-hand-side evaluations
//!   (`f64` plus dual, a count, not a time).

use cablesense::files::readings::ReadingRow;
use cablesense::tendons::TendonSettings;
use cablesense::{Scene, Start};

fn rows(scene: &Scene, ws: &cablesense::tendons::TendonWorkspace) -> Vec<ReadingRow> {
    let mut p = scene.readings_parser(ws);
    let text = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").expect("shipped data");
    text.lines()
        .enumerate()
        .filter_map(|(i, l)| p.line(i + 1, l).ok().flatten())
        .collect()
}

#[test]
fn cold_from_the_reference_matches_the_warm_chain_and_forgets_history() {
    let scene = Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
    let mut warm = scene.tendon_workspace().expect("workspace");
    let mut cold = scene.tendon_workspace().expect("workspace");
    let mut nested = scene.tendon_workspace().expect("workspace");
    nested.set_tendon_settings(TendonSettings {
        joint_newton: false,
        ..TendonSettings::default()
    });
    let rows = rows(&scene, &warm);
    assert!(rows.len() > 400, "{} rows", rows.len());
    let (mut work_cold, mut work_nested) = (0, 0);
    let work = |ws: &cablesense::tendons::TendonWorkspace| {
        let c = ws.workspace().rhs_counts();
        c.f64_rhs + c.dual_rhs
    };
    for (i, row) in rows.iter().enumerate() {
        let w = warm.solve_readings(&row.readings_m).expect("valid row");
        assert!(w.status.is_converged(), "warm row {i}: {w:?}");
        if i % 20 != 7 {
            continue;
        }
        let w0 = work(&cold);
        let c = cold
            .solve_readings_from(&row.readings_m, Start::Cold)
            .expect("valid row");
        let w_row = work(&cold) - w0;
        assert!(c.status.is_converged(), "cold row {i}: {c:?}");
        let d = (cold.tip_position() - warm.tip_position()).norm();
        assert!(
            d <= 1e-9,
            "row {i}: cold tip {d:.3e} m from the warm chain's"
        );
        assert_eq!(cold.taut(), warm.taut(), "row {i}: taut flags");
        // the same row after another one (the last row of the file) first
        let tip = cold.tip_position();
        cold.solve_readings_from(&rows[rows.len() - 1].readings_m, Start::Cold)
            .expect("valid row");
        let again = cold
            .solve_readings_from(&row.readings_m, Start::Cold)
            .expect("valid row");
        assert!(again.status.is_converged());
        let h = (cold.tip_position() - tip).norm();
        assert!(
            h <= 1e-12,
            "row {i}: cold solve moved {h:.3e} m with history"
        );
        if i % 60 == 7 {
            let n0 = work(&nested);
            let n = nested
                .solve_readings_from(&row.readings_m, Start::Cold)
                .expect("valid row");
            assert!(n.status.is_converged(), "nested cold row {i}: {n:?}");
            let dn = (nested.tip_position() - warm.tip_position()).norm();
            assert!(dn <= 1e-9, "row {i}: nested cold tip {dn:.3e} m off");
            work_nested += work(&nested) - n0;
            work_cold += w_row;
        }
    }
    eprintln!("cold solves on every 60th row: {work_cold} RHS, nested method alone {work_nested}");
    assert!(
        work_cold < work_nested,
        "cold {work_cold} vs nested {work_nested} RHS"
    );
}
