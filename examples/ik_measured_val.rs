//! The measured val tips of FTDCR v4 as inverse-kinematics targets: how far the
//! closest reachable tip of the calibrated model lies from each measured tip (the
//! model's error seen from the other side), beside the forward error at the
//! recorded readings.
//!
//! Each val row: the measured marker mapped to the base frame by the calibration's
//! `capture_to_base`; the tip target is that marker less the marker offset turned
//! by the model's tip orientation at the recorded readings (an approximation: the
//! measured orientation is not recorded). IK runs as a chain
//! (`command::ik::IkChain`): warm from the previous row when it was reached, else
//! from the last reached row's readings, and a row ending out of budget or more
//! than 0.5 mm away solved once more from zero readings, the better end kept;
//! inside `[robot.limits]`. `plain` as the second argument runs the plain warm
//! chain instead (each row from the previous row's end, whatever it was). The
//! recorded readings are conditioned as `track` conditions them (the scene's
//! `[readings]` time offset and backlash, row to row), and the IK readings are
//! compared with those conditioned readings (what reaches the tendons). Every row is counted (a row whose forward solve
//! at the recorded readings fails would be reported, not dropped).
//!
//! `cargo run --release --example ik_measured_val [ROWS [plain]]`
use cablesense::calibrate::{Conditioning, ReadingsHistory, RigidTransform};
use cablesense::command::ik::{IkChain, IkStart};
use cablesense::command::{IkSettings, IkStatus, IkTarget, IkWorkspace};
use cablesense::nalgebra::Vector3;
use cablesense::validation::{CALIBRATED_SCENE, VAL_CSV};
use cablesense::Scene;

fn pct(v: &[f64], f: f64) -> f64 {
    v[((v.len() - 1) as f64 * f).round() as usize]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let rows: usize = std::env::args()
        .nth(1)
        .map_or(Ok(usize::MAX), |s| s.parse())?;
    let scene = Scene::parse_validated(
        CALIBRATED_SCENE,
        std::path::Path::new("data/calibration/ftdcr_v4_calibrated.toml"),
        false,
    )?;
    let cal = scene.calibration.clone().ok_or("no [calibration]")?;
    let frame = RigidTransform::from_spec(&cal.capture_to_base);
    let offset = Vector3::from(cal.marker_offset_m);
    let mut tw = scene.tendon_workspace()?;
    let mut parser = scene.readings_parser(&tw);
    let spec = scene.readings.clone().unwrap_or_default();
    let mut history = ReadingsHistory::new(Conditioning::from_spec(Some(&spec)));
    let plain = std::env::args().nth(2).is_some_and(|a| a == "plain");
    let mut ik = IkChain::new(IkWorkspace::from_scene(&scene, IkSettings::default())?);
    let mut plain_ik = IkWorkspace::from_scene(&scene, IkSettings::default())?;
    let (mut starts, mut retried, mut skipped) = ([0usize; 3], 0usize, 0usize);
    let mut worst: Vec<(f64, usize, &'static str)> = Vec::new();
    let (mut fwd, mut reach, mut dq) = (Vec::new(), Vec::new(), Vec::new());
    let (mut fwd_err, mut counts) = (Vec::new(), [0usize; 3]);
    let t0 = std::time::Instant::now();
    for (i, l) in VAL_CSV.lines().enumerate() {
        if fwd.len() >= rows {
            break;
        }
        let Ok(Some(r)) = parser.line(i + 1, l) else {
            continue;
        };
        let Some(m) = r.measured_tip_m else {
            skipped += 1;
            continue;
        };
        let q_rec = history
            .push(r.t_s, &r.readings_m, &spec.time_column)?
            .to_vec();
        if !tw.solve_readings(&q_rec)?.status.is_converged() {
            skipped += 1;
            continue;
        }
        let pose = *tw.workspace_mut().solution().tip();
        let marker = frame.apply(&Vector3::from(m));
        let model_marker = pose.position + pose.rotation * offset;
        fwd_err.push(model_marker - marker);
        fwd.push((model_marker - marker).norm());
        let target = marker - pose.rotation * offset;
        let (rep, q) = if plain {
            let rep = plain_ik.solve(&IkTarget::position(target))?;
            (rep, plain_ik.readings())
        } else {
            let row = ik.solve(&IkTarget::position(target))?;
            starts[match row.start {
                IkStart::Previous => 0,
                IkStart::LastReached => 1,
                IkStart::Zero => 2,
            }] += 1;
            retried += usize::from(row.attempts > 1);
            (row.report, ik.readings())
        };
        worst.push((rep.distance_m, fwd.len() - 1, rep.status.name()));
        counts[match rep.status {
            IkStatus::Reached => 0,
            IkStatus::Unreachable { .. } => 1,
            IkStatus::BudgetExhausted => 2,
        }] += 1;
        reach.push(rep.distance_m);
        let d: f64 = q
            .iter()
            .zip(&q_rec)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>();
        dq.push((d / q_rec.len() as f64).sqrt());
    }
    let n = fwd.len();
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    let mean = fwd_err.iter().sum::<Vector3<f64>>() / n as f64;
    let centred: Vec<f64> = fwd_err.iter().map(|e| (e - mean).norm()).collect();
    for v in [&mut fwd, &mut reach, &mut dq] {
        v.sort_by(f64::total_cmp);
    }
    println!(
        "{n} val rows ({:.1} s, {}; {skipped} rows without a measured tip or a converged forward solve): IK {} reached, {} unreachable, {} out of budget",
        t0.elapsed().as_secs_f64(),
        if plain { "plain warm chain" } else { "robust chain" },
        counts[0],
        counts[1],
        counts[2]
    );
    if !plain {
        println!(
            "kept solves started from: the previous row {}, the last reached row {}, zero readings {}; {retried} rows retried from zero",
            starts[0], starts[1], starts[2]
        );
    }
    println!(
        "forward error at the recorded readings, conditioned (mm): RMSE {:.3} raw, {:.3} mean offset removed; median {:.3}, 95 % {:.3}, max {:.3}",
        rms(&fwd) * 1e3,
        rms(&centred) * 1e3,
        pct(&fwd, 0.5) * 1e3,
        pct(&fwd, 0.95) * 1e3,
        pct(&fwd, 1.0) * 1e3
    );
    println!(
        "reached distance to the measured tip (mm): RMS {:.3}; median {:.4}, 90 % {:.3}, 95 % {:.3}, max {:.3}; within 0.05 mm {:.1} %",
        rms(&reach) * 1e3,
        pct(&reach, 0.5) * 1e3,
        pct(&reach, 0.9) * 1e3,
        pct(&reach, 0.95) * 1e3,
        pct(&reach, 1.0) * 1e3,
        100.0 * reach.iter().filter(|d| **d <= 5e-5).count() as f64 / n as f64
    );
    worst.sort_by(|a, b| b.0.total_cmp(&a.0));
    let w: Vec<String> = worst
        .iter()
        .take(5)
        .map(|(d, k, s)| format!("row {k} {s} {:.3} mm", d * 1e3))
        .collect();
    println!("farthest: {}", w.join(", "));
    let bins = [0.01e-3, 0.05e-3, 0.5e-3, 1e-3, 5e-3, 10e-3];
    let mut lo = 0.0;
    let mut hist = Vec::new();
    for b in bins {
        let c = reach.iter().filter(|d| **d > lo && **d <= b).count()
            + usize::from(lo == 0.0) * reach.iter().filter(|d| **d == 0.0).count();
        hist.push(format!("<= {:.2} mm: {c}", b * 1e3));
        lo = b;
    }
    hist.push(format!(
        "> {:.0} mm: {}",
        lo * 1e3,
        reach.iter().filter(|d| **d > lo).count()
    ));
    println!("reached distance histogram: {}", hist.join(", "));
    println!(
        "IK readings against the recorded ones (RMS over the 9 tendons, mm): median {:.3}, 95 % {:.3}, max {:.3}",
        pct(&dq, 0.5) * 1e3,
        pct(&dq, 0.95) * 1e3,
        pct(&dq, 1.0) * 1e3
    );
    Ok(())
}
