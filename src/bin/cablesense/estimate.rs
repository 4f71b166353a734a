//! `cablesense estimate SCENE --measure FILE`: a batch of encoder samples.

use crate::stream::{
    error_json, estimate_json, estimator, no_rows, open_watched, parser, process, MODEL_HELP,
};
use anyhow::Context;
use std::io::BufRead;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `estimate`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene with an [estimate] table (a path or `demo:NAME`).
    #[arg(default_value = cablesense::files::demo::TRACK_SCENE)]
    scene: PathBuf,
    /// Encoder samples: CSV with a header, or JSON lines (a path or `demo:NAME`); on a
    /// scene with displacement-driven tendons, rows of servo readings with
    /// `tension_<tendon>` load-cell columns (N) and/or `length_<cable>` length changes
    /// of passive measuring cables from the reference state (unit `[readings]
    /// length_scale_m`, default `scale_m`); an empty or missing cell is not measured
    /// in that row, and a row with neither is reported unobservable.
    #[arg(long, default_value = cablesense::files::demo::TRACK_INPUT)]
    measure: PathBuf,
    /// One JSON object per sample instead of a table.
    #[arg(long)]
    json: bool,
    #[arg(long, default_value = "scene", help = MODEL_HELP)]
    model: String,
}

/// Run `estimate`. Exit code 1 if any line was bad, any sample did not converge or
/// was a poor fit (residual beyond `poor_fit_rms_sigma` noise sigmas).
pub fn run(a: Args) -> anyhow::Result<ExitCode> {
    let scene = cablesense::files::demo::DataRef::parse(&a.scene)?.scene()?;
    if crate::readings::is_tendon_scene(&scene) {
        // servo readings and load cells in, unknown loads per row out
        anyhow::ensure!(
            a.model == "scene",
            "--model {}: a scene with displacement-driven tendons is estimated on its own rod model (--model scene)",
            a.model
        );
        let output = if a.json {
            crate::tendon_estimate::Output::Json
        } else {
            crate::tendon_estimate::Output::Text
        };
        let (reader, content) = open_watched(&a.measure)?;
        let (rows, poor, bad) = crate::tendon_estimate::stream(&scene, &a.scene, reader, output)?;
        if let Some(why) = no_rows(&a.measure, rows + bad, &content) {
            eprintln!("error: {why}");
            return Ok(ExitCode::from(1));
        }
        return Ok(if poor + bad == 0 {
            ExitCode::SUCCESS
        } else {
            ExitCode::from(1)
        });
    }
    let (scene, mut est) = estimator(&a.scene, &a.model)?;
    let mut p = parser(&scene, &est);
    let (file, content) = open_watched(&a.measure)?;
    // rows read, good or bad (none: an error below)
    let (mut rows, mut bad) = (0usize, 0usize);
    if !a.json {
        let names = est.names().join("  ");
        println!(
            "scene: {}   measurements: {}   model: {}",
            a.scene.display(),
            a.measure.display(),
            a.model
        );
        println!(
            "{:>5} {:>8} {:<13} {:<16} {}  (+- 1 sigma)   tip x y z (mm)",
            "line", "t (s)", "status", "fit (rms sigma)", names
        );
    }
    for (i, line) in file.lines().enumerate() {
        let line = crate::stream::stream_line(line, i + 1)
            .with_context(|| format!("reading {}", a.measure.display()))?;
        // a line that is not UTF-8 is one bad line, reported like any other
        let parsed = line.map_err(|e| {
            cablesense::files::measure::LineError::new(
                i + 1,
                "line",
                format!("unreadable line: {e}"),
            )
        });
        match parsed.and_then(|l| p.line(i + 1, &l)) {
            Ok(None) => {}
            Ok(Some(s)) => {
                rows += 1;
                let e = process(&mut est, &s);
                if !matches!(e.status, cablesense::estimate::EstimateStatus::Converged)
                    || e.fit == cablesense::estimate::Fit::Poor
                {
                    bad += 1;
                }
                if a.json {
                    println!("{}", estimate_json(&s, &e));
                } else {
                    let vals: Vec<String> = e
                        .values
                        .iter()
                        .zip(&e.std_dev)
                        .map(|(v, s)| format!("{v:.5} +- {s:.1e}"))
                        .collect();
                    let t = &e.tip.position;
                    println!(
                        "{:>5} {:>8} {:<13} {:<16} {}   {:.2} {:.2} {:.2}",
                        s.line,
                        s.t_s.map_or("-".into(), |t| format!("{t:.3}")),
                        format!("{:?}", e.status),
                        format!("{:?} ({:.2})", e.fit, e.rms_sigma),
                        vals.join("  "),
                        t.x * 1e3,
                        t.y * 1e3,
                        t.z * 1e3
                    );
                }
            }
            Err(err) => {
                rows += 1;
                bad += 1;
                if a.json {
                    println!("{}", error_json(&err));
                } else {
                    eprintln!("{err}");
                }
                if err.fatal {
                    break;
                }
            }
        }
    }
    if let Some(why) = no_rows(&a.measure, rows, &content) {
        eprintln!("error: {why}");
        return Ok(ExitCode::from(1));
    }
    Ok(if bad == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
