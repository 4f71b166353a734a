//! Tendon-driven robot benches on the shipped FTDCR v4 scene
//! (`data/scenes/ftdcr_v4.toml`: three segments, 10 disks each, nine
//! displacement-driven tendons) and its validation recording
//! (`data/hardware/ftdcr_v4/val.csv`).
//!
//! * `tendon_readings_warm`: `TendonWorkspace::solve_readings` over the recording's
//!   rows in order, each warm-started from the previous row (the control-loop case).
//!   One iteration = one row. Issue target: <= 100 us.
//! * `tendon_readings_cold`: one row solved with `Start::Cold` (the joint path from
//!   the reference equilibrium at zero readings and the pretensions, else the nested
//!   method from the straight rod). Issue target: <= 2 ms. The same row is solved
//!   cold again and again: from the second time on, its first Jacobian is the one
//!   kept from the first cold solve at the reference (`tendons/solve/joint/
//!   reference.rs`), as for any cold row after the first.
//! * `tendon_track_row`: a warm row plus its JSON record (what `track` does per row,
//!   without the write). Issue target: <= 150 us.
//! * `tendon_control_tick_1khz`: the control-loop case of a servo controller at
//!   1 kHz: the recording's readings linearly interpolated in time to one tick per
//!   millisecond between its rows (rows are ~0.6 s apart, so ~600 ticks a row, and
//!   the pauses between patterns are ticks of constant readings), each tick
//!   warm-started from the previous tick; one iteration = one tick (after the last
//!   row it starts over from the first). No target of its own: issue 9's 100 us is
//!   per recorded row (`tendon_readings_warm`), whose readings change ~600 times as
//!   much from one solve to the next.
//!
//! The scene's coupling is `numerics.cable_coupling = "arc"` since session 20 (the
//! next holes predicted by an arc of the gap, not solved for: `statics/pass/arc.rs`,
//! two rounds a disk since session 25, `numerics.arc_rounds = 2`;
//! `tests/arc_coupling.rs`); before, it was the default `condensed`.
//!
//! The scene solves to a tenth of its coupling's own error since session 27
//! (`numerics.tolerance = 1e-4`, `[numerics.tendons] tolerance_m = 1e-7`: the
//! scene's comments say why); before, to the library's defaults (1e-10, 1e-12 m).
//!
//! * `tendon_readings_warm_tight`: the warm rows at those defaults (tips within 0.47
//!   um mean, max 3.3 um, of the scene's on the 443 val rows), for comparison with
//!   the sessions before 27 and for a user who needs them.
//! * `tendon_readings_warm_condensed`, `tendon_track_row_condensed`: the warm and
//!   track rows with `numerics.cable_coupling = "condensed"` (the next holes solved
//!   for), to compare with the sessions before 20.
//!
//! Rows that do not converge during timing are counted on stderr. Log:
//! `benches/README.md`.

use cablesense::files::readings::ReadingRow;
use cablesense::{Scene, Start};
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::Duration;

fn rows(scene: &Scene, ws: &cablesense::tendons::TendonWorkspace) -> Vec<ReadingRow> {
    let text = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").expect("shipped data");
    scene.readings_parser(ws).good_rows(&text)
}

/// The 1 kHz control loop's position in the recording: row interval `k`, time `t`
/// (s) and the interpolated readings `q` (m).
struct Ticks {
    k: usize,
    t: f64,
    q: Vec<f64>,
}

impl Ticks {
    /// Advance one millisecond (past the last row: back to the first) and
    /// interpolate the readings between the rows around `t`. No allocation.
    fn next(&mut self, rows: &[ReadingRow], times: &[f64]) {
        self.t += 1e-3;
        while self.k + 1 < rows.len() && self.t >= times[self.k + 1] {
            self.k += 1;
        }
        if self.k + 1 >= rows.len() {
            self.k = 0;
            self.t = times[0];
        }
        let (a, b) = (&rows[self.k].readings_m, &rows[self.k + 1].readings_m);
        let (t0, t1) = (times[self.k], times[self.k + 1]);
        let s = if t1 > t0 {
            ((self.t - t0) / (t1 - t0)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        for ((q, a), b) in self.q.iter_mut().zip(a).zip(b) {
            *q = a + s * (b - a);
        }
    }
}

/// What `track` does per row, without the write: a warm solve and its JSON record.
/// `true` when the row converged.
fn track_row(ws: &mut cablesense::tendons::TendonWorkspace, row: &ReadingRow) -> bool {
    let r = ws.solve_readings(&row.readings_m);
    let ok = r.is_ok_and(|r| r.status.is_converged());
    let tip = ws.tip_position();
    let rec = serde_json::json!({
        "line": row.line, "tip_position_m": [tip.x, tip.y, tip.z],
        "tensions_n": ws.tensions(), "taut": ws.taut(),
    });
    black_box(rec.to_string());
    ok
}

fn benches(c: &mut Criterion) {
    let scene = Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
    let mut ws = scene.tendon_workspace().expect("tendon workspace");
    let rows = rows(&scene, &ws);
    let mut g = c.benchmark_group("tendons");
    g.measurement_time(Duration::from_secs(20)).sample_size(20);
    let mut k = 0;
    let mut failed = 0;
    g.bench_function("tendon_readings_warm", |b| {
        b.iter(|| {
            let r = ws.solve_readings(black_box(&rows[k % rows.len()].readings_m));
            failed += usize::from(!r.is_ok_and(|r| r.status.is_converged()));
            k += 1;
        })
    });
    let row = &rows[rows.len() / 3].readings_m;
    g.bench_function("tendon_readings_cold", |b| {
        b.iter(|| {
            let r = ws.solve_readings_from(black_box(row), Start::Cold);
            failed += usize::from(!r.is_ok_and(|r| r.status.is_converged()));
        })
    });
    g.bench_function("tendon_track_row", |b| {
        b.iter(|| {
            failed += usize::from(!track_row(&mut ws, &rows[k % rows.len()]));
            k += 1;
        })
    });
    // 1 kHz ticks between the rows (time stamps of the recording)
    let times: Vec<f64> = rows
        .iter()
        .map(|r| r.t_s.expect("val.csv has time stamps"))
        .collect();
    let mut tick = Ticks {
        k: 0,
        t: times[0],
        q: rows[0].readings_m.clone(),
    };
    g.bench_function("tendon_control_tick_1khz", |b| {
        b.iter(|| {
            tick.next(&rows, &times);
            let r = ws.solve_readings(black_box(&tick.q));
            failed += usize::from(!r.is_ok_and(|r| r.status.is_converged()));
        })
    });
    // the same warm rows at the library's default tolerances (`numerics.tolerance`
    // 1e-10, `numerics.tendons.tolerance_m` 1e-12 m), the scene's before session 27
    let mut tight_scene = scene.clone();
    let defaults = cablesense::SolverSettings::default();
    tight_scene.numerics.tolerance = defaults.tolerance;
    tight_scene.numerics.tendons.tolerance_m = defaults.tendons.tolerance_m;
    let mut ws_tight = tight_scene.tendon_workspace().expect("tendon workspace");
    g.bench_function("tendon_readings_warm_tight", |b| {
        b.iter(|| {
            let r = ws_tight.solve_readings(black_box(&rows[k % rows.len()].readings_m));
            failed += usize::from(!r.is_ok_and(|r| r.status.is_converged()));
            k += 1;
        })
    });
    // the same warm rows and track rows with the condensed coupling (next holes
    // solved for; the arc coupling's tips lie within 8 um mean of these)
    let mut condensed_scene = scene.clone();
    condensed_scene.numerics.cable_coupling = cablesense::CableCoupling::Condensed;
    let mut ws = condensed_scene
        .tendon_workspace()
        .expect("tendon workspace");
    g.bench_function("tendon_readings_warm_condensed", |b| {
        b.iter(|| {
            let r = ws.solve_readings(black_box(&rows[k % rows.len()].readings_m));
            failed += usize::from(!r.is_ok_and(|r| r.status.is_converged()));
            k += 1;
        })
    });
    g.bench_function("tendon_track_row_condensed", |b| {
        b.iter(|| {
            failed += usize::from(!track_row(&mut ws, &rows[k % rows.len()]));
            k += 1;
        })
    });
    g.finish();
    if failed > 0 {
        eprintln!("tendon benches: {failed} solves did not converge during timing");
    }
}

criterion_group!(group, benches);
criterion_main!(group);
