//! The rest term of the inverse solve (`command::ik` module docs, "Rest term";
//! `IkSettings::rest_weight`) acts only within the redundancy: on a robot without
//! one it leaves the solve as it was. (Its effect on long warm chains, measured over
//! thousands of ticks, is in the module docs, not a test.)

use cablesense::command::{IkSettings, IkStatus, IkTarget, IkWorkspace};
use cablesense::Scene;

/// The daru robot (three cables, a 3-D target: no redundancy): the projected rest
/// term has no null space to act in (its projector is only the Gram matrix's
/// `1e-10` regularisation), so IK reaches the target with and without it, at the
/// same readings to well within what the tip tolerance allows (10 um of tip; the
/// tip moves 5-7 mm per mm of reading in bending, so about 2 um of reading):
/// within 1 um (1.3e-7 m measured).
#[test]
fn rest_term_leaves_a_robot_without_redundancy_alone() {
    let scene = Scene::load(super::DARU).unwrap();
    let mut tw = scene.tendon_workspace().unwrap();
    // the property case an unprojected rest term of 1e-4 left 10.2 um away
    let q = [
        0.00127105906955201,
        0.008171892331173315,
        0.003803763151156461,
    ];
    assert!(tw.solve_readings(&q).unwrap().status.is_converged());
    let target = IkTarget::position(tw.tip_position());
    let start = [0.0055, 0.0025, 0.0024];
    let mut ends = Vec::new();
    for w in [0.0, IkSettings::default().rest_weight] {
        let settings = IkSettings {
            rest_weight: w,
            ..IkSettings::default()
        };
        let mut ik = IkWorkspace::from_scene(&scene, settings).unwrap();
        ik.set_readings(&start).unwrap();
        let r = ik.solve(&target).unwrap();
        assert_eq!(r.status, IkStatus::Reached, "rest weight {w}: {r:?}");
        ends.push(ik.readings().to_vec());
    }
    let d = ends[0]
        .iter()
        .zip(&ends[1])
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(d <= 1e-6, "readings differ by {d:e} m");
}
