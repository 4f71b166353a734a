//! Nested versus joint estimator, same cases and inputs, same run.
//!
//! * `joint_tick_warm`: as `estimate_tick_warm` in `benches/estimate.rs` (shipped
//!   `data/scenes/track_demo.toml`: single section, five guides, three passive
//!   cables; lateral tip force unknown; 64 samples along a slowly moving tip force,
//!   cycled), one `tick` per iteration.
//! * `joint_cold`: `set_theta(0)` + one `tick` on sample 3 of 8 (as `estimate_cold`).
//! * `joint_two_section_warm`, `joint_two_section_cold`: shipped `data/scenes/demo_two_section.toml` (two
//!   sections, six cables, 1.5 N and 0.8 N tensions, 20 g payload, gravity across:
//!   36 shooting unknowns) with the lateral tip force `F_y`, `F_z` at the end of
//!   section 2 unknown (tolerance 1e-7 (1 + |F|) N, as the track demo); `warm`: 16
//!   samples along a slowly moving tip force, cycled; `cold`: from zero load.
//!
//! Methods: `nested_lm` (the default: Levenberg-Marquardt, sensitivities reused
//! with Broyden updates), `nested_lm_fresh` (`reuse_jacobian = false`: one exact
//! sweep per iteration, like the joint method) and `joint`.
//!
//! Before timing, one pass over each case prints, per method, the status counts and
//! the mean per tick of iterations, dual-number passes (one pass = up to 6
//! derivative directions) and `f64` passes (ODE right-hand-side counts divided by
//! those of one pass; RK4 has a fixed step count). Results: `benches/README.md`.

use cablesense::estimate::{
    Axis, EstimateSpec, EstimateStatus, Estimator, JointEstimator, Method, UnknownKind, UnknownSpec,
};
use cablesense::{PointLoad, Scene, Start, Workspace};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use std::time::Duration;

fn scene(name: &str) -> Scene {
    Scene::load(format!("{}/data/scenes/{name}", env!("CARGO_MANIFEST_DIR")))
        .expect("shipped scene")
}

/// The track demo's spec, or (two-section scene) lateral tip force y, z at the end
/// of section 1 with the track demo's stopping rule.
fn spec(scene: &Scene) -> EstimateSpec {
    scene.estimate.clone().unwrap_or_else(|| {
        let u = |axis| UnknownSpec::force(1, axis);
        EstimateSpec {
            tolerance: 1e-7,
            ..EstimateSpec::new(vec![u(Axis::Y), u(Axis::Z)])
        }
    })
}

/// Cable changes along a slowly moving tip force on the last section.
fn samples(scene: &Scene, n: usize, amplitude: f64) -> Vec<Vec<f64>> {
    let robot = scene.build_robot().unwrap();
    let section = robot.sections().len() - 1;
    let c = robot.cables().len();
    let mut ws = Workspace::new(robot, scene.loads.clone(), scene.numerics.clone()).unwrap();
    assert!(ws.solve(Start::Cold).status.is_converged());
    let mut reference = vec![0.0; c];
    ws.cable_lengths_into(&mut reference);
    let mut loads = scene.loads.clone();
    let i = match loads.point.iter().position(|p| p.section == section) {
        Some(i) => i,
        None => {
            loads.point.push(PointLoad {
                section,
                ..Default::default()
            });
            loads.point.len() - 1
        }
    };
    let base = loads.point[i].force_n;
    (0..n)
        .map(|k| {
            let t = k as f64 / n as f64 * std::f64::consts::TAU;
            loads.point[i].force_n = [
                base[0],
                base[1] + amplitude * (-1.0 - 0.2 * t.sin()),
                base[2] + amplitude * 0.2 * t.cos(),
            ];
            ws.set_loads(&loads).unwrap();
            assert!(ws.solve(Start::Warm).status.is_converged());
            let mut len = vec![0.0; c];
            ws.cable_lengths_into(&mut len);
            len.iter().zip(&reference).map(|(l, r)| l - r).collect()
        })
        .collect()
}

/// One estimator of either kind behind one interface.
enum Est {
    Nested(Box<Estimator>),
    Joint(Box<JointEstimator>),
}

impl Est {
    fn new(scene: &Scene, method: &str) -> Self {
        let robot = scene.build_robot().unwrap();
        let mut spec = spec(scene);
        spec.method = Method::LevenbergMarquardt;
        spec.reuse_jacobian = method != "nested_lm_fresh";
        let (loads, numerics) = (scene.loads.clone(), scene.numerics.clone());
        if method == "joint" {
            Est::Joint(Box::new(
                JointEstimator::new(robot, loads, numerics, spec).unwrap(),
            ))
        } else {
            Est::Nested(Box::new(
                Estimator::new(robot, loads, numerics, spec).unwrap(),
            ))
        }
    }
    fn tick(&mut self, s: &[f64]) -> EstimateStatus {
        match self {
            Est::Nested(e) => e.tick(s, None),
            Est::Joint(e) => e.tick(s, None),
        }
    }
    fn set_theta(&mut self, t: &[f64]) {
        match self {
            Est::Nested(e) => e.set_theta(t),
            Est::Joint(e) => e.set_theta(t),
        }
    }
    fn p(&self) -> usize {
        match self {
            Est::Nested(e) => e.theta().len(),
            Est::Joint(e) => e.theta().len(),
        }
    }
    fn ws(&mut self) -> &mut Workspace {
        match self {
            Est::Nested(e) => e.workspace(),
            Est::Joint(e) => e.workspace(),
        }
    }
    /// Iterations of the last tick (the snapshot's statistics refresh does not
    /// change them).
    fn iterations(&mut self) -> usize {
        match self {
            Est::Nested(e) => e.estimate().iterations,
            Est::Joint(e) => e.iterations(),
        }
    }
}

const METHODS: [&str; 3] = ["nested_lm", "nested_lm_fresh", "joint"];

/// ODE right-hand-side evaluations of one `f64` pass.
fn rhs_per_pass(ws: &mut Workspace) -> f64 {
    let x = ws.unknowns_vector().to_vec();
    let mut r = vec![0.0; x.len()];
    let before = ws.rhs_counts().f64_rhs;
    ws.shooting_residual(&x, &mut r);
    (ws.rhs_counts().f64_rhs - before) as f64
}

/// Print status counts and mean per-tick work of `ticks` (each `(cold, sample)`).
fn counts(case: &str, scene: &Scene, method: &str, warm_up: &[Vec<f64>], ticks: &[(bool, &[f64])]) {
    let mut e = Est::new(scene, method);
    for s in warm_up {
        e.tick(s);
    }
    let per = rhs_per_pass(e.ws());
    let zero = vec![0.0; e.p()];
    let (mut it, mut f64p, mut dualp) = (0.0, 0.0, 0.0);
    let mut status: Vec<(EstimateStatus, usize)> = Vec::new();
    for (cold, s) in ticks {
        if *cold {
            e.set_theta(&zero);
        }
        let c0 = e.ws().rhs_counts();
        let st = e.tick(s);
        let c1 = e.ws().rhs_counts();
        it += e.iterations() as f64;
        f64p += (c1.f64_rhs - c0.f64_rhs) as f64 / per;
        dualp += (c1.dual_rhs - c0.dual_rhs) as f64 / per;
        match status.iter_mut().find(|(s0, _)| *s0 == st) {
            Some((_, k)) => *k += 1,
            None => status.push((st, 1)),
        }
    }
    let n = ticks.len() as f64;
    println!(
        "COUNTS {case:34} {method:16} ticks {:3} iterations {:6.2} dual passes {:6.2} f64 passes {:7.2} status {status:?}",
        ticks.len(),
        it / n,
        dualp / n,
        f64p / n
    );
}

fn bench_case(
    c: &mut Criterion,
    group: &str,
    scene: &Scene,
    samples: &[Vec<f64>],
    cold: bool,
    time: Duration,
) {
    let ticks: Vec<(bool, &[f64])> = if cold {
        vec![(true, &samples[3][..])]
    } else {
        samples.iter().map(|s| (false, &s[..])).collect()
    };
    let warm_up: &[Vec<f64>] = if cold { &[] } else { samples };
    for method in METHODS {
        counts(group, scene, method, warm_up, &ticks);
    }
    let mut g = c.benchmark_group(group);
    g.measurement_time(time)
        .warm_up_time(Duration::from_millis(500));
    if time > Duration::from_secs(5) {
        g.sample_size(10);
    }
    for method in METHODS {
        let mut e = Est::new(scene, method);
        let zero = vec![0.0; e.p()];
        for s in warm_up {
            e.tick(s);
        }
        let mut i = 0;
        g.bench_function(BenchmarkId::from_parameter(method), |b| {
            b.iter(|| {
                if cold {
                    e.set_theta(&zero);
                    black_box(e.tick(black_box(&samples[3])))
                } else {
                    i = (i + 1) % samples.len();
                    black_box(e.tick(black_box(&samples[i])))
                }
            })
        });
    }
    g.finish();
}

/// Robustness count, printed once (not timed): the track demo with the tensions of
/// cables 0 and 1 unknown instead of the tip force (tensioned cables: hole positions
/// among the shooting unknowns), 32 tension pairs in [0.05, 3] N from a fixed
/// seed, each estimated from zero load by a fresh estimator at the default budget
/// of 20 iterations (spec tolerance 1e-10).
fn robustness(scene: &Scene) {
    let robot = scene.build_robot().unwrap();
    let u = |cable| UnknownSpec {
        cable: Some(cable),
        ..UnknownSpec::new(UnknownKind::Tension)
    };
    let spec = EstimateSpec::new(vec![u(0), u(1)]);
    let mut ws =
        Workspace::new(robot.clone(), scene.loads.clone(), scene.numerics.clone()).unwrap();
    assert!(ws.solve(Start::Cold).status.is_converged());
    let mut reference = vec![0.0; 3];
    ws.cable_lengths_into(&mut reference);
    let mut seed: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut uniform = || {
        // xorshift64* (Vigna 2016)
        seed ^= seed >> 12;
        seed ^= seed << 25;
        seed ^= seed >> 27;
        (seed.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut tally = [(0usize, 0usize, 0usize); 2]; // (converged, iterations sum, cases)
    let mut worst = [0usize; 2];
    for _ in 0..32 {
        let t = [0.05 + 2.95 * uniform(), 0.05 + 2.95 * uniform()];
        let mut loads = scene.loads.clone();
        loads.tensions_n = vec![t[0], t[1], 0.0];
        let mut truth = Workspace::new(robot.clone(), loads, scene.numerics.clone()).unwrap();
        if !truth.solve(Start::Cold).status.is_converged() {
            continue;
        }
        let mut len = vec![0.0; 3];
        truth.cable_lengths_into(&mut len);
        let changes: Vec<f64> = len.iter().zip(&reference).map(|(l, r)| l - r).collect();
        let (l, n) = (scene.loads.clone(), scene.numerics.clone());
        let mut nested = Estimator::new(robot.clone(), l.clone(), n.clone(), spec.clone()).unwrap();
        let sn = nested.tick(&changes, None);
        let itn = nested.estimate().iterations;
        let mut joint = JointEstimator::new(robot.clone(), l, n, spec.clone()).unwrap();
        let sj = joint.tick(&changes, None);
        let itj = joint.iterations();
        for (k, (s, it)) in [(sn, itn), (sj, itj)].into_iter().enumerate() {
            tally[k].2 += 1;
            if s == EstimateStatus::Converged {
                tally[k].0 += 1;
                tally[k].1 += it;
                worst[k] = worst[k].max(it);
            }
        }
    }
    for (k, name) in ["nested_lm", "joint"].into_iter().enumerate() {
        let (ok, its, n) = tally[k];
        println!(
            "ROBUSTNESS tensions cold from zero {name:10} converged {ok}/{n} within 20 iterations, mean iterations of those {:.1}, max {}",
            its as f64 / ok.max(1) as f64,
            worst[k]
        );
    }
}

fn single_section(c: &mut Criterion) {
    let scene = scene("track_demo.toml");
    robustness(&scene);
    // tip force (0, -0.05 - 0.01 sin t, 0.01 cos t) N, as benches/estimate.rs
    let warm = samples(&scene, 64, 0.05);
    bench_case(
        c,
        "joint_tick_warm",
        &scene,
        &warm,
        false,
        Duration::from_secs(3),
    );
    let cold = samples(&scene, 8, 0.05);
    bench_case(c, "joint_cold", &scene, &cold, true, Duration::from_secs(3));
}

fn two_section(c: &mut Criterion) {
    let scene = scene("demo_two_section.toml");
    let s = samples(&scene, 16, 0.02);
    bench_case(
        c,
        "joint_two_section_warm",
        &scene,
        &s,
        false,
        Duration::from_secs(5),
    );
    bench_case(
        c,
        "joint_two_section_cold",
        &scene,
        &s,
        true,
        Duration::from_secs(10),
    );
}

criterion_group!(benches, single_section, two_section);
criterion_main!(benches);
