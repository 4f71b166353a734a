//! The estimator on every rung of the model ladder (constant curvature, piecewise
//! constant curvature, rods), through `Estimator::on_rung`.
//!
//! Tolerances, each with its source:
//! * round trips (loads -> a rung's forward model -> length changes -> the estimator
//!   on the same rung): 1e-6 relative (+1e-9 absolute), the estimator's step
//!   tolerance is 1e-10 and the curvature rungs' fixed points converge to 1e-12..1e-13,
//!   so only conditioning (about 1e3 here) stands between them;
//! * exact sensitivities against central differences of the rung's own forward solve
//!   with step `h = 1e-4 |scale|`: truncation O(h^2 f''') ~ 1e-8 relative plus the
//!   fixed point's tolerance over h (1e-12 / 1e-4 = 1e-8 of the lengths' scale):
//!   agreement to 1e-6 relative of the largest entry;
//! * CC/PCC against Cosserat under pure tip torques without gravity: the Cosserat
//!   solution is then the same arc per section (n = 0 gives v = e3 and m constant
//!   in the body frame, thesis eqs. 2.9-2.12; the ladder's closed-form case), so the
//!   three estimates agree up to the reference integration error (adaptive 1e-10):
//!   1e-6 relative;
//! * CC against Cosserat under pure cable moments without gravity: CC is the dense-disk
//!   limit, so the gap must shrink at second order in the disk spacing (measured,
//!   see the test).

mod common;

mod alloc_counter;
use alloc_counter::allocations;
use cablesense::estimate::{
    Axis, EstimateSpec, EstimateStatus, Estimator, Method, UnknownKind, UnknownSpec,
};
use cablesense::ladder::{
    CcSettings, ConstantCurvature, ForwardModel, PccSettings, PiecewiseConstantCurvature, Rung,
};
use cablesense::statics::ParamSite;
use cablesense::{Frame, GuideMass, Integrator, Loads, PointLoad, Robot, RodModel};
use cablesense::{SolverSettings, Start};
use common::two_section_robot;

// ---------------------------------------------------------------------------
// Allocation counter (thread-local switch, so parallel tests are not counted).

// ---------------------------------------------------------------------------
// Problems.

fn unknown(kind: UnknownKind, section: Option<usize>, axis: Option<Axis>) -> UnknownSpec {
    UnknownSpec {
        section,
        axis,
        ..UnknownSpec::new(kind)
    }
}

fn tension(cable: usize) -> UnknownSpec {
    UnknownSpec {
        cable: Some(cable),
        ..unknown(UnknownKind::Tension, None, None)
    }
}

/// Known loads: gravity across the rod (it stands along +z), a follower torque on
/// section 0 and a tension on cable 4 (ends on section 1).
fn known_loads() -> Loads {
    Loads {
        gravity_m_s2: [0.0, -9.81, 0.0],
        point: vec![PointLoad {
            section: 0,
            torque_nm: [0.0, 1e-3, 0.0],
            frame: Frame::Body,
            ..Default::default()
        }],
        tensions_n: vec![0.0, 0.0, 0.0, 0.0, 0.4, 0.0],
    }
}

/// Tip force x and y, payload mass at the end of section 0 (at the tip it would be
/// the same as a tip force along gravity), tension of cable 3.
fn unknowns() -> Vec<UnknownSpec> {
    vec![
        unknown(UnknownKind::Force, Some(1), Some(Axis::X)),
        unknown(UnknownKind::Force, Some(1), Some(Axis::Y)),
        unknown(UnknownKind::Mass, Some(0), None),
        tension(3),
    ]
}

const TRUTH: [f64; 4] = [0.03, -0.02, 4e-3, 1.2];

/// `loads` with the unknowns at `theta`, applied independently of the estimator: a
/// new world-frame point load at each section end, payloads and tensions added.
fn loads_at(loads: &Loads, unknowns: &[UnknownSpec], theta: &[f64]) -> Loads {
    let mut out = loads.clone();
    for (u, &v) in unknowns.iter().zip(theta) {
        match u.kind {
            UnknownKind::Tension => {
                let j = u.cable.unwrap();
                if out.tensions_n.len() <= j {
                    out.tensions_n.resize(j + 1, 0.0);
                }
                out.tensions_n[j] += v;
            }
            kind => {
                let mut p = PointLoad {
                    section: u.section.unwrap(),
                    ..Default::default()
                };
                let a = match u.axis {
                    Some(Axis::X) => 0,
                    Some(Axis::Y) => 1,
                    _ => 2,
                };
                match kind {
                    UnknownKind::Force => p.force_n[a] = v,
                    UnknownKind::Torque => p.torque_nm[a] = v,
                    _ => p.mass_kg = v,
                }
                out.point.push(p);
            }
        }
    }
    out
}

fn curvature_rungs() -> Vec<Rung> {
    vec![
        Rung::ConstantCurvature(CcSettings::default()),
        Rung::PiecewiseConstantCurvature(PccSettings {
            pieces_per_section: 8,
            guide_mass: GuideMass::Point,
            ..PccSettings::default()
        }),
    ]
}

/// Lengths of `rung`'s forward model at `loads` (cold start, must converge).
fn lengths(robot: &Robot, rung: &Rung, loads: &Loads) -> Vec<f64> {
    let mut m = rung.build(robot).expect("rung builds");
    let rep = m.solve(loads, Start::Cold).expect("valid loads");
    assert!(rep.status.is_converged(), "{}: {rep:?}", rung.label());
    let mut l = vec![0.0; robot.cables().len()];
    m.cable_lengths_into(&mut l);
    l
}

fn changes(
    robot: &Robot,
    rung: &Rung,
    loads: &Loads,
    unknowns: &[UnknownSpec],
    theta: &[f64],
) -> Vec<f64> {
    let zero = vec![0.0; theta.len()];
    let l0 = lengths(robot, rung, &loads_at(loads, unknowns, &zero));
    let l1 = lengths(robot, rung, &loads_at(loads, unknowns, theta));
    l1.iter().zip(&l0).map(|(a, b)| a - b).collect()
}

fn close(got: &[f64], want: &[f64], rel: f64, abs: f64) -> Result<(), String> {
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        if !(g.is_finite() && (g - w).abs() <= abs + rel * w.abs()) {
            return Err(format!(
                "[{i}]: got {g:e}, want {w:e} (|diff| {:e}); all: {got:?} vs {want:?}",
                (g - w).abs()
            ));
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// Tests.

#[test]
fn round_trip_on_each_curvature_rung() {
    let robot = two_section_robot();
    let loads = known_loads();
    let unk = unknowns();
    for rung in curvature_rungs() {
        let ch = changes(&robot, &rung, &loads, &unk, &TRUTH);
        for method in [
            Method::LevenbergMarquardt,
            Method::GaussNewton,
            Method::Constrained,
            Method::ArgminGaussNewton,
        ] {
            let mut spec = EstimateSpec::new(unk.clone());
            spec.method = method;
            spec.max_iterations = 50;
            if method == Method::ArgminGaussNewton {
                // argmin's plain Gauss-Newton (no damping, no line search) overshoots
                // from 0 into loads where PCC has no nearby equilibrium (force_y and
                // the payload below it are nearly collinear): as in offline use, it
                // starts from a rough guess, half the truth
                for (u, t) in spec.unknowns.iter_mut().zip(TRUTH) {
                    u.initial = 0.5 * t;
                }
            }
            let mut est = Estimator::on_rung(robot.clone(), loads.clone(), &rung, spec)
                .expect("estimator builds");
            let st = est.tick(&ch, None);
            let what = format!("{} {method:?}", rung.label());
            assert_eq!(st, EstimateStatus::Converged, "{what}");
            if let Err(e) = close(est.theta(), &TRUTH, 1e-6, 1e-9) {
                panic!("{what}: {e}");
            }
            let e = est.estimate();
            assert_eq!(e.rank, 4, "{what}: rank");
            assert!(
                e.std_dev.iter().all(|s| s.is_finite() && *s > 0.0),
                "{what}: std dev {:?}",
                e.std_dev
            );
            // the estimated shape is the rung's shape at the true loads
            let mut m = rung.build(&robot).unwrap();
            m.solve(&loads_at(&loads, &unk, &TRUTH), Start::Cold)
                .unwrap();
            let d = (e.tip.position - m.tip_position()).norm();
            assert!(d < 1e-9, "{what}: tip off by {d:e} m");
        }
    }
}

/// Solve at the loads, then sensitivities and lengths (as a rung's methods do).
type SolveAndDiff = dyn FnMut(&Loads, &mut [f64], &mut [f64]) -> bool;

/// Exact sensitivities of each curvature rung against central differences of its
/// own forward solve, at a loaded point with every kind of parameter site (world
/// forces, a follower-load section, payload, a tensioned and a slack cable).
#[test]
fn curvature_sensitivities_match_central_differences() {
    let robot = two_section_robot();
    let mut loads = loads_at(&known_loads(), &unknowns(), &TRUTH);
    // parameters act on the world-frame tip load (index 1) and on the tensions
    let params = [
        ParamSite::Force { point: 1, axis: 0 },
        ParamSite::Force { point: 2, axis: 1 },
        ParamSite::Torque { point: 1, axis: 2 },
        ParamSite::Mass { point: 3 },
        ParamSite::Tension { cable: 3 },
        ParamSite::Tension { cable: 0 },
        ParamSite::Torque { point: 1, axis: 0 },
    ];
    let scale = [0.03, 0.02, 1e-3, 4e-3, 1.2, 1.0, 1e-3];
    loads.point[1].torque_nm = [2e-3, 0.0, 1e-3];
    let nc = robot.cables().len();
    let p = params.len();
    let perturbed = |k: usize, h: f64| {
        let mut l = loads.clone();
        match params[k] {
            ParamSite::Force { point, axis } => l.point[point].force_n[axis] += h,
            ParamSite::Torque { point, axis } => l.point[point].torque_nm[axis] += h,
            ParamSite::Mass { point } => l.point[point].mass_kg += h,
            ParamSite::Tension { cable } => l.tensions_n[cable] += h,
        }
        l
    };
    let cc = ConstantCurvature::new(robot.clone(), CcSettings::default()).unwrap();
    let pcc = PiecewiseConstantCurvature::new(
        robot.clone(),
        PccSettings {
            pieces_per_section: 6,
            ..PccSettings::default()
        },
    )
    .unwrap();
    let mut models: Vec<(&str, Box<SolveAndDiff>)> = vec![];
    let mut cc = cc;
    models.push((
        "cc",
        Box::new(move |l: &Loads, g: &mut [f64], len: &mut [f64]| {
            assert!(cc.solve(l, Start::Cold).unwrap().status.is_converged());
            cc.length_sensitivities(&params, g, len)
        }),
    ));
    let mut pcc = pcc;
    models.push((
        "pcc",
        Box::new(move |l: &Loads, g: &mut [f64], len: &mut [f64]| {
            assert!(pcc.solve(l, Start::Cold).unwrap().status.is_converged());
            pcc.length_sensitivities(&params, g, len)
        }),
    ));
    for (name, f) in models.iter_mut() {
        let mut g = vec![0.0; nc * p];
        let mut len = vec![0.0; nc];
        assert!(f(&loads, &mut g, &mut len), "{name}: sensitivities");
        let mut scratch = vec![0.0; nc * p];
        for k in 0..p {
            let h = 1e-4 * scale[k];
            let (mut lp, mut lm) = (vec![0.0; nc], vec![0.0; nc]);
            let fd: Vec<f64> = if matches!(params[k], ParamSite::Tension { cable: 0 }) {
                // a slack cable (tension 0) has only the one-sided derivative:
                // second-order forward difference (-3 f(0) + 4 f(h) - f(2h)) / (2h)
                let mut l0 = vec![0.0; nc];
                assert!(f(&perturbed(k, 0.0), &mut scratch, &mut l0));
                assert!(f(&perturbed(k, h), &mut scratch, &mut lp));
                assert!(f(&perturbed(k, 2.0 * h), &mut scratch, &mut lm));
                (0..nc)
                    .map(|j| (-3.0 * l0[j] + 4.0 * lp[j] - lm[j]) / (2.0 * h))
                    .collect()
            } else {
                assert!(f(&perturbed(k, h), &mut scratch, &mut lp));
                assert!(f(&perturbed(k, -h), &mut scratch, &mut lm));
                (0..nc).map(|j| (lp[j] - lm[j]) / (2.0 * h)).collect()
            };
            let exact: Vec<f64> = (0..nc).map(|j| g[j * p + k]).collect();
            let big = fd.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            assert!(big > 0.0, "{name}: parameter {k} moves no cable");
            if let Err(e) = close(&exact, &fd, 0.0, 1e-6 * big) {
                panic!("{name}: d lengths / d {:?}: {e}", params[k]);
            }
        }
    }
}

/// Bounds hold on every curvature rung and method: tension 3 is capped below its
/// true value and the payload may not go negative (its truth is 0).
#[test]
fn bounds_hold_on_curvature_rungs() {
    let robot = two_section_robot();
    let loads = known_loads();
    let mut unk = unknowns();
    unk[3].max = Some(0.8);
    let truth = [0.03, -0.02, 0.0, 1.2];
    for rung in curvature_rungs() {
        let ch = changes(&robot, &rung, &loads, &unk, &truth);
        for method in [
            Method::LevenbergMarquardt,
            Method::GaussNewton,
            Method::Constrained,
        ] {
            let mut spec = EstimateSpec::new(unk.clone());
            spec.method = method;
            spec.max_iterations = 50;
            let mut est = Estimator::on_rung(robot.clone(), loads.clone(), &rung, spec)
                .expect("estimator builds");
            let st = est.tick(&ch, None);
            let th = est.theta().to_vec();
            let what = format!("{} {method:?}: {st:?} {th:?}", rung.label());
            assert!(th[2] >= 0.0, "{what}: mass below 0");
            assert!(th[3] <= 0.8, "{what}: tension above its max");
            // the data pull the tension above its cap: it ends on the bound
            assert!(
                (th[3] - 0.8).abs() < 1e-9,
                "{what}: tension not at its bound"
            );
            assert!(
                !matches!(st, EstimateStatus::ForwardFailed | EstimateStatus::NoData),
                "{what}"
            );
        }
    }
}

/// Under pure tip torques without gravity CC and PCC are exact (see the module
/// docs): their estimates from Cosserat-generated lengths equal the Cosserat
/// estimator's and the truth.
#[test]
fn curvature_estimates_match_cosserat_under_pure_moments() {
    let robot = two_section_robot();
    let loads = Loads::none();
    let unk = vec![
        unknown(UnknownKind::Torque, Some(1), Some(Axis::X)),
        unknown(UnknownKind::Torque, Some(1), Some(Axis::Y)),
    ];
    let truth = [4e-3, -2.5e-3];
    let cosserat = Rung::Rod(SolverSettings {
        rod_model: RodModel::Cosserat,
        integrator: Integrator::Adaptive {
            tol: 1e-10,
            max_steps: 100_000,
        },
        tolerance: 1e-11,
        ..SolverSettings::default()
    });
    let ch = changes(&robot, &cosserat, &loads, &unk, &truth);
    let mut results = Vec::new();
    for rung in [
        cosserat.clone(),
        Rung::ConstantCurvature(CcSettings::default()),
        Rung::PiecewiseConstantCurvature(PccSettings::default()),
    ] {
        let mut est = Estimator::on_rung(
            robot.clone(),
            loads.clone(),
            &rung,
            EstimateSpec::new(unk.clone()),
        )
        .expect("estimator builds");
        let st = est.tick(&ch, None);
        assert_eq!(st, EstimateStatus::Converged, "{}", rung.label());
        results.push((rung.label(), est.theta().to_vec()));
    }
    for (label, th) in &results {
        if let Err(e) = close(th, &truth, 1e-6, 0.0) {
            panic!("{label} against the truth: {e}");
        }
        if let Err(e) = close(th, &results[0].1, 1e-6, 0.0) {
            panic!("{label} against {}: {e}", results[0].0);
        }
    }
}

/// A warm tick on a curvature rung allocates nothing once the estimator has seen a
/// sample (sensitivity buffers are built on the first use).
#[test]
fn curvature_ticks_do_not_allocate() {
    let robot = two_section_robot();
    let loads = known_loads();
    let unk = unknowns();
    for rung in curvature_rungs() {
        let mut spec = EstimateSpec::new(unk.clone());
        spec.reuse_jacobian = false;
        let mut est = Estimator::on_rung(robot.clone(), loads.clone(), &rung, spec).unwrap();
        let samples: Vec<Vec<f64>> = (1..=4)
            .map(|k| {
                let th: Vec<f64> = TRUTH.iter().map(|t| t * k as f64 / 4.0).collect();
                changes(&robot, &rung, &loads, &unk, &th)
            })
            .collect();
        est.tick(&samples[0], None);
        let mut statuses = Vec::with_capacity(8);
        let n = allocations(|| {
            for s in &samples[1..] {
                statuses.push(est.tick(s, None));
            }
        });
        assert_eq!(n, 0, "{}: {n} allocations in 3 ticks", rung.label());
        assert!(
            statuses.iter().all(|s| *s == EstimateStatus::Converged),
            "{}: {statuses:?}",
            rung.label()
        );
    }
}

/// Invalid rung settings are an error naming the field, not a panic.
#[test]
fn invalid_rung_settings_are_named() {
    let robot = two_section_robot();
    let rung = Rung::PiecewiseConstantCurvature(PccSettings {
        pieces_per_section: 0,
        ..PccSettings::default()
    });
    let err = Estimator::on_rung(robot, Loads::none(), &rung, EstimateSpec::new(unknowns()))
        .err()
        .expect("rejected");
    assert!(err.to_string().contains("pcc.pieces_per_section"), "{err}");
}

/// One 0.3 m section with `disks` evenly spaced disks (the last one `spacing / 2`
/// from the tip) and three cables tied to the last disk.
fn disk_robot(disks: usize) -> Robot {
    let length = 0.3;
    let spacing = length / disks as f64;
    let mut s = common::section(length, 1.56e-3);
    s.guides = Some(common::guides(disks, 0.5 * spacing, spacing));
    Robot::new(cablesense::RobotSpec {
        limits: None,
        base: Default::default(),
        sections: vec![s],
        cables: (0..3)
            .map(|h| cablesense::robot::CableSpec {
                name: None,
                hole: Some(h),
                end_section: 0,
                ..Default::default()
            })
            .collect(),
        tendons: None,
        friction: None,
    })
    .expect("valid robot")
}

/// Pure cable moments without gravity: CC's cable moment `T (e3 x d)` is the limit
/// of dense disks (module docs of `ladder::cc`), so the CC tension estimate from
/// Cosserat-generated lengths approaches the Cosserat estimate as the disks get
/// denser. Measured here: relative gaps 2.2e-2, 5.6e-3, 1.4e-3, 3.6e-4 at 5, 10, 20,
/// 40 disks, i.e. second order in the disk spacing (ratio 3.9-4.0 per halving; the
/// chords cut the arc with a sagitta O(h^2)). Asserted: ratios within 3..5 per
/// halving and the gap below 1e-3 at 40 disks; the Cosserat estimator recovers the
/// truth to 1e-6 relative on every robot.
#[test]
fn cc_tension_estimate_approaches_cosserat_with_dense_disks() {
    let cosserat = Rung::Rod(SolverSettings {
        rod_model: RodModel::Cosserat,
        integrator: Integrator::Adaptive {
            tol: 1e-10,
            max_steps: 100_000,
        },
        tolerance: 1e-11,
        ..SolverSettings::default()
    });
    let unk = vec![tension(0), tension(1)];
    let truth = [1.0, 0.4];
    let mut gaps = Vec::new();
    for disks in [5, 10, 20, 40] {
        let robot = disk_robot(disks);
        let ch = changes(&robot, &cosserat, &Loads::none(), &unk, &truth);
        let mut est = Vec::new();
        for rung in [
            cosserat.clone(),
            Rung::ConstantCurvature(CcSettings::default()),
        ] {
            let mut e = Estimator::on_rung(
                robot.clone(),
                Loads::none(),
                &rung,
                EstimateSpec::new(unk.clone()),
            )
            .expect("estimator builds");
            e.tick(&ch, None);
            est.push(e.theta().to_vec());
        }
        if let Err(e) = close(&est[0], &truth, 1e-6, 0.0) {
            panic!("cosserat with {disks} disks: {e}");
        }
        let gap = (0..2)
            .map(|k| ((est[1][k] - est[0][k]) / est[0][k]).abs())
            .fold(0.0f64, f64::max);
        gaps.push(gap);
    }
    for w in gaps.windows(2) {
        let ratio = w[0] / w[1];
        assert!(
            (3.0..5.0).contains(&ratio),
            "gap ratio per halving of the disk spacing {ratio} (gaps {gaps:?})"
        );
    }
    assert!(gaps[3] < 1e-3, "gaps {gaps:?}");
}
