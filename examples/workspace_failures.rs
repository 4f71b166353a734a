//! Where the workspace sampling's time goes and why samples fail, on the calibrated
//! FTDCR v4 over its shipped limits (docs/command.md, "Figures" of `cablesense
//! workspace`).
//!
//! ```bash
//! cargo run --release --example workspace_failures -- [SAMPLES [MAX_PASSES [PROBED]]]
//! ```
//!
//! One warm chain over the first `SAMPLES` Halton points (default 500) in greedy
//! nearest-neighbour order from reading 0, one readings solve per sample under a
//! budget of `MAX_PASSES` rod passes (default 400; 0: unbudgeted, the nested fallback
//! bounded to 6 shooting solves as the workspace does), then per status the samples,
//! their wall time and rod passes. Then for the first `PROBED` failed samples
//! (default 8), unbudgeted: the straight path from reading 0 by adaptive steps of
//! 1/40 down to 1/2560 of the way (a stall that such small steps do not pass is a
//! turning point along the path, not a step too long), with the tip's tilt, the
//! taut tendons and the tensions at the last converged point; and
//! three other paths (one section at a time, proximal first and distal first, and
//! the pay-outs before the pulls). Last, the distal section's three tendons
//! pulled together from reading 0 by steps of 0.1 mm: where that branch ends (not a
//! fold nor the rod's buckling: the joint Jacobian turns singular in a mode the
//! equal pull does not drive; `examples/workspace_fold.rs`, docs/command.md). Timings depend on
//! the machine's load; the counts do not.

use cablesense::command::workspace::{halton, nearest_neighbour_order};
use cablesense::statics::{SolveStatus, Start};
use cablesense::tendons::TendonWorkspace;
use cablesense::Scene;
use std::collections::BTreeMap;
use std::time::Instant;

#[path = "common/walk.rs"]
mod walk;

/// Solve `q` from `start`; converged or not.
fn solves(w: &mut TendonWorkspace, q: &[f64]) -> bool {
    w.solve_readings_from(q, Start::Warm)
        .is_ok_and(|r| r.status.is_converged())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let arg = |i: usize, d: usize| -> usize {
        std::env::args()
            .nth(i)
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    let (n, max_passes, probed) = (arg(1, 500), arg(2, 400), arg(3, 8));
    let scene = Scene::load("data/calibration/ftdcr_v4_calibrated.toml")?;
    let limits = scene.actuator_limits()?;
    let full = scene.tendon_workspace()?;
    let mut ws = full.clone();
    let mut ts = *ws.tendon_settings();
    ts.max_shooting_solves = ts.max_shooting_solves.min(6);
    ts.max_passes = (max_passes > 0).then_some(max_passes);
    ws.set_tendon_settings(ts)?;
    let p = ws.columns().len();
    let section: Vec<usize> = ws
        .driven()
        .iter()
        .map(|&j| ws.workspace().robot().cables()[j].end_section)
        .collect();
    let unit: Vec<f64> = (1..=n as u64).flat_map(|k| halton(k, p)).collect();
    let q_of = |k: usize| -> Vec<f64> {
        (0..p)
            .map(|i| limits.min_m[i] + unit[k * p + i] * (limits.max_m[i] - limits.min_m[i]))
            .collect()
    };
    let zero: Vec<f64> = (0..p)
        .map(|i| -limits.min_m[i] / (limits.max_m[i] - limits.min_m[i]))
        .collect();
    let mut failed = Vec::new();
    // converged, failed: samples, seconds, rod passes
    let mut acc = [(0usize, 0.0f64, 0usize); 2];
    // failed samples by the first solve's status, and whether its last iterate
    // had another set of taut tendons than the start
    let mut by_status: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    // classes of the probed failures (the warm path from the last converged sample)
    let mut classes: BTreeMap<&str, usize> = BTreeMap::new();
    let mut probes = 0;
    solves(&mut ws, &vec![0.0; p]);
    let mut from = vec![0.0; p];
    for k in nearest_neighbour_order(&unit, p, &zero) {
        let q = q_of(k);
        let taut_before = ws.taut().to_vec();
        let t = Instant::now();
        let r = ws.solve_readings(&q)?;
        let i = usize::from(!r.status.is_converged());
        acc[i].0 += 1;
        acc[i].1 += t.elapsed().as_secs_f64();
        acc[i].2 += r.forward_solves;
        if i == 0 {
            from = q;
            continue;
        }
        failed.push(k);
        // a budgeted solve whose joint paths handed back with passes to spare ends
        // `BudgetExhausted` (the nested fallback was all that was left): a stall
        let status = match r.status {
            SolveStatus::BudgetExhausted if r.forward_solves < max_passes => {
                "stalled (paths handed back within the budget)".to_string()
            }
            s => format!("{s:?}"),
        };
        let e = by_status.entry(status).or_default();
        e.0 += 1;
        e.1 += usize::from(ws.taut() != taut_before.as_slice());
        if probes < probed {
            probes += 1;
            // the warm path from the chain's last converged sample (its state is
            // the rolled-back one), unbudgeted, steps down to 1/2560 of the way
            let mut w = ws.clone();
            w.set_tendon_settings(*full.tendon_settings())?;
            let reached = walk::walk(&mut w, &from, &q, |_, _, _| {});
            let budget_out = max_passes > 0 && r.forward_solves >= max_passes;
            let class = if budget_out && reached >= 1.0 {
                "budget out (unbudgeted steps reach it)"
            } else if reached >= 1.0 {
                "start too far (its paths stalled; small steps from the last converged sample reach it)"
            } else if reached == 0.0 {
                "no equilibrium near the start (not even 1/2560 of the way)"
            } else if w.taut() != taut_before.as_slice() {
                "fold along the warm path, after a slack/taut change"
            } else {
                "fold along the warm path, same taut set as the start"
            };
            *classes.entry(class).or_default() += 1;
        }
    }
    println!(
        "{n} samples, one chain, max_passes {}:",
        if max_passes > 0 {
            max_passes.to_string()
        } else {
            "none (nested fallback, 6 shooting solves)".into()
        }
    );
    for (name, (c, s, w)) in ["converged", "failed"].iter().zip(acc) {
        let c1 = c.max(1) as f64;
        println!(
            "  {name:9} {c:5} samples, {:8.2} ms and {:7.1} rod passes each",
            1e3 * s / c1,
            w as f64 / c1
        );
    }
    println!(
        "  failed by the first solve's status (of which its last iterate changed the taut set):"
    );
    for (s, (c, changed)) in &by_status {
        println!("    {s:46} {c:5} ({changed})");
    }
    println!(
        "  the first {probes} failed samples, by where the warm path from the last converged sample ends (unbudgeted, steps 1/40 down to 1/2560):"
    );
    for (c, n) in &classes {
        println!("    {n:5} {c}");
    }
    let pull = |q: &[f64]| -> Vec<f64> {
        (0..3)
            .map(|s| {
                (0..p)
                    .filter(|&i| section[i] == s)
                    .map(|i| q[i].max(0.0) * 1e3 / 3.0)
                    .sum()
            })
            .collect()
    };
    let mut other = [0usize; 3];
    let mut straight = 0;
    for &k in failed.iter().take(probed) {
        let q = q_of(k);
        let zeros = vec![0.0; p];
        let mut w = full.clone();
        let reached = walk::walk(&mut w, &zeros, &q, |_, _, _| {});
        straight += usize::from(reached >= 1.0);
        let r = *w.report();
        // the last converged point's state (a failed solve is rolled back)
        let _ = solves(&mut w, &q.iter().map(|v| v * reached).collect::<Vec<_>>());
        let rot = w.workspace_mut().solution().tip().rotation;
        let tilt = (rot * cablesense::nalgebra::Vector3::z())
            .z
            .clamp(-1.0, 1.0)
            .acos();
        println!(
            "  failed sample {}: mean pull per section {:.1?} mm; from reading 0 reached {:.3} of the way ({:?} beyond), tip tilt {:.0} deg, taut {:?}, tensions {:.1?} N",
            k + 1,
            pull(&q),
            reached,
            r.status,
            tilt.to_degrees(),
            w.taut().iter().map(|&t| u8::from(t)).collect::<Vec<_>>(),
            w.tensions()
        );
        // other paths: stages of readings moved together
        let stages: [Vec<Vec<bool>>; 3] = [
            (0..3)
                .map(|s| section.iter().map(|&x| x == s).collect())
                .collect(),
            (0..3)
                .rev()
                .map(|s| section.iter().map(|&x| x == s).collect())
                .collect(),
            [true, false]
                .iter()
                .map(|&neg| q.iter().map(|&v| (v < 0.0) == neg).collect())
                .collect(),
        ];
        for (o, st) in other.iter_mut().zip(&stages) {
            let mut w = full.clone();
            let mut cur = vec![0.0; p];
            let reached = st.iter().all(|mask| {
                let next: Vec<f64> = (0..p)
                    .map(|i| if mask[i] { q[i] } else { cur[i] })
                    .collect();
                let ok = walk::walk(&mut w, &cur, &next, |_, _, _| {}) >= 1.0;
                cur = next;
                ok
            });
            *o += usize::from(reached);
        }
    }
    let tried = failed.len().min(probed);
    println!(
        "  of {tried} failed samples, reached unbudgeted: straight from reading 0 {straight}, one section at a time proximal first {}, distal first {}, pay-outs first {}",
        other[0], other[1], other[2]
    );
    // the distal section's three tendons pulled together from reading 0, by steps
    // of 0.1 mm, warm, unbudgeted: where the near-straight branch ends
    let distal = section.iter().copied().max().unwrap_or(0);
    let mut w = full.clone();
    let mut last = (0.0, 0.0, 0usize);
    for k in 1..=130 {
        let pull = f64::from(k) * 1e-4;
        let q: Vec<f64> = section
            .iter()
            .map(|&s| if s == distal { pull } else { 0.0 })
            .collect();
        let r = w.solve_readings(&q)?;
        if !r.status.is_converged() {
            println!(
                "  distal section's tendons pulled together: converged up to {:.1} mm (tension {:.2} N each, {} passes at the last step), {:?} at {:.1} mm",
                last.0 * 1e3,
                last.1,
                last.2,
                r.status,
                pull * 1e3
            );
            break;
        }
        let t = (0..p)
            .filter(|&i| section[i] == distal)
            .map(|i| w.tensions()[i]);
        last = (pull, t.fold(0.0, f64::max), r.forward_solves);
    }
    Ok(())
}
