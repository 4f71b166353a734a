//! Is the workspace's stall a fold? (docs/command.md, "Why the samples fail".)
//!
//! ```bash
//! cargo run --release --example workspace_fold
//! ```
//!
//! The distal section's three tendons pulled together from reading 0 (steps of 0.1
//! mm, then 0.01 mm near the stall), warm, unbudgeted: at each converged point the
//! smallest singular value of the equilibrated joint Jacobian `F_z`
//! (`cablesense::tendons::FoldProbe`), its determinant sign and the tangent's size.

use cablesense::command::workspace::{fold_test, halton, nearest_neighbour_order};
use cablesense::tendons::{FoldPoint, FoldProbe, TendonWorkspace};
use cablesense::Scene;

#[path = "common/walk.rs"]
mod walk;

/// One converged point of a probed path: the fraction of the way and the test.
type Seen = (f64, FoldPoint);

/// The straight path from `from` to `to` by adaptive steps (1/40 down to 1/2560 of
/// the way, `common/walk.rs`), the fold test at every converged
/// point (direction `to - from`).
fn probed_path(
    w: &mut TendonWorkspace,
    probe: &mut FoldProbe,
    from: &[f64],
    to: &[f64],
) -> Vec<Seen> {
    let dir: Vec<f64> = from.iter().zip(to).map(|(f, t)| t - f).collect();
    let mut seen = Vec::new();
    if let Some(f) = probe.measure(w, from, &dir) {
        seen.push((0.0, f));
    }
    walk::walk(w, from, to, |w, a, x| {
        if let Some(f) = probe.measure(w, x, &dir) {
            seen.push((a, f));
        }
    });
    seen
}

/// `chain [SAMPLES [PROBED [quick]]]`: one budgeted warm chain over the first
/// SAMPLES Halton points (default 500), then the first PROBED failed samples
/// (default 20): the workspace's fold test (`fold_test`, 40 passes a solve), and
/// (without `quick`) `F_z` along the unbudgeted warm path from the chain's last
/// converged sample by small steps.
fn chain() -> Result<(), Box<dyn std::error::Error>> {
    let arg = |i: usize, d: usize| -> usize {
        std::env::args()
            .nth(i)
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    let (n, probed) = (arg(2, 500), arg(3, 20));
    let scene = Scene::load("data/calibration/ftdcr_v4_calibrated.toml")?;
    let limits = scene.actuator_limits()?;
    let full = scene.tendon_workspace()?;
    let mut ws = full.clone();
    let mut ts = *ws.tendon_settings();
    ts.max_shooting_solves = ts.max_shooting_solves.min(6);
    ts.max_passes = Some(400);
    ws.set_tendon_settings(ts)?;
    let p = ws.columns().len();
    let unit: Vec<f64> = (1..=n as u64).flat_map(|k| halton(k, p)).collect();
    let q_of = |k: usize| -> Vec<f64> {
        (0..p)
            .map(|i| limits.min_m[i] + unit[k * p + i] * (limits.max_m[i] - limits.min_m[i]))
            .collect()
    };
    let zero: Vec<f64> = (0..p)
        .map(|i| -limits.min_m[i] / (limits.max_m[i] - limits.min_m[i]))
        .collect();
    let mut probe = FoldProbe::new(&ws);
    ws.solve_readings(&vec![0.0; p])?;
    let mut from = vec![0.0; p];
    let mut done = 0;
    println!("sample reached points | start: sigma_min det | last: sigma_min det push_on_null |dz/dl| | min sigma on the path, det flips");
    for k in nearest_neighbour_order(&unit, p, &zero) {
        let q = q_of(k);
        let r = ws.solve_readings(&q)?;
        if r.status.is_converged() {
            from = q;
            continue;
        }
        if done >= probed {
            continue;
        }
        done += 1;
        // the workspace's fold test (its walk under 40 passes a solve)
        let mut rs = ts;
        rs.max_passes = Some(40);
        let t = fold_test(&ws, &from, &q, &rs);
        println!(
            "{:6} fold_test {:?}: reached {:.5}, sigma {:.3e} -> {:.3e}, push {:.2e}, zero extrapolated {:.2e} beyond, {} passes",
            k + 1,
            t.class,
            t.reached,
            t.sigma_start,
            t.sigma_stall,
            t.push,
            t.fold_beyond,
            t.passes
        );
        if std::env::args().nth(4).as_deref() == Some("quick") {
            continue;
        }
        let mut w = ws.clone();
        w.set_tendon_settings(*full.tendon_settings())?;
        let seen = probed_path(&mut w, &mut probe, &from, &q);
        let (Some(first), Some(last)) = (seen.first(), seen.last()) else {
            println!("{:6} no converged point", k + 1);
            continue;
        };
        let tn = |f: &FoldPoint| f.tangent.iter().map(|v| v * v).sum::<f64>().sqrt();
        let min = seen
            .iter()
            .map(|s| s.1.sigma_min)
            .fold(f64::INFINITY, f64::min);
        let flips = seen
            .windows(2)
            .filter(|s| s[0].1.det_sign != s[1].1.det_sign)
            .count();
        println!(
            "{:6} {:.4} {:3} | {:.3e} {:+} | {:.3e} {:+} {:.2e} {:.3e} | {:.3e} {}",
            k + 1,
            last.0,
            seen.len(),
            first.1.sigma_min,
            first.1.det_sign,
            last.1.sigma_min,
            last.1.det_sign,
            last.1.push_on_null,
            tn(&last.1),
            min,
            flips
        );
        // the last points: fraction of the way, sigma_min, push, |dz/dl| (a fold:
        // sigma_min ~ sqrt(l* - l), |dz/dl| ~ 1/sqrt(l* - l), push away from 0)
        let tail: Vec<String> = seen[seen.len().saturating_sub(6)..]
            .iter()
            .map(|(a, f)| {
                format!(
                    "{a:.5}:{:.2e}/{:.2}/{:.1e}",
                    f.sigma_min,
                    f.push_on_null,
                    tn(f)
                )
            })
            .collect();
        println!(
            "       start |dz/dl| {:.3e}; tail {}",
            tn(&first.1),
            tail.join(" ")
        );
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    if std::env::args().nth(1).as_deref() == Some("chain") {
        return chain();
    }
    let mut scene = Scene::load("data/calibration/ftdcr_v4_calibrated.toml")?;
    // ARG4: the cable coupling ("arc", the scene's, or "condensed"), ARG5 arc rounds
    match std::env::args().nth(4).as_deref() {
        Some("condensed") => scene.numerics.cable_coupling = cablesense::CableCoupling::Condensed,
        Some("exact") => scene.numerics.cable_coupling = cablesense::CableCoupling::Exact,
        _ => {}
    }
    if let Some(r) = std::env::args().nth(5).and_then(|s| s.parse().ok()) {
        scene.numerics.arc_rounds = r;
    }
    let mut w: TendonWorkspace = scene.tendon_workspace()?;
    let p = w.driven().len();
    let section: Vec<usize> = w
        .driven()
        .iter()
        .map(|&j| w.workspace().robot().cables()[j].end_section)
        .collect();
    let distal = section.iter().copied().max().unwrap_or(0);
    let dir: Vec<f64> = section
        .iter()
        .map(|&s| if s == distal { 1.0 } else { 0.0 })
        .collect();
    // optional: the proximal section's readings held at ARG1 mm; steps of ARG2 mm
    // from ARG3 mm on
    let arg = |i: usize, d: f64| -> f64 {
        std::env::args()
            .nth(i)
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    let (prox, fine, from) = (arg(1, 0.0) * 1e-3, arg(2, 0.1) * 1e-3, arg(3, 99.0) * 1e-3);
    let base: Vec<f64> = section
        .iter()
        .map(|&s| if s == 0 { prox } else { 0.0 })
        .collect();
    let mut probe = FoldProbe::new(&w);
    println!("F_z is {0} x {0}", probe.size());
    println!(
        "pull_mm sigma_min sigma_max det |dz/dq| tension_N tip_mm passes push_on_null null_vector"
    );
    let mut pull = 0.0f64;
    let mut h = 1e-4;
    let tip0 = w.tip_position();
    w.solve_readings(&base)?;
    while h > 1e-7 {
        if pull >= from - 1e-12 && h > fine {
            h = fine;
        }
        let next = pull + h;
        let q: Vec<f64> = dir.iter().zip(&base).map(|(d, b)| b + d * next).collect();
        let r = w.solve_readings(&q)?;
        if !r.status.is_converged() {
            println!("  {:?} at {:.4} mm", r.status, next * 1e3);
            h *= 0.1;
            // back to the last converged point
            let q: Vec<f64> = dir.iter().zip(&base).map(|(d, b)| b + d * pull).collect();
            w.solve_readings(&q)?;
            continue;
        }
        pull = next;
        let f = probe.measure(&mut w, &q, &dir).ok_or("probe failed")?;
        let tn: f64 = f.tangent.iter().map(|v| v * v).sum::<f64>().sqrt();
        let tmax = (0..p)
            .filter(|&i| section[i] == distal)
            .map(|i| w.tensions()[i])
            .fold(0.0, f64::max);
        println!(
            "{:.4} {:.4e} {:.4e} {:+} {:.4e} {:.3} {:.4} {} {:.2e} {:.2?} taut {:?} T {:.3?}",
            pull * 1e3,
            f.sigma_min,
            f.sigma_max,
            f.det_sign,
            tn,
            tmax,
            (w.tip_position() - tip0).norm() * 1e3,
            r.forward_solves,
            f.push_on_null,
            f.null_right,
            w.taut().iter().map(|&t| u8::from(t)).collect::<Vec<_>>(),
            w.tensions()
        );
    }
    Ok(())
}
