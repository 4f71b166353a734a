//! Estimator benches. The headline is one warm-started estimator tick.
//!
//! * `estimate_tick_warm`: the shipped track demo scene (`data/scenes/track_demo.toml`:
//!   single section, five guides, three passive cables, rod horizontal, gravity) with the
//!   lateral tip force unknown; the measurements follow a slowly moving tip force
//!   (64 samples precomputed with the forward model, cycled), one `tick` per
//!   iteration, for each method. Issue target: <= 50 us.
//! * `estimate_cold`: from zero load with no reusable sensitivities, one sample.
//!   Issue target: <= 1 ms.
//!
//! Samples and estimators are built outside the timed closures. Results log:
//! `benches/README.md`.

use cablesense::estimate::{EstimateSpec, Estimator, Method};
use cablesense::{PointLoad, Scene, Start, Workspace};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use std::time::Duration;

fn scene() -> Scene {
    Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/scenes/track_demo.toml"
    ))
    .expect("shipped scene")
}

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

fn estimator(scene: &Scene, method: Method) -> Estimator {
    let mut spec: EstimateSpec = scene.estimate.clone().expect("track demo has [estimate]");
    spec.method = method;
    Estimator::new(
        scene.build_robot().unwrap(),
        scene.loads.clone(),
        scene.numerics.clone(),
        spec,
    )
    .unwrap()
}

const METHODS: [(Method, &str); 4] = [
    (Method::LevenbergMarquardt, "lm"),
    (Method::GaussNewton, "gn"),
    (Method::Constrained, "constrained_qp"),
    (Method::ArgminGaussNewton, "argmin_gn"),
];

fn tick_warm(c: &mut Criterion) {
    let scene = scene();
    let samples = samples(&scene, 64);
    let mut g = c.benchmark_group("estimate_tick_warm");
    g.measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    for (method, name) in METHODS {
        let mut est = estimator(&scene, method);
        for s in &samples {
            est.tick(s, None);
        }
        let mut i = 0;
        g.bench_function(BenchmarkId::from_parameter(name), |b| {
            b.iter(|| {
                i = (i + 1) % samples.len();
                black_box(est.tick(black_box(&samples[i]), None))
            })
        });
    }
    g.finish();
}

fn cold(c: &mut Criterion) {
    let scene = scene();
    let samples = samples(&scene, 8);
    let mut g = c.benchmark_group("estimate_cold");
    g.measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    for (method, name) in METHODS {
        let mut est = estimator(&scene, method);
        let zero = vec![0.0; est.theta().len()];
        g.bench_function(BenchmarkId::from_parameter(name), |b| {
            b.iter(|| {
                est.set_theta(&zero);
                black_box(est.tick(black_box(&samples[3]), None))
            })
        });
    }
    g.finish();
}

criterion_group!(benches, tick_warm, cold);
criterion_main!(benches);
