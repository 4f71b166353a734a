//! The one plot stack: every SVG figure the library and the CLI write (shape views,
//! calibration report, validation tables, Pareto charts, stability map, workspace) is
//! built from this module.
//!
//! - [`Doc`]: an SVG document with text escaping; every coordinate is written to
//!   1/100 px.
//! - [`Panel`] and [`Axis`]: a 2-D chart panel with linear or log axes, ticks, axis
//!   labels, lines, markers, histogram bars and a legend.
//! - [`Figure`]: equal-scale orthographic views of 3-D items (robot shapes, tip
//!   paths) with smooth Bezier backbones.
//! - One [`nice_step`], [`ticks`] and [`tick_label`] for every axis.
//!
//! The writer is our own rather than plotters because plotters cannot draw what the
//! shape figures need: its backend coordinates are whole pixels
//! (`pub type BackendCoord = (i32, i32);` in plotters-backend 0.3.7) and its SVG
//! backend writes a path as a `<polyline points=...>` of those integers, with no
//! curve element, so a backbone a few millimetres across becomes a staircase
//! (docs/plots.md quotes the code).

mod chart;
mod views;

pub use chart::{extent, Axis, Panel, Swatch};
pub use views::{ramp, Figure, Item, LegendEntry, Marker, Unit, THREE_VIEWS};

use std::fmt::Write as _;

/// An SVG document being written: a white page, drawing calls in paint order,
/// [`Doc::finish`] for the text. `style` arguments are further SVG attributes
/// written as they are (e.g. `fill="red" stroke-width="2"`).
#[derive(Clone, Debug)]
pub struct Doc {
    s: String,
}

impl Doc {
    /// A `width` x `height` px page with a white background; text in sans-serif at
    /// `font_size` px unless a call says otherwise.
    pub fn new(width: f64, height: f64, font_size: f64) -> Self {
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="{font_size}">"#
        );
        s.push_str("<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n");
        Self { s }
    }

    /// `text` (escaped) with its baseline starting at `(x, y)`; nothing when empty.
    pub fn text(&mut self, x: f64, y: f64, text: &str, style: &str) {
        if text.is_empty() {
            return;
        }
        let _ = writeln!(
            self.s,
            r#"<text x="{x:.2}" y="{y:.2}" {style}>{}</text>"#,
            escape(text)
        );
    }

    /// `text` at `(x, y)` turned 90 degrees counter-clockwise (a vertical axis label).
    pub fn text_up(&mut self, x: f64, y: f64, text: &str, style: &str) {
        let style = format!(r#"{style} transform="rotate(-90 {x:.2} {y:.2})""#);
        self.text(x, y, text, &style);
    }

    /// A straight line from `a` to `b`.
    pub fn line(&mut self, a: (f64, f64), b: (f64, f64), style: &str) {
        let _ = writeln!(
            self.s,
            r#"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" {style}/>"#,
            a.0, a.1, b.0, b.1
        );
    }

    /// A rectangle with its top-left corner at `(x, y)`.
    pub fn rect(&mut self, x: f64, y: f64, w: f64, h: f64, style: &str) {
        let _ = writeln!(
            self.s,
            r#"<rect x="{x:.2}" y="{y:.2}" width="{w:.2}" height="{h:.2}" {style}/>"#
        );
    }

    /// A circle; skipped when the centre is not finite.
    pub fn circle(&mut self, x: f64, y: f64, r: f64, style: &str) {
        if x.is_finite() && y.is_finite() {
            let _ = writeln!(
                self.s,
                r#"<circle cx="{x:.2}" cy="{y:.2}" r="{r}" {style}/>"#
            );
        }
    }

    /// A path with data `d` (see [`smooth_path`], [`straight_path`]); skipped when empty.
    pub fn path(&mut self, d: &str, style: &str) {
        if !d.is_empty() {
            let _ = writeln!(self.s, r#"<path d="{d}" {style}/>"#);
        }
    }

    /// Open a group `<g attrs>`; close it with [`Doc::close`].
    pub fn open(&mut self, attrs: &str) {
        let _ = writeln!(self.s, "<g {attrs}>");
    }

    /// Close the group last opened.
    pub fn close(&mut self) {
        self.s.push_str("</g>\n");
    }

    /// Markup written as it is (e.g. a `<text>` of coloured `<tspan>`s); the caller
    /// escapes its text.
    pub fn raw(&mut self, markup: &str) {
        self.s.push_str(markup);
        self.s.push('\n');
    }

    /// The SVG text.
    pub fn finish(mut self) -> String {
        self.s.push_str("</svg>\n");
        self.s
    }
}

/// `t` as SVG/XML text (`&`, `<`, `>` escaped).
pub fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// 1, 2 or 5 times a power of ten, at least `raw`: the tick spacing of every linear
/// axis.
pub fn nice_step(raw: f64) -> f64 {
    let p = 10f64.powf(raw.max(1e-12).log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * p)
}

/// The multiples of `step` in `[lo, hi]` (at most 100; values within 1e-9 step of
/// zero are written as zero).
pub fn ticks(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite() && step.is_finite() && step > 0.0) {
        return Vec::new();
    }
    let k0 = (lo / step).ceil();
    (0..100)
        .map(|i| (k0 + i as f64) * step)
        .take_while(|t| *t <= hi + 1e-9 * step)
        .map(|t| if t.abs() < 1e-9 * step { 0.0 } else { t })
        .collect()
}

/// A tick value as text: as many decimals as `step` needs, or exponent form for
/// magnitudes below 1e-3 or from 1e5 up.
pub fn tick_label(v: f64, step: f64) -> String {
    if v != 0.0 && !(1e-3..1e5).contains(&v.abs()) {
        return format!("{v:.1e}");
    }
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()).min(6.0) as usize
    };
    format!("{v:.decimals$}")
}

/// SVG path data of straight segments through `p` (1/100 px); non-finite points split
/// the line.
pub fn straight_path(p: &[(f64, f64)]) -> String {
    let mut d = String::new();
    for run in p.split(|q| !(q.0.is_finite() && q.1.is_finite())) {
        for (i, q) in run.iter().enumerate() {
            let _ = write!(
                d,
                "{}{:.2},{:.2} ",
                if i == 0 { 'M' } else { 'L' },
                q.0,
                q.1
            );
        }
    }
    d.trim_end().to_string()
}

/// SVG path data of a diagonal cross of half-width `size` centred at `(x, y)`.
pub fn cross_path(x: f64, y: f64, size: f64) -> String {
    format!(
        "M{:.2},{:.2} L{:.2},{:.2} M{:.2},{:.2} L{:.2},{:.2}",
        x - size,
        y - size,
        x + size,
        y + size,
        x - size,
        y + size,
        x + size,
        y - size
    )
}

/// SVG path data of a Catmull-Rom spline through `p` as cubic Bezier segments
/// (control points `p_i + (p_{i+1} - p_{i-1}) / 6`), coordinates to 1/100 px.
/// Non-finite points split the curve.
pub fn smooth_path(p: &[(f64, f64)], closed: bool) -> String {
    let mut d = String::new();
    let finite = |q: &(f64, f64)| q.0.is_finite() && q.1.is_finite();
    for run in p.split(|q| !finite(q)) {
        let n = run.len();
        if n < 2 {
            continue;
        }
        let at = |i: isize| -> (f64, f64) {
            if closed {
                run[i.rem_euclid(n as isize) as usize]
            } else {
                run[i.clamp(0, n as isize - 1) as usize]
            }
        };
        let _ = write!(d, "M{:.2},{:.2}", run[0].0, run[0].1);
        let segments = if closed { n } else { n - 1 };
        for i in 0..segments as isize {
            let (p0, p1, p2, p3) = (at(i - 1), at(i), at(i + 1), at(i + 2));
            let c1 = (p1.0 + (p2.0 - p0.0) / 6.0, p1.1 + (p2.1 - p0.1) / 6.0);
            let c2 = (p2.0 - (p3.0 - p1.0) / 6.0, p2.1 - (p3.1 - p1.1) / 6.0);
            let _ = write!(
                d,
                " C{:.2},{:.2} {:.2},{:.2} {:.2},{:.2}",
                c1.0, c1.1, c2.0, c2.1, p2.0, p2.1
            );
        }
        if closed {
            d.push_str(" Z");
        }
        d.push(' ');
    }
    d.trim_end().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Bezier path passes through every point and keeps sub-pixel precision.
    #[test]
    fn smooth_path_interpolates() {
        let p = [(0.0, 0.0), (10.25, 3.5), (20.0, 0.1)];
        let d = smooth_path(&p, false);
        assert!(d.starts_with("M0.00,0.00 C"), "{d}");
        assert!(d.contains(" 10.25,3.50 C"), "{d}");
        assert!(d.ends_with(" 20.00,0.10"), "{d}");
        assert_eq!(smooth_path(&[(1.0, 1.0)], false), "");
    }

    #[test]
    fn nice_steps() {
        assert_eq!(nice_step(3.0), 5.0);
        assert_eq!(nice_step(0.11), 0.2);
        assert_eq!(nice_step(20.0), 20.0);
    }
}
