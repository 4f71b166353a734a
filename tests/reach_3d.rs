//! Large 3D loads (`P L^2/EI` up to 1000) from a cold start with default settings:
//! global force and moment balance, `R^T R = I`, stability (Jacobi's test on the
//! returned equilibrium), and agreement with the end point of a fine warm load
//! continuation from rest.
//!
//! Rod: the thesis's Nitinol rod (0.39 m, 1.56 mm), Cosserat, no gravity (so the
//! balance is exact: `n(0) = F`, `m(0) = (r(L) - r(0)) x F + tau`, thesis eqs. 2.6 and
//! 2.11 integrated over the rod with the free-end conditions of table 2.1).

use crate::common;

use cablesense::nalgebra::{Matrix3, Vector3};
use cablesense::{Frame, Loads, PointLoad, SolveStatus, SolverSettings, Start, Workspace};
use common::*;

const L: f64 = 0.39;
const D: f64 = 1.56e-3;

/// A world tip force of `P L^2/EI = a` along a skew direction plus a tip torque of
/// `tau L/EI = 2` about another axis.
fn loads(a: f64) -> (Loads, Vector3<f64>, Vector3<f64>) {
    let ei = props(D).ei;
    let f = Vector3::new(1.0, -2.0, 0.5).normalize() * (a * ei / (L * L));
    let tau = Vector3::new(0.3, 0.5, -1.0).normalize() * (2.0 * ei / L) * (a / 1000.0).min(1.0);
    (tip_only(f.into(), tau.into()), f, tau)
}

/// Cold solves at 100, 300 and 1000. Tolerances: force balance 1e-9 of `|F|` and
/// moment balance 1e-9 of `|F| L` (the scaled residual tolerance 1e-10 summed over the
/// solver's continuity conditions, at most 40 intervals); `R^T R = I` to 1e-12
/// (RK4 steps re-orthonormalise by a Newton-Schulz step, node rotations are exact
/// exponentials).
#[test]
fn large_3d_loads_balance_and_are_stable() {
    let robot = plain_rod(L, D);
    for a in [100.0, 300.0, 1000.0] {
        let (ld, f, tau) = loads(a);
        let mut ws = Workspace::new(robot.clone(), ld, SolverSettings::default()).unwrap();
        let rep = ws.solve(Start::Cold);
        assert_eq!(rep.status, SolveStatus::Converged, "{a}: {rep:?}");
        assert!(ws.conjugate_point().is_none(), "{a}: conjugate point");
        let sol = ws.solution();
        let tip = sol.tip().position;
        let fe = (sol.base_force - f).norm() / f.norm();
        let me = (sol.base_moment - (tip.cross(&f) + tau)).norm() / (f.norm() * L);
        eprintln!("{a}: {rep:?} force {fe:e} moment {me:e}");
        assert!(fe < 1e-9, "{a}: force balance {fe:e}");
        assert!(me < 1e-9, "{a}: moment balance {me:e}");
        let worst = sol
            .samples
            .iter()
            .map(|s| {
                (s.rotation.transpose() * s.rotation - Matrix3::identity())
                    .abs()
                    .max()
            })
            .fold(0.0, f64::max);
        assert!(worst < 1e-12, "{a}: R^T R - I up to {worst:e}");
        // the rod hangs along the force: the tip's tangent within 0.1 rad of F
        let t = sol.tip().rotation * Vector3::z();
        assert!(t.angle(&f) < 0.1, "{a}: tip tangent {t:?}");
    }
}

/// The cold solve at 1000 equals the end of a warm continuation from rest in steps of
/// 3 % of the load (at least 0.5), within 1e-8 L (both converge to the scaled
/// tolerance 1e-10 on the same discretisation at that load).
#[test]
fn cold_solve_equals_a_fine_warm_continuation_from_rest() {
    let robot = plain_rod(L, D);
    let settings = SolverSettings::default();
    let mut warm = Workspace::new(robot.clone(), loads(0.0).0, settings.clone()).unwrap();
    assert!(warm.solve(Start::Cold).status.is_converged());
    let mut a: f64 = 0.0;
    let mut solves = 0;
    while a < 1000.0 {
        a = (a + (0.03 * a).max(0.5)).min(1000.0);
        warm.set_loads(&loads(a).0).unwrap();
        let rep = warm.solve(Start::Warm);
        solves += 1;
        assert!(rep.status.is_converged(), "warm at {a}: {rep:?}");
    }
    let mut cold = Workspace::new(robot, loads(1000.0).0, settings).unwrap();
    let rep = cold.solve(Start::Cold);
    assert!(rep.status.is_converged(), "{rep:?}");
    let d = (warm.tip_position() - cold.tip_position()).norm() / L;
    eprintln!("{solves} warm solves; cold {rep:?}; tips {d:e} L apart");
    assert!(
        d < 1e-8,
        "warm continuation ends {d:e} L from the cold solve"
    );
    assert_eq!(warm.report().unknowns, rep.unknowns, "same discretisation");
}

/// A body-frame (follower) tip force across the rod curls it up (at 200 the tip angle
/// is many turns): the continuation from rest takes many steps (seen: 19 at 100, 27 at
/// 200; `max_continuation_steps` bounds the rejected ones, so the default settings
/// serve, also with 64). Converged from a cold start with the force balance in the tip
/// frame (`n(0) = R(L) F_body`) to 1e-9 of `|F|`; to 1000 in `tests/reach_follower.rs`.
#[test]
fn follower_tip_force_to_two_hundred() {
    for (a, steps) in [(100.0, 32), (200.0, 32), (200.0, 64)] {
        follower(a, steps);
    }
}

fn follower(a: f64, steps: usize) {
    let robot = plain_rod(L, D);
    let ei = props(D).ei;
    let fb = Vector3::new(1.0, 0.0, 0.0) * (a * ei / (L * L));
    let ld = Loads {
        point: vec![PointLoad {
            section: 0,
            force_n: fb.into(),
            frame: Frame::Body,
            ..Default::default()
        }],
        ..Loads::none()
    };
    let settings = SolverSettings {
        max_continuation_steps: steps,
        ..SolverSettings::default()
    };
    let mut ws = Workspace::new(robot, ld, settings).unwrap();
    let rep = ws.solve(Start::Cold);
    eprintln!("follower {a}: {rep:?}");
    assert_eq!(rep.status, SolveStatus::Converged, "{rep:?}");
    let sol = ws.solution();
    let fw = sol.tip().rotation * fb;
    let fe = (sol.base_force - fw).norm() / fb.norm();
    assert!(fe < 1e-9, "force balance {fe:e}");
}
