//! `cablesense track [SCENE]`: streaming estimation, one JSON line per input row.

use crate::stream::{
    error_json, estimate_json, estimator, no_rows, open_watched, parser, process, MODEL_HELP,
};
use cablesense::files::demo;
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `track`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene with an [estimate] table, or a scene with displacement-driven tendons
    /// and no [estimate] table (rows of servo readings -> shape per row, warm-started
    /// from the previous row), or one with both (servo readings with `tension_<tendon>`
    /// load cells and/or `length_<cable>` length changes of passive measuring cables,
    /// unit `[readings] length_scale_m`, default `scale_m` -> unknown loads, tensions
    /// and shape per row; an empty cell is not measured in that row). Default: the shipped demo, which also defaults the
    /// input to its recorded stream.
    scene: Option<PathBuf>,
    /// Read rows from this file (or `demo:NAME`) instead of standard input.
    #[arg(long)]
    input: Option<PathBuf>,
    #[arg(long, default_value = "scene", help = MODEL_HELP)]
    model: String,
    /// Write DIR/track.svg: the estimated tip path over the recording and the last
    /// estimated shape (backbone, disks, cables on rod models) in the xy, xz, yz views.
    #[arg(long, value_name = "DIR")]
    plot: Option<PathBuf>,
}

/// Run `track`: bad rows produce `{"line": n, "error": ...}` and the stream goes on;
/// a bad CSV header (`"fatal": true`) stops it with exit code 1.
pub fn run(a: Args) -> anyhow::Result<ExitCode> {
    let (scene_path, input) = match (a.scene.clone(), a.input.clone()) {
        (Some(s), i) => (s, i),
        (None, i) => (
            PathBuf::from(demo::TRACK_SCENE),
            Some(i.unwrap_or_else(|| PathBuf::from(demo::TRACK_INPUT))),
        ),
    };
    let scene = demo::DataRef::parse(&scene_path)?.scene()?;
    if crate::readings::is_tendon_scene(&scene) {
        // the readings streams below run the scene's rod model and draw nothing:
        // refuse what they would otherwise ignore
        anyhow::ensure!(
            a.model == "scene",
            "--model {}: {} has displacement-driven tendons, whose stream runs the scene's own rod model (--model scene); `cablesense solve {} --readings FILE --model LABEL` solves rows on another rung",
            a.model,
            scene_path.display(),
            scene_path.display()
        );
        if let Some(dir) = &a.plot {
            anyhow::bail!(
                "--plot {}: not drawn for {}, a scene with displacement-driven tendons (--plot draws the tip path of an [estimate] scene's encoder stream)",
                dir.display(),
                scene_path.display()
            );
        }
    }
    // rows from --input FILE, or standard input; an input that gives no row (empty,
    // or a header and nothing after it) is an error, exit code 1, as for `solve
    // --readings` and `estimate`: a run over nothing must not look like a clean one
    let (reader, content): (Box<dyn BufRead>, _) = match &input {
        Some(f) => open_watched(f)?,
        None => {
            let (r, c) = crate::stream::Watched::new(std::io::BufReader::new(std::io::stdin()));
            (Box::new(r), c)
        }
    };
    let finish = |rows: usize| {
        let stdin = PathBuf::from("standard input");
        let why = no_rows(input.as_ref().unwrap_or(&stdin), rows, &content);
        if let Some(why) = why {
            eprintln!("error: {why}");
            return ExitCode::from(1);
        }
        ExitCode::SUCCESS
    };
    if crate::readings::is_tendon_scene(&scene) && scene.estimate.is_none() {
        // servo readings in, shape per row out (the control-loop case)
        let (solved, _, bad) = crate::readings::stream(
            &scene,
            &scene_path,
            reader,
            crate::readings::Output::Json,
            None,
        )?;
        return Ok(finish(solved + bad));
    }
    if crate::readings::is_tendon_scene(&scene) {
        // servo readings and load cells in, unknown loads per row out
        let (rows, _, bad) = crate::tendon_estimate::stream(
            &scene,
            &scene_path,
            reader,
            crate::tendon_estimate::Output::Json,
        )?;
        return Ok(finish(rows + bad));
    }
    let (scene, mut est) = estimator(&scene_path, &a.model)?;
    let mut p = parser(&scene, &est);
    let mut rows = 0usize;
    let mut tips = Vec::new();
    // the estimator after the last good row, its whole warm state (the model's
    // shooting unknowns and reused Jacobians included): a bad row is rolled back to
    // it, so the rows after a bad one see exactly what they would without it
    let mut good = est.clone();
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    for (i, line) in reader.lines().enumerate() {
        let line = match crate::stream::stream_line(line, i + 1)? {
            Ok(l) => l,
            Err(e) => {
                rows += 1;
                writeln!(
                    out,
                    "{}",
                    serde_json::json!({"line": i + 1, "error": format!("unreadable line: {e}")})
                )?;
                continue;
            }
        };
        match p.line(i + 1, &line) {
            Ok(None) => {}
            Ok(Some(s)) => {
                rows += 1;
                let e = process(&mut est, &s);
                // a row that stalls, fails or fits poorly must not become the next
                // row's warm start: roll back to the state this row started from
                // (the last good one); `"fallback": true` says so
                let fallback = e.poisons_warm_start();
                if fallback {
                    est.clone_from(&good);
                } else {
                    good.clone_from(&est);
                }
                let mut record = estimate_json(&s, &e);
                record["fallback"] = serde_json::json!(fallback);
                writeln!(out, "{record}")?;
                if a.plot.is_some() && e.status != cablesense::estimate::EstimateStatus::NoData {
                    tips.push(e.tip.position);
                }
            }
            Err(err) => {
                rows += 1;
                writeln!(out, "{}", error_json(&err))?;
                if err.fatal {
                    eprintln!("error: {err}");
                    return Ok(ExitCode::from(1));
                }
            }
        }
        out.flush()?;
    }
    if let Some(dir) = &a.plot {
        crate::plot_track::write(dir, &scene_path, &mut est, tips)?;
    }
    Ok(finish(rows))
}
