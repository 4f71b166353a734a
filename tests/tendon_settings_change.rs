//! Changing the solver settings of a tendon workspace's inner shooting workspace
//! between rows (`TendonWorkspace::workspace_mut().set_settings`). Before session 14,
//! `Workspace::set_settings` rebuilt the workspace without its load parameters (the
//! tendons' tensions), and the next solve from readings panicked on a slice length
//! mismatch. What must hold: every row after the change converges, and its tip equals
//! that of a workspace built with the new settings from the start (within 1e-9 m, the
//! scale of the solver tolerance on this 0.19 m robot).

use cablesense::files::readings::ReadingRow;
use cablesense::Scene;

fn rows(scene: &Scene, ws: &cablesense::tendons::TendonWorkspace) -> Vec<ReadingRow> {
    let mut p = scene.readings_parser(ws);
    let text = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").expect("shipped data");
    text.lines()
        .enumerate()
        .filter_map(|(i, l)| p.line(i + 1, l).ok().flatten())
        .collect()
}

#[test]
fn settings_changed_between_rows_keep_the_tensions() {
    let scene = Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
    let mut ws = scene.tendon_workspace().expect("workspace");
    let rows = rows(&scene, &ws);
    let mut changed = ws.workspace().settings().clone();
    changed.tolerance = 1e-8;
    let mut reference = scene.tendon_workspace().expect("workspace");
    reference
        .workspace_mut()
        .set_settings(changed.clone())
        .expect("valid settings");
    let theta_len = ws.workspace().theta().len();
    for (i, row) in rows.iter().take(40).enumerate() {
        if i == 20 {
            ws.workspace_mut()
                .set_settings(changed.clone())
                .expect("valid settings");
            assert_eq!(ws.workspace().theta().len(), theta_len, "tensions dropped");
        }
        let r = ws.solve_readings(&row.readings_m).expect("valid row");
        assert!(r.status.is_converged(), "row {i}: {r:?}");
        let q = reference
            .solve_readings(&row.readings_m)
            .expect("valid row");
        assert!(q.status.is_converged(), "reference row {i}: {q:?}");
        if i >= 20 {
            let d = (ws.tip_position() - reference.tip_position()).norm();
            assert!(d <= 1e-9, "row {i}: tip {d:.3e} m from the reference");
        }
    }
}
