//! Continuous tendon routing (Rucker & Webster 2011) on Till's example tendon robot
//! (`data/scenes/till_tendon_robot.toml`: 0.5 m steel rod, four straight continuous
//! tendons, 15 N on the first, gravity; 16 RK4 steps).
//!
//! * `till_warm_ramp`: a warm solve per step of a tension ramp on the first tendon,
//!   1 -> 15 -> 1 N in steps of 0.1 N (the control-loop case; `set_loads` keeps the
//!   structure, no allocation). Issue 11 target: <= 50 us.
//! * `till_cold`: one cold solve at 15 N. Issue 11 target: <= 300 us.
//!
//! Solves that do not converge during timing are counted on stderr.

use cablesense::{Scene, Start, Workspace};
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::Duration;

fn benches(c: &mut Criterion) {
    let scene = Scene::load("data/scenes/till_tendon_robot.toml").expect("shipped scene");
    let robot = scene.build_robot().expect("robot");
    let mut ws = Workspace::new(robot, scene.loads.clone(), scene.numerics.clone()).expect("ws");
    let ramp: Vec<f64> = (0..=140)
        .chain((0..140).rev())
        .map(|k| 1.0 + 0.1 * k as f64)
        .collect();
    let mut loads = scene.loads.clone();
    let mut g = c.benchmark_group("continuous");
    g.measurement_time(Duration::from_secs(10)).sample_size(30);
    let (mut k, mut failed) = (0usize, 0usize);
    ws.solve(Start::Cold);
    g.bench_function("till_warm_ramp", |b| {
        b.iter(|| {
            loads.tensions_n[0] = ramp[k % ramp.len()];
            ws.set_loads(&loads).expect("same structure");
            failed += usize::from(!ws.solve(black_box(Start::Warm)).status.is_converged());
            k += 1;
        })
    });
    ws.set_loads(&scene.loads).expect("loads");
    g.bench_function("till_cold", |b| {
        b.iter(|| {
            failed += usize::from(!ws.solve(black_box(Start::Cold)).status.is_converged());
        })
    });
    g.finish();
    if failed > 0 {
        eprintln!("continuous benches: {failed} solves did not converge");
    }
}

criterion_group!(continuous, benches);
criterion_main!(continuous);
