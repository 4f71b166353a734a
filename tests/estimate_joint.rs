//! The joint estimator (`JointEstimator`: shooting unknowns and loads iterated
//! together) against the nested one (`Estimator`, Levenberg-Marquardt, the
//! default): round trips on the estimator problems of `tests/estimate_common`
//! (loads -> forward model -> cable changes -> both estimators -> the same loads),
//! missing/NaN samples, bounds, budgets, and no allocation per tick.
//!
//! Tolerances (from the solver tolerances, as in `tests/estimate_roundtrip.rs`):
//! - loads: `|est - true| <= 1e-8 + 1e-6 |true|` (N); joint vs nested the same;
//! - tip position: `1e-9` m per component;
//! - a `Converged` joint estimate's shape is an equilibrium: the max-norm of its
//!   scaled shooting residual, re-evaluated through the public API, is below the
//!   forward solver's `tolerance` (1e-10 by default).

mod common;
mod estimate_common;

mod alloc_counter;
use alloc_counter::allocations;
use cablesense::estimate::{EstimateSpec, EstimateStatus, JointEstimator, Method};
use cablesense::{Loads, Solution, Workspace};
use estimate_common::*;
use proptest::prelude::*;
use proptest::test_runner::{FileFailurePersistence, TestCaseError};

const LOADS: Tol = Tol {
    abs: 1e-8,
    rel: 1e-6,
};
const TIP: f64 = 1e-9;

fn joint(pb: &Problem, spec: EstimateSpec) -> JointEstimator {
    JointEstimator::new(
        pb.robot.clone(),
        pb.loads.clone(),
        pb.settings.clone(),
        spec,
    )
    .expect("joint estimator builds")
}

/// Max-norm of the scaled shooting residual at the workspace's current unknowns.
fn equilibrium_residual(ws: &mut Workspace) -> f64 {
    let x = ws.unknowns_vector().to_vec();
    let mut r = vec![0.0; x.len()];
    if !ws.shooting_residual(&x, &mut r) {
        return f64::INFINITY;
    }
    r.iter().fold(0.0f64, |a, v| a.max(v.abs()))
}

/// Loads and tip of an estimate against the truth.
fn check(
    what: &str,
    values: &[f64],
    tip: &cablesense::nalgebra::Vector3<f64>,
    theta: &[f64],
    truth: &Solution,
) -> Result<(), TestCaseError> {
    if let Some(m) = LOADS.err(&format!("{what} loads"), values, theta) {
        return Err(TestCaseError::fail(m));
    }
    if let Some(m) = Tol::abs(TIP).err(
        &format!("{what} tip"),
        tip.as_slice(),
        truth.tip().position.as_slice(),
    ) {
        return Err(TestCaseError::fail(m));
    }
    Ok(())
}

/// Joint tick checked: Converged, loads, tip, equilibrium; returns the loads.
fn check_joint(
    est: &mut JointEstimator,
    status: EstimateStatus,
    theta: &[f64],
    truth: &Solution,
    what: &str,
) -> Result<Vec<f64>, TestCaseError> {
    prop_assert_eq!(
        status,
        EstimateStatus::Converged,
        "{} joint at {:?}: {} iterations",
        what,
        theta,
        est.iterations()
    );
    let res = equilibrium_residual(est.workspace());
    // the solve's tolerance: the settings' value raised to the round-off floor of
    // the residual for this robot and load (docs/scene-format.md, `[numerics]`, issue 14)
    let ws = est.workspace();
    let ftol = ws.settings().tolerance.max(ws.residual_floor());
    prop_assert!(
        res <= ftol,
        "{what} joint: Converged but shooting residual {res:e} > {ftol:e}"
    );
    let e = est.estimate();
    check(
        &format!("{what} joint"),
        &e.values,
        &e.tip.position,
        theta,
        truth,
    )?;
    check(
        &format!("{what} joint tip_position()"),
        &e.values,
        &est.tip_position(),
        theta,
        truth,
    )?;
    Ok(e.values)
}

/// Cold round trip at `theta`: nested LM (default spec) and joint (default spec but
/// `joint_iterations`) both recover the loads and the tip, and agree. The
/// tensioned problems give the joint method 200 iterations: from zero load it needs
/// up to ~20 on problem (c) and more on the two-section case, where its trial
/// points (first-order predictor plus chord corrections) leave the equilibrium
/// manifold far behind; that is the robustness gap recorded in `benches/README.md`.
fn roundtrip(
    pb: &Problem,
    reference: &[f64],
    theta: &[f64],
    joint_iterations: usize,
) -> Result<(), TestCaseError> {
    let Some((changes, truth)) = pb.measure(theta, reference) else {
        return Err(TestCaseError::reject("forward solve did not converge"));
    };
    let mut nested = pb.estimator(pb.spec(Method::LevenbergMarquardt));
    let status = nested.tick(&changes, None);
    prop_assert_eq!(status, EstimateStatus::Converged, "nested at {:?}", theta);
    let en = nested.estimate();
    check("nested", &en.values, &en.tip.position, theta, &truth)?;
    let mut j = joint(
        pb,
        EstimateSpec {
            max_iterations: joint_iterations,
            ..pb.spec(Method::LevenbergMarquardt)
        },
    );
    let status = j.tick(&changes, None);
    let vj = check_joint(&mut j, status, theta, &truth, "cold")?;
    if let Some(m) = LOADS.err("joint vs nested", &vj, &en.values) {
        return Err(TestCaseError::fail(m));
    }
    Ok(())
}

/// Warm-started ramp from zero to `target` in 12 ticks: every joint tick tracks
/// the truth.
fn ramp(pb: &Problem, reference: &[f64], target: &[f64]) -> Result<(), TestCaseError> {
    let mut j = joint(pb, pb.spec(Method::LevenbergMarquardt));
    for i in 1..=12 {
        let theta: Vec<f64> = target.iter().map(|t| t * i as f64 / 12.0).collect();
        let Some((changes, truth)) = pb.measure(&theta, reference) else {
            return Err(TestCaseError::reject("forward solve did not converge"));
        };
        let status = j.tick(&changes, None);
        check_joint(&mut j, status, &theta, &truth, &format!("ramp tick {i}"))?;
    }
    Ok(())
}

fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(
            "proptest-regressions/estimate_joint.txt",
        ))),
        ..ProptestConfig::with_cases(cases)
    }
}

fn lateral(max: f64, n: usize) -> impl Strategy<Value = Vec<f64>> {
    proptest::collection::vec(-max..max, n)
}

/// Two sections, six cables, cables 0 (section 1) and 4 (section 2) tensioned at
/// 1.0 N and 0.6 N (known); unknown lateral tip force x, y at the end of section 2.
fn problem_two_section_tensioned() -> Problem {
    Problem {
        loads: Loads {
            tensions_n: vec![1.0, 0.0, 0.0, 0.0, 0.6, 0.0],
            ..Loads::default()
        },
        unknowns: vec![
            force(1, cablesense::estimate::Axis::X),
            force(1, cablesense::estimate::Axis::Y),
        ],
        ..problem_b()
    }
}

proptest! {
    #![proptest_config(config(48))]

    /// (a) one section, three passive cables, horizontal under gravity; tip force
    /// y, z in [-0.3, 0.3] N.
    #[test]
    fn a_joint_matches_nested(theta in lateral(0.3, 2)) {
        let pb = problem_a();
        roundtrip(&pb, &pb.reference_lengths(), &theta, 20)?;
    }
}

proptest! {
    #![proptest_config(config(16))]

    /// (b) two sections, six passive cables; lateral forces at both section ends
    /// in [-0.15, 0.15] N.
    #[test]
    fn b_joint_matches_nested(theta in lateral(0.15, 4)) {
        let pb = problem_b();
        roundtrip(&pb, &pb.reference_lengths(), &theta, 20)?;
    }

    /// (a) warm-started ramp to a random target in [-0.3, 0.3] N.
    #[test]
    fn a_joint_tracks_a_ramp(target in lateral(0.3, 2)) {
        let pb = problem_a();
        ramp(&pb, &pb.reference_lengths(), &target)?;
    }
}

proptest! {
    #![proptest_config(config(8))]

    /// (c) warm-started ramp of both tensions from 0 to a random target in
    /// [0.1, 3] N at the default budget of 20 iterations per tick.
    #[test]
    fn c_joint_tracks_a_ramp(target in proptest::collection::vec(0.1f64..3.0, 2)) {
        let pb = problem_c();
        ramp(&pb, &pb.reference_lengths(), &target)?;
    }

    /// (c) one section, unknown tensions of cables 0 and 1 in [0.05, 3] N
    /// (tensioned cables: hole positions among the shooting unknowns).
    #[test]
    fn c_joint_matches_nested(theta in proptest::collection::vec(0.05f64..3.0, 2)) {
        let pb = problem_c();
        roundtrip(&pb, &pb.reference_lengths(), &theta, 200)?;
    }
}

proptest! {
    #![proptest_config(config(4))]

    /// Two sections with two tensioned cables (36 shooting unknowns); lateral tip
    /// force x, y in [-0.1, 0.1] N.
    #[test]
    fn two_section_tensioned_joint_matches_nested(theta in lateral(0.1, 2)) {
        let pb = problem_two_section_tensioned();
        roundtrip(&pb, &pb.reference_lengths(), &theta, 200)?;
    }
}

/// Missing and NaN samples are ignored as by the nested estimator: with cable 1
/// NaN (and, separately, a slice one short: cable 2 missing) the two remaining
/// cables still determine the two unknowns of problem (a), and joint and nested
/// return the true loads; with every cable NaN the status is `NoData` and the
/// estimate is unchanged.
#[test]
fn missing_and_nan_samples() {
    let pb = problem_a();
    let reference = pb.reference_lengths();
    let theta = [0.12, -0.07];
    let (changes, truth) = pb.measure(&theta, &reference).expect("forward converges");
    let mut nan = changes.clone();
    nan[1] = f64::NAN;
    let short = &changes[..2];
    for (what, sample) in [("NaN cable 1", &nan[..]), ("short slice", short)] {
        let mut nested = pb.estimator(pb.spec(Method::LevenbergMarquardt));
        assert_eq!(
            nested.tick(sample, None),
            EstimateStatus::Converged,
            "{what}"
        );
        let mut j = joint(&pb, pb.spec(Method::LevenbergMarquardt));
        let status = j.tick(sample, None);
        check_joint(&mut j, status, &theta, &truth, what).unwrap();
        LOADS.check(
            &format!("{what}: joint vs nested"),
            j.theta(),
            nested.theta(),
        );
        let e = j.estimate();
        assert!(
            e.measured_m.iter().filter(|m| m.is_none()).count() == 1,
            "{what}"
        );
    }
    // all missing: NoData, previous estimate kept
    let mut j = joint(&pb, pb.spec(Method::LevenbergMarquardt));
    j.tick(&changes, None);
    let before = j.theta().to_vec();
    assert_eq!(j.tick(&[f64::NAN; 3], None), EstimateStatus::NoData);
    assert_eq!(j.theta(), &before[..]);
    // a NaN sigma makes that cable missing too
    let status = j.tick(&changes, Some(&[1e-5, f64::NAN, 1e-5]));
    check_joint(&mut j, status, &theta, &truth, "NaN sigma").unwrap();
}

/// Bounds by projection: problem (c) with the tension of cable 0 bounded above at
/// 0.5 N while the truth is 1.2 N. Joint and nested (projected LM) both stop at the
/// bound with the same other tension (5e-6 relative), and the joint shape is an
/// equilibrium. Both end `Stalled`: with the truth outside the bound the cost stays
/// large, and a step that lowers it by less than its round-off is refused, so the
/// free tension is resolved only to about `sqrt(eps C / C'')`. Seen: 0.7e-6 relative
/// apart, 2.1e-6 after the condensed coupling's linear segment retry (the nested
/// method's stop point moved by 1.4e-6; the joint one by 5e-13); a forward
/// tolerance of 1e-11 or 1e-12 moves neither (checked after the change).
#[test]
fn bounds_are_respected_like_the_nested_method() {
    let mut pb = problem_c();
    let reference = pb.reference_lengths();
    let (changes, _) = pb.measure(&[1.2, 0.4], &reference).expect("forward");
    pb.unknowns[0].max = Some(0.5);
    let mut nested = pb.estimator(pb.spec(Method::LevenbergMarquardt));
    let sn = nested.tick(&changes, None);
    let mut j = joint(&pb, pb.spec(Method::LevenbergMarquardt));
    let sj = j.tick(&changes, None);
    assert_eq!(
        sj,
        sn,
        "joint {:?} vs nested {:?}",
        j.theta(),
        nested.theta()
    );
    assert_eq!(j.theta()[0], 0.5, "at the bound: {:?}", j.theta());
    Tol::both(1e-10, 5e-6).check("joint vs nested", j.theta(), nested.theta());
    assert!(equilibrium_residual(j.workspace()) <= 1e-10);
}

/// A one-iteration budget from a cold start far from the truth ends at
/// `MaxIterations` with a finite estimate whose shape is nevertheless an
/// equilibrium at the returned loads (re-solved, as the nested method keeps it);
/// an exhausted time budget ends at `TimeBudget` the same way.
#[test]
fn budget_exit_returns_an_equilibrium() {
    let pb = problem_a();
    let reference = pb.reference_lengths();
    let (changes, _) = pb.measure(&[-0.25, 0.2], &reference).expect("forward");
    let mut j = joint(
        &pb,
        EstimateSpec {
            max_iterations: 1,
            ..pb.spec(Method::LevenbergMarquardt)
        },
    );
    assert_eq!(j.tick(&changes, None), EstimateStatus::MaxIterations);
    assert!(j.theta().iter().all(|v| v.is_finite()));
    assert!(equilibrium_residual(j.workspace()) <= 1e-10);
    // a time budget that is already spent at the first iteration: TimeBudget, the
    // loads unchanged from the start (zero), the shape the equilibrium there
    let mut jt = joint(
        &pb,
        EstimateSpec {
            time_budget_s: Some(1e-12),
            ..pb.spec(Method::LevenbergMarquardt)
        },
    );
    assert_eq!(jt.tick(&changes, None), EstimateStatus::TimeBudget);
    assert_eq!(jt.theta(), &[0.0, 0.0]);
    assert!(equilibrium_residual(jt.workspace()) <= 1e-10);
    // and the next sample (full budget) finishes the job from there
    let mut j2 = joint(&pb, pb.spec(Method::LevenbergMarquardt));
    j2.set_theta(j.theta());
    assert_eq!(j2.tick(&changes, None), EstimateStatus::Converged);
    LOADS.check("after budget", j2.theta(), &[-0.25, 0.2]);
}

/// An unobservable direction is reported like the nested method: a tip torque
/// about the backbone (world x for the horizontal rod) twists the rod, which the
/// cables barely see; with a torque and two forces unknown the joint and nested
/// estimators report the same status and rank.
#[test]
fn unobservable_status_matches_nested() {
    let mut pb = problem_a();
    pb.unknowns.push(torque(0, cablesense::estimate::Axis::X));
    let reference = pb.reference_lengths();
    let (changes, _) = pb.measure(&[0.05, -0.03, 0.0], &reference).expect("fwd");
    let mut nested = pb.estimator(pb.spec(Method::LevenbergMarquardt));
    let sn = nested.tick(&changes, None);
    let en = nested.estimate();
    let mut j = joint(&pb, pb.spec(Method::LevenbergMarquardt));
    let sj = j.tick(&changes, None);
    let ej = j.estimate();
    assert_eq!(sj, sn);
    assert_eq!(ej.rank, en.rank);
}

// ---------------------------------------------------------------------------
// No allocation per tick after warm-up (the counting allocator of
// tests/alloc_counter: its on/off flag is thread-local, so the other tests of this
// file running on other threads are never counted).

/// Problem (a): after 5 warm-up ticks, 60 ticks along a slowly varying tip force
/// (every 7th with cable 1 missing, every 5th with per-cable sigma) allocate
/// nothing, and every one converges to the truth.
#[test]
fn joint_ticks_do_not_allocate_after_warm_up() {
    let n = allocations(|| {
        std::hint::black_box(vec![1u8; 10]);
    });
    assert_eq!(n, 1, "self-check");

    let pb = problem_a();
    let reference = pb.reference_lengths();
    let samples: Vec<(Vec<f64>, Vec<f64>)> = (0..65)
        .map(|i| {
            let t = i as f64;
            let theta = vec![0.05 * (t / 10.0).sin(), 0.04 * (t / 7.0).cos()];
            let (mut changes, _) = pb.measure(&theta, &reference).expect("forward");
            if i % 7 == 3 {
                changes[1] = f64::NAN;
            }
            (theta, changes)
        })
        .collect();
    let sigma = [1e-5, 2e-5, 1.5e-5];
    let mut j = joint(&pb, pb.spec(Method::LevenbergMarquardt));
    for (_, changes) in &samples[..5] {
        j.tick(changes, None);
    }
    let mut status = [EstimateStatus::NoData; 60];
    let mut values = [[0.0; 2]; 60];
    let count = allocations(|| {
        for (i, (_, changes)) in samples[5..].iter().enumerate() {
            let s = (i % 5 == 0).then_some(&sigma[..]);
            status[i] = j.tick(changes, s);
            values[i].copy_from_slice(j.theta());
        }
    });
    assert_eq!(count, 0, "{count} allocations in 60 joint ticks");
    for i in 0..60 {
        assert_eq!(status[i], EstimateStatus::Converged, "tick {i}");
        LOADS.check(&format!("tick {i}"), &values[i], &samples[5 + i].0);
    }
}
