//! Warm inverse-kinematics ticks on the calibrated FTDCR v4: the targets are the
//! model's tips at consecutive val rows, each tick warm from the previous tick's
//! readings, the rows walked forward then backward as `benches/ik.rs` walks them
//! (PASSES walks; the first tick, from zero readings, is not counted). Prints per-call time percentiles and
//! what a tick costs (iterations = Jacobians, forward solves, QP solves), the
//! forward solves' passes per call (deterministic, unlike the times), the
//! co-contraction the readings drift into (their sum, the largest tension), and
//! the slowest calls with their status.
//!
//! The drift along the redundancy: per target, the spread (max - min) over the
//! walks of the readings' sum at that target.
//!
//! `cargo run --release --example ik_tick_profile [PASSES] [MAX_SOLVE_PASSES|-] [CSV] [REST_WEIGHT]`
//! (CSV default `data/hardware/ftdcr_v4/val.csv`; REST_WEIGHT the
//! `IkSettings::rest_weight`, default its default)
use cablesense::command::{IkSettings, IkTarget, IkWorkspace};
use cablesense::Scene;
use std::time::Instant;

fn pct(v: &[f64], f: f64) -> f64 {
    v[((v.len() - 1) as f64 * f).round() as usize]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let passes: usize = std::env::args().nth(1).map_or(Ok(2), |s| s.parse())?;
    let mut settings = IkSettings::default();
    if let Some(b) = std::env::args().nth(2).filter(|b| b != "-") {
        settings.max_solve_passes = Some(b.parse()?);
    }
    let csv = std::env::args()
        .nth(3)
        .unwrap_or_else(|| "data/hardware/ftdcr_v4/val.csv".into());
    if let Some(w) = std::env::args().nth(4) {
        settings.rest_weight = w.parse()?;
    }
    let scene = Scene::load("data/calibration/ftdcr_v4_calibrated.toml")?;
    let mut tw = scene.tendon_workspace()?;
    let mut parser = scene.readings_parser(&tw);
    let text = std::fs::read_to_string(&csv)?;
    let mut targets = Vec::new();
    for (i, l) in text.lines().enumerate() {
        if let Ok(Some(r)) = parser.line(i + 1, l) {
            if tw.solve_readings(&r.readings_m)?.status.is_converged() {
                targets.push(IkTarget::position(tw.tip_position()));
            }
        }
    }
    let mut ik = IkWorkspace::from_scene(&scene, settings)?;
    let (mut times, mut its, mut jacs, mut fs, mut qps) = (Vec::new(), 0, 0, 0, 0);
    let (mut call_passes, mut peak, mut sums, mut t_max) = (Vec::new(), 0, Vec::new(), 0.0f64);
    let mut far = 0;
    let mut slow = Vec::new();
    let mut statuses = std::collections::BTreeMap::new();
    let n = targets.len();
    let mut spread = vec![(f64::INFINITY, f64::NEG_INFINITY); n];
    for pass in 0..passes {
        for j in 0..n - 1 {
            let k = if pass % 2 == 0 { j } else { n - 1 - j };
            let t = &targets[k];
            let t0 = Instant::now();
            let r = ik.solve(t)?;
            let dt = t0.elapsed().as_secs_f64() * 1e3;
            if pass > 0 || k > 0 {
                times.push(dt);
                its += r.iterations;
                jacs += r.jacobians;
                fs += r.forward_solves;
                qps += r.qp_solves;
                call_passes.push(r.passes as f64);
                peak = peak.max(r.peak_passes);
                let sum = ik.readings().iter().sum::<f64>() * 1e3;
                sums.push(sum);
                spread[k] = (spread[k].0.min(sum), spread[k].1.max(sum));
                let tw = ik.tendon_workspace();
                t_max = tw.tensions().iter().fold(t_max, |m, t| m.max(*t));
                far += usize::from(r.distance_m > 5e-4);
                *statuses.entry(r.status.name()).or_insert(0) += 1;
            }
            if dt > 10.0 {
                slow.push((pass, k, dt, r));
            }
        }
        eprintln!(
            "walk {pass}: {} calls, readings' sum now {:.2} mm",
            times.len(),
            ik.readings().iter().sum::<f64>() * 1e3
        );
    }
    let n = times.len() as f64;
    times.sort_by(f64::total_cmp);
    println!(
        "{} ticks: p50 {:.3} ms, p90 {:.3}, p99 {:.3}, max {:.3}, mean {:.3}",
        times.len(),
        pct(&times, 0.5),
        pct(&times, 0.9),
        pct(&times, 0.99),
        times[times.len() - 1],
        times.iter().sum::<f64>() / n
    );
    println!(
        "per tick: {:.2} iterations, {:.2} Jacobians evaluated, {:.2} forward solves, {:.2} QP solves; {statuses:?}",
        its as f64 / n,
        jacs as f64 / n,
        fs as f64 / n,
        qps as f64 / n
    );
    call_passes.sort_by(f64::total_cmp);
    sums.sort_by(f64::total_cmp);
    println!(
        "passes per call: p50 {}, p99 {}, max {}; most in one forward solve {peak}; {far} calls ended > 0.5 mm away",
        pct(&call_passes, 0.5),
        pct(&call_passes, 0.99),
        call_passes[call_passes.len() - 1]
    );
    println!(
        "sum of the readings: p50 {:.2} mm, p99 {:.2}, max {:.2}; largest tension {t_max:.2} N",
        pct(&sums, 0.5),
        pct(&sums, 0.99),
        sums[sums.len() - 1]
    );
    let mut sp: Vec<f64> = spread
        .iter()
        .filter(|(a, b)| b >= a)
        .map(|(a, b)| b - a)
        .collect();
    sp.sort_by(f64::total_cmp);
    println!(
        "spread of the readings' sum at one target over the walks: p50 {:.2} mm, p99 {:.2}, max {:.2}",
        pct(&sp, 0.5),
        pct(&sp, 0.99),
        sp[sp.len() - 1]
    );
    slow.sort_by(|a, b| b.2.total_cmp(&a.2));
    for (pass, k, dt, r) in slow.iter().take(12) {
        println!("slow: pass {pass} target {k}: {dt:.1} ms {r:?}");
    }
    Ok(())
}
