//! Inverse kinematics on the calibrated FTDCR v4 (`data/calibration/
//! ftdcr_v4_calibrated.toml`, with its `[robot.limits]`): the targets are the model's
//! tips at the readings of the val recording (`data/hardware/ftdcr_v4/val.csv`), in
//! order.
//!
//! * `ik_warm_tick`: `IkWorkspace::solve` of the next row's tip, warm from the
//!   readings the previous solve returned (the control-loop case: a new target per
//!   tick, the previous tick's readings as the start). One iteration = one target;
//!   the rows are walked forward, then backward, and so on, so that every target
//!   is a neighbour of the previous one (starting over from the first row after
//!   the last was a jump across the workspace; the warm chain lost its way after
//!   it, ticks took up to 3.8 s each, and the bench did not finish its samples).
//!   Per-call percentiles: `examples/ik_tick_profile.rs`. Issue 44's target:
//!   <= 1 ms median.

use cablesense::command::{IkSettings, IkTarget, IkWorkspace};
use cablesense::Scene;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::Duration;

fn targets(scene: &Scene) -> Vec<IkTarget> {
    let text = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").unwrap();
    let tips = scene.model_tips(&text, usize::MAX).unwrap();
    tips.into_iter().map(IkTarget::position).collect()
}

fn benches(c: &mut Criterion) {
    let scene = Scene::load("data/calibration/ftdcr_v4_calibrated.toml").unwrap();
    let targets = targets(&scene);
    let mut g = c.benchmark_group("ik");
    g.measurement_time(Duration::from_secs(20)).sample_size(20);
    let mut ik = IkWorkspace::from_scene(&scene, IkSettings::default()).unwrap();
    // position in the forward-then-backward walk over the rows
    let n = targets.len();
    let mut step = 0usize;
    g.bench_function("ik_warm_tick", |b| {
        b.iter(|| {
            step = (step + 1) % (2 * n - 2);
            let k = if step < n { step } else { 2 * n - 2 - step };
            black_box(ik.solve(&targets[k]).unwrap())
        })
    });
    g.finish();
}

criterion_group!(ik, benches);
criterion_main!(ik);
