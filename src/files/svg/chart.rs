//! 2-D chart panels: a pixel rectangle with a linear or logarithmic axis on each
//! side, drawn into a [`Doc`].

use super::{cross_path, nice_step, straight_path, tick_label, ticks, Doc};

/// One axis: the data range `[lo, hi]` mapped onto the panel side, linear or
/// logarithmic (base 10).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    /// Data value at the left (bottom) edge.
    pub lo: f64,
    /// Data value at the right (top) edge.
    pub hi: f64,
    /// Logarithmic scale.
    pub log: bool,
}

impl Axis {
    /// A linear axis over `[lo, hi]`; an empty range is widened to one unit about
    /// `lo`, a non-finite one becomes `[0, 1]`.
    pub fn linear(lo: f64, hi: f64) -> Self {
        let (lo, hi) = if !(lo.is_finite() && hi.is_finite()) {
            (0.0, 1.0)
        } else if hi > lo {
            (lo, hi)
        } else {
            (lo - 0.5, lo + 0.5)
        };
        Self { lo, hi, log: false }
    }

    /// A log axis over `[lo, hi]`; a range not inside `(0, inf)` becomes `[0.1, 10]`,
    /// an empty one ten times `lo`.
    pub fn log(lo: f64, hi: f64) -> Self {
        let (lo, hi) = if !(lo > 0.0 && lo.is_finite() && hi.is_finite()) {
            (0.1, 10.0)
        } else if hi > lo {
            (lo, hi)
        } else {
            (lo, 10.0 * lo)
        };
        Self { lo, hi, log: true }
    }

    /// Where `v` lies along the axis, 0 at `lo` and 1 at `hi` (NaN for `v <= 0` on a
    /// log axis).
    pub fn fraction(&self, v: f64) -> f64 {
        if self.log {
            (v.log10() - self.lo.log10()) / (self.hi.log10() - self.lo.log10())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }

    /// Tick values with their labels: three to seven ticks 1, 2 or 5 times a power of
    /// ten apart on a linear axis; on a
    /// log axis the powers of ten (every second or more when there are over ten), or
    /// 1, 2, 5 times them when the range holds fewer than two.
    pub fn ticks(&self) -> Vec<(f64, String)> {
        if !self.log {
            let step = nice_step((self.hi - self.lo) / 6.0);
            return ticks(self.lo, self.hi, step)
                .into_iter()
                .map(|t| (t, tick_label(t, step)))
                .collect();
        }
        let (a, b) = (self.lo.log10(), self.hi.log10());
        let decades = ticks(a, b, 1.0);
        let every = (decades.len() / 10 + 1) as f64;
        let mut out: Vec<f64> = ticks(a, b, every)
            .into_iter()
            .map(|k| 10f64.powi(k as i32))
            .collect();
        if decades.len() < 2 {
            out = (a.floor() as i32..=b.ceil() as i32)
                .flat_map(|k| [1.0, 2.0, 5.0].map(|m| m * 10f64.powi(k)))
                .filter(|v| *v >= self.lo * (1.0 - 1e-9) && *v <= self.hi * (1.0 + 1e-9))
                .collect();
        }
        out.into_iter()
            .map(|v| {
                let label = if (1e-3..1e5).contains(&v) {
                    let s = format!("{v:.3}");
                    s.trim_end_matches('0').trim_end_matches('.').to_string()
                } else {
                    format!("{v:.0e}")
                };
                (v, label)
            })
            .collect()
    }
}

/// The finite minimum and maximum of `values` (`None` when none is finite).
pub fn extent(values: impl IntoIterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((f64::min(lo, v), f64::max(hi, v))),
        })
}

/// Legend symbols.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Swatch {
    /// A short line.
    Line,
    /// A filled circle.
    Dot,
    /// A diagonal cross.
    Cross,
}

impl Swatch {
    /// A legend of `(symbol, colour, label)` rows, 18 px apart, the first row's centre
    /// line at `(x, y)`: symbol in `[x, x + 24]`, text from `x + 30`.
    pub fn list(doc: &mut Doc, x: f64, y: f64, entries: &[(Swatch, &str, &str)]) {
        for (i, (swatch, colour, label)) in entries.iter().enumerate() {
            let y = y + 18.0 * i as f64;
            match swatch {
                Self::Line => doc.line(
                    (x, y),
                    (x + 24.0, y),
                    &format!(r#"stroke="{colour}" stroke-width="2""#),
                ),
                Self::Dot => doc.circle(x + 12.0, y, 4.0, &format!(r#"fill="{colour}""#)),
                Self::Cross => doc.path(
                    &cross_path(x + 12.0, y, 5.0),
                    &format!(r#"fill="none" stroke="{colour}" stroke-width="1.5""#),
                ),
            }
            doc.text(x + 30.0, y + 4.0, label, "");
        }
    }
}

/// A chart panel: the data box `x` by `y` drawn onto the pixel rectangle with its
/// top-left corner at `(x0, y0)`, `w` wide and `h` high (`y` grows upward).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Panel {
    /// Left edge (px).
    pub x0: f64,
    /// Top edge (px).
    pub y0: f64,
    /// Width (px).
    pub w: f64,
    /// Height (px).
    pub h: f64,
    /// Horizontal axis.
    pub x: Axis,
    /// Vertical axis.
    pub y: Axis,
}

impl Panel {
    /// A panel over the rectangle `[x0, y0, w, h]` (px).
    pub fn new([x0, y0, w, h]: [f64; 4], x: Axis, y: Axis) -> Self {
        Self { x0, y0, w, h, x, y }
    }

    /// A panel with equal linear axes showing the box `lo`..`hi`: the shorter data
    /// range is widened so that one data unit is as long on both axes, plus 5 %.
    pub fn equal(rect: [f64; 4], lo: (f64, f64), hi: (f64, f64)) -> Self {
        let (w, h) = (rect[2], rect[3]);
        let (dx, dy) = ((hi.0 - lo.0).max(1e-9), (hi.1 - lo.1).max(1e-9));
        let k = (dx / w).max(dy / h) * 1.05;
        let (cx, cy) = (0.5 * (lo.0 + hi.0), 0.5 * (lo.1 + hi.1));
        Self::new(
            rect,
            Axis::linear(cx - 0.5 * k * w, cx + 0.5 * k * w),
            Axis::linear(cy - 0.5 * k * h, cy + 0.5 * k * h),
        )
    }

    /// Pixel column of data value `x`.
    pub fn px(&self, x: f64) -> f64 {
        self.x0 + self.x.fraction(x) * self.w
    }

    /// Pixel row of data value `y`.
    pub fn py(&self, y: f64) -> f64 {
        self.y0 + self.h - self.y.fraction(y) * self.h
    }

    fn at(&self, p: &(f64, f64)) -> (f64, f64) {
        (self.px(p.0), self.py(p.1))
    }

    /// Border, title above, axis labels, tick marks with their values.
    pub fn frame(&self, doc: &mut Doc, title: &str, xlabel: &str, ylabel: &str) {
        let (x0, y0, w, h) = (self.x0, self.y0, self.w, self.h);
        doc.rect(
            x0,
            y0,
            w,
            h,
            r#"fill="none" stroke="dimgray" stroke-width="0.8""#,
        );
        let mid = r#"font-size="13" text-anchor="middle""#;
        doc.text(x0 + w / 2.0, y0 - 8.0, title, mid);
        let label = r#"font-size="11" text-anchor="middle""#;
        doc.text(x0 + w / 2.0, y0 + h + 32.0, xlabel, label);
        doc.text_up(x0 - 44.0, y0 + h / 2.0, ylabel, label);
        let tick = r#"stroke="dimgray" stroke-width="0.6""#;
        for (t, text) in self.x.ticks() {
            let x = self.px(t);
            doc.line((x, y0 + h), (x, y0 + h + 4.0), tick);
            doc.text(
                x,
                y0 + h + 14.0,
                &text,
                r#"font-size="9" text-anchor="middle""#,
            );
        }
        for (t, text) in self.y.ticks() {
            let y = self.py(t);
            doc.line((x0 - 4.0, y), (x0, y), tick);
            doc.text(
                x0 - 6.0,
                y + 3.0,
                &text,
                r#"font-size="9" text-anchor="end""#,
            );
        }
    }

    /// Straight segments through the data points (non-finite points split the line).
    pub fn polyline(&self, doc: &mut Doc, pts: &[(f64, f64)], style: &str) {
        let p: Vec<(f64, f64)> = pts.iter().map(|p| self.at(p)).collect();
        doc.path(&straight_path(&p), &format!(r#"fill="none" {style}"#));
    }

    /// A filled circle of radius `r` (px) at each data point, in one group.
    pub fn dots(&self, doc: &mut Doc, pts: &[(f64, f64)], r: f64, style: &str) {
        doc.open(style);
        for p in pts {
            let (x, y) = self.at(p);
            doc.circle(x, y, r, "");
        }
        doc.close();
    }

    /// A diagonal cross of half-width `size` (px) at each finite data point.
    pub fn crosses(&self, doc: &mut Doc, pts: &[(f64, f64)], size: f64, style: &str) {
        for (x, y) in pts.iter().map(|p| self.at(p)) {
            if x.is_finite() && y.is_finite() {
                doc.path(&cross_path(x, y, size), &format!(r#"fill="none" {style}"#));
            }
        }
    }

    /// A bar from `y = 0` up to `top` between `x = a` and `x = b` (histograms).
    pub fn bar(&self, doc: &mut Doc, (a, b): (f64, f64), top: f64, style: &str) {
        let (x0, x1, y) = (self.px(a), self.px(b), self.py(top));
        doc.rect(x0, y, (x1 - x0).max(0.1), self.py(0.0) - y, style);
    }

    /// A boxed legend in the top-right (`right`) or top-left corner inside the panel.
    pub fn legend(&self, doc: &mut Doc, entries: &[(Swatch, &str, &str)], right: bool) {
        // text width estimated at 6.5 px a character of the 12 px font
        let chars = entries.iter().map(|e| e.2.chars().count()).max();
        let bw = 44.0 + 6.5 * chars.unwrap_or(0) as f64;
        let bh = 18.0 * entries.len() as f64 + 8.0;
        let x = if right {
            self.x0 + self.w - bw - 8.0
        } else {
            self.x0 + 8.0
        };
        let y = self.y0 + 8.0;
        doc.rect(
            x,
            y,
            bw,
            bh,
            r#"fill="white" fill-opacity="0.85" stroke="black" stroke-width="0.8""#,
        );
        Swatch::list(doc, x + 6.0, y + 13.0, entries);
    }
}
