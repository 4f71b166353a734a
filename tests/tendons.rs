//! Displacement-driven tendons: readings -> tensions and shape (src/tendons).
//!
//! Sources of the expected values: the constant-curvature kinematics of a tendon
//! (path change `r theta` for a segment bent by `theta` towards the tendon, Webster &
//! Jones 2010), the tendon's constitutive law `T = EA_t (l - L_f)/L_f`, symmetry, and
//! the tension-driven forward model of this crate (`Workspace`) for the round trip.

use cablesense::tendons::TendonWorkspace;
use cablesense::{Loads, Scene, Start, Workspace};

/// One 0.2 m NiTi-like section with 20 point disks and `cables` (TOML snippets).
fn scene(cables: &str, extra: &str) -> Scene {
    let text = format!(
        r#"
[[robot.sections]]
length_m = 0.2
shape = {{ solid = {{ diameter_m = 1.0e-3 }} }}
youngs_modulus_pa = 50.0e9
poisson_ratio = 0.3
density_kg_m3 = 6450.0
[robot.sections.guides]
count = 20
first_offset_m = 0.01
spacing_m = 0.01
thickness_m = 0.0
diameter_m = 0.012
mass_kg = 0.0
holes = {{ radius_m = 0.005 }}
{extra}
{cables}
[loads]
gravity_m_s2 = [0.0, 0.0, 0.0]
[numerics]
rod_model = "kirchhoff"
guide_mass = "none"
integrator = {{ rk4 = {{ steps_per_section = 40 }} }}
tolerance = 1e-12
"#
    );
    Scene::from_toml_str(&text).expect("test scene parses")
}

fn tendon(name: &str, angle: f64, ea: &str, pretension: f64) -> String {
    format!(
        r#"
[[robot.cables]]
name = "{name}"
routing = {{ radius_m = 0.005, angle_deg = {angle} }}
end_section = 0
actuation = "displacement"
tendon = {{ stiffness_n = {ea}, pretension_n = {pretension} }}
"#
    )
}

fn solve(ws: &mut TendonWorkspace, q: &[f64]) -> cablesense::tendons::TendonReport {
    let rep = ws.solve_readings(q).expect("valid readings");
    assert!(rep.status.is_converged(), "{rep:?} at q = {q:?}");
    rep
}

/// Inextensible tendon, no gravity: tension -> path change -> reading -> the same
/// tension (1e-9 relative), and for small bending the tip follows the CC closed form
/// of the reading (theta = q / r) within 0.2 % of the deflection (disk chords and the
/// rod's shear-free bending under point disk loads differ from an arc at second
/// order in the disk spacing).
#[test]
fn inextensible_tendon_round_trip_and_constant_curvature() {
    let sc = scene(&tendon("a", 0.0, "inf", 0.0), "");
    let mut ws = sc.tendon_workspace().unwrap();
    let l0 = ws.rest_free_lengths()[0];
    // tension-driven forward solve with the same robot
    let mut spec = sc.robot.clone();
    spec.cables[0].actuation = cablesense::tendons::Actuation::Tension;
    let robot_t = cablesense::Robot::new(spec).unwrap();
    for t_star in [0.05, 0.5, 2.0] {
        let mut loads = Loads::none();
        loads.tensions_n = vec![t_star];
        let mut fw = Workspace::new(robot_t.clone(), loads, sc.numerics.clone()).unwrap();
        assert!(fw.solve(Start::Cold).status.is_converged());
        let sol = fw.solution();
        let q = l0 - sol.cables[0].total_m;
        solve(&mut ws, &[q]);
        let t = ws.tensions()[0];
        assert!((t - t_star).abs() <= 1e-9 * t_star, "T {t} vs {t_star}");
        let tip = ws.tip_position();
        assert!(
            (tip - sol.tip().position).norm() < 1e-9,
            "tip {tip} vs {}",
            sol.tip().position
        );
    }
    // CC closed form: bending angle theta = q / r towards the tendon (+x)
    let (r, len) = (0.005, 0.2);
    let q = 2e-4;
    solve(&mut ws, &[q]);
    let theta = q / r;
    let (x, z) = (len / theta * (1.0 - theta.cos()), len / theta * theta.sin());
    let tip = ws.tip_position();
    assert!(tip.y.abs() < 1e-12, "out of plane {}", tip.y);
    assert!((tip.x - x).abs() < 2e-3 * x, "tip x {} vs CC {x}", tip.x);
    assert!((tip.z - z).abs() < 2e-3 * x, "tip z {} vs CC {z}", tip.z);
}

/// Elastic tendon: the found tension satisfies `T = EA_t (l - L_f) / L_f` with the
/// solved path `l` to 1e-8 N (the solver's tolerance of 1e-12 m on the length gap
/// times `EA_t / L_f` = 5e3 N/m is 5e-9 N; tensions here are 0.5-5 N, so this is
/// 1e-8 relative or better: the issue's 1e-10 would need a length gap of 1e-14 m,
/// below the shooting solve's own resolution of the path).
#[test]
fn elastic_tendon_obeys_its_constitutive_law() {
    let ea = 1000.0;
    let sc = scene(&tendon("a", 0.0, &format!("{ea}"), 0.5), "");
    let mut ws = sc.tendon_workspace().unwrap();
    let l0 = ws.rest_free_lengths()[0];
    for q in [0.0, 1e-4, 5e-4, 1e-3] {
        solve(&mut ws, &[q]);
        let t = ws.tensions()[0];
        let l = ws.lengths()[0];
        let free = l0 - q;
        let want = ea * (l - free) / free;
        assert!((t - want).abs() < 1e-8, "q {q}: T {t} vs EA strain {want}");
        if q == 0.0 {
            assert!((t - 0.5).abs() < 1e-8, "pretension at q = 0: {t}");
        }
    }
}

/// Slack: releasing a tendon far gives T = 0, taut false, and the shape of the robot
/// without that tendon (1e-12 m); a ramp through the edge of slack converges at every
/// step with a continuous, monotone tension.
#[test]
fn slack_tendon_carries_nothing_and_switches_cleanly() {
    let both = scene(
        &(tendon("a", 0.0, "2000", 0.0) + &tendon("b", 180.0, "2000", 0.0)),
        "",
    );
    let one = scene(&tendon("a", 0.0, "2000", 0.0), "");
    let mut ws2 = both.tendon_workspace().unwrap();
    let mut ws1 = one.tendon_workspace().unwrap();
    let rep = solve(&mut ws2, &[1e-3, -1e-2]);
    assert_eq!(rep.slack, 1);
    assert_eq!(ws2.tensions()[1], 0.0);
    assert!(!ws2.taut()[1] && ws2.taut()[0]);
    solve(&mut ws1, &[1e-3]);
    let d = (ws2.tip_position() - ws1.tip_position()).norm();
    assert!(
        d < 1e-12,
        "tip differs by {d} m from the robot without the slack tendon"
    );
    // ramp tendon b from pulled to released: tension falls continuously to 0
    let mut last = f64::INFINITY;
    let mut was_slack = false;
    for k in 0..=40 {
        let qb = 1e-3 - k as f64 * 1e-4;
        solve(&mut ws2, &[1e-3, qb]);
        let t = ws2.tensions()[1];
        assert!(t <= last + 1e-9, "step {k}: tension rose {last} -> {t}");
        assert!(
            last.is_infinite() || last - t < 1.0,
            "step {k}: jump {last} -> {t}"
        );
        if was_slack {
            assert_eq!(t, 0.0, "step {k}: chatter back to taut");
        }
        was_slack = !ws2.taut()[1];
        last = t;
    }
    assert!(was_slack);
}

/// Antagonistic pair under pretension: equal pulls keep the rod straight and raise
/// both tensions equally (1e-10).
#[test]
fn antagonistic_pair_stays_straight_under_equal_pulls() {
    let sc = scene(
        &(tendon("a", 0.0, "1500", 1.0) + &tendon("b", 180.0, "1500", 1.0)),
        "",
    );
    let mut ws = sc.tendon_workspace().unwrap();
    for q in [0.0, 2e-4, 5e-4] {
        solve(&mut ws, &[q, q]);
        let (ta, tb) = (ws.tensions()[0], ws.tensions()[1]);
        assert!((ta - tb).abs() < 1e-10, "q {q}: {ta} vs {tb}");
        if q > 0.0 {
            assert!(ta > 1.0, "pull raises the pretension: {ta}");
        }
        let tip = ws.tip_position();
        assert!(
            tip.x.abs() < 1e-10 && tip.y.abs() < 1e-10,
            "q {q}: tip {tip}"
        );
    }
}

/// Friction: mu = 0 is no friction (identical results); with mu > 0 loading and
/// unloading differ at the same reading and the loop closes over a full cycle
/// (1e-9 m).
#[test]
fn friction_gives_hysteresis_that_closes() {
    let cables = tendon("a", 0.0, "2000", 1.0) + &tendon("b", 180.0, "2000", 1.0);
    let plain = scene(&cables, "");
    let zero = scene(&cables, "[robot.friction]\nmu = 0.0\n");
    let fric = scene(&cables, "[robot.friction]\nmu = 0.2\n");
    let cycle: Vec<f64> = (0..=10)
        .chain((0..10).rev())
        .map(|k| k as f64 * 1e-4)
        .collect();
    let run = |sc: &Scene| -> Vec<nalgebra::Vector3<f64>> {
        let mut ws = sc.tendon_workspace().unwrap();
        let mut tips = Vec::new();
        for _ in 0..2 {
            for &q in &cycle {
                solve(&mut ws, &[q, -q]);
                tips.push(ws.tip_position());
            }
        }
        tips
    };
    let (a, b) = (run(&plain), run(&zero));
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).norm() == 0.0, "mu = 0 differs: {x} vs {y}");
    }
    let f = run(&fric);
    let n = cycle.len();
    // loading (index 5, q = 5e-4) against unloading (index n - 6, q = 5e-4)
    let (up, down) = (f[5], f[n - 6]);
    assert!((up - down).norm() > 1e-5, "no hysteresis: {up} vs {down}");
    // second cycle repeats the first from its second point on
    for k in 1..n {
        let d = (f[k] - f[n + k]).norm();
        assert!(d < 1e-9, "cycle point {k} differs by {d} m");
    }
}

/// Bad input: each error names the field or value.
#[test]
fn bad_tendon_input_is_named() {
    let err = scene(
        "[[robot.cables]]\nrouting = { radius_m = 0.005, angle_deg = 0 }\nend_section = 0\nactuation = \"displacement\"\n",
        "",
    )
    .validate()
    .unwrap_err()
    .to_string();
    assert!(err.contains("stiffness_n"), "{err}");
    let neg = scene(&tendon("a", 0.0, "-5", 0.0), "")
        .validate()
        .unwrap_err()
        .to_string();
    assert!(
        neg.contains("robot.cables[0].tendon.stiffness_n") && neg.contains("-5"),
        "{neg}"
    );
    let outside = scene(
        "[[robot.cables]]\nrouting = { radius_m = 0.02, angle_deg = 0 }\nend_section = 0\n",
        "",
    )
    .validate()
    .unwrap_err()
    .to_string();
    assert!(
        outside.contains("routing.radius_m") && outside.contains("outside disk"),
        "{outside}"
    );
    let sc = scene(&tendon("a", 0.0, "1000", 0.0), "");
    let mut ws = sc.tendon_workspace().unwrap();
    let e = ws.solve_readings(&[f64::NAN]).unwrap_err().to_string();
    assert!(e.contains("readings[0] (a)") && e.contains("NaN"), "{e}");
    let e = ws.solve_readings(&[1.0]).unwrap_err().to_string();
    assert!(e.contains("pulls in more than the whole tendon"), "{e}");
    let e = ws.solve_readings(&[0.0, 0.0]).unwrap_err().to_string();
    assert!(e.contains("2 readings for 1"), "{e}");
    // the workspace still works after bad readings
    solve(&mut ws, &[1e-4]);
}

/// `TendonSettings::max_shooting_solves` bounds a row's work: a pull the robot cannot
/// follow (82 mm on the shipped two-segment TDCR's 0.1 m segments; a fuzz input that
/// ran 108 shooting solves and 2.5 s before stalling) stops at the budget with
/// `max_iterations`, and the workspace still solves the next, reachable row (from
/// cold, as a stream's fallback would, and warm).
#[test]
fn a_row_stops_at_its_budget_of_forward_solves() {
    use cablesense::tendons::TendonSettings;
    use cablesense::SolveStatus;
    let scene = Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/scenes/tdcr_two_segment.toml"
    ))
    .expect("shipped scene");
    let mut ws = scene.tendon_workspace().expect("scene builds");
    let reachable = [4e-4, -2e-4, -2e-4, 1e-4, 0.0, 0.0];
    let rep = ws.solve_readings(&reachable).expect("valid readings");
    assert!(rep.status.is_converged(), "{rep:?}");
    let tip = ws.tip_position();
    for budget in [1, 5, 12] {
        let mut w = ws.clone();
        w.set_tendon_settings(TendonSettings {
            max_shooting_solves: budget,
            ..TendonSettings::default()
        })
        .expect("valid settings");
        let rep = w
            .solve_readings(&[0.082, -0.052, 0.051, 0.002, -0.001, -0.001])
            .expect("finite readings");
        assert!(rep.shooting_solves <= budget, "{budget}: {rep:?}");
        assert_eq!(rep.status, SolveStatus::MaxIterations, "{budget}: {rep:?}");
        // the next row, from cold (a stream's fallback) and then warm
        w.set_tendon_settings(TendonSettings::default())
            .expect("valid settings");
        let rep = w
            .solve_readings_from(&reachable, Start::Cold)
            .expect("valid readings");
        assert!(rep.status.is_converged(), "{budget}: {rep:?}");
        assert!((w.tip_position() - tip).norm() < 1e-9, "{budget}");
        let rep = w.solve_readings(&reachable).expect("valid readings");
        assert!(rep.status.is_converged(), "{budget}: {rep:?}");
    }
}
