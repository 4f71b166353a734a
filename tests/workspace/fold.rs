//! The fold test of the workspace's failed samples (`cablesense workspace
//! --fold-test`, `cablesense::command::workspace::fold_test`) and the joint
//! Jacobian probe under it (`cablesense::tendons::FoldProbe`), on the calibrated
//! FTDCR v4: the probe's tangent against differences of solves, the distal
//! section's co-contraction stall (singular, not a fold), an ordinary stall
//! (regular), and a sampled box whose solved samples the test leaves bit for bit.

use cablesense::command::workspace::{fold_test, FoldClass, FOLD_PUSH};
use cablesense::command::{sample_workspace, WorkspaceSettings};
use cablesense::tendons::{FoldProbe, TendonWorkspace};
use cablesense::Scene;

const FTDCR: &str = "data/calibration/ftdcr_v4_calibrated.toml";

/// The calibrated workspace converged at reading 0, and the readings that pull
/// the distal section's three tendons by `pull_m` (the rest at 0).
fn at_zero() -> (TendonWorkspace, impl Fn(f64) -> Vec<f64>) {
    let scene = Scene::load(FTDCR).unwrap();
    let mut w = scene.tendon_workspace().unwrap();
    let p = w.driven().len();
    assert!(w
        .solve_readings(&vec![0.0; p])
        .unwrap()
        .status
        .is_converged());
    let section: Vec<usize> = w
        .driven()
        .iter()
        .map(|&j| w.workspace().robot().cables()[j].end_section)
        .collect();
    let distal = section.iter().copied().max().unwrap();
    let pull = move |v: f64| -> Vec<f64> {
        section
            .iter()
            .map(|&s| if s == distal { v } else { 0.0 })
            .collect()
    };
    (w, pull)
}

/// `dz/dlambda` from `F_z` (implicit function theorem) against the difference of
/// two converged solves 1 um apart along the distal pull: the tensions' rates
/// agree within 1e-3 relative (a first-order difference at 1 um; the tensions
/// grow by about 2.46 N/mm, the series spring's stiffness).
#[test]
fn probe_tangent_matches_differences_of_solves() {
    let (mut w, pull) = at_zero();
    let p = w.driven().len();
    let q0 = pull(2e-3);
    assert!(w.solve_readings(&q0).unwrap().status.is_converged());
    let mut probe = FoldProbe::new(&w);
    let dir = pull(1.0);
    let f = probe.measure(&mut w, &q0, &dir).unwrap();
    let nx = probe.size() - p;
    let t0 = w.tensions().to_vec();
    let h = 1e-6;
    assert!(w
        .solve_readings(&pull(2e-3 + h))
        .unwrap()
        .status
        .is_converged());
    for (i, t) in t0.iter().enumerate() {
        let fd = (w.tensions()[i] - t) / h;
        let ift = f.tangent[nx + i];
        assert!(
            (fd - ift).abs() <= 1e-3 * ift.abs().max(1.0),
            "tendon {i}: difference {fd} N/m, F_z {ift} N/m"
        );
    }
    assert!(f.sigma_min > 0.0 && f.sigma_min <= f.sigma_max && f.det_sign.abs() == 1.0);
}

/// The distal section's three tendons pulled together from 6 to 7.5 mm (the
/// stall is at ~7.1 mm, docs/command.md): the walk stops past 6.5 mm where the
/// smallest singular value of `F_z` has fallen by more than four, in a mode the
/// symmetric pull does not drive (push far below `FOLD_PUSH`): `singular`, not
/// `past_fold` (the branch does not turn there).
#[test]
fn co_contraction_stall_is_singular_not_a_fold() {
    let (mut w, pull) = at_zero();
    assert!(w.solve_readings(&pull(6e-3)).unwrap().status.is_converged());
    let mut settings = *w.tendon_settings();
    settings.max_passes = Some(40);
    let t = fold_test(&w, &pull(6e-3), &pull(7.5e-3), &settings);
    assert_eq!(t.class, FoldClass::Singular, "{t:?}");
    let stall_mm = 6.0 + 1.5 * t.reached;
    assert!((6.5..7.2).contains(&stall_mm), "{t:?}");
    assert!(t.push < 1e-2 * FOLD_PUSH, "{t:?}");
    assert!(t.sigma_stall < 0.25 * t.sigma_start, "{t:?}");
}

/// An ordinary stall: under a solve budget of one rod pass the walk stops within
/// the first 10 % of the way, where `F_z` is regular: `regular`.
#[test]
fn a_solve_that_cannot_step_is_a_regular_stall() {
    let (w, pull) = at_zero();
    let p = w.driven().len();
    let mut settings = *w.tendon_settings();
    settings.max_passes = Some(1);
    let t = fold_test(&w, &vec![0.0; p], &pull(3e-3), &settings);
    assert_eq!(t.class, FoldClass::Regular, "{t:?}");
    assert!(t.reached < 0.1, "{t:?}");
    assert!(t.sigma_stall > 0.5 * t.sigma_start, "{t:?}");
}

/// 48 samples of the shipped box in chains of 12, with and without the fold
/// test: the same cloud bit for bit but for the test's verdicts, a verdict for
/// every failed sample and none for a solved one, and at least one fold.
#[test]
fn fold_test_leaves_solved_samples_as_they_were() {
    let scene = Scene::load(FTDCR).unwrap();
    let limits = scene.actuator_limits().unwrap();
    let tw = scene.tendon_workspace().unwrap();
    let settings = |fold_test| WorkspaceSettings {
        samples: 48,
        chunk_samples: 12,
        threads: 2,
        fold_test,
        ..WorkspaceSettings::default()
    };
    let plain = sample_workspace(&tw, &limits, &settings(false), &|_| {}).unwrap();
    let tested = sample_workspace(&tw, &limits, &settings(true), &|_| {}).unwrap();
    assert!(plain.fold.iter().all(Option::is_none));
    assert!(plain.fold_passes.iter().all(|&p| p == 0));
    let mut without = tested.clone();
    without.fold = plain.fold.clone();
    without.fold_passes = plain.fold_passes.clone();
    assert_eq!(plain, without);
    for k in 0..tested.len() {
        assert_eq!(
            tested.fold[k].is_some(),
            !tested.status[k].is_solved(),
            "{k}: {:?} {:?}",
            tested.status[k],
            tested.fold[k]
        );
    }
    let by = tested.failed_by_fold();
    assert_eq!(by.iter().map(|b| b.0).sum::<usize>(), tested.failed());
    assert!(by[0].0 > 0, "no past_fold among {by:?}");
}
