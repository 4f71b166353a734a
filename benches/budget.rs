//! Tick time under a budget per call (`numerics.tendons.max_passes`, issue 43:
//! "a criterion bench reports p50 / p99 / max tick time"), on the shipped FTDCR v4
//! scene and its val recording. Criterion reports the mean; every call is also
//! timed on its own (`iter_custom`) and the p50 / p99 / max of those times, with the
//! calls that did not converge, are printed on stderr at the end. Log:
//! `benches/README.md` ("Budget per call").
//!
//! * `budget_tick_1khz`: the 1 kHz control loop (the val rows' readings linearly
//!   interpolated to one tick a millisecond, as `tendons.rs`'s
//!   `tendon_control_tick_1khz`), `max_passes = 8`.
//! * `budget_rows_5pct_unreachable`: the 443 val rows in order, warm, with an
//!   unreachable row (one tendon pulled in 50 mm, the eight others held) after
//!   every 19th (5 % of the calls), `max_passes = 16`: the unreachable rows end
//!   `budget_exhausted` and are rolled back.

use cablesense::files::readings::ReadingRow;
use cablesense::tendons::{TendonSettings, TendonWorkspace};
use cablesense::Scene;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::{Duration, Instant};

fn rows(scene: &Scene, ws: &TendonWorkspace) -> Vec<ReadingRow> {
    let text = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").expect("shipped data");
    scene.readings_parser(ws).good_rows(&text)
}

/// A workspace whose calls may run `max_passes` rod evaluations.
fn budgeted(scene: &Scene, max_passes: usize) -> TendonWorkspace {
    let mut ws = scene.tendon_workspace().expect("tendon workspace");
    ws.set_tendon_settings(TendonSettings {
        max_passes: Some(max_passes),
        ..*ws.tendon_settings()
    })
    .expect("valid budget");
    ws
}

/// Per-call times (s) and calls that did not converge, for the summary.
#[derive(Default)]
struct Calls {
    times: Vec<f64>,
    failed: usize,
}

impl Calls {
    fn summary(&mut self, name: &str) {
        let t = &mut self.times;
        if t.is_empty() {
            return;
        }
        t.sort_by(f64::total_cmp);
        let n = t.len();
        eprintln!(
            "{name}: {n} calls, p50 {:.1} us, p99 {:.1} us, max {:.1} us; {} not converged",
            t[n / 2] * 1e6,
            t[(n * 99 / 100).min(n - 1)] * 1e6,
            t[n - 1] * 1e6,
            self.failed
        );
    }
}

fn benches(c: &mut Criterion) {
    let scene = Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
    let probe = scene.tendon_workspace().expect("tendon workspace");
    let rows = rows(&scene, &probe);
    let mut g = c.benchmark_group("budget");
    g.measurement_time(Duration::from_secs(10)).sample_size(10);

    // 1 kHz ticks: readings interpolated in time between the rows
    let times: Vec<f64> = rows
        .iter()
        .map(|r| r.t_s.expect("val.csv has time stamps"))
        .collect();
    let mut ticks = Vec::new();
    let (mut k, mut t) = (0, times[0]);
    while k + 1 < rows.len() {
        if t >= times[k + 1] {
            k += 1;
            continue;
        }
        let s = ((t - times[k]) / (times[k + 1] - times[k])).clamp(0.0, 1.0);
        let (a, b) = (&rows[k].readings_m, &rows[k + 1].readings_m);
        ticks.push(
            a.iter()
                .zip(b)
                .map(|(a, b)| a + s * (b - a))
                .collect::<Vec<f64>>(),
        );
        t += 1e-3;
    }
    let mut ws = budgeted(&scene, 8);
    let mut calls = Calls::default();
    calls.times.reserve(1 << 20);
    let mut i = 0;
    g.bench_function("budget_tick_1khz", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let q = &ticks[i % ticks.len()];
                i += 1;
                let t0 = Instant::now();
                let r = ws.solve_readings(black_box(q));
                let dt = t0.elapsed();
                total += dt;
                calls.times.push(dt.as_secs_f64());
                calls.failed += usize::from(!r.is_ok_and(|r| r.status.is_converged()));
            }
            total
        })
    });
    calls.summary("budget_tick_1khz (max_passes 8)");

    // the val rows with 5 % unreachable rows
    let bad = vec![0.05, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let stream: Vec<&Vec<f64>> = rows
        .chunks(19)
        .flat_map(|c| c.iter().map(|r| &r.readings_m).chain(std::iter::once(&bad)))
        .collect();
    let mut ws = budgeted(&scene, 16);
    let (mut good, mut unreachable) = (Calls::default(), Calls::default());
    good.times.reserve(1 << 18);
    unreachable.times.reserve(1 << 14);
    let mut i = 0;
    g.bench_function("budget_rows_5pct_unreachable", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let q = stream[i % stream.len()];
                i += 1;
                let t0 = Instant::now();
                let r = ws.solve_readings(black_box(q));
                let dt = t0.elapsed();
                total += dt;
                let calls = if std::ptr::eq(q, &bad) {
                    &mut unreachable
                } else {
                    &mut good
                };
                calls.times.push(dt.as_secs_f64());
                calls.failed += usize::from(!r.is_ok_and(|r| r.status.is_converged()));
            }
            total
        })
    });
    good.summary("budget_rows_5pct_unreachable, val rows (max_passes 16)");
    unreachable.summary("budget_rows_5pct_unreachable, unreachable rows (max_passes 16)");
    g.finish();
}

criterion_group!(group, benches);
criterion_main!(group);
