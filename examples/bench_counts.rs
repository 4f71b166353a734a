//! The timed closures of the hot-path benches as a plain program, for counting
//! instructions under callgrind (deterministic, unlike criterion's wall clock on a
//! shared machine; `benches/README.md`, session 11).
//!
//! ```text
//! cargo build --release --example bench_counts
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.%p \
//!     target/release/examples/bench_counts CASE ITERS
//! ```
//!
//! `CASE` is a bench id (`bench_counts list` prints them):
//!
//! * `forward_warm/{average,point,accurate}/rk4_24`,
//!   `forward_cold_tensioned/two_section_rk4_24`,
//!   `forward_cold_tensioned/demo_two_section_scene` (`benches/forward.rs`);
//! * `estimate_tick_warm/lm`, `estimate_tick_warm/gn`,
//!   `estimate_tick_warm/constrained_qp` (`benches/estimate.rs`);
//! * `continuous/till_warm_ramp`, `continuous/till_disks_100_warm_ramp`
//!   (`benches/continuous.rs`);
//! * `tendons/tendon_readings_warm`, `tendons/tendon_track_row`,
//!   `tendons/tendon_control_tick_1khz` (`benches/tendons.rs`: the FTDCR v4 val rows,
//!   443 rows a cycle; the tick case walks the recording at 1 kHz).
//!
//! Each case builds its inputs exactly as its bench does (same robots, loads, scenes,
//! settings and set-up solves, all before the loop) and then runs the bench's timed
//! closure `ITERS` times. Besides the closure, each iteration only adds a few
//! additions into a checksum (the cable lengths the forward closures compute, the
//! estimate `theta` after a tick, the tip position after a continuous solve), and
//! counts non-converged solves (forward) or ticks whose status is not `converged`
//! (estimator). The checksum (printed with 17 digits, and the final tip position)
//! shows whether two builds computed the same numbers. Per-iteration cost without
//! the set-up: `(I(2N) - I(N)) / N` from two runs. A bench's counter (`k`, `i`)
//! starts where the bench's first timed call starts; criterion's warm-up iterations
//! are not replayed, so choose `N` a multiple of the input cycle (3 tip forces,
//! 64 estimator samples, 281 ramp steps) to average over whole cycles.
//!
//! The same file builds against the old library (`9bb275a`, before the reliability
//! work), with two differences there, both at run time and without `cfg`:
//!
//! * `continuous/till_warm_ramp` needs continuous tendon routing and the scene
//!   `data/scenes/till_tendon_robot.toml`, neither of which exists at `9bb275a`; the
//!   case exits with an error there (counted on the new build only).
//! * `continuous/till_disks_100_warm_ramp` takes its loads from that scene in the
//!   bench; here they are written out (`till_loads`: gravity 9.81 m/s^2 along +x,
//!   tensions 15, 0, 0, 0 N, no point loads), so the case runs on both builds. On a
//!   build that has the scene, the case checks that the written-out loads equal the
//!   scene's and exits with an error otherwise.

use cablesense::estimate::{EstimateSpec, EstimateStatus, Estimator, Method};
use cablesense::robot::{CableSpec, GuideSpec, HolesSpec, SectionSpec};
use cablesense::{
    CrossSection, GuideMass, Integrator, Loads, Material, PointLoad, Robot, RobotSpec, RodModel,
    Scene, SolverSettings, Start, Workspace,
};
use std::hint::black_box;
use std::process::ExitCode;

const CASES: [&str; 13] = [
    "forward_warm/average/rk4_24",
    "forward_warm/point/rk4_24",
    "forward_warm/accurate/rk4_24",
    "forward_cold_tensioned/two_section_rk4_24",
    "forward_cold_tensioned/demo_two_section_scene",
    "estimate_tick_warm/lm",
    "estimate_tick_warm/gn",
    "estimate_tick_warm/constrained_qp",
    "continuous/till_warm_ramp",
    "continuous/till_disks_100_warm_ramp",
    "tendons/tendon_readings_warm",
    "tendons/tendon_track_row",
    "tendons/tendon_control_tick_1khz",
];

/// What a case hands back: the checksum, the final tip and the failed count.
struct Outcome {
    checksum: f64,
    tip: [f64; 3],
    not_converged: u64,
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("list") {
        for c in CASES {
            println!("{c}");
        }
        return ExitCode::SUCCESS;
    }
    let (case, iters) = match (args.get(1), args.get(2).and_then(|s| s.parse::<u64>().ok())) {
        (Some(case), Some(iters)) if args.len() == 3 => (case.as_str(), iters),
        _ => {
            eprintln!("usage: bench_counts CASE ITERS   (bench_counts list: the cases)");
            return ExitCode::from(2);
        }
    };
    let outcome = match case {
        "forward_warm/average/rk4_24" => Ok(forward_warm(iters, GuideMass::Average)),
        "forward_warm/point/rk4_24" => Ok(forward_warm(iters, GuideMass::Point)),
        "forward_warm/accurate/rk4_24" => Ok(forward_warm(iters, GuideMass::Accurate)),
        "forward_cold_tensioned/two_section_rk4_24" => Ok(forward_cold(
            iters,
            two_section_robot(),
            tensioned_loads(),
            SolverSettings::default(),
        )),
        "forward_cold_tensioned/demo_two_section_scene" => {
            let scene = load_scene("demo_two_section.toml");
            scene.map(|scene| {
                let robot = scene.build_robot().expect("demo scene robot");
                forward_cold(iters, robot, scene.loads, scene.numerics)
            })
        }
        "estimate_tick_warm/lm" => Ok(tick_warm(iters, Method::LevenbergMarquardt)),
        "estimate_tick_warm/gn" => Ok(tick_warm(iters, Method::GaussNewton)),
        "estimate_tick_warm/constrained_qp" => Ok(tick_warm(iters, Method::Constrained)),
        "continuous/till_warm_ramp" => till_warm_ramp(iters),
        "continuous/till_disks_100_warm_ramp" => till_disks_warm_ramp(iters),
        "tendons/tendon_readings_warm" => tendon_rows(iters, TendonCase::Warm),
        "tendons/tendon_track_row" => tendon_rows(iters, TendonCase::Track),
        "tendons/tendon_control_tick_1khz" => tendon_rows(iters, TendonCase::Tick),
        _ => Err(format!(
            "unknown case {case:?} (bench_counts list: the cases)"
        )),
    };
    match outcome {
        Ok(o) => {
            println!(
                "case {case} iters {iters} checksum {:.17e} tip {:.17e} {:.17e} {:.17e} not_converged {}",
                o.checksum, o.tip[0], o.tip[1], o.tip[2], o.not_converged
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{case}: {e}");
            ExitCode::FAILURE
        }
    }
}

fn load_scene(file: &str) -> Result<Scene, String> {
    let path = format!("{}/data/scenes/{file}", env!("CARGO_MANIFEST_DIR"));
    Scene::load(&path).map_err(|e| format!("scene {path}: {e}"))
}

fn tip(ws: &Workspace) -> [f64; 3] {
    let t = ws.tip_position();
    [t.x, t.y, t.z]
}

// ---------------------------------------------------------------- benches/forward.rs

/// Gravity across the rod: the backbone runs along world +z, gravity along -y.
const GRAVITY_ACROSS: [f64; 3] = [0.0, -9.81, 0.0];

/// The three tip forces (N, world) the warm bench cycles through.
const TIP_FORCES: [[f64; 3]; 3] = [
    [0.02, 0.0, 0.0],
    [0.0205, 0.0005, 0.0],
    [0.0205, 0.0, 0.0005],
];

fn nitinol() -> Material {
    Material {
        youngs_modulus_pa: 62.7e9,
        poisson_ratio: 0.3,
        density_kg_m3: 6800.0,
    }
}

fn section(length: f64, guides: GuideSpec) -> SectionSpec {
    SectionSpec {
        length_m: length,
        shape: CrossSection::Solid {
            diameter_m: 1.56e-3,
        },
        material: nitinol(),
        shear_coefficient: 1.0,
        precurvature_per_m: [0.0; 3],
        guides: Some(guides),
    }
}

/// Guide disks: 3.01 mm thick, 2.2 g, holes on a 1 cm radius at 90/210/330 deg.
fn guides(count: usize, first: f64, spacing: f64) -> GuideSpec {
    GuideSpec {
        count,
        first_offset_m: first,
        spacing_m: spacing,
        thickness_m: 3.01e-3,
        diameter_m: 0.028,
        mass_kg: 2.2e-3,
        holes: HolesSpec {
            radius_m: 0.01,
            angles_deg: vec![90.0, 210.0, 330.0],
        },
        even: Default::default(),
    }
}

fn cable(hole: usize, end_section: usize) -> CableSpec {
    CableSpec {
        name: None,
        hole: Some(hole),
        end_section,
        ..Default::default()
    }
}

/// One 0.39 m section, five guides, three cables ending on the last disk.
fn single_section_robot() -> Robot {
    Robot::new(RobotSpec {
        limits: None,
        base: Default::default(),
        sections: vec![section(0.39, guides(5, 0.0054, 0.095))],
        cables: (0..3).map(|h| cable(h, 0)).collect(),
        tendons: None,
        friction: None,
    })
    .expect("valid single-section robot")
}

/// Two 0.195 m sections with four guides each; cables 0-2 end on section 0, 3-5 on 1.
fn two_section_robot() -> Robot {
    let s = || section(0.195, guides(4, 0.045, 0.045));
    Robot::new(RobotSpec {
        limits: None,
        base: Default::default(),
        sections: vec![s(), s()],
        cables: (0..6).map(|j| cable(j % 3, j / 3)).collect(),
        tendons: None,
        friction: None,
    })
    .expect("valid two-section robot")
}

/// Gravity across the rod, three passive cables, tip force `TIP_FORCES[k]`.
fn warm_loads(k: usize) -> Loads {
    Loads {
        gravity_m_s2: GRAVITY_ACROSS,
        point: vec![PointLoad {
            section: 0,
            force_n: TIP_FORCES[k],
            ..Default::default()
        }],
        tensions_n: vec![0.0; 3],
    }
}

/// Gravity across the rod, one tensioned cable per section.
fn tensioned_loads() -> Loads {
    Loads {
        gravity_m_s2: GRAVITY_ACROSS,
        point: Vec::new(),
        tensions_n: vec![1.5, 0.0, 0.0, 0.0, 0.8, 0.0],
    }
}

/// `forward_warm/average/rk4_24`: `warm_workspace` + `bench_warm`'s closure.
fn forward_warm(iters: u64, guide_mass: GuideMass) -> Outcome {
    let robot = single_section_robot();
    let s = SolverSettings {
        integrator: Integrator::Rk4 {
            steps_per_section: 24,
        },
        guide_mass,
        rod_model: RodModel::Cosserat,
        ..Default::default()
    };
    let mut ws = Workspace::new(robot.clone(), warm_loads(0), s).expect("valid workspace");
    for k in [0, 1, 2, 0] {
        ws.set_loads(&warm_loads(k)).expect("valid loads");
        let rep = ws.solve(Start::Warm);
        assert!(
            rep.status.is_converged(),
            "setup solve with tip force {:?} did not converge: {rep:?}",
            TIP_FORCES[k]
        );
    }
    let loads = [warm_loads(0), warm_loads(1), warm_loads(2)];
    let mut lengths = vec![0.0; robot.cables().len()];
    let mut k = 0usize;
    let mut not_converged = 0u64;
    let mut checksum = 0.0;
    for _ in 0..iters {
        k = (k + 1) % loads.len();
        ws.set_loads(black_box(&loads[k])).expect("valid loads");
        let rep = ws.solve(Start::Warm);
        not_converged += u64::from(!rep.status.is_converged());
        ws.cable_lengths_into(&mut lengths);
        black_box(&lengths);
        checksum += lengths.iter().sum::<f64>();
    }
    Outcome {
        checksum: black_box(checksum),
        tip: tip(&ws),
        not_converged,
    }
}

/// `forward_cold_tensioned/*`: `bench_cold`'s set-up and closure.
fn forward_cold(iters: u64, robot: Robot, loads: Loads, s: SolverSettings) -> Outcome {
    let mut lengths = vec![0.0; robot.cables().len()];
    let mut ws = Workspace::new(robot, loads, s).expect("valid workspace");
    let rep = ws.solve(Start::Cold);
    assert!(rep.status.is_converged(), "setup cold solve: {rep:?}");
    let mut not_converged = 0u64;
    let mut checksum = 0.0;
    for _ in 0..iters {
        let rep = ws.solve(black_box(Start::Cold));
        not_converged += u64::from(!rep.status.is_converged());
        ws.cable_lengths_into(&mut lengths);
        black_box(&lengths);
        checksum += lengths.iter().sum::<f64>();
    }
    Outcome {
        checksum: black_box(checksum),
        tip: tip(&ws),
        not_converged,
    }
}

// --------------------------------------------------------------- benches/estimate.rs

/// Cable changes along a slowly moving tip force (the control-loop case).
fn samples(scene: &Scene, n: usize) -> Vec<Vec<f64>> {
    let robot = scene.build_robot().unwrap();
    let mut ws = Workspace::new(robot, scene.loads.clone(), scene.numerics.clone()).unwrap();
    ws.solve(Start::Cold);
    let mut reference = vec![0.0; 3];
    ws.cable_lengths_into(&mut reference);
    let mut loads = scene.loads.clone();
    loads.point.push(PointLoad {
        section: 0,
        ..Default::default()
    });
    (0..n)
        .map(|i| {
            let t = i as f64 / n as f64 * std::f64::consts::TAU;
            loads.point[0].force_n = [0.0, -0.05 - 0.01 * t.sin(), 0.01 * t.cos()];
            ws.set_loads(&loads).unwrap();
            assert!(ws.solve(Start::Warm).status.is_converged());
            let mut len = vec![0.0; 3];
            ws.cable_lengths_into(&mut len);
            len.iter().zip(&reference).map(|(l, r)| l - r).collect()
        })
        .collect()
}

/// `estimate_tick_warm/*`: 64 samples, the estimator run once through them, then
/// one `tick` per iteration on the next sample.
fn tick_warm(iters: u64, method: Method) -> Outcome {
    let scene = load_scene("track_demo.toml").expect("shipped scene");
    let samples = samples(&scene, 64);
    let mut spec: EstimateSpec = scene.estimate.clone().expect("track demo has [estimate]");
    spec.method = method;
    let mut est = Estimator::new(
        scene.build_robot().unwrap(),
        scene.loads.clone(),
        scene.numerics.clone(),
        spec,
    )
    .unwrap();
    for s in &samples {
        est.tick(s, None);
    }
    let mut i = 0;
    let mut not_converged = 0u64;
    let mut checksum = 0.0;
    for _ in 0..iters {
        i = (i + 1) % samples.len();
        let status = black_box(est.tick(black_box(&samples[i]), None));
        not_converged += u64::from(status != EstimateStatus::Converged);
        checksum += est.theta().iter().sum::<f64>();
    }
    let t = est.tip_position();
    Outcome {
        checksum: black_box(checksum),
        tip: [t.x, t.y, t.z],
        not_converged,
    }
}

// ------------------------------------------------------------- benches/continuous.rs

/// The tension ramp on the first tendon: 1 -> 15 -> 1 N in steps of 0.1 N.
fn ramp() -> Vec<f64> {
    (0..=140)
        .chain((0..140).rev())
        .map(|k| 1.0 + 0.1 * k as f64)
        .collect()
}

/// `continuous/till_warm_ramp` (new build only: continuous routing).
fn till_warm_ramp(iters: u64) -> Result<Outcome, String> {
    let scene = load_scene("till_tendon_robot.toml")?;
    let robot = scene.build_robot().map_err(|e| format!("robot: {e}"))?;
    let mut ws = Workspace::new(robot, scene.loads.clone(), scene.numerics.clone()).expect("ws");
    let ramp = ramp();
    let mut loads = scene.loads.clone();
    let (mut k, mut failed) = (0usize, 0u64);
    ws.solve(Start::Cold);
    let mut checksum = 0.0;
    for _ in 0..iters {
        loads.tensions_n[0] = ramp[k % ramp.len()];
        ws.set_loads(&loads).expect("same structure");
        failed += u64::from(!ws.solve(black_box(Start::Warm)).status.is_converged());
        k += 1;
        checksum += tip(&ws).iter().sum::<f64>();
    }
    Ok(Outcome {
        checksum: black_box(checksum),
        tip: tip(&ws),
        not_converged: failed,
    })
}

/// The loads of `data/scenes/till_tendon_robot.toml`, written out.
fn till_loads() -> Loads {
    Loads {
        gravity_m_s2: [9.81, 0.0, 0.0],
        point: Vec::new(),
        tensions_n: vec![15.0, 0.0, 0.0, 0.0],
    }
}

/// `continuous/till_disks_100_warm_ramp`.
fn till_disks_warm_ramp(iters: u64) -> Result<Outcome, String> {
    if let Ok(scene) = load_scene("till_tendon_robot.toml") {
        if scene.loads != till_loads() {
            return Err(format!(
                "written-out loads {:?} differ from the scene's {:?}",
                till_loads(),
                scene.loads
            ));
        }
    }
    let mut disks = Workspace::new(
        till_with_disks(100),
        till_loads(),
        SolverSettings {
            integrator: Integrator::Rk4 {
                steps_per_section: 100,
            },
            ..SolverSettings::default()
        },
    )
    .expect("ws");
    let ramp = ramp();
    let mut loads = till_loads();
    let (mut k, mut failed) = (0usize, 0u64);
    disks.solve(Start::Cold);
    let mut checksum = 0.0;
    for _ in 0..iters {
        loads.tensions_n[0] = ramp[k % ramp.len()];
        disks.set_loads(&loads).expect("same structure");
        failed += u64::from(!disks.solve(black_box(Start::Warm)).status.is_converged());
        k += 1;
        checksum += tip(&disks).iter().sum::<f64>();
    }
    Ok(Outcome {
        checksum: black_box(checksum),
        tip: tip(&disks),
        not_converged: failed,
    })
}

/// Till's rod (0.5 m steel, r = 1 mm) with `n` massless, zero-thickness disks at
/// spacing `L/n` carrying the four tendons through holes at 15.06 mm.
fn till_with_disks(n: usize) -> Robot {
    let h = 0.5 / n as f64;
    Robot::new(RobotSpec {
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
            guides: Some(GuideSpec {
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
            }),
        }],
        cables: (0..4).map(|k| CableSpec::through_hole(k, 0)).collect(),
        tendons: None,
        friction: None,
    })
    .expect("robot")
}

// ---------------------------------------------------------------- benches/tendons.rs

/// The timed closure of a tendon bench.
#[derive(Clone, Copy)]
enum TendonCase {
    /// `tendon_readings_warm`: one warm row.
    Warm,
    /// `tendon_track_row`: one warm row and its JSON record.
    Track,
    /// `tendon_control_tick_1khz`: one tick of readings interpolated at 1 kHz.
    Tick,
}

/// The FTDCR v4 val rows on the shipped scene, each case's closure `iters` times from
/// the bench's state at its first timed call (a fresh workspace, row 0, tick 0). The
/// rows are read line by line as at `c1f105d` (the same rows as `good_rows`).
fn tendon_rows(iters: u64, case: TendonCase) -> Result<Outcome, String> {
    let scene = load_scene("ftdcr_v4.toml")?;
    let mut ws = scene.tendon_workspace().map_err(|e| e.to_string())?;
    let path = format!(
        "{}/data/hardware/ftdcr_v4/val.csv",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{path}: {e}"))?;
    let mut p = scene.readings_parser(&ws);
    let rows: Vec<_> = text
        .lines()
        .enumerate()
        .filter_map(|(i, l)| p.line(i + 1, l).ok().flatten())
        .collect();
    let times: Vec<f64> = rows.iter().map(|r| r.t_s.unwrap_or(0.0)).collect();
    let (mut k, mut t, mut q) = (0usize, times[0], rows[0].readings_m.clone());
    let mut not_converged = 0u64;
    let mut checksum = 0.0;
    for i in 0..iters as usize {
        let r = match case {
            TendonCase::Warm | TendonCase::Track => {
                ws.solve_readings(black_box(&rows[i % rows.len()].readings_m))
            }
            TendonCase::Tick => {
                // benches/tendons.rs `Ticks::next`
                t += 1e-3;
                while k + 1 < rows.len() && t >= times[k + 1] {
                    k += 1;
                }
                if k + 1 >= rows.len() {
                    k = 0;
                    t = times[0];
                }
                let (a, b) = (&rows[k].readings_m, &rows[k + 1].readings_m);
                let (t0, t1) = (times[k], times[k + 1]);
                let s = if t1 > t0 {
                    ((t - t0) / (t1 - t0)).clamp(0.0, 1.0)
                } else {
                    1.0
                };
                for ((q, a), b) in q.iter_mut().zip(a).zip(b) {
                    *q = a + s * (b - a);
                }
                ws.solve_readings(black_box(&q))
            }
        };
        not_converged += u64::from(!r.is_ok_and(|r| r.status.is_converged()));
        let tip = ws.tip_position();
        if let TendonCase::Track = case {
            let rec = serde_json::json!({
                "line": rows[i % rows.len()].line, "tip_position_m": [tip.x, tip.y, tip.z],
                "tensions_n": ws.tensions(), "taut": ws.taut(),
            });
            black_box(rec.to_string());
        }
        checksum += tip.x + tip.y + tip.z;
    }
    let tip = ws.tip_position();
    Ok(Outcome {
        checksum: black_box(checksum),
        tip: [tip.x, tip.y, tip.z],
        not_converged,
    })
}
