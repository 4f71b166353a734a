//! Rows of actuator readings through a tendon-driven scene (`solve --readings`,
//! `track` on a scene with displacement-driven tendons): one warm-started solve per
//! row, one output record per row; a bad row is reported and the stream goes on.

use anyhow::Context;
use cablesense::files::readings::{ReadingRow, ReadingsParser};
use cablesense::tendons::{TendonReport, TendonWorkspace};
use cablesense::Scene;
use serde_json::{json, Value};
use std::io::{BufRead, Write};
use std::path::Path;

/// Whether a scene has displacement-driven tendons.
pub fn is_tendon_scene(scene: &Scene) -> bool {
    scene
        .robot
        .cables
        .iter()
        .any(|c| c.actuation == cablesense::tendons::Actuation::Displacement)
}

/// How to print each row.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Output {
    /// One JSON object per row.
    Json,
    /// One text line per row.
    Text,
}

/// The per-row record.
pub fn row_json(
    ws: &TendonWorkspace,
    row: &ReadingRow,
    rep: &TendonReport,
    elapsed_s: f64,
) -> Value {
    let robot = ws.workspace().robot();
    let tip = ws.tip_position();
    let names: Vec<&str> = ws
        .driven()
        .iter()
        .map(|&j| robot.cables()[j].name.as_str())
        .collect();
    // a row that did not converge has no tip: its last iterate is given apart,
    // named as such, never as a result
    let (tip_json, last_iterate) = if rep.status.is_converged() {
        (json!([tip.x, tip.y, tip.z]), Value::Null)
    } else {
        (Value::Null, json!([tip.x, tip.y, tip.z]))
    };
    json!({
        "line": row.line,
        "t_s": row.t_s,
        "status": rep.status,
        "iterations": rep.iterations,
        "forward_solves": rep.forward_solves,
        "residual_m": rep.residual_m,
        "tip_position_m": tip_json,
        "last_iterate_tip_m": last_iterate,
        "measured_tip_m": row.measured_tip_m,
        "tendons": names,
        "readings_m": row.readings_m,
        "tensions_n": ws.tensions(),
        "taut": ws.taut(),
        "elapsed_s": elapsed_s,
    })
}

fn row_text(ws: &TendonWorkspace, row: &ReadingRow, rep: &TendonReport) -> String {
    let tip = ws.tip_position() * 1e3;
    let measured = row
        .measured_tip_m
        .map(|m| format!("[{:8.2} {:8.2} {:8.2}]", m[0] * 1e3, m[1] * 1e3, m[2] * 1e3))
        .unwrap_or_else(|| "-".into());
    let tensions: Vec<String> = ws
        .tensions()
        .iter()
        .zip(ws.taut())
        .map(|(t, taut)| {
            if *taut {
                format!("{t:.2}")
            } else {
                "slack".into()
            }
        })
        .collect();
    let status = format!("{:?}", rep.status).to_lowercase();
    if !rep.status.is_converged() {
        // no result: the last iterate is not a tip (a stalled chain would repeat it)
        return format!(
            "line {:5}  {:<14} STALLED: no tip (last iterate [{:8.2} {:8.2} {:8.2}] mm, not a result)  measured {measured}",
            row.line, status, tip.x, tip.y, tip.z
        );
    }
    format!(
        "line {:5}  {:<14} tip [{:8.2} {:8.2} {:8.2}] mm  measured {measured}  T [{}] N",
        row.line,
        status,
        tip.x,
        tip.y,
        tip.z,
        tensions.join(" ")
    )
}

/// Stream `reader` through the scene; returns (rows solved, rows converged, bad rows).
pub fn stream(
    scene: &Scene,
    scene_path: &Path,
    reader: Box<dyn BufRead>,
    output: Output,
    mut samples: Option<&mut dyn Write>,
) -> anyhow::Result<(usize, usize, usize)> {
    let ws = scene
        .tendon_workspace()
        .with_context(|| format!("{}: building the tendon model", scene_path.display()))?;
    let mut parser: ReadingsParser = scene.readings_parser(&ws);
    // warm row to row; a row that does not converge is not the next row's warm start
    let mut chain = cablesense::validation::TrackChain::for_scene(scene, ws);
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    if output == Output::Text {
        let ws = chain.workspace();
        let robot = ws.workspace().robot();
        let names: Vec<String> = ws
            .driven()
            .iter()
            .zip(ws.columns())
            .map(|(&j, c)| format!("{}<-{c}", robot.cables()[j].name))
            .collect();
        writeln!(out, "tendons: {}", names.join(" "))?;
    }
    if let Some(w) = samples.as_deref_mut() {
        writeln!(w, "line,s_m,x_m,y_m,z_m")?;
    }
    let (mut solved, mut converged, mut bad) = (0, 0, 0);
    for (i, line) in reader.lines().enumerate() {
        let Some(row) = next_row(&mut parser, i + 1, line, &mut out, output, &mut bad)? else {
            continue;
        };
        let t0 = std::time::Instant::now();
        let (rep, fallback) = match chain.step_at(row.t_s, &row.readings_m) {
            Ok(s) => (s.report, s.fallback),
            Err(e) => {
                bad += 1;
                emit_error(&mut out, output, row.line, "readings", &e.to_string())?;
                continue;
            }
        };
        let elapsed = t0.elapsed().as_secs_f64();
        solved += 1;
        converged += usize::from(rep.status.is_converged());
        // (a row that did not converge is not the next row's warm start: the chain
        // solves the last converged row again before the next one)
        let ws = chain.workspace_mut();
        // why a row did not converge, in the scene's terms (the loads and pulls that
        // bend the rod most: `TendonWorkspace::diagnose`)
        let why = (!rep.status.is_converged()).then(|| ws.diagnose().to_string());
        match output {
            Output::Json => {
                let mut record = row_json(ws, &row, &rep, elapsed);
                record["fallback"] = json!(fallback);
                if let Some(why) = &why {
                    record["diagnosis"] = json!(why);
                }
                writeln!(out, "{record}")?
            }
            Output::Text => {
                writeln!(out, "{}", row_text(ws, &row, &rep))?;
                if let Some(why) = &why {
                    writeln!(out, "            why: {why}")?;
                }
            }
        }
        if let Some(w) = samples.as_deref_mut() {
            let sol = ws.workspace_mut().solution();
            for s in &sol.samples {
                writeln!(w, "{},{},{},{},{}", row.line, s.s, s.r.x, s.r.y, s.r.z)?;
            }
        }
        out.flush()?;
    }
    Ok((solved, converged, bad))
}

/// Stream `reader` through a curvature rung of the readings ladder (CC or PCC: the
/// constant-curvature tendon kinematics, no mechanics, so no tensions; `taut` says
/// which tendons the kinematics uses). The readings are used as given (the scene's
/// `[readings]` time offset and backlash are the rod solve's conditioning, not
/// applied here). Returns (rows solved, rows converged, bad rows).
pub fn stream_kinematics(
    scene: &Scene,
    scene_path: &Path,
    rung: &cablesense::ladder::Rung,
    reader: Box<dyn BufRead>,
    output: Output,
) -> anyhow::Result<(usize, usize, usize)> {
    let ws = scene
        .tendon_workspace()
        .with_context(|| format!("{}: building the tendon model", scene_path.display()))?;
    let mut parser: ReadingsParser = scene.readings_parser(&ws);
    let robot = ws.workspace().robot().clone();
    let mut model = rung
        .build_readings(&robot, &scene.loads)
        .with_context(|| format!("{}: building {}", scene_path.display(), rung.label()))?;
    let label = rung.label();
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    if output == Output::Text {
        writeln!(
            out,
            "model {label}: constant-curvature tendon kinematics (no tensions)"
        )?;
    }
    let (mut solved, mut converged, mut bad) = (0, 0, 0);
    for (i, line) in reader.lines().enumerate() {
        let Some(row) = next_row(&mut parser, i + 1, line, &mut out, output, &mut bad)? else {
            continue;
        };
        let t0 = std::time::Instant::now();
        let rep = match model.solve_readings(&row.readings_m, cablesense::Start::Warm) {
            Ok(r) => r,
            Err(e) => {
                bad += 1;
                emit_error(&mut out, output, row.line, "readings", &e.to_string())?;
                continue;
            }
        };
        let elapsed = t0.elapsed().as_secs_f64();
        solved += 1;
        converged += usize::from(rep.status.is_converged());
        let tip = model.tip_position();
        match output {
            Output::Json => writeln!(
                out,
                "{}",
                json!({
                    "line": row.line,
                    "t_s": row.t_s,
                    "model": label,
                    "status": rep.status,
                    "tip_position_m": [tip.x, tip.y, tip.z],
                    "measured_tip_m": row.measured_tip_m,
                    "readings_m": row.readings_m,
                    "taut": model.taut(),
                    "elapsed_s": elapsed,
                })
            )?,
            Output::Text => {
                let t = tip * 1e3;
                let measured = row
                    .measured_tip_m
                    .map(|m| format!("[{:8.2} {:8.2} {:8.2}]", m[0] * 1e3, m[1] * 1e3, m[2] * 1e3))
                    .unwrap_or_else(|| "-".into());
                writeln!(
                    out,
                    "line {:5}  {:<14} tip [{:8.2} {:8.2} {:8.2}] mm  measured {measured}",
                    row.line,
                    format!("{:?}", rep.status).to_lowercase(),
                    t.x,
                    t.y,
                    t.z
                )?
            }
        }
        out.flush()?;
    }
    Ok((solved, converged, bad))
}

/// The row on line `no`: `None` for a line without a row (header, blank) and for a
/// bad one, which is reported (naming its line and field) and counted in `bad`.
fn next_row(
    parser: &mut ReadingsParser,
    no: usize,
    line: std::io::Result<String>,
    out: &mut impl Write,
    output: Output,
    bad: &mut usize,
) -> std::io::Result<Option<ReadingRow>> {
    let parsed = match crate::stream::stream_line(line, no)
        .map_err(|e| std::io::Error::other(format!("{e:#}")))?
    {
        Ok(l) => parser.line(no, &l),
        Err(e) => {
            *bad += 1;
            emit_error(out, output, no, "line", &format!("unreadable: {e}"))?;
            return Ok(None);
        }
    };
    match parsed {
        Ok(row) => Ok(row),
        Err(e) => {
            *bad += 1;
            emit_error(out, output, e.line, &e.field, &e.why)?;
            Ok(None)
        }
    }
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
