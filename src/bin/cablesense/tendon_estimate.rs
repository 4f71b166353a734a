//! `estimate` and `track` on a scene with displacement-driven tendons and an
//! `[estimate]` table: unknown loads from load cells and measuring cables, one row of
//! servo readings (and `tension_<cable>` load-cell columns, `length_<cable>` length
//! changes of passive cables) per line (`estimate::TendonLoadEstimator`). A bad row
//! is reported and the stream goes on.

use anyhow::Context;
use cablesense::estimate::{EstimateStatus, Fit, TendonEstimate, TendonLoadEstimator};
use cablesense::files::load_cells;
use cablesense::files::readings::ReadingRow;
use cablesense::Scene;
use serde_json::{json, Value};
use std::io::{BufRead, Write};
use std::path::Path;

/// How to print each row.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Output {
    /// One JSON object per row.
    Json,
    /// One text line per row.
    Text,
}

/// The per-row record.
fn row_json(row: &ReadingRow, e: &TendonEstimate, fallback: bool) -> Value {
    let est = &e.estimate;
    let map = |v: &[f64]| -> serde_json::Map<String, Value> {
        est.names
            .iter()
            .zip(v)
            .map(|(n, v)| (n.clone(), json!(v)))
            .collect()
    };
    let p = &est.tip.position;
    json!({
        "line": row.line,
        "t_s": row.t_s,
        "status": est.status,
        "fit": est.fit,
        "rms_sigma": est.rms_sigma,
        "redundancy": est.redundancy,
        "estimate": map(&est.values),
        "std_dev": map(&est.std_dev),
        "covariance": est.covariance,
        "rank": est.rank,
        "condition": if est.condition.is_finite() { json!(est.condition) } else { json!(null) },
        "unobservable": est.unobservable,
        "tip_position_m": [p.x, p.y, p.z],
        "section_tips_m": est.section_tips.iter().map(|s| [s.position.x, s.position.y, s.position.z]).collect::<Vec<_>>(),
        "measured_tip_m": row.measured_tip_m,
        "tendons": e.tendons,
        "readings_m": e.readings_m,
        "tensions_n": e.tensions_n,
        "taut": e.taut,
        "measured_tension_n": e.measured_tension_n,
        "tension_residual_n": e.tension_residual_n,
        "slack_no_residual": e.slack_no_residual,
        // per robot cable: measured only for passive cables with a `length_` cell
        "measured_length_change_m": est.measured_m,
        "length_change_residual_m": est.residual_m,
        "iterations": est.iterations,
        "jacobian_evals": est.jacobian_evals,
        "elapsed_s": est.elapsed_s,
        "fallback": fallback,
    })
}

fn row_text(row: &ReadingRow, e: &TendonEstimate) -> String {
    let est = &e.estimate;
    let vals: Vec<String> = est
        .values
        .iter()
        .zip(&est.std_dev)
        .map(|(v, s)| format!("{v:.5} +- {s:.1e}"))
        .collect();
    let tensions: Vec<String> = e
        .tensions_n
        .iter()
        .zip(&e.taut)
        .map(|(t, taut)| {
            if *taut {
                format!("{t:.3}")
            } else {
                "slack".into()
            }
        })
        .collect();
    let p = est.tip.position * 1e3;
    format!(
        "{:>5} {:>8} {:<13} {:<16} {}   {:.2} {:.2} {:.2}   [{}]",
        row.line,
        row.t_s.map_or("-".into(), |t| format!("{t:.3}")),
        format!("{:?}", est.status),
        format!("{:?} ({:.2})", est.fit, est.rms_sigma),
        vals.join("  "),
        p.x,
        p.y,
        p.z,
        tensions.join(" ")
    )
}

/// Stream `reader` through the scene's load estimator; returns (rows estimated,
/// rows not converged or poorly fitted, bad rows).
pub fn stream(
    scene: &Scene,
    scene_path: &Path,
    reader: Box<dyn BufRead>,
    output: Output,
) -> anyhow::Result<(usize, usize, usize)> {
    let mut est: TendonLoadEstimator = load_cells::estimator(scene)
        .with_context(|| format!("{}: building the load estimator", scene_path.display()))?;
    let mut parser = load_cells::parser(scene, &mut est);
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    if output == Output::Text {
        writeln!(
            out,
            "scene: {}   unknowns from load cells and measuring cables (tension_<tendon>, length_<passive cable> columns)",
            scene_path.display()
        )?;
        writeln!(
            out,
            "{:>5} {:>8} {:<13} {:<16} {}  (+- 1 sigma)   tip x y z (mm)   T {} (N)",
            "line",
            "t (s)",
            "status",
            "fit (rms sigma)",
            est.estimator().names().join("  "),
            est.tendons().join(" ")
        )?;
    }
    let (mut rows, mut poor, mut bad) = (0, 0, 0);
    let mut start = est.estimator().theta().to_vec();
    for (i, line) in reader.lines().enumerate() {
        let line = match crate::stream::stream_line(line, i + 1)? {
            Ok(l) => l,
            Err(e) => {
                bad += 1;
                emit_error(&mut out, output, i + 1, "line", &format!("unreadable: {e}"))?;
                continue;
            }
        };
        let row = match parser.line(i + 1, &line) {
            Ok(None) => continue,
            Ok(Some(r)) => r,
            Err(e) => {
                bad += 1;
                emit_error(&mut out, output, e.line, &e.field, &e.why)?;
                continue;
            }
        };
        start.copy_from_slice(est.estimator().theta());
        if let Err(e) = est.tick(&row.readings_m, &row.tensions_n, row.length_changes()) {
            bad += 1;
            emit_error(&mut out, output, row.line, "row", &e.to_string())?;
            continue;
        }
        let e = est.estimate();
        rows += 1;
        let fallback = e.estimate.poisons_warm_start();
        if fallback {
            est.estimator().set_theta(&start);
        }
        if e.estimate.status != EstimateStatus::Converged || e.estimate.fit == Fit::Poor {
            poor += 1;
        }
        match output {
            Output::Json => writeln!(out, "{}", row_json(&row, &e, fallback))?,
            Output::Text => writeln!(out, "{}", row_text(&row, &e))?,
        }
        out.flush()?;
    }
    Ok((rows, poor, bad))
}

fn emit_error(
    out: &mut impl Write,
    output: Output,
    line: usize,
    field: &str,
    why: &str,
) -> std::io::Result<()> {
    match output {
        Output::Json => writeln!(
            out,
            "{}",
            json!({"line": line, "error": why, "field": field})
        ),
        Output::Text => writeln!(out, "line {line:5}  error: {field}: {why}"),
    }
}
