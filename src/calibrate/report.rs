//! Outputs of a calibration: the calibrated scene (TOML, with the non-scene
//! parameters in its `[calibration]` table), a per-row residual CSV and an SVG report
//! (measured and model marker paths in three orthographic views with equal axes,
//! the error histogram, error over time, error against one input column).
//!
//! The SVG is written by hand with sub-pixel coordinates (plotters' SVG backend
//! rounds to whole pixels, which turns mm-scale paths into staircases).

use super::fit::{CalibrationReport, RowResult, Split};
use super::CalibrationError;
use crate::files::svg::escape;
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

/// A plot panel: a pixel rectangle and a data box mapped onto it.
struct Panel {
    x0: f64,
    y0: f64,
    w: f64,
    h: f64,
    lo: (f64, f64),
    hi: (f64, f64),
}

impl Panel {
    fn new(x0: f64, y0: f64, w: f64, h: f64, lo: (f64, f64), hi: (f64, f64)) -> Self {
        let fix = |a: f64, b: f64| if b > a { (a, b) } else { (a - 0.5, a + 0.5) };
        let (lx, hx) = fix(lo.0, hi.0);
        let (ly, hy) = fix(lo.1, hi.1);
        Self {
            x0,
            y0,
            w,
            h,
            lo: (lx, ly),
            hi: (hx, hy),
        }
    }
    /// Equal axes: widen the shorter data range so one data unit is as long on both.
    fn equal(x0: f64, y0: f64, w: f64, h: f64, lo: (f64, f64), hi: (f64, f64)) -> Self {
        let (dx, dy) = ((hi.0 - lo.0).max(1e-9), (hi.1 - lo.1).max(1e-9));
        let k = (dx / w).max(dy / h) * 1.05;
        let (cx, cy) = (0.5 * (lo.0 + hi.0), 0.5 * (lo.1 + hi.1));
        Self::new(
            x0,
            y0,
            w,
            h,
            (cx - 0.5 * k * w, cy - 0.5 * k * h),
            (cx + 0.5 * k * w, cy + 0.5 * k * h),
        )
    }
    fn px(&self, x: f64) -> f64 {
        self.x0 + (x - self.lo.0) / (self.hi.0 - self.lo.0) * self.w
    }
    fn py(&self, y: f64) -> f64 {
        self.y0 + self.h - (y - self.lo.1) / (self.hi.1 - self.lo.1) * self.h
    }
    fn frame(&self, s: &mut String, title: &str, xlabel: &str, ylabel: &str) {
        let _ = writeln!(
            s,
            r#"<rect x="{:.2}" y="{:.2}" width="{:.2}" height="{:.2}" fill="none" stroke="dimgray" stroke-width="0.8"/>"#,
            self.x0, self.y0, self.w, self.h
        );
        let _ = writeln!(
            s,
            r#"<text x="{:.2}" y="{:.2}" font-size="13" text-anchor="middle">{}</text>"#,
            self.x0 + self.w / 2.0,
            self.y0 - 8.0,
            escape(title)
        );
        let _ = writeln!(
            s,
            r#"<text x="{:.2}" y="{:.2}" font-size="11" text-anchor="middle">{}</text>"#,
            self.x0 + self.w / 2.0,
            self.y0 + self.h + 32.0,
            escape(xlabel)
        );
        let _ = writeln!(
            s,
            r#"<text x="{:.2}" y="{:.2}" font-size="11" text-anchor="middle" transform="rotate(-90 {:.2} {:.2})">{}</text>"#,
            self.x0 - 40.0,
            self.y0 + self.h / 2.0,
            self.x0 - 40.0,
            self.y0 + self.h / 2.0,
            escape(ylabel)
        );
        for t in ticks(self.lo.0, self.hi.0) {
            let x = self.px(t);
            let _ = writeln!(
                s,
                r#"<line x1="{x:.2}" y1="{:.2}" x2="{x:.2}" y2="{:.2}" stroke="dimgray" stroke-width="0.6"/><text x="{x:.2}" y="{:.2}" font-size="9" text-anchor="middle">{}</text>"#,
                self.y0 + self.h,
                self.y0 + self.h + 4.0,
                self.y0 + self.h + 14.0,
                fmt_tick(t)
            );
        }
        for t in ticks(self.lo.1, self.hi.1) {
            let y = self.py(t);
            let _ = writeln!(
                s,
                r#"<line x1="{:.2}" y1="{y:.2}" x2="{:.2}" y2="{y:.2}" stroke="dimgray" stroke-width="0.6"/><text x="{:.2}" y="{:.2}" font-size="9" text-anchor="end">{}</text>"#,
                self.x0 - 4.0,
                self.x0,
                self.x0 - 6.0,
                y + 3.0,
                fmt_tick(t)
            );
        }
    }
    fn polyline(&self, s: &mut String, pts: &[(f64, f64)], color: &str, width: f64) {
        if pts.is_empty() {
            return;
        }
        let mut d = String::new();
        for (i, (x, y)) in pts.iter().enumerate() {
            let _ = write!(
                d,
                "{}{:.2},{:.2}",
                if i == 0 { "M" } else { " L" },
                self.px(*x),
                self.py(*y)
            );
        }
        let _ = writeln!(
            s,
            r#"<path d="{d}" fill="none" stroke="{color}" stroke-width="{width}" stroke-opacity="0.85"/>"#
        );
    }
    fn dots(&self, s: &mut String, pts: &[(f64, f64)], color: &str) {
        for (x, y) in pts {
            let _ = writeln!(
                s,
                r#"<circle cx="{:.2}" cy="{:.2}" r="1.6" fill="{color}" fill-opacity="0.7"/>"#,
                self.px(*x),
                self.py(*y)
            );
        }
    }
}

/// About 5 round tick values covering `[lo, hi]`.
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = hi - lo;
    if span.is_nan() || span <= 0.0 || !span.is_finite() {
        return vec![lo];
    }
    let step = crate::files::svg::nice_step(span / 5.0);
    let mut t = (lo / step).ceil() * step;
    let mut out = Vec::new();
    while t <= hi + 1e-9 * step && out.len() < 20 {
        out.push(if t.abs() < 1e-12 * step { 0.0 } else { t });
        t += step;
    }
    out
}

fn fmt_tick(t: f64) -> String {
    let a = t.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        format!("{t:.1e}")
    } else {
        let s = format!("{t:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

fn bounds(pts: impl Iterator<Item = (f64, f64)>) -> ((f64, f64), (f64, f64)) {
    let mut lo = (f64::INFINITY, f64::INFINITY);
    let mut hi = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    for (x, y) in pts {
        if x.is_finite() && y.is_finite() {
            lo = (lo.0.min(x), lo.1.min(y));
            hi = (hi.0.max(x), hi.1.max(y));
        }
    }
    if !lo.0.is_finite() {
        return ((0.0, 0.0), (1.0, 1.0));
    }
    (lo, hi)
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
    let (w, h) = (1260.0, 880.0);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif">"#
    );
    let _ = writeln!(s, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
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
    let _ = writeln!(
        s,
        r#"<text x="20" y="24" font-size="15">{}</text>"#,
        escape(&opts.title)
    );
    let _ = writeln!(
        s,
        r#"<text x="20" y="44" font-size="11">{}</text>"#,
        escape(&line(&report.train, "train"))
    );
    if let Some(v) = &report.val {
        let _ = writeln!(
            s,
            r#"<text x="20" y="60" font-size="11">{}</text>"#,
            escape(&line(v, "val"))
        );
    }
    if !report.failed_rows.is_empty() {
        let _ = writeln!(
            s,
            r#"<text x="20" y="92" font-size="11" fill="{MODEL}">{}</text>"#,
            escape(&format!(
                "{} rows left out, their solve failed even from cold: {}",
                report.failed_rows.len(),
                super::FailedRow::list(&report.failed_rows, 12)
            ))
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="20" y="76" font-size="11"><tspan fill="{TRAIN}">measured (train, dots)</tspan>  <tspan fill="{VAL}">measured (val, dots)</tspan>  <tspan fill="{MODEL}">model (line)</tspan>  (robot base frame, mm; errors are model - measured distances)</text>"#
    );
    // three orthographic views
    let views = [
        (0usize, 1usize, "x", "y"),
        (0, 2, "x", "z"),
        (1, 2, "y", "z"),
    ];
    for (v, (a, b, la, lb)) in views.iter().enumerate() {
        let all = report.rows.iter().flat_map(|r| {
            [
                (r.measured_base_m[*a] * 1e3, r.measured_base_m[*b] * 1e3),
                (r.model_base_m[*a] * 1e3, r.model_base_m[*b] * 1e3),
            ]
        });
        let (lo, hi) = bounds(all);
        let p = Panel::equal(70.0 + v as f64 * 410.0, 110.0, 340.0, 300.0, lo, hi);
        p.frame(
            &mut s,
            &format!("{la}{lb} view"),
            &format!("{la} (mm)"),
            &format!("{lb} (mm)"),
        );
        for (split, color) in [(Split::Train, TRAIN), (Split::Val, VAL)] {
            let rows: Vec<&RowResult> = report.rows.iter().filter(|r| r.split == split).collect();
            let meas: Vec<(f64, f64)> = rows
                .iter()
                .map(|r| (r.measured_base_m[*a] * 1e3, r.measured_base_m[*b] * 1e3))
                .collect();
            let model: Vec<(f64, f64)> = rows
                .iter()
                .map(|r| (r.model_base_m[*a] * 1e3, r.model_base_m[*b] * 1e3))
                .collect();
            p.dots(&mut s, &meas, color);
            p.polyline(&mut s, &model, MODEL, 0.8);
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
    let p = Panel::new(70.0, 520.0, 340.0, 300.0, (0.0, 0.0), (emax, cmax * 1.05));
    p.frame(&mut s, "error histogram", "error (mm)", "rows");
    for (k, color) in [(0usize, TRAIN), (1, VAL)] {
        for (b, c) in counts[k].iter().enumerate() {
            if *c == 0 {
                continue;
            }
            let x0 = p.px(b as f64 * emax / nb as f64);
            let x1 = p.px((b + 1) as f64 * emax / nb as f64);
            let y = p.py(*c as f64);
            let _ = writeln!(
                s,
                r#"<rect x="{x0:.2}" y="{y:.2}" width="{:.2}" height="{:.2}" fill="{color}" fill-opacity="0.45"/>"#,
                (x1 - x0).max(0.1),
                p.py(0.0) - y
            );
        }
    }
    // error over time (or row order)
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
    let (lo, hi) = bounds(over.iter().map(|(_, x, y)| (*x, *y)));
    let p = Panel::new(480.0, 520.0, 340.0, 300.0, (lo.0, 0.0), (hi.0, hi.1 * 1.05));
    p.frame(
        &mut s,
        "error over time",
        if has_t { "t (s)" } else { "row" },
        "error (mm)",
    );
    for (split, color) in [(Split::Train, TRAIN), (Split::Val, VAL)] {
        let pts: Vec<(f64, f64)> = over
            .iter()
            .filter(|(sp, _, _)| *sp == split)
            .map(|(_, x, y)| (*x, *y))
            .collect();
        p.dots(&mut s, &pts, color);
    }
    // error against an input
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
        let (lo, hi) = bounds(pts.iter().map(|(_, x, y)| (*x, *y)));
        let p = Panel::new(890.0, 520.0, 340.0, 300.0, (lo.0, 0.0), (hi.0, hi.1 * 1.05));
        let name = &report.input_names[k];
        p.frame(&mut s, &format!("error against {name}"), name, "error (mm)");
        for (split, color) in [(Split::Train, TRAIN), (Split::Val, VAL)] {
            let sel: Vec<(f64, f64)> = pts
                .iter()
                .filter(|(sp, _, _)| *sp == split)
                .map(|(_, x, y)| (*x, *y))
                .collect();
            p.dots(&mut s, &sel, color);
        }
    }
    s.push_str("</svg>\n");
    s
}
