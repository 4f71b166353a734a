//! Model-ladder benches: time per forward solve for each rung family and setting, and
//! one estimator tick per rod rung, through the public ladder API (`Rung::build`,
//! `ForwardModel`) on a shipped thesis scene.
//!
//! * `ladder_forward_warm`: `data/thesis/table_4_4.toml` as shipped (one 0.39 m
//!   Nitinol section clamped horizontally, five 2.2 g guide disks, one measuring cable,
//!   gravity, 83.2 g tip mass; accurate guide-mass model). Each iteration moves to the
//!   next of three loads (the scene; the tip mass at 87.4 g, +5 %; the scene plus a
//!   horizontal tip force of the same 41 mN) and measures `solve(Start::Warm)` +
//!   `cable_lengths_into`, so every warm start begins from another load's equilibrium.
//!   (Until session 9 it alternated between the first two: the rod rungs' load-path
//!   predictor extrapolates an alternation exactly to the stored solution; three loads
//!   whose steps are not parallel keep it out.)
//!   Rungs: constant curvature; piecewise constant curvature at 4 and 16 pieces per
//!   section; Kirchhoff and Cosserat rods at RK4 8/24/64 steps per section and adaptive
//!   Dormand-Prince at tol 1e-6 and 1e-10. The curvature rungs and the rods use the
//!   scene's guide-mass model (accurate); other settings are the rungs' defaults.
//! * `ladder_estimate_tick`: per rung (curvature rungs included), Levenberg-Marquardt (`EstimateSpec` defaults)
//!   with the vertical tip force as unknown (the one cable sees it); the measurements
//!   are the same rung's cable changes along a slowly varying extra tip force
//!   `-0.02 - 0.01 sin t` N (32 samples, cycled), one warm `tick` per iteration.
//!
//! Robots, models, samples and estimators are built, and checked to converge, outside
//! the timed closures; a timed solve or tick that does not converge is counted and
//! reported on stderr. Results log: `benches/README.md`.

use cablesense::estimate::{Axis, EstimateSpec, EstimateStatus, Estimator};
use cablesense::estimate::{Method, UnknownSpec};
use cablesense::ladder::{CcSettings, ForwardModel, PccSettings, Rung};
use cablesense::{Integrator, Loads, PointLoad, RodModel, Scene, SolverSettings, Start};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use std::time::Duration;

/// Extra tip mass of the second warm load (kg): +5 % of the scene's 83.2 g.
const EXTRA_MASS_KG: f64 = 0.0832 * 0.05;
/// Samples of the estimator bench (one revolution of the tip-force wobble).
const TICK_SAMPLES: usize = 32;

fn scene() -> Scene {
    Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/thesis/table_4_4.toml"
    ))
    .expect("shipped thesis scene")
}

/// The rungs benchmarked, with bench ids.
fn rungs(scene: &Scene) -> Vec<(String, Rung)> {
    let guide_mass = scene.numerics.guide_mass;
    let mut out = vec![(
        "cc".to_string(),
        Rung::ConstantCurvature(CcSettings::default()),
    )];
    for pieces in [4, 16] {
        out.push((
            format!("pcc_{pieces}"),
            Rung::PiecewiseConstantCurvature(PccSettings {
                pieces_per_section: pieces,
                guide_mass,
                ..PccSettings::default()
            }),
        ));
    }
    for (model, name) in [
        (RodModel::Kirchhoff, "kirchhoff"),
        (RodModel::Cosserat, "cosserat"),
    ] {
        let mut ints: Vec<(String, Integrator)> = [8, 24, 64]
            .into_iter()
            .map(|n| {
                (
                    format!("rk4_{n}"),
                    Integrator::Rk4 {
                        steps_per_section: n,
                    },
                )
            })
            .collect();
        for (tol, label) in [(1e-6, "1e-6"), (1e-10, "1e-10")] {
            ints.push((
                format!("adaptive_{label}"),
                Integrator::Adaptive {
                    tol,
                    max_steps: 100_000,
                },
            ));
        }
        for (int_name, integrator) in ints {
            out.push((
                format!("{name}_{int_name}"),
                Rung::Rod(SolverSettings {
                    rod_model: model,
                    guide_mass,
                    integrator,
                    ..SolverSettings::default()
                }),
            ));
        }
    }
    out
}

/// The scene's loads with the tip mass raised by `extra` kg.
fn heavier(loads: &Loads, extra: f64) -> Loads {
    let mut out = loads.clone();
    out.point[0].mass_kg += extra;
    out
}

fn forward_warm(c: &mut Criterion) {
    let scene = scene();
    let robot = scene.build_robot().expect("scene robot");
    let mut sideways = scene.loads.clone();
    sideways.point[0].force_n[0] += EXTRA_MASS_KG * 9.81;
    let loads = [
        scene.loads.clone(),
        heavier(&scene.loads, EXTRA_MASS_KG),
        sideways,
    ];
    let nc = robot.cables().len();
    let mut g = c.benchmark_group("ladder_forward_warm");
    g.measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(300))
        .sample_size(20);
    for (id, rung) in rungs(&scene) {
        let mut model = rung.build(&robot).expect("rung builds");
        for l in &loads {
            let rep = model.solve(l, Start::Cold).expect("valid loads");
            assert!(rep.status.is_converged(), "{id}: {rep:?}");
        }
        let mut lengths = vec![0.0; nc];
        let mut i = 0;
        let mut failed = 0usize;
        g.bench_function(BenchmarkId::from_parameter(&id), |b| {
            b.iter(|| {
                i = (i + 1) % loads.len();
                let rep = model
                    .solve(black_box(&loads[i]), Start::Warm)
                    .expect("valid loads");
                failed += usize::from(!rep.status.is_converged());
                model.cable_lengths_into(&mut lengths);
                black_box(&lengths);
            })
        });
        if failed > 0 {
            eprintln!("WARNING ladder_forward_warm/{id}: {failed} timed solves did not converge");
        }
    }
    g.finish();
}

/// Cable changes of `model` along the tip-force wobble, from its lengths at `loads`.
fn samples(model: &mut dyn ForwardModel, loads: &Loads) -> Vec<Vec<f64>> {
    let nc = model.robot().cables().len();
    let mut reference = vec![0.0; nc];
    assert!(model
        .solve(loads, Start::Cold)
        .expect("valid loads")
        .status
        .is_converged());
    model.cable_lengths_into(&mut reference);
    let mut l = loads.clone();
    l.point.push(PointLoad {
        section: 0,
        ..Default::default()
    });
    let k = l.point.len() - 1;
    (0..TICK_SAMPLES)
        .map(|i| {
            let t = i as f64 / TICK_SAMPLES as f64 * std::f64::consts::TAU;
            l.point[k].force_n = [0.0, -0.02 - 0.01 * t.sin(), 0.0];
            let rep = model.solve(&l, Start::Warm).expect("valid loads");
            assert!(rep.status.is_converged(), "sample {i}: {rep:?}");
            let mut len = vec![0.0; nc];
            model.cable_lengths_into(&mut len);
            len.iter().zip(&reference).map(|(a, b)| a - b).collect()
        })
        .collect()
}

fn estimate_tick(c: &mut Criterion) {
    let scene = scene();
    let robot = scene.build_robot().expect("scene robot");
    let mut g = c.benchmark_group("ladder_estimate_tick");
    g.measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(300))
        .sample_size(20);
    for (id, rung) in rungs(&scene) {
        let mut model = rung.build(&robot).expect("rung builds");
        let samples = samples(model.as_mut(), &scene.loads);
        let spec = EstimateSpec {
            method: Method::LevenbergMarquardt,
            ..EstimateSpec::new(vec![UnknownSpec::force(0, Axis::Y)])
        };
        // every rung, the curvature ones included (exact sensitivities, `ladder::sens`)
        let mut est = Estimator::on_rung(robot.clone(), scene.loads.clone(), &rung, spec)
            .expect("estimator builds");
        for s in &samples {
            est.tick(s, None);
        }
        let mut i = 0;
        let mut failed = 0usize;
        g.bench_function(BenchmarkId::from_parameter(&id), |b| {
            b.iter(|| {
                i = (i + 1) % samples.len();
                let status = est.tick(black_box(&samples[i]), None);
                failed += usize::from(status != EstimateStatus::Converged);
                black_box(status)
            })
        });
        if failed > 0 {
            eprintln!("WARNING ladder_estimate_tick/{id}: {failed} timed ticks did not converge");
        }
    }
    g.finish();
}

criterion_group!(benches, forward_warm, estimate_tick);
criterion_main!(benches);
