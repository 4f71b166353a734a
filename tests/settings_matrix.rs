//! Settings matrix (issue 14, "Reliability for a control loop"): every shipped scene
//! (the scenes embedded in the binary, `files::demo::FILES`: `data/scenes/*.toml` and
//! `data/thesis/*.toml`) under combinations of rod model (Cosserat, Kirchhoff),
//! integrator (the scene's own and the other kind: RK4 32 steps per section or
//! adaptive 1e-8), guide-mass model (none, average, accurate, point), cable coupling
//! (condensed, exact), continuation (on, off) and branch guard (on, off): 128
//! combinations, 64 on the tendon-driven scenes (their coupling is the scene's).
//!
//! The load axis is a factor `lambda` on every load of the scene: gravity, point
//! forces, torques, payloads and cable tensions times `lambda` (`lambda = 1` is the
//! scene as shipped). On tendon-driven scenes (`ftdcr_v4`, `tdcr_two_segment`) the
//! factor scales gravity and a servo reading of 2 mm on the first tendon of every
//! segment (the others at 0), solved from cold by `TendonWorkspace`.
//!
//! Claims ([`CLAIMS`], the table of docs/settings-matrix.md): every combination
//! converges cold (status `converged`, finite tip) at every load factor up to the
//! scene's claimed one, and beyond it each solve "fails cleanly": either `converged`
//! with a finite tip and a residual within the reported tolerance, or a failure status;
//! never a panic. Tolerance: the solver's own (`converged` means residual <= the
//! reported tolerance); source: this matrix's own full sweep, run with
//! `cargo test --release --test integration settings_matrix:: -- --ignored --nocapture`
//! (it prints the table docs/settings-matrix.md is written from). On 2 busy shared cores, with
//! `SETTINGS_MATRIX_LAMBDAS=0.25,0.5,1,2`, the thesis scenes, the track demo and the
//! two-section demo took 8 minutes, `ftdcr_v4` 1 minute; `tdcr_modeling` spends 6 s
//! per exact solve at factor 1. `tdcr_two_segment` (session 10, 2026-11-27, with the
//! tendon rows' budget of `TendonSettings::max_shooting_solves`): all 64 combinations
//! at 0.25, 0.5 and 1 in 316 s beside other work (its failing solves at factor 2 take
//! 1-186 s each, so factor 2 was run for the first 11 combinations only: every one
//! `stalled` there, cleanly); in 2026-11-24 it had been stopped after 18 of 64.
//!
//! In normal CI each scene runs 8 of the combinations (a covering design: every value
//! of every setting at least twice; 4 on tendon scenes, 6 on `tdcr_modeling`) at the
//! claimed factor, and every other condensed one at twice the claim (16 s in all).

use cablesense::files::demo;
use cablesense::{
    CableCoupling, GuideMass, Integrator, Loads, RodModel, Scene, SolverSettings, Start, Workspace,
};

/// Load factors of the full sweep.
const SWEEP: [f64; 7] = [0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0];

/// Claimed load factor per scene, with continuation on and off: every combination
/// converges cold at every factor of the sweep up to this one. Written from the
/// measured sample (see docs/settings-matrix.md); the full sweep checks them
/// on all 128 (64) combinations.
const CLAIMS: [(&str, f64, f64); 13] = [
    ("scenes/demo_two_section.toml", 2.0, 0.5),
    ("scenes/track_demo.toml", 2.0, 2.0),
    ("scenes/tdcr_modeling.toml", 1.0, 0.25),
    ("scenes/ftdcr_v4.toml", 1.0, 1.0),
    ("scenes/tdcr_two_segment.toml", 1.0, 0.5),
    // continuous routing; claimed from the CI sample only (not the full sweep)
    ("scenes/till_tendon_robot.toml", 1.0, 1.0),
    // continuous routing, displacement-driven; claimed from the CI sample only
    ("scenes/till_tendon_readings.toml", 1.0, 1.0),
    // the one-segment robot of data/hardware/daru; claimed from the CI sample only
    ("scenes/daru.toml", 1.0, 1.0),
    ("thesis/table_4_1.toml", 2.0, 2.0),
    ("thesis/table_4_2.toml", 2.0, 1.0),
    ("thesis/table_4_3.toml", 1.0, 0.5),
    ("thesis/table_4_3_measured_mass.toml", 1.0, 0.5),
    ("thesis/table_4_4.toml", 1.0, 0.5),
];

/// Combinations claimed lower than their scene's claim: (scene, coupling, continuation,
/// claimed factor); 0 claims nothing (every factor is "beyond": clean failures only).
/// On `tdcr_modeling` exact coupling without continuation stalls at every factor of
/// the sweep (Cosserat, RK4 32, factor 0.25: `stalled`), where condensed coupling
/// converges to factor 2.
const EXCEPTIONS: [(&str, CableCoupling, bool, f64); 1] = [(
    "scenes/tdcr_modeling.toml",
    CableCoupling::Exact,
    false,
    0.0,
)];

/// Rod models claimed lower than their scene's claim (both continuation settings):
/// (scene, rod model, claimed factor). On `tdcr_two_segment` (session 10's full
/// sweep of its 64 combinations at 0.25, 0.5 and 1: every Cosserat one reaches 1 with
/// continuation and 0.5 without) a Kirchhoff rod with the scene's RK4 20 ends
/// `stalled` at factor 0.5 (1 mm readings; the tension iteration's merit falls from
/// 1e-3 to 7e-5 m in 9 steps and stops, tensions near 60 N) for every guide-mass
/// model, with continuation on and off, and with adaptive steps it reaches 0.5 or 1
/// with continuation and 0.25 without. The scene's claim of 0.5 (all rods) came from
/// the partial sweep of 2026-11-24 (`9bb275a`), where the Kirchhoff solve at 0.5
/// converged in 8 tension iterations. Bisected: lost with `3d513ed` (the condensed
/// coupling's first-order prediction of the next holes); disabling that prediction
/// on today's main does not bring it back. Why it is fragile: at the stalled point
/// (tensions 61 N in the first segment, 31 N in the second; a Cosserat rod needs 26
/// and 9 N, its axial compression taking up part of the pull) a warm shooting solve
/// with one tension moved by 1e-4 N ends `non_finite` (15 continuation steps): the
/// inextensible rod is near a singular equilibrium there (about 270 N of tendon
/// compression in the first segment, its three tendons and the second segment's
/// three passing through, against about 290 N, the Euler load of one 10 mm disk span
/// of the 1 mm rod at 60 GPa), so `stalled` is the honest answer, not a lost solution.
const ROD_EXCEPTIONS: [(&str, RodModel, f64); 1] =
    [("scenes/tdcr_two_segment.toml", RodModel::Kirchhoff, 0.25)];

/// Scenes whose exact coupling is too costly above the shipped load for a test: on
/// `tdcr_modeling` (90 shooting unknowns) one cold exact solve took 6.4 s at factor 1
/// and ended `max_iterations` after 134 s at factor 2 (2 shared cores). There the
/// full sweep runs exact coupling up to factor 1 only, and the CI sample runs two of
/// its four exact combinations.
const EXPENSIVE_EXACT: [&str; 1] = ["scenes/tdcr_modeling.toml"];

/// The shipped scenes: every embedded `.toml` that parses as a scene (the thesis
/// directory also holds `fitted.toml`, parameter values, not a scene).
fn shipped_scenes() -> Vec<(&'static str, Scene)> {
    demo::FILES
        .iter()
        .filter(|f| f.path.ends_with(".toml"))
        .filter_map(|f| Scene::from_toml_str(f.text).ok().map(|s| (f.path, s)))
        .collect()
}

fn is_tendon_scene(scene: &Scene) -> bool {
    scene
        .robot
        .cables
        .iter()
        .any(|c| c.actuation == cablesense::tendons::Actuation::Displacement)
}

/// One combination of the six settings, on top of the scene's own numerics
/// (tolerance, iteration limits, RK4 steps when the scene uses RK4).
#[derive(Clone, Copy, Debug)]
struct Combo {
    rod: RodModel,
    /// `false`: the scene's integrator; `true`: the other kind.
    other_integrator: bool,
    mass: GuideMass,
    coupling: CableCoupling,
    continuation: bool,
    branch_guard: bool,
}

const MASSES: [GuideMass; 4] = [
    GuideMass::None,
    GuideMass::Average,
    GuideMass::Accurate,
    GuideMass::Point,
];

impl Combo {
    /// Combination `i` of 128 (bits: rod, integrator, coupling, continuation, guard;
    /// then the guide mass).
    fn nth(i: usize) -> Self {
        Self {
            rod: if i & 1 == 0 {
                RodModel::Cosserat
            } else {
                RodModel::Kirchhoff
            },
            other_integrator: i & 2 != 0,
            coupling: if i & 4 == 0 {
                CableCoupling::Condensed
            } else {
                CableCoupling::Exact
            },
            continuation: i & 8 == 0,
            branch_guard: i & 16 == 0,
            mass: MASSES[(i >> 5) & 3],
        }
    }

    fn all() -> Vec<Self> {
        (0..128).map(Self::nth).collect()
    }

    /// 8 combinations in which every value of every setting occurs at least twice.
    fn covering() -> Vec<Self> {
        (0..8usize)
            .map(|i| {
                let b = |k: usize| (i >> k) & 1;
                let bits = b(0) | b(1) << 1 | b(2) << 2 | (b(0) ^ b(1)) << 3 | (b(1) ^ b(2)) << 4;
                Self::nth(bits | (i % 4) << 5)
            })
            .collect()
    }

    fn settings(&self, scene: &SolverSettings) -> SolverSettings {
        let integrator = match (scene.integrator, self.other_integrator) {
            (i, false) => i,
            (Integrator::Rk4 { .. }, true) => Integrator::Adaptive {
                tol: 1e-8,
                max_steps: 100_000,
            },
            (Integrator::Adaptive { .. }, true) => Integrator::Rk4 {
                steps_per_section: 32,
            },
        };
        SolverSettings {
            rod_model: self.rod,
            integrator,
            guide_mass: self.mass,
            cable_coupling: self.coupling,
            continuation: self.continuation,
            branch_guard: self.branch_guard,
            ..scene.clone()
        }
    }

    fn label(&self) -> String {
        format!(
            "{:?}/{}/{:?}/{:?}/cont-{}/guard-{}",
            self.rod,
            if self.other_integrator {
                "other-int"
            } else {
                "scene-int"
            },
            self.mass,
            self.coupling,
            self.continuation,
            self.branch_guard
        )
        .to_lowercase()
    }
}

/// The scene's loads times `lambda`.
fn scaled(loads: &Loads, lambda: f64) -> Loads {
    let mut l = loads.clone();
    l.gravity_m_s2.iter_mut().for_each(|g| *g *= lambda);
    for p in &mut l.point {
        p.force_n.iter_mut().for_each(|f| *f *= lambda);
        p.torque_nm.iter_mut().for_each(|t| *t *= lambda);
        p.mass_kg *= lambda;
    }
    l.tensions_n.iter_mut().for_each(|t| *t *= lambda);
    l
}

/// What one cold solve gave.
#[derive(Clone, Debug)]
enum Outcome {
    Converged,
    /// A failure status (its name).
    Failed(String),
    /// A result that is not clean: converged but non-finite or above tolerance,
    /// or the model could not be built (the message).
    Unclean(String),
}

/// Solve `scene` cold under `combo` at load factor `lambda`.
fn solve(scene: &Scene, combo: &Combo, lambda: f64) -> Outcome {
    let settings = combo.settings(&scene.numerics);
    let robot = match scene.build_robot() {
        Ok(r) => r,
        Err(e) => return Outcome::Unclean(format!("robot: {e}")),
    };
    let loads = scaled(&scene.loads, lambda);
    if is_tendon_scene(scene) {
        let mut ws = match cablesense::tendons::TendonWorkspace::new(robot, loads, settings) {
            Ok(ws) => ws,
            // the reference solve at rest failed: a failure, reported as such
            Err(e) => return Outcome::Failed(format!("reference: {e}")),
        };
        // 2 mm on the first tendon of every segment, times lambda
        let robot = ws.workspace().robot().clone();
        let mut seen = std::collections::HashSet::new();
        let q: Vec<f64> = ws
            .driven()
            .iter()
            .map(|&j| {
                if seen.insert(robot.cables()[j].end_section) {
                    2e-3 * lambda
                } else {
                    0.0
                }
            })
            .collect();
        return match ws.solve_readings(&q) {
            Err(e) => Outcome::Failed(format!("readings: {e}")),
            Ok(rep) if rep.status.is_converged() => {
                let tip = ws.tip_position();
                if tip.iter().all(|x| x.is_finite()) {
                    Outcome::Converged
                } else {
                    Outcome::Unclean(format!("converged with tip {tip:?}"))
                }
            }
            Ok(rep) => Outcome::Failed(format!("{:?}", rep.status)),
        };
    }
    let mut ws = match Workspace::new(robot, loads, settings) {
        Ok(ws) => ws,
        Err(e) => return Outcome::Unclean(format!("workspace: {e}")),
    };
    let report = ws.solve(Start::Cold);
    if !report.status.is_converged() {
        return Outcome::Failed(format!("{:?}", report.status));
    }
    let tip = ws.tip_position();
    let branch_verdict = report.residual > report.tolerance;
    if !tip.iter().all(|x| x.is_finite()) || (branch_verdict && !ws.settings().branch_guard) {
        return Outcome::Unclean(format!(
            "converged with tip {tip:?}, residual {:e} against {:e}",
            report.residual, report.tolerance
        ));
    }
    Outcome::Converged
}

/// The claimed factor of `name` for `combo` (continuation on or off).
fn claim(name: &str, combo: &Combo) -> f64 {
    let c = CLAIMS
        .iter()
        .find(|(n, ..)| *n == name)
        .unwrap_or_else(|| panic!("no claim for the shipped scene {name}: add it to CLAIMS"));
    let exception = EXCEPTIONS.iter().find(|(n, coupling, cont, _)| {
        *n == name && *coupling == combo.coupling && *cont == combo.continuation
    });
    let claimed = match exception {
        Some(e) => e.3,
        None if combo.continuation => c.1,
        None => c.2,
    };
    ROD_EXCEPTIONS
        .iter()
        .filter(|(n, rod, _)| *n == name && *rod == combo.rod)
        .fold(claimed, |c, e| c.min(e.2))
}

fn combos_for(scene: &Scene, combos: Vec<Combo>) -> Vec<Combo> {
    if is_tendon_scene(scene) {
        // the tendon workspace's coupling is the scene's: one value only
        combos
            .into_iter()
            .filter(|c| c.coupling == CableCoupling::Condensed)
            .collect()
    } else {
        combos
    }
}

/// CI sample of one scene: the covering combinations converge at the claimed factor
/// and fail cleanly at two factors beyond the sweep's.
fn sample(name: &str) {
    let scenes = shipped_scenes();
    let (_, scene) = scenes
        .iter()
        .find(|(n, _)| *n == name)
        .unwrap_or_else(|| panic!("{name} is not shipped"));
    let mut failures = Vec::new();
    for (k, combo) in combos_for(scene, Combo::covering()).into_iter().enumerate() {
        let exact = combo.coupling == CableCoupling::Exact;
        if exact && EXPENSIVE_EXACT.contains(&name) && k % 2 == 1 {
            continue;
        }
        let lambda = claim(name, &combo);
        if lambda > 0.0 {
            match solve(scene, &combo, lambda) {
                Outcome::Converged => {}
                other => failures.push(format!("{} at {lambda}: {other:?}", combo.label())),
            }
        } else if let Outcome::Unclean(why) = solve(scene, &combo, SWEEP[0]) {
            failures.push(format!("{} at {}: {why}", combo.label(), SWEEP[0]));
        }
        // beyond the claim: a clean answer either way (every other condensed
        // combination, to keep the test affordable; the full sweep does all)
        if k % 2 == 0 && !exact {
            let beyond = 2.0 * lambda;
            if let Outcome::Unclean(why) = solve(scene, &combo, beyond) {
                failures.push(format!("{} at {beyond}: {why}", combo.label()));
            }
        }
    }
    assert!(failures.is_empty(), "{name}: {failures:#?}");
}

#[test]
fn every_shipped_scene_has_a_claim() {
    let names: Vec<&str> = shipped_scenes().iter().map(|(n, _)| *n).collect();
    for n in &names {
        claim(n, &Combo::nth(0));
    }
    assert!(names.len() >= 10, "shipped scenes: {names:?}");
    assert!(names.contains(&"scenes/tdcr_modeling.toml"));
}

#[test]
fn demo_two_section() {
    sample("scenes/demo_two_section.toml");
}

#[test]
fn track_demo() {
    sample("scenes/track_demo.toml");
}

#[test]
fn tdcr_modeling() {
    sample("scenes/tdcr_modeling.toml");
}

#[test]
fn ftdcr_v4() {
    sample("scenes/ftdcr_v4.toml");
}

#[test]
fn tdcr_two_segment() {
    sample("scenes/tdcr_two_segment.toml");
}

#[test]
fn till_tendon_readings() {
    sample("scenes/till_tendon_readings.toml");
}

#[test]
fn thesis_scenes() {
    for name in [
        "thesis/table_4_1.toml",
        "thesis/table_4_2.toml",
        "thesis/table_4_3.toml",
        "thesis/table_4_3_measured_mass.toml",
        "thesis/table_4_4.toml",
    ] {
        sample(name);
    }
}

/// The full sweep: every combination at every factor of [`SWEEP`]; prints, per scene
/// and combination, the largest factor up to which every solve converged, and the
/// summary the table of docs/settings-matrix.md is written from; asserts the claims and clean failures.
/// `SETTINGS_MATRIX_SCENE=track` restricts it to scenes whose name contains `track`.
#[test]
#[ignore = "the full matrix: an hour or more on 2 shared cores (see the module docs)"]
fn full_sweep() {
    let only = std::env::var("SETTINGS_MATRIX_SCENE").ok();
    // SETTINGS_MATRIX_COMBOS=covering: only the 8 combinations of the CI sample;
    // SETTINGS_MATRIX_LAMBDAS=0.25,0.5,1: other load factors
    let covering = std::env::var("SETTINGS_MATRIX_COMBOS").is_ok_and(|c| c == "covering");
    let sweep: Vec<f64> = std::env::var("SETTINGS_MATRIX_LAMBDAS")
        .ok()
        .map(|l| {
            l.split(',')
                .map(|x| x.trim().parse().expect("a load factor"))
                .collect()
        })
        .unwrap_or_else(|| SWEEP.to_vec());
    let mut failures = Vec::new();
    for (name, scene) in shipped_scenes() {
        if only.as_deref().is_some_and(|o| !name.contains(o)) {
            continue;
        }
        let t0 = std::time::Instant::now();
        let combos = combos_for(
            &scene,
            if covering {
                Combo::covering()
            } else {
                Combo::all()
            },
        );
        let mut reach = Vec::new();
        for combo in &combos {
            let mut up_to = 0.0;
            let mut all_so_far = true;
            let mut trail = String::new();
            for &lambda in &sweep {
                if combo.coupling == CableCoupling::Exact
                    && EXPENSIVE_EXACT.contains(&name)
                    && lambda > 1.0
                {
                    trail.push_str(&format!(" {lambda}:not-run"));
                    break;
                }
                let t = std::time::Instant::now();
                let out = solve(&scene, combo, lambda);
                let short = match &out {
                    Outcome::Converged => "ok".to_string(),
                    Outcome::Failed(s) => s.chars().take(24).collect(),
                    Outcome::Unclean(s) => format!("UNCLEAN {s}"),
                };
                trail.push_str(&format!(
                    " {lambda}:{short}({:.0}ms)",
                    t.elapsed().as_secs_f64() * 1e3
                ));
                match out {
                    Outcome::Converged if all_so_far => up_to = lambda,
                    Outcome::Converged => {}
                    Outcome::Failed(_) => all_so_far = false,
                    Outcome::Unclean(why) => {
                        all_so_far = false;
                        failures.push(format!("{name} {} at {lambda}: {why}", combo.label()));
                    }
                }
            }
            println!("{name} {:<50} reach {up_to:>4}  {trail}", combo.label());
            let claimed = claim(name, combo);
            if up_to < claimed && sweep.contains(&claimed) {
                failures.push(format!(
                    "{name} {}: converges only up to {up_to}, claimed {claimed}",
                    combo.label()
                ));
            }
            reach.push((combo.label(), up_to, combo.continuation));
        }
        // per continuation setting: the smallest reach, the largest, the limiting ones
        for cont in [true, false] {
            let part: Vec<&(String, f64, bool)> = reach.iter().filter(|r| r.2 == cont).collect();
            let min = part.iter().map(|r| r.1).fold(f64::INFINITY, f64::min);
            let max = part.iter().map(|r| r.1).fold(0.0, f64::max);
            let limiting: Vec<&str> = part
                .iter()
                .filter(|r| r.1 == min)
                .map(|r| r.0.as_str())
                .take(4)
                .collect();
            println!(
                "SUMMARY | `{name}` | continuation {cont} | {} | {min} | {max} | {} at {min}, e.g. {} |",
                part.len(),
                part.iter().filter(|r| r.1 == min).count(),
                limiting.join(", "),
            );
        }
        println!("{name}: {:.0} s", t0.elapsed().as_secs_f64());
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
