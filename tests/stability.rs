//! The documented stability region (README "Where methods fail", measured by
//! `cablesense stability` on data/scenes/track_demo.toml): inside it every method
//! converges to the physical branch; outside it a method returns a failure status
//! (or, where the README says so, a finite shape), never a panic, a hang or a NaN.
//!
//! Loads are non-dimensional: a tip force `P L^2 / EI` along a direction, or a cable
//! tension `T r L / EI` (the bending angle a CC arc would have; the rod doubles back
//! past ~pi). The physical branch is found by tracking the load up from zero in small
//! warm-started steps (0.1, tensions 0.02) with the same model.

use cablesense::estimate::{EstimateStatus, Estimator, Method};
use cablesense::ladder::{CcSettings, PccSettings, Rung};
use cablesense::nalgebra::Vector3;
use cablesense::{
    GuideMass, Integrator, Loads, PointLoad, Robot, RodModel, Scene, SolverSettings, Start,
};
use std::time::Instant;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Dir {
    Down,
    Up,
    Lateral,
    Axial,
    Tension,
}

fn scene() -> Scene {
    Scene::load("data/scenes/track_demo.toml").expect("shipped scene")
}

fn loads_at(robot: &Robot, base: &Loads, dir: Dir, magnitude: f64) -> Loads {
    let l = robot.length();
    let ei = robot.sections()[0].stiffness.bend_twist.x;
    let mut out = base.clone();
    if dir == Dir::Tension {
        let r = robot.cables()[0].base_hole.norm();
        out.tensions_n = vec![magnitude * ei / (r * l)];
        return out;
    }
    let t = robot.base_rotation() * Vector3::z();
    let g = Vector3::from(base.gravity_m_s2);
    let down = (g - t * t.dot(&g)).normalize();
    let d = match dir {
        Dir::Down => down,
        Dir::Up => -down,
        Dir::Lateral => t.cross(&down).normalize(),
        _ => -t,
    };
    out.point.push(PointLoad {
        section: 0,
        force_n: (d * (magnitude * ei / (l * l))).into(),
        ..Default::default()
    });
    out
}

fn rod(model: RodModel, steps: usize, continuation: bool) -> Rung {
    Rung::Rod(SolverSettings {
        rod_model: model,
        guide_mass: GuideMass::Point,
        integrator: Integrator::Rk4 {
            steps_per_section: steps,
        },
        continuation,
        ..SolverSettings::default()
    })
}

/// Tips (and cable lengths) on the physical branch at each magnitude of `grid`.
fn track(
    rung: &Rung,
    robot: &Robot,
    base: &Loads,
    dir: Dir,
    grid: &[f64],
) -> Vec<(Vector3<f64>, Vec<f64>)> {
    let h = if dir == Dir::Tension { 0.02 } else { 0.1 };
    let mut m = rung.build(robot).unwrap();
    assert!(m
        .solve(&loads_at(robot, base, dir, 0.0), Start::Cold)
        .unwrap()
        .status
        .is_converged());
    let mut a: f64 = 0.0;
    let mut out = Vec::new();
    for &g in grid {
        while a < g - 1e-12 {
            a = (a + h).min(g);
            let rep = m
                .solve(&loads_at(robot, base, dir, a), Start::Warm)
                .unwrap();
            assert!(
                rep.status.is_converged(),
                "tracking {dir:?} at {a}: {rep:?}"
            );
        }
        let mut l = vec![0.0; robot.cables().len()];
        m.cable_lengths_into(&mut l);
        out.push((m.tip_position(), l));
    }
    out
}

#[test]
fn rod_shooting_converges_to_the_physical_branch_inside_the_documented_region() {
    let sc = scene();
    let robot = sc.build_robot().unwrap();
    // default cold solve (4 Newton iterations, then load continuation)
    let region: [(Dir, &[f64]); 5] = [
        (Dir::Down, &[1.0, 3.0, 5.0, 10.0, 20.0]),
        (Dir::Up, &[1.0, 3.0, 5.0, 10.0, 20.0]),
        (Dir::Lateral, &[1.0, 5.0, 10.0, 15.0, 30.0]),
        (Dir::Axial, &[1.0, 2.0, 3.0]),
        (Dir::Tension, &[1.0, 2.0, 3.0, 4.0, 6.0]),
    ];
    for model in [RodModel::Kirchhoff, RodModel::Cosserat] {
        let rung = rod(model, 32, true);
        let tracker = rod(model, 32, false);
        for (dir, grid) in region {
            let truth = track(&tracker, &robot, &sc.loads, dir, grid);
            let mut m = rung.build(&robot).unwrap();
            for (g, (tip, _)) in grid.iter().zip(&truth) {
                let rep = m
                    .solve(&loads_at(&robot, &sc.loads, dir, *g), Start::Cold)
                    .unwrap();
                assert!(rep.status.is_converged(), "{model:?} {dir:?} {g}: {rep:?}");
                let d = (m.tip_position() - tip).norm();
                assert!(d < 1e-6, "{model:?} {dir:?} {g}: off the branch by {d:e} m");
            }
        }
        // warm from the previous grid point, no continuation: up to 10 in steps <= 2.5
        let grid = [0.5, 1.0, 2.0, 3.0, 5.0, 7.5, 10.0];
        let truth = track(&tracker, &robot, &sc.loads, Dir::Down, &grid);
        let mut m = rod(model, 32, false).build(&robot).unwrap();
        m.solve(&sc.loads, Start::Cold).unwrap();
        for (g, (tip, _)) in grid.iter().zip(&truth) {
            let rep = m
                .solve(&loads_at(&robot, &sc.loads, Dir::Down, *g), Start::Warm)
                .unwrap();
            assert!(rep.status.is_converged(), "warm {model:?} {g}: {rep:?}");
            assert!((m.tip_position() - tip).norm() < 1e-6, "warm {g}");
        }
    }
}

#[test]
fn pcc_with_its_continuation_stays_on_the_branch_to_fifty() {
    let sc = scene();
    let robot = sc.build_robot().unwrap();
    let pcc = Rung::PiecewiseConstantCurvature(PccSettings {
        pieces_per_section: 8,
        guide_mass: GuideMass::Point,
        ..PccSettings::default()
    });
    let l = robot.length();
    for dir in [Dir::Down, Dir::Up, Dir::Lateral] {
        let grid = [5.0, 20.0, 50.0];
        let truth = track(
            &rod(RodModel::Kirchhoff, 32, false),
            &robot,
            &sc.loads,
            dir,
            &grid,
        );
        let mut m = pcc.build(&robot).unwrap();
        for (g, (tip, _)) in grid.iter().zip(&truth) {
            let rep = m
                .solve(&loads_at(&robot, &sc.loads, dir, *g), Start::Cold)
                .unwrap();
            assert!(rep.status.is_converged(), "PCC {dir:?} {g}: {rep:?}");
            // its discretisation error is O(h^2), a few mm at 8 pieces: far below a
            // branch jump (tenths of L)
            let d = (m.tip_position() - tip).norm();
            assert!(d < 0.02 * l, "PCC {dir:?} {g}: {d:e} m from the branch");
        }
    }
}

/// Estimator with unknown tip force y, z (the scene's [estimate]) and `method`.
fn estimator(sc: &Scene, robot: &Robot, method: Method) -> Estimator {
    let mut spec = sc.estimate.clone().expect("track demo has [estimate]");
    spec.method = method;
    spec.max_iterations = 50;
    spec.time_budget_s = Some(2.0);
    Estimator::new(robot.clone(), sc.loads.clone(), sc.numerics.clone(), spec).unwrap()
}

/// Measured changes at each grid point (the scene's own model, tracked) and the true
/// force components (y, z).
fn measurements(sc: &Scene, robot: &Robot, dir: Dir, grid: &[f64]) -> Vec<(Vec<f64>, [f64; 2])> {
    let model = Rung::Rod(SolverSettings {
        continuation: false,
        ..sc.numerics.clone()
    });
    let zero = track(&model, robot, &sc.loads, dir, &[0.0]);
    let tracked = track(&model, robot, &sc.loads, dir, grid);
    grid.iter()
        .zip(tracked)
        .map(|(g, (_, l))| {
            let f = loads_at(robot, &sc.loads, dir, *g)
                .point
                .last()
                .unwrap()
                .force_n;
            let ch = l.iter().zip(&zero[0].1).map(|(a, b)| a - b).collect();
            (ch, [f[1], f[2]])
        })
        .collect()
}

const METHODS: [Method; 4] = [
    Method::LevenbergMarquardt,
    Method::GaussNewton,
    Method::Constrained,
    Method::ArgminGaussNewton,
];

#[test]
fn every_estimation_method_converges_inside_the_documented_region() {
    let sc = scene();
    let robot = sc.build_robot().unwrap();
    let ei = robot.sections()[0].stiffness.bend_twist.x;
    let fscale = ei / robot.length().powi(2);
    for dir in [Dir::Down, Dir::Up, Dir::Lateral] {
        let grid = [0.5, 5.0, 10.0];
        for (g, (ch, truth)) in grid.iter().zip(measurements(&sc, &robot, dir, &grid)) {
            for method in METHODS {
                let mut est = estimator(&sc, &robot, method);
                let st = est.tick(&ch, None);
                assert_eq!(st, EstimateStatus::Converged, "{method:?} {dir:?} {g}");
                let th = est.theta();
                let err = ((th[0] - truth[0]).powi(2) + (th[1] - truth[1]).powi(2)).sqrt();
                assert!(
                    err < 1e-4 * (fscale + truth[0].hypot(truth[1])),
                    "{method:?} {dir:?} {g}: estimate {th:?} vs {truth:?}"
                );
            }
        }
    }
}

#[test]
fn outside_the_region_methods_return_a_failure_status() {
    let sc = scene();
    let robot = sc.build_robot().unwrap();
    // large world-fixed forces: a cold Newton lands on looped or inverted equilibria;
    // the branch guard (Jacobi's condition) turns those into `Unstable`, so every start
    // either converges onto the tracked branch or returns a failure status
    for model in [RodModel::Kirchhoff, RodModel::Cosserat] {
        let tracker = rod(model, 32, false);
        for dir in [Dir::Down, Dir::Up, Dir::Lateral] {
            let grid = [15.0, 20.0, 30.0, 40.0, 50.0];
            let truth = track(&tracker, &robot, &sc.loads, dir, &grid);
            for continuation in [false, true] {
                let mut m = rod(model, 32, continuation).build(&robot).unwrap();
                for (g, (tip, _)) in grid.iter().zip(&truth) {
                    let t0 = Instant::now();
                    let rep = m
                        .solve(&loads_at(&robot, &sc.loads, dir, *g), Start::Cold)
                        .unwrap();
                    if rep.status.is_converged() {
                        let d = (m.tip_position() - tip).norm();
                        assert!(d < 1e-6, "{model:?} {dir:?} {g}: converged {d:e} m off");
                    }
                    assert!(t0.elapsed().as_secs_f64() < 5.0);
                }
            }
        }
    }
    // estimation past PL^2/EI = 20: the cable lengths no longer single out the force
    for dir in [Dir::Down, Dir::Lateral] {
        let grid = [30.0, 50.0];
        for (g, (ch, _)) in grid.iter().zip(measurements(&sc, &robot, dir, &grid)) {
            for method in METHODS {
                let mut est = estimator(&sc, &robot, method);
                let t0 = Instant::now();
                let st = est.tick(&ch, None);
                assert_ne!(st, EstimateStatus::Converged, "{method:?} {dir:?} {g}");
                assert!(est.theta().iter().all(|x| x.is_finite()));
                assert!(t0.elapsed().as_secs_f64() < 5.0);
            }
        }
    }
}

#[test]
fn absurd_loads_and_data_never_panic_hang_or_give_nan() {
    let sc = scene();
    let robot = sc.build_robot().unwrap();
    let rungs = [
        Rung::ConstantCurvature(CcSettings::default()),
        Rung::PiecewiseConstantCurvature(PccSettings::default()),
        rod(RodModel::Kirchhoff, 16, true),
        rod(RodModel::Cosserat, 16, true),
        rod(RodModel::Cosserat, 16, false),
    ];
    for rung in &rungs {
        let mut m = rung.build(&robot).unwrap();
        for dir in [Dir::Down, Dir::Lateral, Dir::Axial, Dir::Tension] {
            for g in [1e3, 1e6, 1e12] {
                for start in [Start::Cold, Start::Warm] {
                    let t0 = Instant::now();
                    let rep = m
                        .solve(&loads_at(&robot, &sc.loads, dir, g), start)
                        .unwrap();
                    let dt = t0.elapsed().as_secs_f64();
                    assert!(dt < 5.0, "{} {dir:?} {g}: {dt} s", rung.label());
                    if rep.status.is_converged() {
                        assert!(rep.residual.is_finite());
                        assert!(m.tip_position().iter().all(|x| x.is_finite()));
                        let mut l = vec![0.0; robot.cables().len()];
                        m.cable_lengths_into(&mut l);
                        assert!(l.iter().all(|x| x.is_finite()));
                    }
                }
            }
        }
    }
    for method in METHODS {
        let mut est = estimator(&sc, &robot, method);
        for ch in [
            vec![1.0, -1.0, 0.5],
            vec![1e300, 1e300, -1e300],
            vec![f64::NAN; 3],
            vec![f64::INFINITY, 0.0, 0.0],
        ] {
            let t0 = Instant::now();
            let st = est.tick(&ch, None);
            assert!(t0.elapsed().as_secs_f64() < 5.0, "{method:?} {ch:?}");
            if st == EstimateStatus::Converged {
                assert!(est.theta().iter().all(|x| x.is_finite()));
            }
        }
    }
}
