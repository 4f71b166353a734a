//! Exact derivatives of the tendon terms against central finite differences, on the
//! shipped FTDCR v4 scene (nine displacement-driven tendons, all nine through the first
//! segment's disks: the condensed coupling's fold with 27 next-hole coordinates
//! through the 6 jump directions, `statics::pass`), at rows of its recording.
//!
//! * `[R_x R_T]` and `[dl/dx dl/dT]` from one dual sweep over `[x; T]`
//!   (`Workspace::joint_jacobians`, what the joint Newton of `tendons/solve/joint.rs`
//!   builds its generalized Jacobian from) against central differences of the shooting
//!   residual and the path lengths at a point perturbed off the equilibrium.
//! * The total `dl/dT` at an equilibrium (`Workspace::length_sensitivities`, the
//!   nested method's Jacobian) against central differences of converged solves.
//!
//! Tolerances: step `h = 1e-4` (scaled unknowns ~1; tensions in N ~1). The condensed
//! coupling settles the next holes to round-off, or stops at a floor of 1e-13 L
//! (~2e-14 m here) once they stop improving; that moves the residual by up to ~1e-11
//! and a length by ~2e-14 m, i.e. a quotient by ~1e-7 (residual) and ~2e-10 m
//! (length) at this step; truncation is ~h^2 ~1e-8 relative. Residual entries (the
//! largest O(100)) must agree to 1e-5 absolute + 1e-5 relative, length entries (up to
//! ~1e-2 m per unit) to 1e-9 absolute + 1e-5 relative. (At `h = 1e-6` the settle
//! noise reached 1.5e-5 in a residual quotient and 6.6e-9 m in a length one: too
//! close to any useful tolerance.) Converged re-solves carry the shooting tolerance
//! (1e-10 scaled) through an ill-conditioned map (at `1e-6` N the re-solve noise was
//! 1e-6 m/N, 1.3e-4 relative): the equilibrium test asks 1e-7 absolute + 1e-5
//! relative at `1e-4` N.

use crate::common;

use cablesense::Scene;
use cablesense::Start;
use common::Tol;
use proptest::prelude::*;
use proptest::test_runner::FileFailurePersistence;

const HT: f64 = 1e-4;

/// Readings of the recording's rows (m, in the scene's tendon order).
fn rows(scene: &Scene, ws: &cablesense::tendons::TendonWorkspace) -> Vec<Vec<f64>> {
    let mut p = scene.readings_parser(ws);
    let text =
        std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").expect("shipped recording");
    text.lines()
        .enumerate()
        .filter_map(|(i, l)| p.line(i + 1, l).ok().flatten())
        .map(|r| r.readings_m)
        .collect()
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 4,
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource(
            "proptest-regressions",
        ))),
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    /// The joint sweep's partials at a point off the equilibrium.
    #[test]
    fn joint_sweep_partials_match_central_differences(row in 0usize..443, seed in 0u64..1000) {
        let scene = Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
        let mut tw = scene.tendon_workspace().expect("tendon workspace");
        let all = rows(&scene, &tw);
        let rep = tw.solve_readings(&all[row % all.len()]).expect("valid readings");
        prop_assert!(rep.status.is_converged(), "{rep:?}");
        let check = common::joint_partials_against_central_differences(&mut tw, seed);
        prop_assert!(check.is_ok(), "{}", check.unwrap_err());
    }

    /// The total `dl/dT` of the equilibrium (implicit function theorem through the
    /// shooting problem) against re-solved equilibria at `T +- h`.
    #[test]
    fn equilibrium_length_sensitivities_match_resolves(row in 0usize..443) {
        // re-solves to round-off (the scene's own 1e-4 / 1e-7 m would be the noise)
        let scene = common::default_tolerances(
            Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene"),
        );
        let mut tw = scene.tendon_workspace().expect("tendon workspace");
        let all = rows(&scene, &tw);
        let rep = tw.solve_readings(&all[row % all.len()]).expect("valid readings");
        prop_assert!(rep.status.is_converged(), "{rep:?}");
        let theta: Vec<f64> = tw.tensions().to_vec();
        let ws = tw.workspace_mut();
        let p = theta.len();
        let c = ws.robot().cables().len();
        ws.set_theta(&theta);
        prop_assert!(ws.solve(Start::Warm).status.is_converged());
        let (mut sens, mut lengths) = (vec![0.0; c * p], vec![0.0; c]);
        prop_assert!(ws.length_sensitivities(&mut sens, &mut lengths));
        let (mut lp, mut lm) = (vec![0.0; c], vec![0.0; c]);
        let tol = Tol::both(1e-7, 1e-5);
        for k in 0..p {
            for (sign, l) in [(1.0, &mut lp), (-1.0, &mut lm)] {
                let mut th = theta.clone();
                th[k] += sign * HT;
                ws.set_theta(&th);
                let rep = ws.solve(Start::Warm);
                prop_assert!(rep.status.is_converged(), "{rep:?}");
                ws.cable_lengths_into(l);
            }
            for j in 0..c {
                let fd = (lp[j] - lm[j]) / (2.0 * HT);
                let exact = sens[j * p + k];
                prop_assert!(tol.ok(fd, exact), "dl[{j}]/dT[{k}]: exact {exact:e}, fd {fd:e}");
            }
        }
    }
}
