//! Displacement actuation of continuously routed tendons (`routing = "continuous"`,
//! Rucker & Webster 2011 coupled rod/tendon equations, `src/statics/pass/continuous.rs`)
//! through the readings solve of `src/tendons/`.
//!
//! The robot is John Till's tendon robot (`data/scenes/till_tendon_robot.toml`: a
//! 0.5 m steel rod of 1 mm radius, straight continuous tendons at 15.06 mm) without
//! gravity, its tendons displacement-driven. Sources of the expected values: the
//! tendon's constitutive law `T = EA_t (l - L_f)/L_f` (`src/tendons/mod.rs`), the
//! tension-driven forward model of this crate (`Workspace`) for the round trip, the
//! constant-curvature closed form of a straight tendon on a Kirchhoff rod (its path
//! is the parallel curve at offset `r`: `l = L (1 - kappa r)`, so `q = r theta`
//! exactly, Webster & Jones 2010 section 3.1.1), central differences for the exact
//! derivatives, and each refusal's documented message.

use crate::common;

use cablesense::ladder::{CcSettings, PccSettings, Rung, TendonKinematics};
use cablesense::nalgebra::Vector3;
use cablesense::tendons::{TendonReport, TendonSettings, TendonWorkspace};
use cablesense::{Loads, Robot, Scene, Start, Workspace};
use common::Tol;

/// Till's rod (one 0.5 m section, or two of 0.25 m with `two`), no gravity, Kirchhoff
/// or Cosserat, RK4 at `steps` per section, with `cables` (TOML) and `extra` tables.
fn scene_with(cables: &str, extra: &str, sections: &str, numerics: &str) -> Scene {
    let text = format!(
        r#"
{sections}
{extra}
{cables}
[loads]
gravity_m_s2 = [0.0, 0.0, 0.0]
[numerics]
{numerics}
"#
    );
    Scene::from_toml_str(&text).expect("test scene parses")
}

const TILL_SECTION: &str = r#"
[[robot.sections]]
length_m = 0.5
shape = { solid = { diameter_m = 2.0e-3 } }
youngs_modulus_pa = 200.0e9
poisson_ratio = 0.25
density_kg_m3 = 8000.0
"#;

const NUMERICS: &str = r#"
integrator = { rk4 = { steps_per_section = 32 } }
tolerance = 1e-12
"#;

fn till(cables: &str, extra: &str) -> Scene {
    scene_with(cables, extra, TILL_SECTION, NUMERICS)
}

/// A straight continuous tendon at Till's 15.06 mm.
fn cont(name: &str, angle: f64, end: usize, actuation: &str, ea: &str, t0: f64) -> String {
    let tendon = if actuation == "displacement" {
        format!("tendon = {{ stiffness_n = {ea}, pretension_n = {t0} }}\n")
    } else {
        String::new()
    };
    format!(
        r#"
[[robot.cables]]
name = "{name}"
routing = "continuous"
path = {{ straight = {{ radius_m = 0.01506, angle_deg = {angle} }} }}
end_section = {end}
actuation = "{actuation}"
{tendon}"#
    )
}

fn solve(ws: &mut TendonWorkspace, q: &[f64]) -> TendonReport {
    let rep = ws.solve_readings(q).expect("valid readings");
    assert!(rep.status.is_converged(), "{rep:?} at q = {q:?}");
    rep
}

/// The same robot with every displacement-driven tendon tension-driven.
fn tension_robot(sc: &Scene) -> Robot {
    let mut spec = sc.robot.clone();
    for c in &mut spec.cables {
        c.actuation = cablesense::tendons::Actuation::Tension;
    }
    Robot::new(spec).unwrap()
}

/// Inextensible tendons (`EA_t = inf`): tensions -> solved path lengths -> readings
/// `q = L0 - l` -> the readings solve returns the same tensions (1e-9 relative) and
/// the same tip (1e-9 m). Source: the forward model is the same equations; the
/// readings solve stops at `|G| <= 1e-12 m`, which with `dl/dT` ~ 1e-3 m/N moves a
/// tension by ~1e-9 N at most (tensions here 1-15 N).
#[test]
fn inextensible_round_trip_returns_the_tensions_and_tip() {
    let sc = till(
        &(cont("t0", 0.0, 0, "displacement", "inf", 0.0)
            + &cont("t90", 90.0, 0, "displacement", "inf", 0.0)),
        "",
    );
    let mut ws = sc.tendon_workspace().unwrap();
    let l0 = ws.rest_free_lengths().to_vec();
    // at the zero pretension the rod is straight: both free lengths are L = 0.5 m
    for l in &l0 {
        assert!((l - 0.5).abs() < 1e-12, "L0 = {l}");
    }
    let robot_t = tension_robot(&sc);
    for t_star in [[1.0, 0.5], [5.0, 2.0], [15.0, 4.0]] {
        let mut loads = Loads::none();
        loads.tensions_n = t_star.to_vec();
        let mut fw = Workspace::new(robot_t.clone(), loads, sc.numerics.clone()).unwrap();
        assert!(fw.solve(Start::Cold).status.is_converged());
        let sol = fw.solution();
        let q: Vec<f64> = (0..2).map(|i| l0[i] - sol.cables[i].total_m).collect();
        for start in [Start::Warm, Start::Cold] {
            let rep = ws.solve_readings_from(&q, start).unwrap();
            assert!(rep.status.is_converged(), "{rep:?}");
            for (i, want) in t_star.iter().enumerate() {
                Tol::rel(1e-9).check("tension", i, 0.5, ws.tensions()[i], *want);
            }
            let d = (ws.tip_position() - sol.tip().position).norm();
            assert!(d < 1e-9, "{start:?} T* {t_star:?}: tip differs by {d} m");
            let rel = (0..2).fold(0.0f64, |m, i| {
                m.max((ws.tensions()[i] - t_star[i]).abs() / t_star[i])
            });
            eprintln!("{start:?} T* {t_star:?}: tension rel error {rel:e}, tip {d:e} m");
        }
    }
}

/// Elastic tendons: the found tension obeys `T = EA_t (l - L_f)/L_f` with the solved
/// path, as strain `|T/EA_t - (l - L_f)/L_f| <= 1e-10` (the solve's tolerance 1e-12 m
/// on the length gap over `L_f` ~ 0.5 m is 2e-12), and the pretension at q = 0
/// (1e-9 N: the same gap times `EA_t/L_f` = 4e3 N/m).
#[test]
fn elastic_continuous_tendon_obeys_its_constitutive_law() {
    let ea = 2000.0;
    let sc = till(
        &(cont("t0", 0.0, 0, "displacement", "2000", 1.0)
            + &cont("t180", 180.0, 0, "displacement", "2000", 1.0)),
        "",
    );
    let mut ws = sc.tendon_workspace().unwrap();
    let l0 = ws.rest_free_lengths().to_vec();
    for q in [[0.0, 0.0], [1e-4, 0.0], [1e-3, -2e-4], [3e-3, -1e-3]] {
        solve(&mut ws, &q);
        for i in 0..2 {
            let (t, l, free) = (ws.tensions()[i], ws.lengths()[i], l0[i] - q[i]);
            let gap = t / ea - (l - free) / free;
            assert!(
                gap.abs() <= 1e-10,
                "q {q:?}, tendon {i}: T/EA {} vs strain {}",
                t / ea,
                (l - free) / free
            );
            eprintln!("q {q:?} tendon {i}: T {t} N, strain gap {gap:e}");
            assert!(ws.taut()[i] && t > 0.0, "q {q:?}: tendon {i} T {t}");
            if q[0] == 0.0 {
                assert!((t - 1.0).abs() < 1e-9, "pretension at q = 0: {t}");
            }
        }
    }
}

/// Slack: a tendon paid out far gives T = 0, taut false, and the tip of the robot
/// without that tendon (1e-12 m: a tendon at zero tension adds exactly zero to the
/// coupled right-hand side, RW 2011 eqs. 14-16, so only round-off separates them).
#[test]
fn slack_continuous_tendon_carries_nothing() {
    let both = till(
        &(cont("t0", 0.0, 0, "displacement", "2000", 0.0)
            + &cont("t180", 180.0, 0, "displacement", "2000", 0.0)),
        "",
    );
    let one = till(&cont("t0", 0.0, 0, "displacement", "2000", 0.0), "");
    let mut ws2 = both.tendon_workspace().unwrap();
    let mut ws1 = one.tendon_workspace().unwrap();
    let rep = solve(&mut ws2, &[2e-3, -2e-2]);
    assert_eq!(rep.slack, 1);
    assert_eq!(ws2.tensions()[1], 0.0);
    assert!(!ws2.taut()[1] && ws2.taut()[0]);
    // the slack tendon's path is shorter than its free length
    assert!(ws2.lengths()[1] < ws2.rest_free_lengths()[1] + 2e-2);
    solve(&mut ws1, &[2e-3]);
    let d = (ws2.tip_position() - ws1.tip_position()).norm();
    assert!(d < 1e-12, "tip differs by {d} m from the robot without it");
    eprintln!("slack: tip difference {d:e} m, T0 {} N", ws2.tensions()[0]);
    Tol::rel(1e-12).check("T0", 0, 0.5, ws2.tensions()[0], ws1.tensions()[0]);
}

/// Constant curvature: on a Kirchhoff rod without gravity an inextensible straight
/// continuous tendon pulled by `q` bends the section into an arc of `theta = q / r`
/// (its path is the parallel curve at `r`), the constant-curvature kinematics
/// (`TendonKinematics`) say the same, and they equal those of disk holes at the same
/// radius and angle (1e-15 rad: the same closed form). Tip tolerance 1e-9 m for the
/// rod: RK4 at 32 steps on an arc of 0.6 rad (the error of the rotation's
/// integration); 1e-12 m for the CC and PCC rungs driven by the reading (closed-form
/// arcs).
#[test]
fn straight_continuous_tendon_matches_constant_curvature_kinematics() {
    let kirchhoff = "rod_model = \"kirchhoff\"\nintegrator = { rk4 = { steps_per_section = 32 } }\ntolerance = 1e-12\n";
    let sc = scene_with(
        &cont("t30", 30.0, 0, "displacement", "inf", 0.0),
        "",
        TILL_SECTION,
        kirchhoff,
    );
    let mut ws = sc.tendon_workspace().unwrap();
    let (r, len, a) = (0.01506, 0.5, 30f64.to_radians());
    let q = 9e-3;
    solve(&mut ws, &[q]);
    let theta = q / r;
    let (x, z) = (len / theta * (1.0 - theta.cos()), len / theta * theta.sin());
    let want = Vector3::new(x * a.cos(), x * a.sin(), z);
    let tip = ws.tip_position();
    assert!((tip - want).norm() < 1e-9, "tip {tip} vs arc {want}");
    eprintln!("arc: tip error {:e} m", (tip - want).norm());
    // the ladder's kinematics, and those of disk holes at r, 30 deg
    let robot = sc.build_robot().unwrap();
    let mut kin = TendonKinematics::new(&robot).unwrap();
    kin.solve(&[q]).unwrap();
    let (th, phi) = kin.angles(0);
    assert!(
        (th - theta).abs() < 1e-15 && (phi - a).abs() < 1e-15,
        "{th} {phi}"
    );
    // the CC and PCC rungs driven by the reading: the same arc, and the path length
    // L (1 - kappa r) = L - q (1e-12 m: closed forms, no integration)
    for rung in [
        Rung::ConstantCurvature(CcSettings::default()),
        Rung::PiecewiseConstantCurvature(PccSettings::default()),
    ] {
        let mut m = rung.build_readings(&robot, &sc.loads).unwrap();
        m.solve_readings(&[q], Start::Warm).unwrap();
        let d = (m.tip_position() - want).norm();
        let mut l = [0.0];
        m.cable_lengths_into(&mut l);
        eprintln!("{}: tip error {d:e} m, length {}", rung.label(), l[0]);
        assert!(
            d < 1e-12,
            "{}: tip {} vs {want}",
            rung.label(),
            m.tip_position()
        );
        assert!(
            (l[0] - (len - q)).abs() < 1e-12,
            "{}: length {}",
            rung.label(),
            l[0]
        );
    }
    let disks = scene_with(
        r#"
[[robot.cables]]
name = "d30"
routing = { radius_m = 0.01506, angle_deg = 30.0 }
end_section = 0
actuation = "displacement"
tendon = { stiffness_n = inf }
"#,
        "",
        &format!(
            "{TILL_SECTION}[robot.sections.guides]\ncount = 10\nfirst_offset_m = 0.05\nspacing_m = 0.05\nthickness_m = 0.0\ndiameter_m = 0.04\nmass_kg = 0.0\nholes = {{ radius_m = 0.01506 }}\n"
        ),
        kirchhoff,
    );
    let mut kd = TendonKinematics::new(&disks.build_robot().unwrap()).unwrap();
    kd.solve(&[q]).unwrap();
    let (thd, phid) = kd.angles(0);
    assert!(
        (thd - th).abs() < 1e-15 && (phid - phi).abs() < 1e-15,
        "{thd} {phid}"
    );
}

/// Two sections: disk-routed driven tendons on section 0 (10 disks, holes at 10 mm,
/// condensed coupling), a continuous driven tendon ending on section 1 and another
/// on section 0, a tension-driven one beside them. Every row converges, warm and
/// cold, each taut tendon obeys its law as strain (1e-10, as above) and the joint
/// and nested methods agree (tensions 1e-8 relative: both stop at `|G| <= 1e-12 m`,
/// times `EA_t / L_f` ~ 4e3 N/m over tensions ~1 N; tip 1e-9 m).
fn mixed() -> Scene {
    mixed_with("")
}

fn mixed_with(extra: &str) -> Scene {
    let sections = r#"
[[robot.sections]]
length_m = 0.25
shape = { solid = { diameter_m = 2.0e-3 } }
youngs_modulus_pa = 200.0e9
poisson_ratio = 0.25
density_kg_m3 = 8000.0
[robot.sections.guides]
count = 10
first_offset_m = 0.025
spacing_m = 0.025
thickness_m = 0.0
diameter_m = 0.04
mass_kg = 0.0
holes = { radius_m = 0.01, angles_deg = [0.0, 180.0] }

[[robot.sections]]
length_m = 0.25
shape = { solid = { diameter_m = 2.0e-3 } }
youngs_modulus_pa = 200.0e9
poisson_ratio = 0.25
density_kg_m3 = 8000.0
"#;
    let cables = r#"
[[robot.cables]]
name = "d0"
hole = 0
end_section = 0
actuation = "displacement"
tendon = { stiffness_n = 2000, pretension_n = 0.5 }

[[robot.cables]]
name = "d180"
hole = 1
end_section = 0
actuation = "displacement"
tendon = { stiffness_n = 2000, pretension_n = 0.5 }

[[robot.cables]]
name = "c90"
routing = "continuous"
path = { straight = { radius_m = 0.012, angle_deg = 90.0 } }
end_section = 1
actuation = "displacement"
tendon = { stiffness_n = 2000, pretension_n = 0.5 }

[[robot.cables]]
name = "c250"
routing = "continuous"
path = { straight = { radius_m = 0.012, angle_deg = 250.0 } }
end_section = 0
actuation = "displacement"
tendon = { stiffness_n = 2000, pretension_n = 0.5 }

[[robot.cables]]
name = "c300"
routing = "continuous"
path = { straight = { radius_m = 0.008, angle_deg = 300.0 } }
end_section = 1
"#;
    let numerics = "guide_mass = \"none\"\nintegrator = { rk4 = { steps_per_section = 20 } }\ntolerance = 1e-12\n";
    let mut sc = scene_with(cables, extra, sections, numerics);
    sc.loads.tensions_n = vec![0.0, 0.0, 0.0, 0.0, 0.3];
    sc
}

const MIXED_ROWS: [[f64; 4]; 5] = [
    [0.0, 0.0, 0.0, 0.0],
    [1e-3, -5e-4, 0.0, 2e-4],
    [1e-3, -5e-4, 2e-3, 2e-4],
    [-2e-4, 1.5e-3, 3e-3, -4e-3],
    [5e-4, 5e-4, 1e-3, 1e-3],
];

#[test]
fn mixed_disk_and_continuous_tendons_converge_and_obey_their_law() {
    let sc = mixed();
    let mut joint = sc.tendon_workspace().unwrap();
    let mut nested = sc.tendon_workspace().unwrap();
    nested
        .set_tendon_settings(TendonSettings {
            joint_newton: false,
            ..TendonSettings::default()
        })
        .expect("valid settings");
    let l0 = joint.rest_free_lengths().to_vec();
    assert_eq!(joint.driven(), &[0, 1, 2, 3]);
    let mut worst = 0.0f64;
    for q in MIXED_ROWS {
        for ws in [&mut joint, &mut nested] {
            solve(ws, &q);
            for (i, &j) in ws.driven().iter().enumerate() {
                let (t, l, free) = (ws.tensions()[i], ws.lengths()[j], l0[i] - q[i]);
                if ws.taut()[i] {
                    let gap = t / 2000.0 - (l - free) / free;
                    assert!(gap.abs() <= 1e-10, "q {q:?} tendon {i}: strain gap {gap:e}");
                    worst = worst.max(gap.abs());
                } else {
                    assert!(t == 0.0 && l <= free + 1e-12, "q {q:?} slack {i}: {t} {l}");
                }
            }
        }
        for i in 0..4 {
            Tol::both(1e-12, 1e-8).check(
                "joint vs nested T",
                i,
                0.0,
                joint.tensions()[i],
                nested.tensions()[i],
            );
        }
        let d = (joint.tip_position() - nested.tip_position()).norm();
        assert!(d < 1e-9, "q {q:?}: joint and nested tips differ by {d} m");
        eprintln!(
            "q {q:?}: T {:?}, taut {:?}, joint/nested tip {d:e} m",
            joint.tensions(),
            joint.taut()
        );
    }
    eprintln!("mixed: largest strain gap {worst:e}");
    // a cold start from the reference lands on the same equilibrium
    let last = MIXED_ROWS[4];
    let warm = joint.tip_position();
    let rep = joint.solve_readings_from(&last, Start::Cold).unwrap();
    assert!(rep.status.is_converged(), "{rep:?}");
    assert!((joint.tip_position() - warm).norm() < 1e-9);
    // the row with c250 paid out 4 mm: slack, as its release exceeds the bend
    solve(&mut joint, &MIXED_ROWS[3]);
    assert!(!joint.taut()[3] && joint.tensions()[3] == 0.0);
}

/// Exact derivatives on the mixed robot (condensed coupling on section 0, continuous
/// tendons across both sections): `[R_x R_T]`, `[dl/dx dl/dT]` of the joint sweep
/// against central differences off the equilibrium, and the total `dl/dT` of the
/// equilibrium against re-solves. (Before the condensed fold carried the integrated
/// lengths, `statics::pass::condensed::fold_segment`, a continuous tendon's `dl/dx`
/// here was off by up to 1e-3 m per unit, 10 %, at every step size: no truncation.)
/// Step and tolerances as `tests/tendon_derivatives.rs`
/// (h = 1e-4; residual 1e-5 abs + 1e-5 rel; lengths 1e-9 m abs + 1e-5 rel; re-solved
/// lengths 1e-7 abs + 1e-5 rel: the condensed coupling's settle floor and the
/// shooting tolerance through the quotient).
#[test]
fn continuous_tendon_derivatives_match_central_differences() {
    let worst = check_derivatives(mixed(), &MIXED_ROWS[2], &[2, 3]);
    eprintln!("mixed: largest |exact - fd| of a continuous tendon's dl/dz: {worst:e}");
}

/// As above on Till's rod with a helical and a tabulated driven tendon (the path's
/// `r'`, `r''` terms of RW 2011 eqs. 14-16 and a table starting on the axis, whose
/// slack-branch scale comes from its largest offset).
#[test]
fn helical_and_tabulated_tendon_derivatives_match_central_differences() {
    let sc = till(
        r#"
[[robot.cables]]
name = "h"
routing = "continuous"
path = { helical = { radius_m = 0.01, start_angle_deg = 0.0, pitch_m_per_turn = 0.8 } }
end_section = 0
actuation = "displacement"
tendon = { stiffness_n = 2000, pretension_n = 0.5 }

[[robot.cables]]
name = "tab"
routing = "continuous"
path = { table = { points_m = [[0.0, 0.0, 0.0], [0.2, -0.004, 0.008], [0.5, -0.012, 0.002]] } }
end_section = 0
actuation = "displacement"
tendon = { stiffness_n = 2000, pretension_n = 0.5 }
"#,
        "",
    );
    let worst = check_derivatives(sc.clone(), &[2e-3, 1e-3], &[0, 1]);
    eprintln!("helical/table: largest |exact - fd| of dl/dz: {worst:e}");
    // and the law at a few rows
    let mut ws = sc.tendon_workspace().unwrap();
    let l0 = ws.rest_free_lengths().to_vec();
    for q in [[1e-3, 0.0], [3e-3, 2e-3], [-1e-3, 4e-3]] {
        solve(&mut ws, &q);
        for i in 0..2 {
            let (t, l, free) = (ws.tensions()[i], ws.lengths()[i], l0[i] - q[i]);
            if ws.taut()[i] {
                let gap = t / 2000.0 - (l - free) / free;
                assert!(gap.abs() <= 1e-10, "q {q:?} tendon {i}: strain gap {gap:e}");
            } else {
                assert!(t == 0.0 && l <= free + 1e-12, "q {q:?} slack {i}: {t} {l}");
            }
        }
        eprintln!(
            "helical/table q {q:?}: T {:?} taut {:?}",
            ws.tensions(),
            ws.taut()
        );
    }
}

/// The derivative checks of the two tests above at the readings `q` of `sc`; returns
/// the largest `|exact - fd|` of the `dl/dz` rows of cables `cont` (asserted nonzero).
fn check_derivatives(sc: Scene, q: &[f64], cont: &[usize]) -> f64 {
    const H: f64 = 1e-4;
    let mut tw = sc.tendon_workspace().unwrap();
    solve(&mut tw, q);
    let theta = tw.tensions().to_vec();
    let ws = tw.workspace_mut();
    let n = ws.unknowns();
    let p = theta.len();
    let c = ws.robot().cables().len();
    let w = n + p;
    let x: Vec<f64> = ws
        .unknowns_vector()
        .iter()
        .enumerate()
        .map(|(i, x)| x + 1e-3 * ((i % 7) as f64 - 3.0) / 3.0)
        .collect();
    ws.set_theta(&theta);
    let (mut js, mut jm) = (vec![0.0; n * w], vec![0.0; c * w]);
    assert!(ws.joint_jacobians(&x, &mut js, &mut jm));
    let (mut rp, mut rm) = (vec![0.0; n], vec![0.0; n]);
    let (mut lp, mut lm) = (vec![0.0; c], vec![0.0; c]);
    let (tol_r, tol_l) = (Tol::both(1e-5, 1e-5), Tol::both(1e-9, 1e-5));
    let mut worst = 0.0f64;
    for col in 0..w {
        for (sign, r, l) in [(1.0, &mut rp, &mut lp), (-1.0, &mut rm, &mut lm)] {
            let mut xs = x.clone();
            let mut th = theta.clone();
            if col < n {
                xs[col] += sign * H;
            } else {
                th[col - n] += sign * H;
            }
            ws.set_theta(&th);
            assert!(ws.adopt_unknowns(&xs, true).is_finite());
            r.copy_from_slice(ws.residual_vector());
            ws.cable_lengths_into(l);
        }
        for k in 0..n {
            let fd = (rp[k] - rm[k]) / (2.0 * H);
            tol_r.check("dr/dz", k * w + col, 0.0, js[k * w + col], fd);
        }
        for j in 0..c {
            let fd = (lp[j] - lm[j]) / (2.0 * H);
            tol_l.check("dl/dz", j * w + col, 0.0, jm[j * w + col], fd);
            if cont.contains(&j) {
                worst = worst.max((jm[j * w + col] - fd).abs());
            }
        }
    }
    // the continuous tendons' rows are not trivially zero
    assert!(cont
        .iter()
        .all(|&j| (0..w).any(|col| jm[j * w + col].abs() > 1e-6)));
    // total dl/dT at the equilibrium against re-solves
    ws.set_theta(&theta);
    assert!(ws.solve(Start::Warm).status.is_converged());
    let (mut sens, mut lengths) = (vec![0.0; c * p], vec![0.0; c]);
    assert!(ws.length_sensitivities(&mut sens, &mut lengths));
    let tol = Tol::both(1e-7, 1e-5);
    for k in 0..p {
        for (sign, l) in [(1.0, &mut lp), (-1.0, &mut lm)] {
            let mut th = theta.clone();
            th[k] += sign * H;
            ws.set_theta(&th);
            assert!(ws.solve(Start::Warm).status.is_converged());
            ws.cable_lengths_into(l);
        }
        for j in 0..c {
            let fd = (lp[j] - lm[j]) / (2.0 * H);
            tol.check("dl/dT", j * p + k, 0.0, sens[j * p + k], fd);
        }
    }
    worst
}

/// Large pulls: the readings solve never switches to multiple shooting (its tensions
/// are load parameters, which `statics::multiple` does not take; for a straight
/// tendon the load intensity `T r L/EI` is the bending angle, so its switch at 20
/// would be three turns of the rod), so a continuous driven tendon pulled until the
/// rod bends by ~1-4 rad stays on single shooting (the report's unknowns are single
/// shooting's 6) with continuation from a cold start, and converges, its law holding
/// (1e-10 as strain, as above).
#[test]
fn large_pull_stays_on_single_shooting_and_converges() {
    let sc = till(&cont("t0", 0.0, 0, "displacement", "2000", 0.0), "");
    let mut ws = sc.tendon_workspace().unwrap();
    let l0 = ws.rest_free_lengths()[0];
    for q in [0.02, 0.04, 0.06, 0.08] {
        let rep = ws.solve_readings_from(&[q], Start::Cold).unwrap();
        assert!(rep.status.is_converged(), "q {q}: {rep:?}");
        assert_eq!(
            ws.workspace().report().unknowns,
            6,
            "single shooting answered"
        );
        let (t, l, free) = (ws.tensions()[0], ws.lengths()[0], l0 - q);
        let gap = t / 2000.0 - (l - free) / free;
        assert!(gap.abs() <= 1e-10, "q {q}: strain gap {gap:e}");
        let intensity = t * 0.01506 * 0.5 / ws.workspace().robot().min_bending_stiffness();
        eprintln!("q {q}: T {t} N, intensity {intensity}, {rep:?}");
    }
}

/// Refusals name the field: capstan friction on a continuous driven tendon (a
/// per-disk model), `calibrate identify` (hole angles), and the constant-curvature
/// kinematics of a helical driven tendon.
#[test]
fn refusals_name_the_field() {
    let sc = till(
        &(cont("t0", 0.0, 0, "displacement", "2000", 0.0)
            + &cont("t180", 180.0, 0, "displacement", "2000", 0.0)),
        "[robot.friction]\nmu = 0.1\n",
    );
    let e = sc.build_robot().unwrap_err().to_string();
    assert!(
        e.contains("robot.friction") && e.contains("robot.cables[0]") && e.contains("continuous"),
        "{e}"
    );
    assert!(sc.tendon_workspace().is_err());
    // identify maps servos onto disk holes' angles: a continuous tendon is refused
    let e = cablesense::calibrate::scene_segments(&till(
        &cont("t0", 0.0, 0, "displacement", "2000", 0.0),
        "",
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("cable 0 is continuously routed"), "{e}");
    // mu = 0 is no friction: accepted
    let ok = till(
        &cont("t0", 0.0, 0, "displacement", "2000", 0.0),
        "[robot.friction]\nmu = 0.0\n",
    );
    assert!(ok.tendon_workspace().is_ok());
    // a tension-driven continuous tendon beside friction is not affected by it
    let tension = till(
        &cont("t0", 0.0, 0, "tension", "", 0.0),
        "[robot.friction]\nmu = 0.1\n",
    );
    assert!(tension.build_robot().is_ok());
    // helical driven tendon: the rod's readings solve takes it, CC kinematics do not
    let helical = till(
        r#"
[[robot.cables]]
name = "h"
routing = "continuous"
path = { helical = { radius_m = 0.01, start_angle_deg = 0.0, pitch_m_per_turn = 1.0 } }
end_section = 0
actuation = "displacement"
tendon = { stiffness_n = 2000 }
"#,
        "",
    );
    let robot = helical.build_robot().unwrap();
    let e = TendonKinematics::new(&robot).unwrap_err().to_string();
    assert!(
        e.contains("robot.cables[0].path") && e.contains("curvature constant"),
        "{e}"
    );
    let mut ws = helical.tendon_workspace().unwrap();
    solve(&mut ws, &[1e-3]);
    assert!(ws.tensions()[0] > 0.0);
}

/// Unknown tip force on the mixed robot from load cells on its four driven tendons
/// (`estimate::TendonLoadEstimator`, its sensitivities through the continuous
/// tendons' exact `dl/dphi`): data synthesised by the same model at (0.05, -0.03) N,
/// noise-free, are estimated back within 1e-6 N (the estimator's 1e-9 relative step
/// tolerance at sensitivities ~0.1-10 N/N, as `tests/estimate_tendon_loads.rs`).
#[test]
fn tip_force_from_load_cells_on_continuous_tendons() {
    use cablesense::estimate::{EstimateStatus, TendonLoadEstimator};
    let sc = mixed_with(
        r#"
[estimate]
load_cell_sigma_n = 0.01
method = "levenberg_marquardt"
tolerance = 1e-9

[[estimate.unknowns]]
kind = "force"
section = 1
axis = "x"

[[estimate.unknowns]]
kind = "force"
section = 1
axis = "y"
"#,
    );
    let make = || {
        TendonLoadEstimator::new(
            sc.build_robot().unwrap(),
            sc.loads.clone(),
            sc.numerics.clone(),
            sc.estimate.clone().unwrap(),
        )
        .expect("estimator builds")
    };
    let (mut truth, mut est) = (make(), make());
    let theta = [0.05, -0.03];
    for q in [MIXED_ROWS[1], MIXED_ROWS[2], MIXED_ROWS[4]] {
        let pred = truth.predict(&theta, &q).unwrap();
        assert!(pred.status.is_converged(), "{pred:?}");
        let status = est.tick(&q, &pred.tensions_n, None).unwrap();
        let e = est.estimate();
        assert_eq!(status, EstimateStatus::Converged, "{e:?}");
        for (k, want) in theta.iter().enumerate() {
            let err = (e.estimate.values[k] - want).abs();
            eprintln!("q {q:?}: {} error {err:e} N", e.estimate.names[k]);
            assert!(
                err < 1e-6,
                "{} = {}",
                e.estimate.names[k],
                e.estimate.values[k]
            );
        }
    }
}

const READINGS_SCENE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/data/scenes/till_tendon_readings.toml"
);
const READINGS_CSV: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/data/measurements/till_tendon_readings.csv"
);

/// The shipped example through the binary: `cablesense solve
/// data/scenes/till_tendon_readings.toml --readings data/measurements/till_tendon_readings.csv
/// --json` exits 0, every row converges, and its tensions and tips equal the
/// library's warm chain of the same rows (1e-9 N, 1e-9 m: the same solves, printed
/// with full precision by serde_json); each taut tendon obeys its law (1e-10 strain).
#[test]
fn cli_solves_the_shipped_continuous_readings_example() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_cablesense"))
        .args([
            "solve",
            READINGS_SCENE,
            "--readings",
            READINGS_CSV,
            "--json",
        ])
        .output()
        .expect("binary runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "exit {:?}: {}\n{stdout}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    let csv = std::fs::read_to_string(READINGS_CSV).unwrap();
    let q: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').skip(1).map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), q.len());
    let sc = Scene::load(READINGS_SCENE).unwrap();
    let mut ws = sc.tendon_workspace().unwrap();
    let l0 = ws.rest_free_lengths().to_vec();
    for (row, q) in rows.iter().zip(&q) {
        assert_eq!(row["status"], "converged", "{row}");
        solve(&mut ws, q);
        let t: Vec<f64> = serde_json::from_value(row["tensions_n"].clone()).unwrap();
        let tip: Vec<f64> = serde_json::from_value(row["tip_position_m"].clone()).unwrap();
        for i in 0..4 {
            Tol::abs(1e-9).check("CLI tension", i, 0.0, t[i], ws.tensions()[i]);
            Tol::abs(1e-9).check(
                "CLI tip",
                i.min(2),
                0.0,
                tip[i.min(2)],
                ws.tip_position()[i.min(2)],
            );
            if ws.taut()[i] {
                let free = l0[i] - q[i];
                let gap = ws.tensions()[i] / 2.0e4 - (ws.lengths()[i] - free) / free;
                assert!(
                    gap.abs() <= 1e-10,
                    "row {q:?} tendon {i}: strain gap {gap:e}"
                );
            }
        }
        eprintln!("CLI row {q:?}: T {t:?}, taut {}", row["taut"]);
    }
}
