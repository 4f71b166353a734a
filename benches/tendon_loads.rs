//! Load estimation on a tendon robot from load cells
//! (`estimate::TendonLoadEstimator`), on the shipped demo
//! `data/load_cells/tdcr_load_cells.toml` (two segments, 10 disks each, six
//! displacement-driven tendons with load cells; unknown tip force x, y and payload
//! mass) and its synthetic recording `data/load_cells/tdcr_load_cells.csv`.
//!
//! * `tendon_load_tick`: one row (readings + six load cells) through `tick`,
//!   warm-started from the previous row, rows cycled in order. One iteration = one
//!   row (each new row starts with a fresh sensitivity sweep).
//! * `tendon_load_tick_and_snapshot`: the same plus `estimate()` (what `track`
//!   computes per row before printing).
//!
//! Rows whose status is not `converged` during timing are counted on stderr.

use cablesense::estimate::EstimateStatus;
use cablesense::files::load_cells;
use cablesense::Scene;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::Duration;

fn benches(c: &mut Criterion) {
    let scene = Scene::load("data/load_cells/tdcr_load_cells.toml").expect("shipped scene");
    let mut est = load_cells::estimator(&scene).expect("estimator");
    let mut p = load_cells::parser(&scene, &mut est);
    let text = std::fs::read_to_string("data/load_cells/tdcr_load_cells.csv").expect("data");
    let rows: Vec<_> = text
        .lines()
        .enumerate()
        .filter_map(|(i, l)| p.line(i + 1, l).ok().flatten())
        .collect();
    for r in &rows {
        est.tick(&r.readings_m, &r.tensions_n, None)
            .expect("valid row");
    }
    let mut g = c.benchmark_group("tendon_loads");
    g.measurement_time(Duration::from_secs(15)).sample_size(20);
    let (mut k, mut bad) = (0usize, 0usize);
    g.bench_function("tendon_load_tick", |b| {
        b.iter(|| {
            let r = &rows[k % rows.len()];
            k += 1;
            let s = est
                .tick(&r.readings_m, &r.tensions_n, None)
                .expect("valid row");
            bad += usize::from(s != EstimateStatus::Converged);
            black_box(s)
        })
    });
    g.bench_function("tendon_load_tick_and_snapshot", |b| {
        b.iter(|| {
            let r = &rows[k % rows.len()];
            k += 1;
            let s = est
                .tick(&r.readings_m, &r.tensions_n, None)
                .expect("valid row");
            bad += usize::from(s != EstimateStatus::Converged);
            black_box(est.estimate())
        })
    });
    g.finish();
    if bad > 0 {
        eprintln!("tendon_loads: {bad} of {k} timed rows did not converge");
    }
}

criterion_group!(group, benches);
criterion_main!(group);
