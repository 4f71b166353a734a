//! Inverse kinematics across a tendon's taut/slack boundary (`command::ik`, module
//! docs "Taut/slack boundary"): val row 19 of the calibrated FTDCR v4 round trip,
//! whose solution has a tendon at that boundary. Before the boundary was treated as
//! a kink of the piecewise-smooth map, steps from a linearisation that took the
//! tendon as slack were rejected (trust ratio down to -533), the trust radius
//! collapsed to about 1e-6 m, and the tick ended 14-15 um away, `unreachable` from
//! the warm chain's start and `budget_exhausted` from the same readings set afresh.

use cablesense::command::{IkSettings, IkStatus, IkTarget, IkWorkspace};
use cablesense::Scene;

/// The readings the warm chain over val rows 0..18 ended at before the fix (m,
/// `tendon_workspace().driven()` order): the start of the failing tick.
const ROW19_START_M: [f64; 9] = [
    0.00035599278044505143,
    6.873726966153613e-5,
    0.0003684837199594603,
    0.0007286139292323292,
    0.0003755495160828892,
    0.00041617379280313633,
    2.793332412706259e-5,
    -0.00029216746417860817,
    4.550824732074304e-5,
];

fn scene_and_targets() -> (Scene, Vec<IkTarget>) {
    super::ftdcr_targets(20)
}

/// Row 19 from the readings the warm chain reached it from: reached.
#[test]
fn val_row_19_from_the_chain_start_is_reached() {
    let (scene, targets) = scene_and_targets();
    let mut ik = IkWorkspace::from_scene(&scene, IkSettings::default()).unwrap();
    ik.set_readings(&ROW19_START_M).unwrap();
    let r = ik.solve(&targets[19]).unwrap();
    eprintln!("row 19 from the pinned start: {r:?}");
    assert_eq!(r.status, IkStatus::Reached, "{r:?}");
    assert!(r.distance_m <= 1e-5, "{r:?}");
}

/// The warm chain itself (rows 0..19, each from the previous readings): every
/// tick reached.
#[test]
fn val_rows_0_to_19_warm_chain_all_reached() {
    let (scene, targets) = scene_and_targets();
    let mut ik = IkWorkspace::from_scene(&scene, IkSettings::default()).unwrap();
    for (k, t) in targets.iter().enumerate() {
        let r = ik.solve(t).unwrap();
        assert_eq!(r.status, IkStatus::Reached, "row {k}: {r:?}");
    }
}
