//! The exact (dual-number) shooting Jacobian against central finite differences of the
//! shooting residual (argmin-testfunctions style), at random points near solutions.
//!
//! Tolerance: |J_exact - J_fd| <= 1e-5 + 1e-5 |J_exact| entrywise. Central differences
//! with step h = 1e-6 (scaled unknowns, O(1) near a solution) have truncation error
//! ~h^2 |f'''| ~ 1e-12 and round-off ~eps |f| / h ~ 1e-10, far below that.
//!
//! The condensed cable coupling settles each segment's next holes to 1e-13 of the rod
//! length inside the pass; that inner error moves the residual by ~1e-11, i.e. ~1e-5
//! of a difference quotient at most, and in practice far less (the inner Newton
//! converges quadratically past the tolerance).
//!
//! The adaptive integrator chooses its steps from the state, so its residual is only
//! piecewise smooth in the unknowns (the dual pass differentiates the discretisation at
//! fixed steps). Its tolerance is set to 1e-12 here so that a step-sequence change
//! inside the difference stencil moves the residual by ~1e-12, i.e. ~1e-6 in the
//! difference quotient.

use crate::common;

use cablesense::nalgebra::Vector3;
use cablesense::{
    CableCoupling, Frame, GuideMass, Loads, PointLoad, Robot, SolverSettings, Start, Workspace,
};
use common::*;
use proptest::prelude::*;
use proptest::test_runner::FileFailurePersistence;

const H: f64 = 1e-6;

#[derive(Clone, Copy, Debug)]
enum Kind {
    /// Plain rod, world-frame loads: n(0) in closed form, 3 unknowns.
    PlainWorld,
    /// Plain rod, body-frame (follower) tip load: 6 unknowns.
    PlainBody,
    /// Five guides, three cables, random tensions: 6 + 12 per tensioned cable.
    FiveGuide,
    /// Two sections, cables ending on both: up to 96 unknowns.
    TwoSection,
}

#[derive(Clone, Debug)]
struct Case {
    axis: [f64; 3],
    angle: f64,
    force: [f64; 3],
    torque: [f64; 3],
    tensions: Vec<f64>,
    guide_mass: GuideMass,
    /// Perturbation of the solved unknowns, scaled units.
    delta: Vec<f64>,
}

fn case() -> impl Strategy<Value = Case> {
    (
        [-1.0..1.0f64, -1.0..1.0, -1.0..1.0],
        0.0..3.0f64,
        [-0.1..0.1f64, -0.1..0.1, -0.1..0.1],
        [-0.005..0.005f64, -0.005..0.005, -0.005..0.005],
        // every cable tensioned in (0.2, 1.5) N: the Jacobian then has all its blocks
        proptest::collection::vec(0.2..1.5f64, 6),
        prop_oneof![
            Just(GuideMass::None),
            Just(GuideMass::Average),
            Just(GuideMass::Accurate),
            Just(GuideMass::Point)
        ],
        proptest::collection::vec(-0.02..0.02f64, 96),
    )
        .prop_map(
            |(axis, angle, force, torque, tensions, guide_mass, delta)| Case {
                axis: if axis.iter().all(|a| a.abs() < 1e-3) {
                    [0.0, 0.0, 1.0]
                } else {
                    axis
                },
                angle,
                force,
                torque,
                tensions,
                guide_mass,
                delta,
            },
        )
}

fn problem(kind: Kind, c: &Case) -> (Robot, Loads) {
    let base = axis_angle(c.axis, c.angle);
    let (robot, body) = match kind {
        Kind::PlainWorld => (plain_rod(0.39, 1.56e-3), false),
        Kind::PlainBody => (plain_rod(0.39, 1.56e-3), true),
        Kind::FiveGuide => (five_guide_robot(), false),
        Kind::TwoSection => (two_section_robot(), false),
    };
    let robot = robot.with_base(base, Vector3::zeros());
    let last = robot.sections().len() - 1;
    let loads = Loads {
        point: vec![PointLoad {
            section: last,
            force_n: c.force,
            torque_nm: c.torque,
            frame: if body { Frame::Body } else { Frame::World },
            mass_kg: 0.005,
        }],
        tensions_n: c.tensions[..robot.cables().len()].to_vec(),
        ..Loads::default()
    };
    (robot, loads)
}

fn check(
    kind: Kind,
    c: &Case,
    settings: SolverSettings,
    want_unknowns: Option<usize>,
) -> Result<(), TestCaseError> {
    let (robot, loads) = problem(kind, c);
    let settings = SolverSettings {
        guide_mass: c.guide_mass,
        ..settings
    };
    let mut ws = Workspace::new(robot, loads, settings).unwrap();
    let rep = ws.solve(Start::Cold);
    prop_assert!(rep.status.is_converged(), "{kind:?}: {rep:?}");
    let n = ws.unknowns();
    if let Some(w) = want_unknowns {
        prop_assert_eq!(n, w, "{:?}: unknowns", kind);
    }
    let x: Vec<f64> = ws
        .unknowns_vector()
        .iter()
        .zip(&c.delta)
        .map(|(x, d)| x + d)
        .collect();
    prop_assert_eq!(x.len(), n);
    let jac = ws
        .shooting_jacobian(&x)
        .expect("integration is finite near a solution");
    prop_assert_eq!(jac.len(), n * n);
    let (mut rp, mut rm) = (vec![0.0; n], vec![0.0; n]);
    let tol = Tol::both(1e-5, 1e-5);
    for col in 0..n {
        let mut xp = x.clone();
        xp[col] += H;
        prop_assert!(ws.shooting_residual(&xp, &mut rp));
        xp[col] -= 2.0 * H;
        prop_assert!(ws.shooting_residual(&xp, &mut rm));
        for row in 0..n {
            let fd = (rp[row] - rm[row]) / (2.0 * H);
            let exact = jac[row * n + col];
            prop_assert!(
                tol.ok(fd, exact),
                "{:?} ({} unknowns): J[{}][{}] exact {:e}, finite difference {:e}",
                kind,
                n,
                row,
                col,
                exact,
                fd
            );
        }
    }
    Ok(())
}

/// `s` with every tensioned cable's hole positions as shooting unknowns.
fn exact(s: SolverSettings) -> SolverSettings {
    SolverSettings {
        cable_coupling: CableCoupling::Exact,
        ..s
    }
}

fn adaptive_fd() -> SolverSettings {
    adaptive(1e-12)
}

/// Fixed case counts; failures are persisted to `proptest-regressions/forward_jacobian.txt`
/// (replayed first on the next run; commit that file).
fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(
            "proptest-regressions/forward_jacobian.txt",
        ))),
        ..ProptestConfig::with_cases(cases)
    }
}

proptest! {
    #![proptest_config(config(24))]

    #[test]
    fn plain_rod_world_loads_three_unknowns(c in case()) {
        check(Kind::PlainWorld, &c, rk4(24), Some(3))?;
        check(Kind::PlainWorld, &c, adaptive_fd(), Some(3))?;
    }

    #[test]
    fn plain_rod_body_frame_load_six_unknowns(c in case()) {
        check(Kind::PlainBody, &c, rk4(24), Some(6))?;
        check(Kind::PlainBody, &c, adaptive_fd(), Some(6))?;
    }

}

proptest! {
    // 42 unknowns: fewer cases
    #![proptest_config(config(12))]

    #[test]
    fn five_guide_robot_with_tensions(c in case()) {
        // exact coupling: 6 + 3 cables x 4 downstream disks x 3 coordinates
        check(Kind::FiveGuide, &c, exact(rk4(24)), Some(42))?;
        check(Kind::FiveGuide, &c, exact(adaptive_fd()), Some(42))?;
        // condensed coupling: the base wrench only, hole positions settled per segment
        check(Kind::FiveGuide, &c, rk4(24), Some(6))?;
        check(Kind::FiveGuide, &c, adaptive_fd(), Some(6))?;
    }
}

proptest! {
    // 96 unknowns: fewer cases still
    #![proptest_config(config(4))]

    #[test]
    fn two_section_robot_with_tensions_in_both_sections(c in case()) {
        // exact coupling: 6 + 3 cables x 3 x 3 (section 0) + 3 cables x 7 x 3 (section 1)
        check(Kind::TwoSection, &c, exact(rk4(24)), Some(96))?;
        check(Kind::TwoSection, &c, exact(adaptive_fd()), Some(96))?;
        // condensed: six tensioned cables pass the disks of section 0 (18 local directions)
        check(Kind::TwoSection, &c, rk4(24), Some(6))?;
        check(Kind::TwoSection, &c, adaptive_fd(), Some(6))?;
    }
}
