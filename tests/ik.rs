//! Inverse kinematics (`cablesense::command`) on the calibrated FTDCR v4 scene and the
//! one-segment daru robot: round trips through the model's own tips, the exact
//! Jacobian against differences of converged solves, honest outcomes (unreachable
//! targets, NaN, zero direction, limits excluding zero) and a property test.

use cablesense::command::{IkObjective, IkSettings, IkStatus, IkTarget, IkWorkspace};
use cablesense::nalgebra::Vector3;
use cablesense::robot::ActuatorLimits;
use cablesense::Scene;
use proptest::prelude::*;
use proptest::test_runner::FileFailurePersistence;

#[path = "ik_boundary.rs"]
mod boundary;
#[path = "ik_budget.rs"]
mod budget;
#[path = "ik_rest.rs"]
mod rest;

const FTDCR: &str = "data/calibration/ftdcr_v4_calibrated.toml";
const DARU: &str = "data/calibration/daru_calibrated.toml";

/// The calibrated FTDCR v4 scene and the model's tips at its first `take` val rows
/// ([`Scene::model_tips`]) as position targets.
fn ftdcr_targets(take: usize) -> (Scene, Vec<IkTarget>) {
    let scene = Scene::load(FTDCR).unwrap();
    let text = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").unwrap();
    let targets = scene
        .model_tips(&text, take)
        .unwrap()
        .into_iter()
        .map(IkTarget::position)
        .collect();
    (scene, targets)
}

/// The recording's val rows' readings (m) and the model's tips there (m), solved in
/// sequence (warm), rows that do not converge left out.
fn val_rows(scene: &Scene, take: usize) -> Vec<(Vec<f64>, Vector3<f64>)> {
    let mut tw = scene.tendon_workspace().unwrap();
    let mut p = scene.readings_parser(&tw);
    let text = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").unwrap();
    let mut out = Vec::new();
    for (i, l) in text.lines().enumerate() {
        let Ok(Some(r)) = p.line(i + 1, l) else {
            continue;
        };
        if tw
            .solve_readings(&r.readings_m)
            .unwrap()
            .status
            .is_converged()
        {
            out.push((r.readings_m, tw.tip_position()));
        }
        if out.len() == take {
            break;
        }
    }
    out
}

/// Round trip on `n` val rows: from the previous row's readings and from zero; the
/// fractions within 0.05 mm.
fn round_trip(n: usize) -> (f64, f64) {
    let scene = Scene::load(FTDCR).unwrap();
    let rows = val_rows(&scene, n + 1);
    let mut ik = IkWorkspace::from_scene(&scene, IkSettings::default()).unwrap();
    let (mut warm_ok, mut cold_ok) = (0, 0);
    for k in 1..rows.len() {
        let target = IkTarget::position(rows[k].1);
        ik.set_readings(&rows[k - 1].0).unwrap();
        let r = ik.solve(&target).unwrap();
        if r.distance_m <= 5e-5 {
            warm_ok += 1;
        }
        // the tip reported is the model's at the returned readings
        assert!((r.tip_m - ik.tip_position()).norm() == 0.0);
        for (i, q) in ik.readings().iter().enumerate() {
            assert!(*q >= ik.limits().min_m[i] && *q <= ik.limits().max_m[i]);
        }
        ik.set_readings(&[0.0; 9]).unwrap();
        let r = ik.solve(&target).unwrap();
        if r.distance_m <= 5e-5 {
            cold_ok += 1;
        }
    }
    let m = (rows.len() - 1) as f64;
    (warm_ok as f64 / m, cold_ok as f64 / m)
}

#[test]
fn ftdcr_round_trip_from_previous_and_from_zero() {
    let (warm, cold) = round_trip(60);
    eprintln!(
        "round trip on 60 val rows: {:.1} % from the previous row, {:.1} % from zero",
        100.0 * warm,
        100.0 * cold
    );
    assert!(warm >= 0.99, "from the previous row: {warm}");
    assert!(cold >= 0.95, "from zero: {cold}");
}

/// The full val set (443 rows): run with `--ignored`; prints the figures.
#[test]
#[ignore]
fn ftdcr_round_trip_full_val() {
    let (warm, cold) = round_trip(usize::MAX);
    eprintln!(
        "round trip on the val set: {:.2} % from the previous row, {:.2} % from zero",
        100.0 * warm,
        100.0 * cold
    );
    assert!(warm >= 0.99 && cold >= 0.95);
}

#[test]
fn exact_jacobian_matches_differences_of_solves() {
    // converged solves to 1e-11 m (the scene's 1e-7 m would put ~1e-2 relative noise
    // in a difference of solves at the 1e-5 m step)
    let mut scene = Scene::load(FTDCR).unwrap();
    scene.numerics.tendons.tolerance_m = 1e-11;
    let rows = val_rows(&scene, 40);
    // a slack tendon within 0.1 of the trust radius of its engagement point is
    // linearised on its taut side (with the others' columns), which differences of
    // solves at the slack point do not see: a small radius keeps every slack
    // tendon on its slack side here
    let settings = IkSettings {
        trust_radius_m: 1e-8,
        ..IkSettings::default()
    };
    let mut ik = IkWorkspace::from_scene(&scene, settings).unwrap();
    let mut compared = 0;
    for k in [5, 25, 39] {
        ik.set_readings(&rows[k].0).unwrap();
        assert_eq!(ik.compute_jacobian(), Some(0));
        let (jp, jt) = (ik.tip_jacobian().to_vec(), ik.tension_jacobian().to_vec());
        // taut tendons' columns (a slack one's exact column is the one-sided
        // derivative beyond its engagement point, which a central difference of
        // solves at the slack point does not see)
        let taut = ik.tendon_workspace().taut().to_vec();
        assert!(ik.finite_difference_jacobian().is_some());
        let (fp, ft) = (ik.tip_jacobian().to_vec(), ik.tension_jacobian().to_vec());
        let cols = |v: &[f64], rows: usize| -> Vec<f64> {
            (0..rows * 9)
                .filter(|e| taut[e % 9])
                .map(|e| v[e])
                .collect()
        };
        let (jp, fp, jt, ft) = (cols(&jp, 3), cols(&fp, 3), cols(&jt, 9), cols(&ft, 9));
        compared += jp.len() / 3;
        let scale = fp.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = jp
            .iter()
            .zip(&fp)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(scale > 0.1, "tip moves with the readings: {scale}");
        assert!(
            worst < 1e-4 * scale,
            "row {k}: dp/dq differs by {worst} (scale {scale})"
        );
        let tscale = ft.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let tworst = jt
            .iter()
            .zip(&ft)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(
            tworst < 1e-3 * tscale,
            "row {k}: dT/dq differs by {tworst} (scale {tscale})"
        );
        // still at the row's readings
        assert_eq!(ik.readings(), &rows[k].0[..]);
    }
    assert!(compared >= 6, "taut columns compared: {compared}");
}

#[test]
fn target_outside_the_workspace_is_unreachable_with_the_closest_tip() {
    let scene = Scene::load(FTDCR).unwrap();
    let mut ik = IkWorkspace::from_scene(&scene, IkSettings::default()).unwrap();
    let start = ik.tip_position();
    // 10 cm beyond the straight tip: longer than the robot can stretch
    let target = IkTarget::position(start + Vector3::new(0.0, 0.0, 0.1));
    let r = ik.solve(&target).unwrap();
    match r.status {
        IkStatus::Unreachable {
            closest_tip_m,
            distance_m,
        } => {
            assert!(distance_m > 0.09, "{distance_m}");
            // declared at a constrained stationary point
            assert!(r.first_order <= 1e-2, "{r:?}");
            assert_eq!(closest_tip_m, ik.tip_position());
            assert!((distance_m - (target.position_m - closest_tip_m).norm()).abs() < 1e-15);
        }
        s => panic!("expected unreachable, got {s:?} ({r:?})"),
    }
    // far to the side: the closest tip is nearer than the start
    ik.set_readings(&[0.0; 9]).unwrap();
    let side = IkTarget::position(Vector3::new(0.3, 0.0, 0.1));
    let r = ik.solve(&side).unwrap();
    assert!(matches!(r.status, IkStatus::Unreachable { .. }), "{r:?}");
    assert!(r.first_order <= 1e-2, "{r:?}");
    assert!(r.distance_m < (side.position_m - start).norm());
    for (i, q) in ik.readings().iter().enumerate() {
        assert!(*q >= ik.limits().min_m[i] - 1e-15 && *q <= ik.limits().max_m[i] + 1e-15);
    }
    // and the workspace still solves a reachable target afterwards (from readings at
    // their limits: a larger budget)
    let long = IkSettings {
        max_iterations: 100,
        max_forward_solves: 300,
        ..IkSettings::default()
    };
    ik.set_settings(long).unwrap();
    let back = IkTarget::position(start);
    let r = ik.solve(&back).unwrap();
    eprintln!("back to the start: {r:?}");
    assert_eq!(r.status, IkStatus::Reached);
}

#[test]
fn bad_targets_and_limits_are_clear_errors() {
    let scene = Scene::load(FTDCR).unwrap();
    let mut ik = IkWorkspace::from_scene(&scene, IkSettings::default()).unwrap();
    let e = ik
        .solve(&IkTarget::position(Vector3::new(f64::NAN, 0.0, 0.1)))
        .unwrap_err()
        .to_string();
    assert!(e.contains("target.position_m[0]"), "{e}");
    let mut t = IkTarget::position(Vector3::new(0.0, 0.0, 0.18));
    t.direction = Some(Vector3::zeros());
    let e = ik.solve(&t).unwrap_err().to_string();
    assert!(
        e.contains("target.direction") && e.contains("zero length"),
        "{e}"
    );
    t.direction = Some(Vector3::new(0.0, f64::INFINITY, 1.0));
    assert!(ik
        .solve(&t)
        .unwrap_err()
        .to_string()
        .contains("target.direction[1]"));
    // limits that exclude zero readings
    let tw = scene.tendon_workspace().unwrap();
    let mut lim = ActuatorLimits::unbounded(9);
    lim.min_m[3] = 0.001;
    let e = IkWorkspace::new(tw.clone(), lim, IkSettings::default())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("limits.servo_5_mm") && e.contains("excludes reading 0"),
        "{e}"
    );
    let mut lim = ActuatorLimits::unbounded(9);
    lim.max_m[0] = f64::NAN;
    let e = IkWorkspace::new(tw.clone(), lim, IkSettings::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("limits.servo_4_mm"), "{e}");
    let bad = IkSettings {
        tolerance_m: 0.0,
        ..IkSettings::default()
    };
    let e = IkWorkspace::new(tw, ActuatorLimits::unbounded(9), bad)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("ik.tolerance_m"), "{e}");
    // start readings outside the limits
    let e = ik
        .set_readings(&[0.02, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("servo_4_mm") && e.contains("actuator limits"),
        "{e}"
    );
}

#[test]
fn objectives_choose_among_solutions_and_say_so() {
    let scene = Scene::load(FTDCR).unwrap();
    let rows = val_rows(&scene, 30);
    let target = IkTarget::position(rows[29].1);
    let mut sums = Vec::new();
    for objective in [
        IkObjective::Closest,
        IkObjective::LeastPull,
        IkObjective::LeastTension,
    ] {
        let settings = IkSettings {
            objective,
            ..IkSettings::default()
        };
        let mut ik = IkWorkspace::from_scene(&scene, settings).unwrap();
        let r = ik.solve(&target).unwrap();
        assert_eq!(r.status, IkStatus::Reached, "{objective:?}: {r:?}");
        assert_eq!(r.objective, objective);
        let pull: f64 = ik.readings().iter().sum();
        let peak = ik
            .tendon_workspace()
            .tensions()
            .iter()
            .fold(0.0f64, |m, t| m.max(*t));
        let t2: f64 = ik.tendon_workspace().tensions().iter().map(|t| t * t).sum();
        eprintln!(
            "{objective:?}: sum q {:.3} mm, peak T {peak:.3} N, |T|^2 {t2:.3}, slack {}, {} solves",
            pull * 1e3,
            r.slack,
            r.forward_solves
        );
        sums.push((pull, t2));
    }
    assert!(
        sums[1].0 <= sums[0].0 + 1e-6,
        "least pull pulls least: {sums:?}"
    );
    assert!(sums[2].1 <= sums[0].1 + 1e-6, "least tension: {sums:?}");
}

#[test]
fn direction_target_is_followed() {
    let scene = Scene::load(FTDCR).unwrap();
    let rows = val_rows(&scene, 20);
    let long = IkSettings {
        max_iterations: 100,
        max_forward_solves: 300,
        ..IkSettings::default()
    };
    let mut ik = IkWorkspace::from_scene(&scene, long).unwrap();
    ik.set_readings(&rows[19].0).unwrap();
    let (tip, axis) = (ik.tip_position(), ik.tip_axis());
    let with = IkTarget {
        position_m: tip,
        direction: Some(axis * 3.0),
    };
    // from the previous row: position and direction reached
    ik.set_readings(&rows[18].0).unwrap();
    let r = ik.solve(&with).unwrap();
    eprintln!("direction target from the previous row: {r:?}");
    assert_eq!(r.status, IkStatus::Reached, "{r:?}");
    assert!(r.angle_rad <= 1e-3 && r.distance_m <= 1e-5, "{r:?}");
    // from farther: the direction term turns the tip towards the target direction
    ik.set_readings(&rows[10].0).unwrap();
    let free = ik.solve(&IkTarget::position(tip)).unwrap();
    let angle_free = axis.normalize().dot(&ik.tip_axis()).clamp(-1.0, 1.0).acos();
    ik.set_readings(&rows[10].0).unwrap();
    let r = ik.solve(&with).unwrap();
    eprintln!("from row 10: position only {free:?} (angle {angle_free}); with direction {r:?}");
    assert!(r.angle_rad < angle_free, "{} vs {angle_free}", r.angle_rad);
    assert!(r.distance_m < 1e-3, "{r:?}");
}

/// A fixed seed: the same cases on every run, so CI does not depend on the draw
/// (change the seed to explore other cases).
fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 16,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x5eed_0044),
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource(
            "proptest-regressions",
        ))),
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    /// IK(forward(q)) reproduces forward(q)'s tip for random q inside the daru
    /// robot's limits (0..100 units each), started from q moved by up to 10 % of
    /// the range per cable (kept inside the limits): the control loop's case, a
    /// start near the answer. Its counterexample (tests/ik.proptest-regressions,
    /// q = (4.0, 43.0, 27.7) units started 5.7 units below on cable 3) was called
    /// `unreachable` 0.046 mm away before the step's Levenberg-Marquardt damping
    /// (`command::ik` module docs).
    #[test]
    fn ik_of_forward_reproduces_the_tip(
        a in 0.0f64..1.0, b in 0.0f64..1.0, c in 0.0f64..1.0,
        d in proptest::collection::vec(-1.0f64..1.0, 3),
    ) {
        let scene = Scene::load(DARU).unwrap();
        let mut ik = IkWorkspace::from_scene(&scene, IkSettings::default()).unwrap();
        let hi = ik.limits().max_m.clone();
        let q = [a * hi[0], b * hi[1], c * hi[2]];
        // readings whose forward solve does not converge are skipped (not IK's case)
        prop_assume!(ik.set_readings(&q).is_ok());
        let tip = ik.tip_position();
        let start: Vec<f64> = (0..3).map(|i| (q[i] + 0.1 * hi[i] * d[i]).clamp(0.0, hi[i])).collect();
        prop_assume!(ik.set_readings(&start).is_ok());
        let r = ik.solve(&IkTarget::position(tip)).unwrap();
        prop_assert_eq!(r.status, IkStatus::Reached, "q {:?}: {:?}", q, r);
        prop_assert!(r.distance_m <= ik.settings().tolerance_m);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 8, ..config() })]

    /// IK(forward(q)) reproduces forward(q)'s tip for random q inside the calibrated
    /// FTDCR v4's shipped limits, started from q moved by up to 1 mm per tendon (kept
    /// inside the limits). Readings whose forward solve does not converge (large
    /// curls of the distal segment) are skipped.
    #[test]
    fn ftdcr_ik_of_forward_reproduces_the_tip(
        u in proptest::collection::vec(0.0f64..1.0, 9),
        d in proptest::collection::vec(-1.0f64..1.0, 9),
    ) {
        let scene = Scene::load(FTDCR).unwrap();
        let mut ik = IkWorkspace::from_scene(&scene, IkSettings::default()).unwrap();
        let (lo, hi) = (ik.limits().min_m.clone(), ik.limits().max_m.clone());
        let q: Vec<f64> = (0..9).map(|i| lo[i] + u[i] * (hi[i] - lo[i])).collect();
        let mut tw = scene.tendon_workspace().unwrap();
        prop_assume!(tw.solve_readings(&q).unwrap().status.is_converged());
        let tip = tw.tip_position();
        let start: Vec<f64> = (0..9).map(|i| (q[i] + 1e-3 * d[i]).clamp(lo[i], hi[i])).collect();
        prop_assume!(ik.set_readings(&start).is_ok());
        let r = ik.solve(&IkTarget::position(tip)).unwrap();
        prop_assert_eq!(r.status, IkStatus::Reached, "q {:?}: {:?}", q, r);
        prop_assert!(r.distance_m <= ik.settings().tolerance_m);
        prop_assert!(ik.readings().iter().zip(&lo).zip(&hi).all(|((v, l), h)| v >= l && v <= h));
    }
}
