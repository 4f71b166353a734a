//! Inverse kinematics on the calibrated FTDCR v4 (`data/calibration/
//! ftdcr_v4_calibrated.toml`, with its `[robot.limits]`): the targets are the model's
//! tips at the readings of the val recording (`data/hardware/ftdcr_v4/val.csv`), in
//! order.
//!
//! * `ik_warm_tick`: `IkWorkspace::solve` of the next row's tip, warm from the
//!   readings the previous solve returned (the control-loop case: a new target per
//!   tick, the previous tick's readings as the start). One iteration = one target;
//!   after the last row it starts over from the first (one jump per 442 ticks).
//!   Issue 44's target: <= 1 ms median.

use cablesense::command::{IkSettings, IkTarget, IkWorkspace};
use cablesense::Scene;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::Duration;

fn targets(scene: &Scene) -> Vec<IkTarget> {
    let mut tw = scene.tendon_workspace().unwrap();
    let mut p = scene.readings_parser(&tw);
    let text = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").unwrap();
    let mut out = Vec::new();
    for (i, l) in text.lines().enumerate() {
        if let Ok(Some(r)) = p.line(i + 1, l) {
            if tw
                .solve_readings(&r.readings_m)
                .unwrap()
                .status
                .is_converged()
            {
                out.push(IkTarget::position(tw.tip_position()));
            }
        }
    }
    out
}

fn benches(c: &mut Criterion) {
    let scene = Scene::load("data/calibration/ftdcr_v4_calibrated.toml").unwrap();
    let targets = targets(&scene);
    let mut g = c.benchmark_group("ik");
    g.measurement_time(Duration::from_secs(20)).sample_size(20);
    let mut ik = IkWorkspace::from_scene(&scene, IkSettings::default()).unwrap();
    let mut k = 0;
    g.bench_function("ik_warm_tick", |b| {
        b.iter(|| {
            k = (k + 1) % targets.len();
            black_box(ik.solve(&targets[k]).unwrap())
        })
    });
    g.finish();
}

criterion_group!(ik, benches);
criterion_main!(ik);
