//! Continuous tendon routing (Rucker & Webster 2011, `src/statics/continuous.rs`).

use cablesense::{Scene, Start, Workspace};

fn till() -> Scene {
    Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/scenes/till_tendon_robot.toml"
    ))
    .unwrap()
}

#[test]
fn till_tip_matches_reference() {
    let sc = till();
    let robot = sc.build_robot().unwrap();
    let mut ws = Workspace::new(robot, sc.loads.clone(), sc.numerics.clone()).unwrap();
    let rep = ws.solve(Start::Cold);
    let tip = ws.tip_position();
    eprintln!("{rep:?} tip {tip:?}");
    assert!(rep.status.is_converged());
}
