//! Outputs of a calibration: the calibrated scene (TOML, with the non-scene
//! parameters in its `[calibration]` table), a per-row residual CSV and an SVG report
//! (measured and model marker paths in three orthographic views with equal axes,
//! the error histogram, error over time, error against one input column).
//!
//! The SVG is drawn with the project's plot stack ([`crate::files::svg`]).

use super::fit::{CalibrationReport, RowResult, Split};
use super::CalibrationError;
use crate::files::svg::{extent, Axis, Doc, Panel};
use crate::files::Scene;
use crate::scene::calibration::{CalibrationSpec, TransformSpec};
use crate::scene::{set_params, ParamPath};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

/// The scene with the fitted scene parameters written in and the fitted capture
/// frame and marker offset stored in its `[calibration]` table (created from `spec`
/// when the scene has none).
pub fn calibrated_scene(
    scene: &Scene,
    spec: &CalibrationSpec,
    report: &CalibrationReport,
    param_paths: &[ParamPath],
) -> Result<Scene, CalibrationError> {
    let pairs: Vec<(ParamPath, f64)> = param_paths
        .iter()
        .cloned()
        .zip(report.scene_values.iter().copied())
        .collect();
    let mut out = set_params(scene, &pairs)?;
    let mut cal = spec.clone();
    let w = report.capture_to_base.rotation_vector();
    let t = report.capture_to_base.translation;
    cal.capture_to_base = TransformSpec {
        rotation_vector: [w.x, w.y, w.z],
        translation_m: [t.x, t.y, t.z],
    };
    let o = report.marker_offset_m;
    cal.marker_offset_m = [o.x, o.y, o.z];
    out.calibration = Some(cal);
    Ok(out)
}

/// Write one CSV line per row: split, line, time, measured (capture and base frame),
/// model (base frame), error vector and norm (m), IRLS weight, status (`ok`, or the
/// solve status of a row left out because its solve failed even from cold: then
/// the numbers are empty), the inputs (empty for failed rows).
pub fn write_residuals_csv(
    path: &Path,
    report: &CalibrationReport,
) -> Result<(), CalibrationError> {
    let io = |e: std::io::Error| CalibrationError::Io {
        path: path.display().to_string(),
        why: e.to_string(),
    };
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
    let mut header = String::from(
        "split,line,t_s,measured_capture_x_m,measured_capture_y_m,measured_capture_z_m,\
         measured_base_x_m,measured_base_y_m,measured_base_z_m,model_x_m,model_y_m,model_z_m,\
         error_x_m,error_y_m,error_z_m,error_m,weight,status",
    );
    for n in &report.input_names {
        header.push(',');
        header.push_str(n);
    }
    writeln!(f, "{header}").map_err(io)?;
    for r in &report.rows {
        let e = r.error_m();
        let mut line = format!(
            "{},{},{}",
            match r.split {
                Split::Train => "train",
                Split::Val => "val",
            },
            r.line,
            r.t_s.map(|t| t.to_string()).unwrap_or_default()
        );
        for v in r
            .measured_capture_m
            .iter()
            .chain(r.measured_base_m.iter())
            .chain(r.model_base_m.iter())
            .chain(e.iter())
        {
            let _ = write!(line, ",{v:.9e}");
        }
        let _ = write!(line, ",{:.9e},{},ok", e.norm(), r.weight);
        for v in &r.inputs {
            let _ = write!(line, ",{v}");
        }
        writeln!(f, "{line}").map_err(io)?;
    }
    for r in &report.failed_rows {
        let split = match r.split {
            Split::Train => "train",
            Split::Val => "val",
        };
        // 15 empty cells: t_s, measured (capture, base), model, error (3 each), norm,
        // weight
        writeln!(
            f,
            "{split},{},{}{}",
            r.line,
            ",".repeat(15),
            r.status_name()
        )
        .map_err(io)?;
    }
    f.flush().map_err(io)
}

/// Options of [`write_report_svg`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SvgOptions {
    /// Title line.
    pub title: String,
    /// Input column for the "error against input" panel (default: the first input).
    pub input: Option<String>,
}

const TRAIN: &str = "#1f77b4";
const VAL: &str = "#2ca02c";
const MODEL: &str = "#d62728";

/// Bounds of the points with both coordinates finite, `((0, 0), (1, 1))` when none.
fn bounds(pts: impl Iterator<Item = (f64, f64)>) -> ((f64, f64), (f64, f64)) {
    let p: Vec<(f64, f64)> = pts.filter(|p| p.0.is_finite() && p.1.is_finite()).collect();
    match (extent(p.iter().map(|p| p.0)), extent(p.iter().map(|p| p.1))) {
        (Some(x), Some(y)) => ((x.0, y.0), (x.1, y.1)),
        _ => ((0.0, 0.0), (1.0, 1.0)),
    }
}

/// Write the SVG report of `report` to `path`.
pub fn write_report_svg(
    path: &Path,
    report: &CalibrationReport,
    opts: &SvgOptions,
) -> Result<(), CalibrationError> {
    let svg = report_svg(report, opts);
    std::fs::write(path, svg).map_err(|e| CalibrationError::Io {
        path: path.display().to_string(),
        why: e.to_string(),
    })
}

fn mm(r: &RowResult) -> (f64, f64) {
    (0.0, r.error_m().norm() * 1e3)
}

/// The SVG text of the report.
fn report_svg(report: &CalibrationReport, opts: &SvgOptions) -> String {
    let mut doc = Doc::new(1260.0, 880.0, 12.0);
    let len_mm = report.robot_length_m * 1e3;
    let line = |e: &super::stats::TipErrors, name: &str| {
        format!(
            "{name}: raw RMSE {:.3} mm ({:.2} % of L), median {:.3}, p95 {:.3}, max {:.3} mm; mean offset removed (upstream metric) RMSE {:.3} mm ({:.2} %)",
            e.raw.rmse_m * 1e3,
            e.raw.rmse_m * 1e3 / len_mm * 100.0,
            e.raw.median_m * 1e3,
            e.raw.p95_m * 1e3,
            e.raw.max_m * 1e3,
            e.mean_removed.rmse_m * 1e3,
            e.mean_removed.rmse_m * 1e3 / len_mm * 100.0
        )
    };
    let small = r#"font-size="11""#;
    doc.text(20.0, 24.0, &opts.title, r#"font-size="15""#);
    doc.text(20.0, 44.0, &line(&report.train, "train"), small);
    if let Some(v) = &report.val {
        doc.text(20.0, 60.0, &line(v, "val"), small);
    }
    if !report.failed_rows.is_empty() {
        let text = format!(
            "{} rows left out, their solve failed even from cold: {}",
            report.failed_rows.len(),
            super::FailedRow::list(&report.failed_rows, 12)
        );
        doc.text(
            20.0,
            92.0,
            &text,
            &format!(r#"font-size="11" fill="{MODEL}""#),
        );
    }
    doc.raw(&format!(
        r#"<text x="20" y="76" font-size="11"><tspan fill="{TRAIN}">measured (train, dots)</tspan>  <tspan fill="{VAL}">measured (val, dots)</tspan>  <tspan fill="{MODEL}">model (line)</tspan>  (robot base frame, mm; errors are model - measured distances)</text>"#
    ));
    let splits = [(Split::Train, TRAIN), (Split::Val, VAL)];
    // three orthographic views
    for (v, (a, b, la, lb)) in [
        (0usize, 1usize, "x", "y"),
        (0, 2, "x", "z"),
        (1, 2, "y", "z"),
    ]
    .into_iter()
    .enumerate()
    {
        let at = |p: &nalgebra::Vector3<f64>| (p[a] * 1e3, p[b] * 1e3);
        let all = report
            .rows
            .iter()
            .flat_map(|r| [at(&r.measured_base_m), at(&r.model_base_m)]);
        let (lo, hi) = bounds(all);
        let p = Panel::equal([70.0 + v as f64 * 410.0, 110.0, 340.0, 300.0], lo, hi);
        let (title, xl, yl) = (
            format!("{la}{lb} view"),
            format!("{la} (mm)"),
            format!("{lb} (mm)"),
        );
        p.frame(&mut doc, &title, &xl, &yl);
        for (split, color) in splits {
            let rows = report.rows.iter().filter(|r| r.split == split);
            let meas: Vec<(f64, f64)> = rows.clone().map(|r| at(&r.measured_base_m)).collect();
            let model: Vec<(f64, f64)> = rows.map(|r| at(&r.model_base_m)).collect();
            p.dots(
                &mut doc,
                &meas,
                1.6,
                &format!(r#"fill="{color}" fill-opacity="0.7""#),
            );
            let style = format!(r#"stroke="{MODEL}" stroke-width="0.8" stroke-opacity="0.85""#);
            p.polyline(&mut doc, &model, &style);
        }
    }
    // error histogram
    let errs: Vec<f64> = report.rows.iter().map(|r| mm(r).1).collect();
    let emax = errs.iter().cloned().fold(0.0f64, f64::max).max(1e-6);
    let nb = 30usize;
    let mut counts = [[0usize; 30]; 2];
    for r in &report.rows {
        let b = ((mm(r).1 / emax * nb as f64) as usize).min(nb - 1);
        counts[(r.split == Split::Val) as usize][b] += 1;
    }
    let cmax = counts.iter().flatten().copied().max().unwrap_or(1).max(1) as f64;
    let p = Panel::new(
        [70.0, 520.0, 340.0, 300.0],
        Axis::linear(0.0, emax),
        Axis::linear(0.0, cmax * 1.05),
    );
    p.frame(&mut doc, "error histogram", "error (mm)", "rows");
    for (k, color) in [(0usize, TRAIN), (1, VAL)] {
        for (b, c) in counts[k].iter().enumerate().filter(|(_, c)| **c > 0) {
            let (x0, x1) = (
                b as f64 * emax / nb as f64,
                (b + 1) as f64 * emax / nb as f64,
            );
            let style = format!(r#"fill="{color}" fill-opacity="0.45""#);
            p.bar(&mut doc, (x0, x1), *c as f64, &style);
        }
    }
    // error over time (or row order), and against an input
    let has_t = report.rows.iter().all(|r| r.t_s.is_some());
    let over: Vec<(Split, f64, f64)> = report
        .rows
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let x = if has_t {
                r.t_s.unwrap_or(0.0)
            } else {
                i as f64
            };
            (r.split, x, mm(r).1)
        })
        .collect();
    let xlabel = if has_t { "t (s)" } else { "row" };
    scatter(&mut doc, 480.0, &over, "error over time", xlabel);
    let k = opts
        .input
        .as_ref()
        .and_then(|n| report.input_names.iter().position(|x| x == n))
        .or(if report.input_names.is_empty() {
            None
        } else {
            Some(0)
        });
    if let Some(k) = k {
        let pts: Vec<(Split, f64, f64)> = report
            .rows
            .iter()
            .map(|r| (r.split, r.inputs[k], mm(r).1))
            .collect();
        let name = &report.input_names[k];
        scatter(
            &mut doc,
            890.0,
            &pts,
            &format!("error against {name}"),
            name,
        );
    }
    doc.finish()
}

/// A bottom-row panel at `x0` of the error (mm, from 0) against `x`, dots coloured
/// by split.
fn scatter(doc: &mut Doc, x0: f64, pts: &[(Split, f64, f64)], title: &str, xlabel: &str) {
    let (lo, hi) = bounds(pts.iter().map(|(_, x, y)| (*x, *y)));
    let p = Panel::new(
        [x0, 520.0, 340.0, 300.0],
        Axis::linear(lo.0, hi.0),
        Axis::linear(0.0, hi.1 * 1.05),
    );
    p.frame(doc, title, xlabel, "error (mm)");
    for (split, color) in [(Split::Train, TRAIN), (Split::Val, VAL)] {
        let sel: Vec<(f64, f64)> = pts
            .iter()
            .filter(|(sp, _, _)| *sp == split)
            .map(|(_, x, y)| (*x, *y))
            .collect();
        p.dots(
            doc,
            &sel,
            1.6,
            &format!(r#"fill="{color}" fill-opacity="0.7""#),
        );
    }
}
