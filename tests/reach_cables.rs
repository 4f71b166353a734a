//! Tensioned cables with a large world-fixed tip force (a tendon robot holding a heavy
//! payload) up to `P L^2/EI = 1000` from a cold start with default settings: multiple
//! shooting with a node at every cable disk (`src/statics/multiple/cables.rs`).
//!
//! Robot: `five_guide_robot` (the thesis's Nitinol rod, 0.39 m, 1.56 mm, five disks
//! with holes at 10 mm, three cables ending on the last disk), Cosserat, no gravity.
//! Cable 0 (and in one case cable 1) at tension `T r L/EI` = 0.5..2 (well inside the
//! tension-only branch, which folds near 7.9).
//!
//! Global balance (thesis eqs. 2.6 and 2.11 over the rod with the free-end conditions
//! of table 2.1; the jump conditions of eq. 3.5 at the disks): a cable's chords pull
//! neighbouring disks with equal and opposite forces along one line, so its net
//! wrench on the rod is that of its first chord, `T u` with `u` from the first hole
//! `p_0` towards the base-plate hole. Hence `n(0) = F + sum T u` and
//! `m(0) = (r(L) - r(0)) x F + sum (p_0 - r(0)) x T u`.

use crate::common;

use cablesense::nalgebra::Vector3;
use cablesense::{Loads, PointLoad, Robot, SolveStatus, SolverSettings, Start, Workspace};
use common::*;

const L: f64 = 0.39;
const D: f64 = 1.56e-3;
const R: f64 = 0.01;

/// Tip force `P L^2/EI = a` along `dir` and tensions `T r L/EI = t[j]`.
fn loads(a: f64, dir: Vector3<f64>, t: [f64; 3]) -> (Loads, Vector3<f64>) {
    let ei = props(D).ei;
    let f = dir.normalize() * (a * ei / (L * L));
    let ld = Loads {
        point: vec![PointLoad {
            section: 0,
            force_n: f.into(),
            ..Default::default()
        }],
        tensions_n: t.iter().map(|x| x * ei / (R * L)).collect(),
        ..Loads::none()
    };
    (ld, f)
}

/// Force and moment balance errors, relative to `|F| + sum T` and that times `L`.
fn balance(ws: &mut Workspace, robot: &Robot, ld: &Loads, f: &Vector3<f64>) -> (f64, f64) {
    let sol = ws.solution();
    let r0 = sol.samples[0].r;
    let tip = sol.tip().position;
    let (mut fc, mut mc) = (Vector3::zeros(), Vector3::zeros());
    let mut scale = f.norm();
    for (j, c) in robot.cables().iter().enumerate() {
        let t = ld.tension(j);
        if t == 0.0 {
            continue;
        }
        let g = &sol.guides[c.route[0]].pose;
        let p0 = g.position + g.rotation * c.hole_local[0];
        let base_hole = robot.base_position() + robot.base_rotation() * c.base_hole;
        let fj = (base_hole - p0).normalize() * t;
        fc += fj;
        mc += (p0 - r0).cross(&fj);
        scale += t;
    }
    let fe = (sol.base_force - (f + fc)).norm() / scale;
    let me = (sol.base_moment - ((tip - r0).cross(f) + mc)).norm() / (scale * L);
    (fe, me)
}

/// Cold default solves from 50 to 1000 in three directions and two tension cases
/// converge with the balance above to 1e-9 (relative; the scaled residual tolerance
/// 1e-10 summed over at most 40 intervals' continuity conditions).
#[test]
fn tension_and_payload_to_one_thousand_balance() {
    let robot = five_guide_robot();
    let dirs = [
        Vector3::new(0.0, -1.0, 0.0),
        Vector3::new(-1.0, 0.0, 0.0),
        Vector3::new(1.0, -2.0, 0.5),
    ];
    for t in [[0.5, 0.0, 0.0], [2.0, 1.0, 0.0]] {
        for dir in dirs {
            for a in [50.0, 200.0, 1000.0] {
                let (ld, f) = loads(a, dir, t);
                let mut ws =
                    Workspace::new(robot.clone(), ld.clone(), SolverSettings::default()).unwrap();
                let rep = ws.solve(Start::Cold);
                assert_eq!(
                    rep.status,
                    SolveStatus::Converged,
                    "{t:?} {dir:?} {a}: {rep:?}"
                );
                let (fe, me) = balance(&mut ws, &robot, &ld, &f);
                eprintln!("{t:?} {dir:?} {a}: {rep:?} force {fe:e} moment {me:e}");
                assert!(fe < 1e-9, "{t:?} {dir:?} {a}: force balance {fe:e}");
                assert!(me < 1e-9, "{t:?} {dir:?} {a}: moment balance {me:e}");
            }
        }
    }
}

/// The cold solve at 1000 equals the end of a warm continuation in steps of 3 % of the
/// load from the cold solve at 21 (itself equal to single shooting, next test), within
/// 1e-8 L (both converge to the scaled tolerance 1e-10 on the same discretisation).
#[test]
fn cold_solve_equals_a_fine_warm_continuation() {
    let robot = five_guide_robot();
    let dir = Vector3::new(1.0, -2.0, 0.5);
    let t = [2.0, 1.0, 0.0];
    let settings = SolverSettings::default();
    let mut warm = Workspace::new(robot.clone(), loads(21.0, dir, t).0, settings.clone()).unwrap();
    assert!(warm.solve(Start::Cold).status.is_converged());
    let mut a: f64 = 21.0;
    let mut solves = 0;
    while a < 1000.0 {
        a = (a * 1.03).min(1000.0);
        warm.set_loads(&loads(a, dir, t).0).unwrap();
        let rep = warm.solve(Start::Warm);
        solves += 1;
        assert!(rep.status.is_converged(), "warm at {a}: {rep:?}");
        assert_eq!(rep.continuation_steps, 0, "warm at {a} went cold: {rep:?}");
    }
    let mut cold = Workspace::new(robot, loads(1000.0, dir, t).0, settings).unwrap();
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

/// At a moderate load (intensity 21: just above the switch to multiple shooting) the
/// cold multiple-shooting solve equals single shooting's, warm in steps of 0.2 from
/// a cold solve at 19.4 (below the switch), within 1e-10 m (tip and every disk). Both integrate adaptively at 1e-12 (the
/// two cut the rod at different points, so their RK4 grids differ: with the default
/// RK4 24 per section they are 1.2e-8 m apart, the integration error).
#[test]
fn moderate_load_equals_single_shooting() {
    let robot = five_guide_robot();
    let dir = Vector3::new(0.0, -1.0, 0.0);
    let t = [0.5, 0.0, 0.0];
    let settings = adaptive(1e-12);
    let mut single =
        Workspace::new(robot.clone(), loads(19.4, dir, t).0, settings.clone()).unwrap();
    assert!(single.solve(Start::Cold).status.is_converged());
    let mut rs = *single.report();
    for a in [19.6, 19.8, 20.0, 20.2, 20.4, 20.5] {
        single.set_loads(&loads(a, dir, t).0).unwrap();
        rs = single.solve(Start::Warm);
        assert!(rs.status.is_converged(), "{a}: {rs:?}");
        assert_eq!(rs.continuation_steps, 0, "{a}: {rs:?}");
    }
    let mut multi = Workspace::new(robot, loads(20.5, dir, t).0, settings).unwrap();
    let rm = multi.solve(Start::Cold);
    assert!(rm.status.is_converged(), "{rm:?}");
    assert_ne!(rs.unknowns, rm.unknowns, "single vs multiple shooting");
    let (a, b) = (single.solution(), multi.solution());
    let d = (a.tip().position - b.tip().position).norm();
    eprintln!("single {rs:?}\nmulti {rm:?}\ntips {d:e} m apart");
    assert!(d < 1e-10, "tips {d:e} m apart");
    for (ga, gb) in a.guides.iter().zip(&b.guides) {
        let d = (ga.pose.position - gb.pose.position).norm();
        assert!(d < 1e-10, "disk {} {d:e} m apart", ga.index);
    }
}
