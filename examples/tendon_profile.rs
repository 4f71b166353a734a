//! Per-row work of the warm tendon solve on the FTDCR v4 val recording: `f64` and
//! dual right-hand sides, joint iterations, time. For profiling (issue 9's speed).
//!
//! `cargo run --release --example tendon_profile [SCENE] [READINGS] [REPEAT]`
//! (`VERBOSE=1` a line per row, `COLD=1` every row cold, `TIPS=FILE` every row's tip,
//! `KHZ=N` the first N ticks of a 1 kHz control loop between the rows, `TOL_M=X` the
//! tendon tolerance in m instead of the default, `COUPLING=arc|exact|condensed` the
//! cable coupling instead of the scene's, `TOL=X` the shooting tolerance instead of the
//! scene's, `ROLLBACK=0` the rollback policy off, `MAX_PASSES=N` a work budget per call,
//! `TIME_BUDGET_US=X` a wall-time budget per call, `BAD_EVERY=K` an unreachable row
//! (one tendon pulled in 50 mm) after every K-th row, timed with the rows)
use cablesense::Scene;
use std::time::Instant;

/// The environment variable `name` parsed as a `T`, if set and valid.
fn env_parse<T: std::str::FromStr>(name: &str) -> Option<T> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let scene_path = args.get(1).map_or("data/scenes/ftdcr_v4.toml", |s| s);
    let data = args.get(2).map_or("data/hardware/ftdcr_v4/val.csv", |s| s);
    let repeat: usize = args.get(3).map_or(Ok(1), |s| s.parse())?;
    let verbose = std::env::var_os("VERBOSE").is_some();
    // COLD=1: every row from a cold start (the `tendon_readings_cold` bench case)
    let cold = std::env::var_os("COLD").is_some();
    let mut scene = Scene::load(scene_path)?;
    // COUPLING=arc|exact|condensed: the cable coupling instead of the scene's
    if let Ok(c) = std::env::var("COUPLING") {
        scene.numerics.cable_coupling = match c.as_str() {
            "arc" => cablesense::CableCoupling::Arc,
            "exact" => cablesense::CableCoupling::Exact,
            _ => cablesense::CableCoupling::Condensed,
        };
    }
    // TOL=x: the shooting tolerance (scaled) instead of the scene's
    if let Some(tol) = env_parse::<f64>("TOL") {
        scene.numerics.tolerance = tol;
    }
    let mut ws = scene.tendon_workspace()?;
    // ROLLBACK=0: the rollback policy off (to time what it costs)
    if std::env::var("ROLLBACK").is_ok_and(|v| v == "0") {
        ws.set_rollback(false);
    }
    // TOL_M=x: the tendon tolerance (m) instead of the default
    if let Some(tol) = env_parse::<f64>("TOL_M") {
        ws.set_tendon_settings(cablesense::tendons::TendonSettings {
            tolerance_m: tol,
            ..Default::default()
        })?;
    }
    // MAX_PASSES=n, TIME_BUDGET_US=x: the per-call budget (`numerics.tendons`)
    let max_passes = env_parse::<usize>("MAX_PASSES");
    let time_budget_s = env_parse::<f64>("TIME_BUDGET_US").map(|us| us * 1e-6);
    if max_passes.is_some() || time_budget_s.is_some() {
        ws.set_tendon_settings(cablesense::tendons::TendonSettings {
            max_passes,
            time_budget_s,
            ..*ws.tendon_settings()
        })?;
    }
    let bad_every = env_parse::<usize>("BAD_EVERY");
    let mut parser = scene.readings_parser(&ws);
    let text = std::fs::read_to_string(data)?;
    let mut rows: Vec<_> = text
        .lines()
        .enumerate()
        .filter_map(|(i, l)| parser.line(i + 1, l).ok().flatten())
        .collect();
    // KHZ=N: the first N ticks of the control loop at 1 kHz instead (the readings
    // linearly interpolated in time between the rows; `tendon_control_tick_1khz`)
    if let Some(n) = env_parse::<usize>("KHZ") {
        let mut ticks = Vec::with_capacity(n);
        let (mut k, mut t) = (0, rows[0].t_s.unwrap_or(0.0));
        while ticks.len() < n && k + 1 < rows.len() {
            let (t0, t1) = (rows[k].t_s.unwrap_or(0.0), rows[k + 1].t_s.unwrap_or(0.0));
            if t >= t1 {
                k += 1;
                continue;
            }
            let s = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
            let mut row = rows[k].clone();
            for (q, b) in row.readings_m.iter_mut().zip(&rows[k + 1].readings_m) {
                *q += s * (b - *q);
            }
            ticks.push(row);
            t += 1e-3;
        }
        rows = ticks;
    }
    if let Some(k) = bad_every.filter(|&k| k > 0) {
        let mut bad = rows[0].clone();
        bad.readings_m.iter_mut().for_each(|q| *q = 0.0);
        bad.readings_m[0] = 0.05;
        bad.line = 0;
        rows = rows
            .chunks(k)
            .flat_map(|c| c.iter().cloned().chain(std::iter::once(bad.clone())))
            .collect();
    }
    let (mut f_all, mut d_all, mut t_all) = (0u64, 0u64, 0.0);
    let mut per_row = Vec::new();
    let mut bad = 0;
    let mut tips = std::env::var_os("TIPS")
        .map(std::fs::File::create)
        .transpose()?;
    for _ in 0..repeat {
        for row in &rows {
            let t = Instant::now();
            // a pending rollback restores the counters too: count from after it
            ws.apply_rollback();
            let c0 = ws.workspace().rhs_counts();
            let rep = if cold {
                ws.solve_readings_from(&row.readings_m, cablesense::Start::Cold)?
            } else {
                ws.solve_readings(&row.readings_m)?
            };
            let dt = t.elapsed().as_secs_f64();
            let c1 = ws.workspace().rhs_counts();
            let (f, d) = (c1.f64_rhs - c0.f64_rhs, c1.dual_rhs - c0.dual_rhs);
            let li = c1.local_iterations - c0.local_iterations;
            bad += usize::from(!rep.status.is_converged());
            if let Some(w) = tips.as_mut() {
                use std::io::Write;
                let t = ws.tip_position();
                writeln!(
                    w,
                    "{} {:.17e} {:.17e} {:.17e} {:?} {:?}",
                    row.line,
                    t.x,
                    t.y,
                    t.z,
                    ws.taut(),
                    rep.status
                )?;
            }
            if verbose {
                println!(
                    "line {:4} {:?} it {} fw {} sh {} slack {} f64 {} dual {} local {} {:.0} us",
                    row.line,
                    rep.status,
                    rep.iterations,
                    rep.forward_solves,
                    rep.shooting_solves,
                    rep.slack,
                    f,
                    d,
                    li,
                    dt * 1e6
                );
            }
            f_all += f;
            d_all += d;
            t_all += dt;
            per_row.push((dt, f, d));
        }
    }
    let n = per_row.len();
    let mut times: Vec<f64> = per_row.iter().map(|r| r.0).collect();
    times.sort_by(f64::total_cmp);
    let mut f: Vec<u64> = per_row.iter().map(|r| r.1).collect();
    f.sort();
    println!(
        "{n} rows ({bad} not converged): mean {:.0} us, median {:.0} us, p95 {:.0} us, p99 {:.0} us, max {:.0} us; f64 RHS mean {:.0} median {}, dual RHS mean {:.1}",
        t_all / n as f64 * 1e6,
        times[n / 2] * 1e6,
        times[n * 95 / 100] * 1e6,
        times[n * 99 / 100] * 1e6,
        times[n - 1] * 1e6,
        f_all as f64 / n as f64,
        f[n / 2],
        d_all as f64 / n as f64
    );
    Ok(())
}
