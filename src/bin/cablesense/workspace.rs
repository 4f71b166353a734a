//! `cablesense workspace [SCENE]`: the reachable workspace of a robot driven by
//! actuator readings, sampled over the box of its `[robot.limits]`
//! (`cablesense::command::workspace`): the tip cloud (CSV), its convex hull
//! (OBJ) and volume, a summary (JSON) and an SVG with the `xy`, `xz` and `yz` views
//! and a 3-D perspective. With `--recording FILE` the recording's measured markers
//! (the scene's `[calibration]` capture frame) are overlaid, with the coverage: the
//! share of the model's hull that the recording's hull covers, and with `--val FILE`
//! which of its rows lie outside the recording's hull. Without arguments: the
//! embedded calibrated FTDCR v4 scene, its train recording and its val rows, written
//! to `out/workspace/`.

mod files;

use crate::progress;
use anyhow::{bail, Context};
use cablesense::calibrate::{Recording, RigidTransform};
use cablesense::command::workspace::FoldClass;
use cablesense::command::{sample_workspace, Hull, SampleStatus, WorkspaceSettings};
use cablesense::files::svg::{Doc, Swatch};
use cablesense::nalgebra::Vector3;
use cablesense::validation::{column_map, TRAIN_CSV, VAL_CSV};
use cablesense::Scene;
use files::{stop_name, write_cloud, write_obj};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Quasi-Monte Carlo points of the coverage estimate.
const COVERAGE_POINTS: usize = 200_000;
/// Most cloud points drawn per view (every k-th sample; the CSV has them all).
const DRAWN_POINTS: usize = 6000;
/// A tip this far outside a hull plane still counts as inside (m): round-off.
const INSIDE_TOLERANCE_M: f64 = 1e-9;
/// A retried sample's tip and a cold solve's this close are one equilibrium (m).
const SAME_TIP_M: f64 = 1e-6;

#[derive(clap::Args)]
pub struct Args {
    /// Scene with displacement-driven tendons and `[robot.limits]` (a path, or
    /// `demo:NAME`). Default: the embedded calibrated FTDCR v4 scene.
    scene: Option<PathBuf>,
    /// Samples of the actuator box (Halton sequence).
    #[arg(long, default_value_t = 20_000)]
    samples: usize,
    /// Output folder (created).
    #[arg(long, default_value = "out/workspace")]
    output: PathBuf,
    /// A recording (the scene's `[calibration]` columns) whose measured markers are
    /// overlaid. Default without a scene: the embedded FTDCR v4 train.csv.
    #[arg(long)]
    recording: Option<PathBuf>,
    /// Rows to check against the recording's hull (same columns). Default without a
    /// scene: the embedded FTDCR v4 val.csv.
    #[arg(long)]
    val: Option<PathBuf>,
    /// Threads (0: all cores). The cloud does not depend on it.
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Samples per warm chain (nearest-neighbour order within it).
    #[arg(long, default_value_t = 500)]
    chunk: usize,
    /// Rod passes one readings solve may run (deterministic budget; 0: unbudgeted,
    /// with the nested fallback, many times slower per failing sample).
    #[arg(long, default_value_t = 400)]
    max_passes: usize,
    /// Solves of the continuation from the chain's last converged sample toward a
    /// sample whose first solve failed (0: none).
    #[arg(long, default_value_t = 0)]
    substeps: usize,
    /// After everything else failed, one more unbudgeted solve from the straight
    /// rod (slow: 0.1 to 0.4 s a failing sample on FTDCR v4).
    #[arg(long)]
    cold_retry: bool,
    /// Retry pass: a failed sample warm from each of its N nearest solved ones.
    #[arg(long, default_value_t = WorkspaceSettings::DEFAULT_RETRY_NEIGHBOURS)]
    retry_neighbours: usize,
    /// Retry pass: solves of the continuation from the nearest solved sample.
    #[arg(long, default_value_t = WorkspaceSettings::DEFAULT_RETRY_STEPS)]
    retry_steps: usize,
    /// Retry pass: one more solve cold from the reference.
    #[arg(long)]
    retry_cold: bool,
    /// Rod passes of each retry solve (0: as --max-passes).
    #[arg(long, default_value_t = WorkspaceSettings::DEFAULT_RETRY_PASSES)]
    retry_passes: usize,
    /// Check each retried sample by a cold solve at its readings (another tip: a
    /// second equilibrium).
    #[arg(long)]
    check_retries: bool,
    /// Test each failed sample for a fold of the warm path to it (small steps under
    /// --retry-passes a solve, then the joint Jacobian's smallest singular value):
    /// past_fold, singular, regular, reached (cloud.csv's fold_test column,
    /// summary.json).
    #[arg(long)]
    fold_test: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// Measured markers of a recording in the base frame, with their file lines.
struct Measured {
    name: String,
    lines: Vec<usize>,
    points: Vec<Vector3<f64>>,
}

fn measured(scene: &Scene, name: &str, text: &str) -> anyhow::Result<Measured> {
    let map = column_map(scene).with_context(|| format!("{name}: reading the markers"))?;
    let rec = Recording::parse_str(name, text, &map)?;
    let spec = scene.calibration.clone().unwrap_or_default();
    let frame = RigidTransform::from_spec(&spec.capture_to_base);
    Ok(Measured {
        name: name.to_string(),
        lines: rec.rows.iter().map(|r| r.line).collect(),
        points: rec.rows.iter().map(|r| frame.apply(&r.marker_m)).collect(),
    })
}

fn read(p: &Path) -> anyhow::Result<String> {
    std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))
}

pub fn run(a: Args) -> anyhow::Result<ExitCode> {
    if a.samples == 0 {
        bail!("--samples must be at least 1 (got 0)");
    }
    if a.chunk == 0 {
        bail!("--chunk must be at least 1 (got 0)");
    }
    let (scene, name) = crate::reach::scene_or_calibrated(a.scene.as_deref())?;
    let recording = match (&a.recording, &a.scene) {
        (Some(f), _) => Some(measured(&scene, &f.display().to_string(), &read(f)?)?),
        (None, None) => Some(measured(&scene, "train.csv (embedded)", TRAIN_CSV)?),
        (None, Some(_)) => None,
    };
    let val = match (&a.val, &a.scene) {
        (Some(_), _) if recording.is_none() => bail!("--val needs --recording"),
        (Some(f), _) => Some(measured(&scene, &f.display().to_string(), &read(f)?)?),
        (None, None) if a.recording.is_none() => {
            Some(measured(&scene, "val.csv (embedded)", VAL_CSV)?)
        }
        _ => None,
    };
    // the measured point is the marker: set it against the model's marker
    let marker_offset = match &scene.calibration {
        Some(c) if recording.is_some() && c.marker_s_m.is_none() => {
            Some(Vector3::from(c.marker_offset_m))
        }
        _ => None,
    };
    let tw = scene
        .tendon_workspace()
        .with_context(|| format!("{name}: the readings model"))?;
    let limits = scene.actuator_limits()?;
    let settings = WorkspaceSettings {
        samples: a.samples,
        threads: a.threads,
        chunk_samples: a.chunk,
        max_passes: (a.max_passes > 0).then_some(a.max_passes),
        max_substeps: a.substeps,
        cold_retry: a.cold_retry,
        retry_neighbours: a.retry_neighbours,
        retry_steps: a.retry_steps,
        retry_cold: a.retry_cold,
        retry_passes: (a.retry_passes > 0).then_some(a.retry_passes),
        check_retries: a.check_retries,
        fold_test: a.fold_test,
        marker_offset_m: marker_offset,
        ..WorkspaceSettings::default()
    };
    let pb = progress::bar(a.samples as u64, a.quiet);
    let t0 = std::time::Instant::now();
    let cloud = sample_workspace(&tw, &limits, &settings, &|d| pb.set_position(d as u64))
        .with_context(|| format!("{name}: sampling the workspace"))?;
    let sample_s = t0.elapsed().as_secs_f64();
    pb.finish_and_clear();
    let tips = cloud.solved_tips();
    let hull = Hull::of(&tips).with_context(|| {
        format!(
            "{name}: the hull of the {} solved tips ({} of {} samples failed)",
            tips.len(),
            cloud.failed(),
            cloud.len()
        )
    })?;
    let outside = tips
        .iter()
        .filter(|t| !hull.contains(t, INSIDE_TOLERANCE_M))
        .count();
    std::fs::create_dir_all(&a.output)
        .with_context(|| format!("creating {}", a.output.display()))?;
    let scale = scene.readings_scale_m();
    write_cloud(
        &cloud,
        scale,
        settings.fold_test,
        &a.output.join("cloud.csv"),
    )?;
    write_obj(&hull, &name, &a.output.join("hull.obj"))?;
    // where the work went: rod passes per status (deterministic, unlike times)
    let work = cloud.passes_by_status();
    let names = SampleStatus::ALL.map(SampleStatus::name);
    let total_passes: u64 = work.iter().map(|w| w.1).sum();
    let work_json: serde_json::Map<String, serde_json::Value> = names
        .iter()
        .zip(&work)
        .map(|(n, (c, w))| {
            (
                n.to_string(),
                serde_json::json!({ "samples": c, "passes": w }),
            )
        })
        .collect();
    let work_line = format!(
        "rod passes: {total_passes} in all; per sample {}",
        names
            .iter()
            .zip(&work)
            .filter(|(_, (c, _))| *c > 0)
            .map(|(n, (c, w))| format!("{n} {:.1}", *w as f64 / *c as f64))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let count = |s: SampleStatus| cloud.status.iter().filter(|x| **x == s).count();
    let by_stop = cloud.failed_by_stop();
    let by_stop_json: serde_json::Map<String, serde_json::Value> = by_stop
        .iter()
        .map(|(s, c)| (stop_name(*s), serde_json::json!(c)))
        .collect();
    let checks = cloud.retry_checks(SAME_TIP_M);
    // the largest residual of a sample a retry solved (m)
    let retried = |(s, _): &(&SampleStatus, _)| s.is_solved() && **s != SampleStatus::Converged;
    let residuals = cloud.status.iter().zip(&cloud.residual_m).filter(retried);
    let retried_residual = residuals.map(|(_, r)| *r).fold(f64::NAN, f64::max);
    // coverage of a recording
    let mut summary = serde_json::json!({
        "scene": name,
        "samples": cloud.len(),
        "solved": tips.len(),
        "solved_neighbour": count(SampleStatus::ConvergedNeighbour),
        "solved_stepped": cloud.stepped(),
        "solved_cold": cloud.cold(),
        "failed": cloud.failed(),
        "failed_by_last_solve": by_stop_json,
        "sampling_s": sample_s,
        "chunk_samples": settings.chunk_samples,
        "max_passes": settings.max_passes,
        "max_substeps": settings.max_substeps,
        "cold_retry": settings.cold_retry,
        "retry_neighbours": settings.retry_neighbours, "retry_steps": settings.retry_steps,
        "retry_cold": settings.retry_cold, "retry_passes": settings.retry_passes,
        "check_retries": settings.check_retries, "fold_test": settings.fold_test,
        "rod_passes": work_json,
        "hull_vertices": hull.vertices.len(),
        "hull_triangles": hull.triangles.len(),
        "hull_volume_m3": hull.volume_m3,
        "tips_outside_hull": outside,
        "limits_min": limits.min_m.iter().map(|v| v / scale).collect::<Vec<_>>(),
        "limits_max": limits.max_m.iter().map(|v| v / scale).collect::<Vec<_>>(),
        "columns": cloud.columns,
    });
    let mut lines = vec![format!(
        "{} samples ({name}): {} solved ({} by a retry from a neighbour, {} by continuation, {} cold), {} failed, in {:.1} s",
        cloud.len(),
        tips.len(),
        count(SampleStatus::ConvergedNeighbour),
        cloud.stepped(),
        cloud.cold(),
        cloud.failed(),
        sample_s
    )];
    if !by_stop.is_empty() {
        lines.push(format!(
            "failed samples by how their last solve ended: {}",
            by_stop
                .iter()
                .map(|(s, c)| format!("{} {c}", stop_name(*s)))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    if settings.check_retries {
        summary["retry_checks"] = serde_json::json!({
            "same_tip_tolerance_m": SAME_TIP_M, "same_tip": checks.0, "other_tip": checks.1,
            "cold_not_converged": checks.2, "max_residual_m": retried_residual,
        });
        lines.push(format!(
            "retried samples (largest residual {retried_residual:.1e} m) checked by a cold solve at the same readings: {} the same tip (within {SAME_TIP_M:e} m), {} another tip (a second equilibrium), {} where the cold solve did not converge",
            checks.0, checks.1, checks.2
        ));
    }
    if settings.fold_test {
        let by_fold = cloud.failed_by_fold();
        let names = FoldClass::ALL.map(FoldClass::name);
        let json: serde_json::Map<String, serde_json::Value> = names
            .iter()
            .zip(&by_fold)
            .map(|(n, (c, w))| {
                (
                    n.to_string(),
                    serde_json::json!({ "samples": c, "passes": w }),
                )
            })
            .collect();
        summary["failed_by_fold_test"] = serde_json::Value::Object(json);
        lines.push(format!(
            "failed samples by the fold test (rod passes of the tests {}): {}",
            by_fold.iter().map(|w| w.1).sum::<u64>(),
            names
                .iter()
                .zip(&by_fold)
                .map(|(n, (c, _))| format!("{n} {c}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    lines.push(work_line);
    lines.push(format!(
        "convex hull: {} vertices, {} triangles, volume {:.1} cm^3 ({:.3e} m^3); solved tips outside it: {outside}",
        hull.vertices.len(),
        hull.triangles.len(),
        hull.volume_m3 * 1e6,
        hull.volume_m3
    ));
    let mut overlay = Overlay::default();
    if let Some(rec) = &recording {
        let model_markers = if marker_offset.is_some() {
            cloud.solved_markers()
        } else {
            tips.clone()
        };
        let model_hull = Hull::of(&model_markers).context("the hull of the model's markers")?;
        let rec_hull = Hull::of(&rec.points)
            .with_context(|| format!("{}: the hull of its markers", rec.name))?;
        let covered = model_hull.covered_fraction(&rec_hull, COVERAGE_POINTS);
        let rec_outside = rec
            .points
            .iter()
            .filter(|p| !model_hull.contains(p, 0.0))
            .count();
        let what = if marker_offset.is_some() {
            "the model's marker points (tip + marker offset)"
        } else {
            "the model's tips"
        };
        lines.push(format!(
            "{}: {} rows; its hull {:.1} cm^3 covers {:.1} % of the hull of {what} ({:.1} cm^3); {} of its rows lie outside that hull",
            rec.name,
            rec.points.len(),
            rec_hull.volume_m3 * 1e6,
            100.0 * covered,
            model_hull.volume_m3 * 1e6,
            rec_outside
        ));
        summary["recording"] = serde_json::json!({
            "file": rec.name,
            "rows": rec.points.len(),
            "hull_volume_m3": rec_hull.volume_m3,
            "model_point": if marker_offset.is_some() { "marker" } else { "tip" },
            "model_hull_volume_m3": model_hull.volume_m3,
            "covered_fraction": covered,
            "rows_outside_model_hull": rec_outside,
        });
        overlay.recording = rec.points.clone();
        overlay.model_markers = marker_offset.is_some();
        if let Some(v) = &val {
            let out: Vec<usize> = v
                .points
                .iter()
                .enumerate()
                .filter(|(_, p)| !rec_hull.contains(p, 0.0))
                .map(|(k, _)| k)
                .collect();
            let mut csv = String::from("row,line,x_m,y_m,z_m,outside_recording_hull,excess_m\n");
            for (k, p) in v.points.iter().enumerate() {
                writeln!(
                    csv,
                    "{k},{},{},{},{},{},{}",
                    v.lines[k],
                    p.x,
                    p.y,
                    p.z,
                    out.contains(&k),
                    rec_hull.excess(p).max(0.0)
                )?;
            }
            std::fs::write(a.output.join("val_coverage.csv"), csv)?;
            let far = out
                .iter()
                .map(|&k| rec_hull.excess(&v.points[k]))
                .fold(0.0f64, f64::max);
            lines.push(format!(
                "{}: {} of {} rows lie outside the hull of {} (farthest {:.2} mm beyond a face); rows in val_coverage.csv",
                v.name,
                out.len(),
                v.points.len(),
                rec.name,
                far * 1e3
            ));
            summary["val"] = serde_json::json!({
                "file": v.name,
                "rows": v.points.len(),
                "outside_recording_hull": out.len(),
                "outside_lines": out.iter().map(|&k| v.lines[k]).collect::<Vec<_>>(),
                "farthest_beyond_m": far,
            });
            overlay.val_inside = (0..v.points.len())
                .filter(|k| !out.contains(k))
                .map(|k| v.points[k])
                .collect();
            overlay.val_outside = out.iter().map(|&k| v.points[k]).collect();
        }
    }
    summary["lines"] = serde_json::json!(lines);
    std::fs::write(
        a.output.join("summary.json"),
        serde_json::to_string_pretty(&summary)?,
    )?;
    let title = format!(
        "Reachable workspace, {name}: {} of {} samples solved, convex hull {:.1} cm^3",
        tips.len(),
        cloud.len(),
        hull.volume_m3 * 1e6
    );
    std::fs::write(
        a.output.join("workspace.svg"),
        svg(&title, &tips, &hull, &overlay),
    )?;
    for l in &lines {
        eprintln!("{l}");
    }
    eprintln!(
        "wrote {}/{{cloud.csv, hull.obj, summary.json, workspace.svg{}}}",
        a.output.display(),
        if val.is_some() {
            ", val_coverage.csv"
        } else {
            ""
        }
    );
    Ok(if cloud.failed() == 0 && outside == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// What is drawn over the cloud.
#[derive(Default)]
struct Overlay {
    recording: Vec<Vector3<f64>>,
    model_markers: bool,
    val_inside: Vec<Vector3<f64>>,
    val_outside: Vec<Vector3<f64>>,
}

/// Four panels: `xy`, `xz`, `yz` (orthographic, one scale for all, mm) and a
/// perspective view (camera at azimuth 45 deg, elevation 25 deg, three extents away).
fn svg(title: &str, tips: &[Vector3<f64>], hull: &Hull, o: &Overlay) -> String {
    const PANEL: f64 = 420.0;
    const PAD: f64 = 36.0;
    let (w, h) = (2.0 * PANEL + 3.0 * PAD, 2.0 * PANEL + 3.0 * PAD + 90.0);
    let mut doc = Doc::new(w, h, 12.0);
    doc.text(PAD, 22.0, title, r#"font-size="14""#);
    let (lo, hi) = hull.bounds();
    let centre = (lo + hi) * 0.5;
    let extent = (hi - lo).max() * 1.1;
    let stride = (tips.len() / DRAWN_POINTS).max(1);
    let drawn: Vec<Vector3<f64>> = tips.iter().step_by(stride).copied().collect();
    let mut edges: Vec<(usize, usize)> = hull
        .triangles
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    // camera of the perspective panel
    let (az, el) = (45f64.to_radians(), 25f64.to_radians());
    let fwd = -Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
    let right = fwd.cross(&Vector3::z()).normalize();
    let up = right.cross(&fwd);
    let eye = centre - fwd * (3.0 * extent);
    let views: [(&str, usize, usize); 3] = [("x-y (top)", 0, 1), ("x-z", 0, 2), ("y-z", 1, 2)];
    for panel in 0..4 {
        let ox = PAD + (panel % 2) as f64 * (PANEL + PAD);
        let oy = 40.0 + (panel / 2) as f64 * (PANEL + PAD);
        doc.rect(ox, oy, PANEL, PANEL, r##"fill="none" stroke="#888""##);
        let view = views.get(panel).copied();
        let project = |p: &Vector3<f64>| -> (f64, f64) {
            if let Some((_, i, j)) = view {
                let u = (p[i] - centre[i]) / extent;
                let v = (p[j] - centre[j]) / extent;
                (ox + PANEL * (0.5 + u), oy + PANEL * (0.5 - v))
            } else {
                let d = p - eye;
                let z = d.dot(&fwd);
                let f = 3.0 / z; // focal length: the extent spans about the panel
                (
                    ox + PANEL * (0.5 + f * d.dot(&right)),
                    oy + PANEL * (0.5 - f * d.dot(&up)),
                )
            }
        };
        let label = if let Some((n, i, j)) = view {
            let ax = ["x", "y", "z"];
            format!(
                "{n}: {} {:.0}..{:.0} mm, {} {:.0}..{:.0} mm",
                ax[i],
                (centre[i] - 0.5 * extent) * 1e3,
                (centre[i] + 0.5 * extent) * 1e3,
                ax[j],
                (centre[j] - 0.5 * extent) * 1e3,
                (centre[j] + 0.5 * extent) * 1e3
            )
        } else {
            "perspective (azimuth 45 deg, elevation 25 deg)".to_string()
        };
        doc.text(ox + 4.0, oy + 14.0, &label, "");
        let mut path = String::new();
        for &(a, b) in &edges {
            let (x0, y0) = project(&hull.vertices[a]);
            let (x1, y1) = project(&hull.vertices[b]);
            let _ = write!(path, "M{x0:.1} {y0:.1}L{x1:.1} {y1:.1}");
        }
        doc.path(&path, r##"stroke="#bbb" stroke-width="0.5" fill="none""##);
        for (pts, colour, r, opacity) in [
            (&drawn, "#3b6fb6", 1.4, 0.6),
            (&o.recording, "#e08a1e", 1.3, 0.8),
            (&o.val_inside, "#2a9d3a", 1.6, 0.9),
            (&o.val_outside, "#d62728", 2.2, 1.0),
        ] {
            if !pts.is_empty() {
                doc.open(&format!(r#"fill="{colour}" fill-opacity="{opacity}""#));
                for (x, y) in pts.iter().map(project) {
                    doc.circle(x, y, r, "");
                }
                doc.close();
            }
        }
    }
    let legend = [
        format!(
            "model tips at the sampled readings ({} of {} drawn; all in cloud.csv); grey: edges of their convex hull (over-states a non-convex workspace)",
            drawn.len(),
            tips.len()
        ),
        format!(
            "recording: measured markers, base frame ({} rows){}",
            o.recording.len(),
            if o.model_markers {
                "; its coverage is computed against the model's marker points"
            } else {
                ""
            }
        ),
        format!(
            "val rows inside the recording's hull ({})",
            o.val_inside.len()
        ),
        format!(
            "val rows outside the recording's hull ({})",
            o.val_outside.len()
        ),
    ];
    let entries: Vec<(Swatch, &str, &str)> = ["#3b6fb6", "#e08a1e", "#2a9d3a", "#d62728"]
        .into_iter()
        .zip(&legend)
        .map(|(c, t)| (Swatch::Dot, c, t.as_str()))
        .collect();
    Swatch::list(
        &mut doc,
        PAD - 8.0,
        40.0 + 2.0 * (PANEL + PAD) + 4.0,
        &entries,
    );
    doc.finish()
}
