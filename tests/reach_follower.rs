//! Follower (body-frame) tip forces up to `P L^2/EI = 1000` from a cold start with
//! default settings: the multiple-shooting continuation's step control (second-order
//! predictor, step from the corrector-to-predictor ratio, `max_continuation_steps`
//! bounding the rejected steps) carries the curling rod from rest to full load.
//!
//! Rod: the thesis's Nitinol rod (0.39 m, 1.56 mm), Cosserat, no gravity, a force
//! across the rod in the tip frame. Its equilibrium balance is exact: `n(0) = R(L) F`
//! and `m(0) = (r(L) - r(0)) x R(L) F` (thesis eqs. 2.6 and 2.11 integrated over the
//! rod with the free-end conditions of table 2.1).

use crate::common;

use cablesense::nalgebra::Vector3;
use cablesense::{
    Frame, Loads, PointLoad, SolveReport, SolveStatus, SolverSettings, Start, Workspace,
};
use common::*;

const L: f64 = 0.39;
const D: f64 = 1.56e-3;

/// Body-frame tip force of `P L^2/EI = a` along the local x axis.
fn follower(a: f64) -> (Loads, Vector3<f64>) {
    let fb = Vector3::new(1.0, 0.0, 0.0) * (a * props(D).ei / (L * L));
    let ld = Loads {
        point: vec![PointLoad {
            section: 0,
            force_n: fb.into(),
            frame: Frame::Body,
            ..Default::default()
        }],
        ..Loads::none()
    };
    (ld, fb)
}

fn cold(a: f64) -> (Workspace, SolveReport) {
    let mut ws = Workspace::new(plain_rod(L, D), follower(a).0, SolverSettings::default()).unwrap();
    let rep = ws.solve(Start::Cold);
    (ws, rep)
}

/// Cold default solves at 300, 500 and 1000 converge (the continuation takes 36, 52
/// and 78 steps there, more than the 32 that bounded it before). Balance tolerances:
/// force 1e-9 of `|F|`, moment 1e-9 of `|F| L` (the scaled residual tolerance 1e-10
/// summed over at most 40 intervals' continuity conditions).
#[test]
fn follower_cold_to_one_thousand_balances() {
    for a in [300.0, 500.0, 1000.0] {
        let (mut ws, rep) = cold(a);
        eprintln!("follower {a}: {rep:?}");
        assert_eq!(rep.status, SolveStatus::Converged, "{a}: {rep:?}");
        assert!(rep.continuation_steps > 32, "{a}: {rep:?}");
        let sol = ws.solution();
        let tip = sol.tip();
        let fw = tip.rotation * follower(a).1;
        let r0 = sol.samples[0].r;
        let fe = (sol.base_force - fw).norm() / fw.norm();
        let me = (sol.base_moment - (tip.position - r0).cross(&fw)).norm() / (fw.norm() * L);
        eprintln!("  force {fe:e} moment {me:e}");
        assert!(fe < 1e-9, "{a}: force balance {fe:e}");
        assert!(me < 1e-9, "{a}: moment balance {me:e}");
    }
}

/// The cold solve at 1000 is the end of the branch from rest: it equals a warm
/// continuation (plain Newton steps of 1 % of the load, each checked by the sign of
/// `det J`) from the cold solve at 500, within 1e-8 L (both converge to the scaled
/// tolerance 1e-10 on the same discretisation: design intensity 1024).
#[test]
fn follower_cold_equals_warm_continuation() {
    let (mut warm, rep) = cold(500.0);
    assert!(rep.status.is_converged(), "{rep:?}");
    let mut a: f64 = 500.0;
    while a < 1000.0 {
        a = (a * 1.01).min(1000.0);
        warm.set_loads(&follower(a).0).unwrap();
        let rep = warm.solve(Start::Warm);
        assert!(rep.status.is_converged(), "warm at {a}: {rep:?}");
        assert_eq!(rep.continuation_steps, 0, "warm at {a} went cold: {rep:?}");
    }
    let (cold, rep) = cold(1000.0);
    assert!(rep.status.is_converged(), "{rep:?}");
    let d = (warm.tip_position() - cold.tip_position()).norm() / L;
    eprintln!("cold {rep:?}; tips {d:e} L apart");
    assert!(
        d < 1e-8,
        "warm continuation ends {d:e} L from the cold solve"
    );
    assert_eq!(warm.report().unknowns, rep.unknowns, "same discretisation");
}
