//! Continuous tendon routing (Rucker & Webster 2011, `src/statics/pass/continuous.rs`):
//! Till's example robot, the disk model's convergence to it, the constant-curvature
//! closed form of a straight tendon, a helical tendon against an independent
//! integration, exact Jacobians, and bad scene fields.

use cablesense::nalgebra::{Matrix3, Matrix6, Vector3, Vector6};
use cablesense::robot::{CableSpec, GuideSpec, HolesSpec, PathSpec, RobotSpec, SectionSpec};
use cablesense::statics::ParamSite;
use cablesense::{
    CrossSection, Integrator, Loads, Material, Robot, RodModel, Scene, SolverSettings, Start,
    Workspace,
};

const TILL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/data/scenes/till_tendon_robot.toml"
);

fn till() -> Scene {
    Scene::load(TILL).unwrap()
}

fn rk4(steps: usize) -> SolverSettings {
    SolverSettings {
        integrator: Integrator::Rk4 {
            steps_per_section: steps,
        },
        ..SolverSettings::default()
    }
}

fn solve_tip(robot: Robot, loads: &Loads, settings: SolverSettings) -> Vector3<f64> {
    let mut ws = Workspace::new(robot, loads.clone(), settings).unwrap();
    let rep = ws.solve(Start::Cold);
    assert!(rep.status.is_converged(), "{rep:?}");
    ws.tip_position()
}

/// Till's rod (0.5 m steel, r = 1 mm) with `cables`, optionally with disks.
fn till_spec(guides: Option<GuideSpec>, cables: Vec<CableSpec>) -> RobotSpec {
    RobotSpec {
        limits: None,
        base: Default::default(),
        sections: vec![SectionSpec {
            length_m: 0.5,
            shape: CrossSection::Solid { diameter_m: 2e-3 },
            material: Material {
                youngs_modulus_pa: 200e9,
                poisson_ratio: 0.25,
                density_kg_m3: 8000.0,
            },
            shear_coefficient: 1.0,
            precurvature_per_m: [0.0; 3],
            guides,
        }],
        cables,
        tendons: None,
        friction: None,
    }
}

/// Till's robot emulated with `n` massless point disks (holes at the tendons'
/// 15.06 mm), the four tendons through them.
fn till_disks(n: usize) -> Robot {
    let h = 0.5 / n as f64;
    let guides = GuideSpec {
        count: n,
        first_offset_m: h,
        spacing_m: h,
        thickness_m: 0.0,
        diameter_m: 0.04,
        mass_kg: 0.0,
        holes: HolesSpec {
            radius_m: 0.01506,
            angles_deg: vec![0.0, 90.0, 180.0, 270.0],
        },
        even: Default::default(),
    };
    let cables = (0..4).map(|k| CableSpec::through_hole(k, 0)).collect();
    Robot::new(till_spec(Some(guides), cables)).unwrap()
}

fn continuous(path: PathSpec) -> CableSpec {
    CableSpec {
        continuous: true,
        path: Some(path),
        ..CableSpec::default()
    }
}

/// Source: issue 11 (Till's ContinuumRobotExamples 05_Tendon_Robot, solved
/// continuously by the issue's author). Tolerance 1 um. The shipped 16 RK4 steps are
/// within 2e-8 m of 512 steps (integration error: 1.0e-8 m seen; 32 steps 6e-10 m).
#[test]
fn till_tip_within_1um_of_reference() {
    let sc = till();
    let tip = solve_tip(sc.build_robot().unwrap(), &sc.loads, sc.numerics.clone());
    let reference = Vector3::new(0.1822116, 0.0, 0.4532293);
    assert!((tip - reference).norm() < 1e-6, "tip {tip:?}");
    let fine = solve_tip(sc.build_robot().unwrap(), &sc.loads, rk4(512));
    assert!(
        (tip - fine).norm() < 2e-8,
        "16 vs 512 steps: {}",
        (tip - fine).norm()
    );
}

/// The disk model (straight chords between `n` point disks, thesis 3.8.1) approaches
/// the continuous one with order 2 in the disk spacing (issue 11: 31 um at 100 disks,
/// 8 um at 200). Asserted: both error ratios 100/200 and 200/400 within 4 +- 0.5
/// (observed order 2 +- 0.17), and 400 disks within 3 um.
#[test]
fn disk_model_converges_to_continuous_with_order_two() {
    let sc = till();
    let reference = solve_tip(sc.build_robot().unwrap(), &sc.loads, rk4(512));
    let mut errors = Vec::new();
    for n in [100usize, 200, 400] {
        let tip = solve_tip(till_disks(n), &sc.loads, rk4(n));
        errors.push((tip - reference).norm());
    }
    let (r1, r2) = (errors[0] / errors[1], errors[1] / errors[2]);
    eprintln!("disk errors {errors:?} m, ratios {r1:.3} {r2:.3}");
    assert!(
        (r1 - 4.0).abs() < 0.5 && (r2 - 4.0).abs() < 0.5,
        "ratios {r1} {r2}"
    );
    assert!(errors[2] < 3e-6, "{errors:?}");
}

/// A straight tendon without gravity is an exact arc in the Rucker-Webster model:
/// the rod carries `n_b = -tau e3`, `m_b = -tau r x e3` everywhere (the tendon's
/// tangent stays along `e3`), so `u = tau |r| / EI` about the axis normal to `r`,
/// `v = (1 - tau/EA) e3`; tip `(v3/k (1 - cos kL), 0, v3/k sin kL)`; the tendon
/// length is `L (v3 - k |r|)` and the opposite one's `L (v3 + k |r|)`.
/// Tolerance 1e-9 m (RK4 with 256 steps), Cosserat and Kirchhoff rods.
#[test]
fn straight_tendon_without_gravity_is_an_exact_arc() {
    let r = 0.01;
    let cables = vec![
        continuous(PathSpec::Straight {
            radius_m: r,
            angle_deg: 0.0,
        }),
        continuous(PathSpec::Straight {
            radius_m: r,
            angle_deg: 180.0,
        }),
    ];
    let robot = Robot::new(till_spec(None, cables)).unwrap();
    let (ei, ea) = (
        200e9 * std::f64::consts::PI * 1e-12 / 4.0,
        200e9 * std::f64::consts::PI * 1e-6,
    );
    let tau = 4.0;
    let loads = Loads {
        gravity_m_s2: [0.0; 3],
        tensions_n: vec![tau, 0.0],
        ..Loads::default()
    };
    for kirchhoff in [false, true] {
        let mut settings = rk4(256);
        if kirchhoff {
            settings.rod_model = RodModel::Kirchhoff;
        }
        let mut ws = Workspace::new(robot.clone(), loads.clone(), settings).unwrap();
        assert!(ws.solve(Start::Cold).status.is_converged());
        let k = tau * r / ei;
        let v3 = if kirchhoff { 1.0 } else { 1.0 - tau / ea };
        let expect = Vector3::new(
            v3 / k * (1.0 - (k * 0.5).cos()),
            0.0,
            v3 / k * (k * 0.5).sin(),
        );
        let tip = ws.tip_position();
        assert!(
            (tip - expect).norm() < 1e-9,
            "kirchhoff {kirchhoff}: {tip:?} vs {expect:?}"
        );
        let mut l = [0.0; 2];
        ws.cable_lengths_into(&mut l);
        assert!((l[0] - 0.5 * (v3 - k * r)).abs() < 1e-10, "{l:?}");
        assert!((l[1] - 0.5 * (v3 + k * r)).abs() < 1e-10, "{l:?}");
    }
}

fn helical_robot() -> (Robot, Loads) {
    let cables = vec![
        continuous(PathSpec::Helical {
            radius_m: 0.012,
            start_angle_deg: 20.0,
            pitch_m_per_turn: Some(0.6),
            rate_rad_per_m: None,
        }),
        continuous(PathSpec::Straight {
            radius_m: 0.012,
            angle_deg: 200.0,
        }),
    ];
    let robot = Robot::new(till_spec(None, cables)).unwrap();
    let loads = Loads {
        gravity_m_s2: [0.0, -9.81, 0.0],
        tensions_n: vec![6.0, 1.5],
        ..Loads::default()
    };
    (robot, loads)
}

/// An independent solution in a different formulation: Rucker & Webster's own state
/// `(p, R, v, u)` (as in Till's example), the 6 x 6 system of RW eq. 16 solved by
/// nalgebra's LU, 4000 RK4 steps without re-orthonormalisation, the tip wrench
/// balance of RW eqs. 18-20, and a shooting Newton with a finite-difference
/// Jacobian on `(n_b(0), u(0))`.
fn independent_tip(taus: [f64; 2], gravity: Vector3<f64>, start: Vector6<f64>) -> Vector3<f64> {
    let (e, g, rad, rho, len) = (200e9, 80e9, 1e-3, 8000.0, 0.5);
    let pi = std::f64::consts::PI;
    let (area, inertia) = (pi * rad * rad, pi * rad.powi(4) / 4.0);
    let kse = Matrix3::from_diagonal(&Vector3::new(g * area, g * area, e * area));
    let kbt = Matrix3::from_diagonal(&Vector3::new(e * inertia, e * inertia, 2.0 * g * inertia));
    let f = gravity * rho * area;
    let w = 2.0 * pi / 0.6;
    let route = |i: usize, s: f64| -> [Vector3<f64>; 3] {
        let rr = 0.012;
        if i == 0 {
            let a = 20f64.to_radians() + w * s;
            [
                rr * Vector3::new(a.cos(), a.sin(), 0.0),
                rr * w * Vector3::new(-a.sin(), a.cos(), 0.0),
                -rr * w * w * Vector3::new(a.cos(), a.sin(), 0.0),
            ]
        } else {
            let a = 200f64.to_radians();
            [
                rr * Vector3::new(a.cos(), a.sin(), 0.0),
                Vector3::zeros(),
                Vector3::zeros(),
            ]
        }
    };
    type Y = (Vector3<f64>, Matrix3<f64>, Vector3<f64>, Vector3<f64>);
    let ode = |s: f64, y: &Y| -> Y {
        let (_, rm, v, u) = *y;
        let mut k = Matrix6::zeros();
        k.fixed_view_mut::<3, 3>(0, 0).copy_from(&kse);
        k.fixed_view_mut::<3, 3>(3, 3).copy_from(&kbt);
        let (mut a, mut b) = (Vector3::zeros(), Vector3::zeros());
        for (i, tau) in taus.iter().enumerate() {
            let [r, r1, r2] = route(i, s);
            let pb = u.cross(&r) + v + r1;
            let nn = pb.norm();
            let ai = -pb.cross_matrix() * pb.cross_matrix() * (tau / nn.powi(3));
            let gi = -ai * r.cross_matrix();
            let av = ai * (u.cross(&pb) + u.cross(&r1) + r2);
            a += av;
            b += r.cross(&av);
            let mut blk = k.fixed_view_mut::<3, 3>(0, 0);
            blk += ai;
            let mut blk = k.fixed_view_mut::<3, 3>(0, 3);
            blk += gi;
            let mut blk = k.fixed_view_mut::<3, 3>(3, 0);
            blk += gi.transpose();
            let mut blk = k.fixed_view_mut::<3, 3>(3, 3);
            blk += r.cross_matrix() * gi;
        }
        let nb = kse * (v - Vector3::z());
        let mb = kbt * u;
        let top = -u.cross(&nb) - rm.transpose() * f - a;
        let bot = -u.cross(&mb) - v.cross(&nb) - b;
        let sol = k
            .lu()
            .solve(&Vector6::new(top.x, top.y, top.z, bot.x, bot.y, bot.z))
            .unwrap();
        (
            rm * v,
            rm * u.cross_matrix(),
            sol.fixed_rows::<3>(0).into(),
            sol.fixed_rows::<3>(3).into(),
        )
    };
    let add = |y: &Y, k: &Y, h: f64| -> Y {
        (y.0 + k.0 * h, y.1 + k.1 * h, y.2 + k.2 * h, y.3 + k.3 * h)
    };
    let shoot = |x: &Vector6<f64>| -> (Vector6<f64>, Vector3<f64>) {
        let n0: Vector3<f64> = x.fixed_rows::<3>(0).into();
        let mut y: Y = (
            Vector3::zeros(),
            Matrix3::identity(),
            kse.try_inverse().unwrap() * n0 + Vector3::z(),
            x.fixed_rows::<3>(3).into(),
        );
        let steps = 4000;
        let h = len / steps as f64;
        for i in 0..steps {
            let s = i as f64 * h;
            let k1 = ode(s, &y);
            let k2 = ode(s + h / 2.0, &add(&y, &k1, h / 2.0));
            let k3 = ode(s + h / 2.0, &add(&y, &k2, h / 2.0));
            let k4 = ode(s + h, &add(&y, &k3, h));
            y = (
                y.0 + (k1.0 + k2.0 * 2.0 + k3.0 * 2.0 + k4.0) * (h / 6.0),
                y.1 + (k1.1 + k2.1 * 2.0 + k3.1 * 2.0 + k4.1) * (h / 6.0),
                y.2 + (k1.2 + k2.2 * 2.0 + k3.2 * 2.0 + k4.2) * (h / 6.0),
                y.3 + (k1.3 + k2.3 * 2.0 + k3.3 * 2.0 + k4.3) * (h / 6.0),
            );
        }
        let (_, _, v, u) = y;
        let mut fe = -kse * (v - Vector3::z());
        let mut me = -kbt * u;
        for (i, tau) in taus.iter().enumerate() {
            let [r, r1, _] = route(i, len);
            let fb = -(u.cross(&r) + v + r1).normalize() * *tau;
            fe += fb;
            me += r.cross(&fb);
        }
        // scaled like the library's residual: forces by EI/L^2, moments by EI/L
        let ei = e * inertia;
        let res = Vector6::new(fe.x, fe.y, fe.z, me.x, me.y, me.z)
            .component_mul(&Vector6::new(1.0, 1.0, 1.0, len, len, len))
            * (len * len / ei);
        (res, y.0)
    };
    let mut x = start;
    for _ in 0..30 {
        let (r0, _) = shoot(&x);
        if r0.amax() < 1e-12 {
            break;
        }
        let mut jac = Matrix6::zeros();
        for c in 0..6 {
            let d = 1e-6 * (1.0 + x[c].abs()) * if c < 3 { 1e3 } else { 1.0 };
            let (mut xp, mut xm) = (x, x);
            xp[c] += d;
            xm[c] -= d;
            jac.set_column(c, &((shoot(&xp).0 - shoot(&xm).0) / (2.0 * d)));
        }
        x -= jac.lu().solve(&r0).unwrap();
    }
    let (r0, tip) = shoot(&x);
    assert!(
        r0.amax() < 1e-11,
        "independent shooting residual {}",
        r0.amax()
    );
    tip
}

/// A helical tendon (one turn per 0.6 m) plus a straight one, under gravity: the tip
/// agrees with the independent formulation above within 1e-9 m (source: that
/// integration, 4000 RK4 steps; the library uses its adaptive DP5(4) at 1e-12).
#[test]
fn helical_tendon_matches_independent_integration() {
    let (robot, loads) = helical_robot();
    let settings = SolverSettings {
        integrator: Integrator::Adaptive {
            tol: 1e-12,
            max_steps: 100_000,
        },
        tolerance: 1e-12,
        ..SolverSettings::default()
    };
    let mut ws = Workspace::new(robot, loads, settings).unwrap();
    assert!(ws.solve(Start::Cold).status.is_converged());
    let tip = ws.tip_position();
    // start the independent Newton near the answer: (n_b(0), u(0) = m(0)/EI)
    let (n0, m0) = ws.base_wrench();
    let ei = 200e9 * std::f64::consts::PI * 1e-12 / 4.0;
    let gj = 2.0 * 80e9 * std::f64::consts::PI * 1e-12 / 4.0;
    let start = Vector6::new(n0.x, n0.y, n0.z, m0.x / ei, m0.y / ei, m0.z / gj) * 0.9;
    let other = independent_tip([6.0, 1.5], Vector3::new(0.0, -9.81, 0.0), start);
    eprintln!(
        "helical tip {tip:?}, independent {other:?}, diff {:e}",
        (tip - other).norm()
    );
    assert!((tip - other).norm() < 1e-9);
}

/// The dual-number Jacobian of the shooting residual, and the length sensitivities
/// to a tension parameter, agree with central differences (step 1e-6 scaled, tolerance
/// 1e-6 of the largest entry; and 1e-3 N on solves to 1e-13, tolerance 1e-5 relative:
/// the differences' truncation and solve error).
#[test]
fn exact_jacobian_and_tension_sensitivities_match_differences() {
    let (robot, loads) = helical_robot();
    let settings = SolverSettings {
        tolerance: 1e-13,
        ..rk4(64)
    };
    let mut ws =
        Workspace::with_params(robot, loads, settings, &[ParamSite::Tension { cable: 1 }]).unwrap();
    assert!(ws.solve(Start::Cold).status.is_converged());
    let x: Vec<f64> = ws.unknowns_vector().iter().map(|v| v + 0.01).collect();
    let n = x.len();
    let jac = ws.shooting_jacobian(&x).unwrap();
    let (mut rp, mut rm) = (vec![0.0; n], vec![0.0; n]);
    let scale = jac.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for c in 0..n {
        let (mut xp, mut xm) = (x.clone(), x.clone());
        xp[c] += 1e-6;
        xm[c] -= 1e-6;
        assert!(ws.shooting_residual(&xp, &mut rp) && ws.shooting_residual(&xm, &mut rm));
        for r in 0..n {
            let fd = (rp[r] - rm[r]) / 2e-6;
            assert!(
                (jac[r * n + c] - fd).abs() < 1e-6 * scale,
                "J[{r},{c}] {} vs {fd}",
                jac[r * n + c]
            );
        }
    }
    // dl/dT at the solution, against re-solved lengths at T +- 1e-4 N
    assert!(ws.solve(Start::Cold).status.is_converged());
    let (mut sens, mut lengths) = ([0.0; 2], [0.0; 2]);
    assert!(ws.length_sensitivities(&mut sens, &mut lengths));
    let mut at = |t: f64| {
        ws.set_theta(&[t]);
        assert!(ws.solve(Start::Warm).status.is_converged());
        let mut l = [0.0; 2];
        ws.cable_lengths_into(&mut l);
        l
    };
    let (lp, lm) = (at(1e-3), at(-1e-3));
    for j in 0..2 {
        let fd = (lp[j] - lm[j]) / 2e-3;
        assert!(
            (sens[j] - fd).abs() < 1e-5 * sens[j].abs(),
            "dl{j}/dT {} vs {fd}",
            sens[j]
        );
    }
}

/// A continuous tendon on a robot with disk-routed cables on another section: both
/// kinds solve together, and the continuous tendon's length is its path integral
/// (positive, shorter than the backbone on the side it bends towards).
#[test]
fn continuous_and_disk_cables_mix() {
    let text = r#"
        [[robot.sections]]
        length_m = 0.2
        shape = { solid = { diameter_m = 1.5e-3 } }
        youngs_modulus_pa = 60e9
        poisson_ratio = 0.3
        density_kg_m3 = 6500.0
        [robot.sections.guides]
        count = 4
        first_offset_m = 0.05
        spacing_m = 0.05
        thickness_m = 0.0
        diameter_m = 0.03
        mass_kg = 0.0
        holes = { radius_m = 0.01, angles_deg = [0, 120, 240] }
        [[robot.sections]]
        length_m = 0.2
        shape = { solid = { diameter_m = 1.2e-3 } }
        youngs_modulus_pa = 60e9
        poisson_ratio = 0.3
        density_kg_m3 = 6500.0
        [[robot.cables]]
        hole = 0
        end_section = 0
        [[robot.cables]]
        routing = "continuous"
        path = { table = { points_m = [[0.0, 0.0, 0.01], [0.2, 0.0, 0.01], [0.3, 0.005, 0.008], [0.4, 0.01, 0.0]] } }
        end_section = 1
        [loads]
        gravity_m_s2 = [0.0, 0.0, -9.81]
        tensions_n = [1.0, 0.8]
    "#;
    let sc = Scene::from_toml_str(text).unwrap();
    let mut ws = Workspace::new(
        sc.build_robot().unwrap(),
        sc.loads.clone(),
        sc.numerics.clone(),
    )
    .unwrap();
    let rep = ws.solve(Start::Cold);
    assert!(rep.status.is_converged(), "{rep:?}");
    let mut l = [0.0; 2];
    ws.cable_lengths_into(&mut l);
    assert!(l[1] > 0.3 && l[1] < 0.4, "{l:?}");
    let sol = ws.solution();
    assert_eq!(sol.cables[1].segments_m.len(), 1);
}

fn scene_error(cable: &str) -> String {
    let text = format!(
        r#"
        [[robot.sections]]
        length_m = 0.5
        shape = {{ solid = {{ diameter_m = 2e-3 }} }}
        youngs_modulus_pa = 200e9
        poisson_ratio = 0.25
        density_kg_m3 = 8000.0
        [robot.sections.guides]
        count = 2
        first_offset_m = 0.1
        spacing_m = 0.2
        thickness_m = 0.0
        diameter_m = 0.03
        mass_kg = 0.0
        holes = {{ radius_m = 0.01 }}
        [[robot.cables]]
        {cable}
        end_section = 0
        "#
    );
    match Scene::from_toml_str(&text) {
        Ok(sc) => sc
            .build_robot()
            .map(|_| String::new())
            .unwrap_or_else(|e| e.to_string()),
        Err(e) => e.to_string(),
    }
}

/// Bad continuous paths fail with the field and value named.
#[test]
fn bad_paths_name_the_field() {
    let cases = [
        (
            r#"routing = "continuous"
            path = { table = { points_m = [[0.0, 0.0, 0.01], [0.3, 0.0, 0.01], [0.2, 0.0, 0.01], [0.5, 0.0, 0.01]] } }"#,
            "robot.cables[0].path.table.points_m[2][0]",
        ),
        (
            r#"routing = "continuous"
            path = { table = { points_m = [[0.0, 0.0, 0.01], [0.4, 0.0, 0.01]] } }"#,
            "the cable runs over [0, 0.5] m",
        ),
        (
            r#"routing = "continuous"
            path = { straight = { radius_m = 0.02, angle_deg = 0.0 } }"#,
            "robot.cables[0].path.straight.radius_m = 0.02",
        ),
        (
            r#"routing = "continuous"
            path = { helical = { radius_m = 0.01, start_angle_deg = 0.0, pitch_m_per_turn = 0.0 } }"#,
            "robot.cables[0].path.helical.pitch_m_per_turn = 0",
        ),
        (
            r#"routing = "continuous"
            path = { helical = { radius_m = 0.01, start_angle_deg = 0.0, pitch_m_per_turn = 0.2, rate_rad_per_m = 3.0 } }"#,
            "exactly one of",
        ),
        (r#"routing = "continuous""#, "robot.cables[0].path"),
        (
            r#"path = { straight = { radius_m = 0.01, angle_deg = 0.0 } }
            hole = 0"#,
            "needs `routing = \"continuous\"`",
        ),
        (r#"routing = "continuus""#, "continuus"),
        (
            r#"routing = "continuous"
            path = { spiral = { radius_m = 0.01 } }"#,
            "spiral",
        ),
    ];
    for (cable, want) in cases {
        let err = scene_error(cable);
        assert!(err.contains(want), "{cable}: got {err:?}, want {want:?}");
    }
    // the disk forms keep working beside it
    assert_eq!(scene_error("hole = 1"), "");
    assert_eq!(
        scene_error("routing = { radius_m = 0.01, angle_deg = 45.0 }"),
        ""
    );
}

/// The estimator reads continuous tendons' length changes like disk cables': a tip
/// force (x, y) on Till's robot from the four tendons' changes (one tensioned, three
/// passive) comes back within `1e-8 + 1e-6 |F|` N (the estimate round-trip tolerance
/// of `tests/estimate_roundtrip.rs`: forward solves to 1e-10 scaled residual).
#[test]
fn estimator_recovers_a_tip_force_from_continuous_tendon_lengths() {
    use cablesense::estimate::{Axis, EstimateSpec, Estimator, UnknownSpec};
    use cablesense::PointLoad;
    let sc = till();
    let robot = sc.build_robot().unwrap();
    let lengths_at = |loads: &Loads| {
        let mut ws = Workspace::new(robot.clone(), loads.clone(), sc.numerics.clone()).unwrap();
        assert!(ws.solve(Start::Cold).status.is_converged());
        let mut l = [0.0; 4];
        ws.cable_lengths_into(&mut l);
        l
    };
    let reference = lengths_at(&sc.loads);
    let truth = [0.05, -0.03];
    let mut loaded = sc.loads.clone();
    loaded.point.push(PointLoad {
        section: 0,
        force_n: [truth[0], truth[1], 0.0],
        ..PointLoad::default()
    });
    let measured = lengths_at(&loaded);
    let changes: Vec<f64> = measured
        .iter()
        .zip(&reference)
        .map(|(a, b)| a - b)
        .collect();
    let spec = EstimateSpec::new(vec![
        UnknownSpec::force(0, Axis::X),
        UnknownSpec::force(0, Axis::Y),
    ]);
    let mut est =
        Estimator::new(robot.clone(), sc.loads.clone(), sc.numerics.clone(), spec).unwrap();
    let status = est.tick(&changes, None);
    let e = est.estimate();
    eprintln!("{status:?} {:?} changes {changes:?}", e.values);
    for (v, t) in e.values.iter().zip(truth) {
        assert!(
            (v - t).abs() < 1e-8 + 1e-6 * t.abs(),
            "{:?} vs {truth:?}",
            e.values
        );
    }
}

/// The curvature rungs on straight continuous tendons (`ladder::reject_continuous`).
/// Without gravity a straight tendon at radius `r` with tension `T` bends its section
/// into one arc of curvature `k = T r / EI` (Kirchhoff, no extension): the CC and
/// PCC tips equal `(1/k)(1 - cos kL), 0, (1/k) sin kL` rotated to the tendon's side,
/// and the tendon lengths are `L (1 -+ k r)` for the pulled and the opposite one
/// (1e-12 m: both rungs are exact there). Their length sensitivities to the tension
/// equal central differences (1e-7 relative, step 1e-3 N); with gravity, PCC
/// approaches the Kirchhoff rod rung at second order in the piece length (ratio of
/// the errors at 8 and 16 pieces per section within 4 +- 0.6, 32 pieces within 10 um).
/// A helical path is refused by both with the cable's field named.
#[test]
fn curvature_rungs_take_straight_continuous_tendons() {
    use cablesense::ladder::{
        CcSettings, ConstantCurvature, Differentiable, ForwardModel, PccSettings,
        PiecewiseConstantCurvature,
    };
    let sc = till();
    let robot = sc.build_robot().unwrap();
    let mut loads = sc.loads.clone();
    loads.gravity_m_s2 = [0.0; 3];
    let (t, r, len) = (15.0, 0.01506, 0.5);
    let ei = 200e9 * std::f64::consts::PI * 1e-12 / 4.0;
    let k = t * r / ei;
    // the tendon at angle 0 (+x) pulls the tip towards +x
    let exact = Vector3::new((1.0 - (k * len).cos()) / k, 0.0, (k * len).sin() / k);
    let pcc = |n: usize| PccSettings {
        pieces_per_section: n,
        ..PccSettings::default()
    };
    let mut cc = ConstantCurvature::new(robot.clone(), CcSettings::default()).unwrap();
    let mut pc = PiecewiseConstantCurvature::new(robot.clone(), pcc(8)).unwrap();
    let models: [&mut dyn Differentiable; 2] = [&mut cc, &mut pc];
    for m in models {
        assert!(m.solve(&loads, Start::Cold).unwrap().status.is_converged());
        let tip = m.tip_position();
        assert!((tip - exact).norm() < 1e-12, "{tip:?} vs {exact:?}");
        let mut l = [0.0; 4];
        m.cable_lengths_into(&mut l);
        let want = [len * (1.0 - k * r), len, len * (1.0 + k * r), len];
        for (a, b) in l.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "lengths {l:?} vs {want:?}");
        }
        // d l / d T against central differences
        let sites = [ParamSite::Tension { cable: 0 }];
        let (mut d, mut l0) = ([0.0; 4], [0.0; 4]);
        m.solve_params(&loads, &sites, &[0.0], Start::Cold).unwrap();
        assert!(m.length_sensitivities(&sites, &mut d, &mut l0));
        let h = 1e-3;
        let mut fd = [[0.0; 4]; 2];
        for (i, sgn) in [1.0, -1.0].into_iter().enumerate() {
            m.solve_params(&loads, &sites, &[sgn * h], Start::Cold)
                .unwrap();
            m.cable_lengths_into(&mut fd[i]);
        }
        for j in 0..4 {
            let c = (fd[0][j] - fd[1][j]) / (2.0 * h);
            assert!(
                (d[j] - c).abs() <= 1e-7 * c.abs().max(1e-6),
                "cable {j}: {} vs {c}",
                d[j]
            );
        }
    }
    // with gravity: PCC against the Kirchhoff rod rung
    let rod = solve_tip(
        robot.clone(),
        &sc.loads,
        SolverSettings {
            rod_model: RodModel::Kirchhoff,
            ..rk4(512)
        },
    );
    let err = |n: usize| {
        let mut m = PiecewiseConstantCurvature::new(robot.clone(), pcc(n)).unwrap();
        assert!(m
            .solve(&sc.loads, Start::Cold)
            .unwrap()
            .status
            .is_converged());
        (m.tip_position() - rod).norm()
    };
    let (e8, e16, e32) = (err(8), err(16), err(32));
    eprintln!("PCC vs Kirchhoff rod with gravity: {e8:.3e} {e16:.3e} {e32:.3e} m");
    assert!(
        (e8 / e16 - 4.0).abs() < 0.6 && e32 < 1e-5,
        "{e8} {e16} {e32}"
    );
    // a helical path is refused, naming the cable
    let text = std::fs::read_to_string(TILL).unwrap().replacen(
        "path = { straight = { radius_m = 0.01506, angle_deg = 90.0 } }",
        "path = { helical = { radius_m = 0.01506, start_angle_deg = 90.0, pitch_m_per_turn = 0.5 } }",
        1,
    );
    let helical = Scene::from_toml_str(&text).unwrap().build_robot().unwrap();
    let e = ConstantCurvature::new(helical.clone(), CcSettings::default())
        .err()
        .unwrap();
    assert!(e.to_string().contains("robot.cables[1].routing"), "{e}");
    let e = PiecewiseConstantCurvature::new(helical, PccSettings::default())
        .err()
        .unwrap();
    assert!(e.to_string().contains("helical"), "{e}");
}

/// Till's robot with its continuous tendons driven by displacement (refused before
/// the readings solve took continuous lengths; it once gave a misleading "no free
/// length" from a zero hole-path length): it builds, each free length `L0` comes from
/// the integrated path at the pretension (about the rod's 0.5 m, its tendons sagging
/// with the rod under gravity), zero readings give back the pretensions (1e-9 N: the
/// reference is the solution), and a pull obeys `T = EA_t (l - L_f)/L_f` as strain to
/// 1e-10 (the solve's 1e-12 m length tolerance over `L_f` ~ 0.5 m). More in
/// `tests/tendon_continuous.rs`.
#[test]
fn displacement_driven_continuous_tendons_solve_from_readings() {
    let text = std::fs::read_to_string(TILL)
        .unwrap()
        .replace(
            "end_section = 0\n",
            "end_section = 0\nactuation = \"displacement\"\n",
        )
        .replace(
            "[loads]",
            "[robot.tendons]\nstiffness_n = 2.0e4\npretension_n = 2.0\n\n[loads]",
        )
        .replace("tensions_n = [15.0, 0.0, 0.0, 0.0]\n", "");
    let sc = Scene::from_toml_str(&text).unwrap();
    let mut ws = sc.tendon_workspace().unwrap();
    for l0 in ws.rest_free_lengths() {
        assert!((l0 - 0.5).abs() < 1e-2, "L0 = {l0}");
    }
    let rep = ws.solve_readings(&[0.0; 4]).unwrap();
    assert!(rep.status.is_converged(), "{rep:?}");
    for t in ws.tensions() {
        assert!((t - 2.0).abs() < 1e-9, "zero readings: T = {t}");
    }
    let q = [2e-3, 0.0, 0.0, 0.0];
    let rep = ws.solve_readings(&q).unwrap();
    assert!(rep.status.is_converged(), "{rep:?}");
    assert!(ws.tensions()[0] > 2.0);
    let l0 = ws.rest_free_lengths().to_vec();
    for i in 0..4 {
        let (t, l, free) = (ws.tensions()[i], ws.lengths()[i], l0[i] - q[i]);
        if ws.taut()[i] {
            let gap = t / 2.0e4 - (l - free) / free;
            assert!(gap.abs() < 1e-10, "tendon {i}: strain gap {gap:e}");
        }
    }
}

/// Warm solves along a tension ramp on the disk model (40 disks, the condensed
/// coupling): each warm tip equals a cold solve of the same loads (2e-9 m: both
/// stop within the 1e-10 scaled tolerance), and the load-path predictor's
/// extrapolated next holes (`pass::local_next`) keep the local iteration short, and
/// its small steps are carried to the segment's end through the sweep's state map
/// (`pass::condensed::linear_retry`) instead of re-integrating the gap: at most 0.3
/// re-integrations per disk gap per solve on average (0.101 measured; 1.54 with every
/// local step re-integrated; without the extrapolated holes the first pass of each
/// step starts 1e-9..1e-6 L off: 3.51 here; 0.305 when the predictor's history kept
/// chord-refined unknowns without moving their holes along, `refine_local_next`).
#[test]
fn warm_ramp_on_disks_matches_cold_with_few_local_iterations() {
    let sc = till();
    let n = 40usize;
    let robot = till_disks(n);
    let mut loads = sc.loads.clone();
    loads.tensions_n[0] = 1.0;
    let mut ws = Workspace::new(robot.clone(), loads.clone(), rk4(n)).unwrap();
    assert!(ws.solve(Start::Cold).status.is_converged());
    let c0 = ws.rhs_counts();
    let ramp: Vec<f64> = (1..=60)
        .chain((0..59).rev())
        .map(|k| 1.0 + 0.2 * k as f64)
        .collect();
    for (k, &t) in ramp.iter().enumerate() {
        loads.tensions_n[0] = t;
        ws.set_loads(&loads).unwrap();
        let rep = ws.solve(Start::Warm);
        assert!(rep.status.is_converged(), "step {k}: {rep:?}");
        if k % 15 == 7 {
            let cold = solve_tip(robot.clone(), &loads, rk4(n));
            let d = (ws.tip_position() - cold).norm();
            assert!(
                d < 2e-9,
                "step {k} (T = {t} N): warm and cold tips {d:.3e} m apart"
            );
        }
    }
    let per_gap =
        (ws.rhs_counts().local_iterations - c0.local_iterations) as f64 / (ramp.len() * n) as f64;
    eprintln!("local iterations per gap per warm solve: {per_gap:.3}");
    assert!(
        per_gap <= 0.3,
        "{per_gap:.3} re-integrations per gap per solve"
    );
}
