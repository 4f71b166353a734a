//! Orthographic views of robot shapes: every coordinate keeps sub-pixel precision
//! and curves are cubic Bezier paths, so backbones stay smooth at any zoom.
//!
//! A [`Figure`] holds 3D items ([`Item`]: smooth curves, straight polylines, markers)
//! and a list of orthographic views (pairs of world axes, e.g. `xy`); every view
//! uses the **same scale** (equal axis units within and across views) and carries
//! tick labels in the figure's [`Unit`]. [`Figure::shape`] builds the standard picture
//! of a solved robot (backbone, guide disks, cables) in the `xy`, `xz` and `yz`
//! views; [`Figure::to_svg`] renders.

use super::{cross_path, nice_step, smooth_path, straight_path, tick_label, ticks, Doc, Swatch};
use crate::robot::Robot;
use crate::statics::Solution;
use nalgebra::{Matrix3, Vector3};

/// Length unit of the axes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    /// Millimetres.
    Mm,
    /// Centimetres.
    Cm,
}

impl Unit {
    fn per_m(self) -> f64 {
        match self {
            Self::Mm => 1e3,
            Self::Cm => 1e2,
        }
    }
    fn name(self) -> &'static str {
        match self {
            Self::Mm => "mm",
            Self::Cm => "cm",
        }
    }
}

/// Marker shapes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    /// Filled circle.
    Dot,
    /// Diagonal cross.
    Cross,
}

/// One thing to draw, in world coordinates (m).
#[derive(Clone, Debug, PartialEq)]
pub enum Item {
    /// A smooth curve through the points (Catmull-Rom as cubic Bezier segments).
    Curve {
        /// Points (m).
        points: Vec<Vector3<f64>>,
        /// CSS colour.
        colour: String,
        /// Stroke width (px).
        width: f64,
        /// Closed loop (disk outlines).
        closed: bool,
    },
    /// Straight segments through the points (cable chords).
    Polyline {
        /// Points (m).
        points: Vec<Vector3<f64>>,
        /// CSS colour.
        colour: String,
        /// Stroke width (px).
        width: f64,
    },
    /// A marker at a point.
    Marker {
        /// Position (m).
        at: Vector3<f64>,
        /// Shape.
        shape: Marker,
        /// CSS colour.
        colour: String,
        /// Size (px).
        size: f64,
    },
}

impl Item {
    fn points(&self) -> &[Vector3<f64>] {
        match self {
            Self::Curve { points, .. } | Self::Polyline { points, .. } => points,
            Self::Marker { at, .. } => std::slice::from_ref(at),
        }
    }
}

/// A legend entry.
#[derive(Clone, Debug, PartialEq)]
pub struct LegendEntry {
    /// Text.
    pub label: String,
    /// CSS colour.
    pub colour: String,
}

/// A figure of one or more orthographic views sharing one scale.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    /// Title line.
    pub title: String,
    /// Axis unit.
    pub unit: Unit,
    /// Views as pairs of world axes `(horizontal, vertical)`, 0 = x, 1 = y, 2 = z.
    pub views: Vec<(usize, usize)>,
    /// Items, drawn in order.
    pub items: Vec<Item>,
    /// Legend.
    pub legend: Vec<LegendEntry>,
    /// Largest panel side (px); the scale is the largest that fits every view.
    pub panel_px: f64,
}

/// The three standard views.
pub const THREE_VIEWS: [(usize, usize); 3] = [(0, 1), (0, 2), (1, 2)];
const AXIS: [&str; 3] = ["x", "y", "z"];
const MARGIN: f64 = 56.0;
const TITLE_H: f64 = 34.0;

/// Colour of item `k` of `n`, blue to red.
pub fn ramp(k: usize, n: usize) -> String {
    let t = if n > 1 {
        k as f64 / (n - 1) as f64
    } else {
        0.0
    };
    format!(
        "rgb({},{},{})",
        (40.0 + 200.0 * t).round(),
        60,
        (230.0 - 190.0 * t).round()
    )
}

impl Figure {
    /// An empty figure with these views.
    pub fn new(title: impl Into<String>, unit: Unit, views: &[(usize, usize)]) -> Self {
        Self {
            title: title.into(),
            unit,
            views: views.to_vec(),
            items: Vec::new(),
            legend: Vec::new(),
            panel_px: 420.0,
        }
    }

    /// Backbone (samples), guide disks (outlines of their diameter, from the robot
    /// spec) and cables (straight chords from the base-plate hole through each
    /// disk's hole, thesis 3.8.1) of a solution, in the three standard views.
    pub fn shape(title: impl Into<String>, robot: &Robot, sol: &Solution) -> Self {
        let mut f = Self::new(title, Unit::Mm, &THREE_VIEWS);
        f.add_solution(robot, sol, "rgb(20,20,20)");
        f
    }

    /// Add a solution's backbone (in `colour`), disks and cables.
    pub fn add_solution(&mut self, robot: &Robot, sol: &Solution, colour: &str) {
        let spec = robot.spec();
        for g in &sol.guides {
            let Some(gs) = spec.sections.get(g.section).and_then(|s| s.guides.as_ref()) else {
                continue;
            };
            let r = gs.diameter_m / 2.0;
            let rot: &Matrix3<f64> = &g.pose.rotation;
            let (e1, e2) = (rot.column(0).into_owned(), rot.column(1).into_owned());
            let points = (0..32)
                .map(|i| {
                    let a = i as f64 / 32.0 * std::f64::consts::TAU;
                    g.pose.position + (e1 * a.cos() + e2 * a.sin()) * r
                })
                .collect();
            self.items.push(Item::Curve {
                points,
                colour: "rgb(150,150,150)".into(),
                width: 1.0,
                closed: true,
            });
        }
        for (j, c) in robot.cables().iter().enumerate() {
            let mut points = vec![robot.base_position() + robot.base_rotation() * c.base_hole];
            for (&gi, hole) in c.route.iter().zip(&c.hole_local) {
                let Some(pose) = sol.guides.get(gi) else {
                    continue;
                };
                points.push(pose.pose.position + pose.pose.rotation * hole);
            }
            self.items.push(Item::Polyline {
                points,
                colour: format!("hsl({},70%,45%)", (j * 137) % 360),
                width: 1.0,
            });
        }
        self.items.push(Item::Curve {
            points: sol.samples.iter().map(|s| s.r).collect(),
            colour: colour.into(),
            width: 2.0,
            closed: false,
        });
        for t in &sol.section_tips {
            self.items.push(Item::Marker {
                at: t.position,
                shape: Marker::Dot,
                colour: colour.into(),
                size: 3.0,
            });
        }
    }

    /// Add a path (e.g. the estimated tip over a recording) and a legend entry.
    pub fn add_path(&mut self, points: Vec<Vector3<f64>>, colour: &str, label: &str) {
        if let Some(last) = points.last().copied() {
            self.items.push(Item::Marker {
                at: last,
                shape: Marker::Cross,
                colour: colour.into(),
                size: 5.0,
            });
        }
        self.items.push(Item::Curve {
            points,
            colour: colour.into(),
            width: 1.5,
            closed: false,
        });
        self.legend.push(LegendEntry {
            label: label.into(),
            colour: colour.into(),
        });
    }

    /// Bounds per view `(u0, u1, v0, v1)` in the figure unit, padded by 5 %.
    fn bounds(&self) -> Vec<[f64; 4]> {
        let k = self.unit.per_m();
        self.views
            .iter()
            .map(|&(a, b)| {
                let mut bb = [
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                ];
                for p in self.items.iter().flat_map(Item::points) {
                    let (u, v) = (p[a] * k, p[b] * k);
                    if u.is_finite() && v.is_finite() {
                        bb = [bb[0].min(u), bb[1].max(u), bb[2].min(v), bb[3].max(v)];
                    }
                }
                if !bb[0].is_finite() {
                    bb = [-1.0, 1.0, -1.0, 1.0];
                }
                // at least 1 unit wide, and 5 % padding
                let pad = |lo: f64, hi: f64| {
                    let c = 0.5 * (lo + hi);
                    let h = (0.5 * (hi - lo)).max(0.5) * 1.05;
                    (c - h, c + h)
                };
                let (u0, u1) = pad(bb[0], bb[1]);
                let (v0, v1) = pad(bb[2], bb[3]);
                [u0, u1, v0, v1]
            })
            .collect()
    }

    /// Render to SVG text.
    pub fn to_svg(&self) -> String {
        let bounds = self.bounds();
        // one scale (px per unit) for every view: the largest that fits each panel
        let span = bounds
            .iter()
            .map(|b| (b[1] - b[0]).max(b[3] - b[2]))
            .fold(0.0, f64::max);
        let scale = self.panel_px / span;
        let sizes: Vec<(f64, f64)> = bounds
            .iter()
            .map(|b| ((b[1] - b[0]) * scale, (b[3] - b[2]) * scale))
            .collect();
        let height = sizes.iter().map(|s| s.1).fold(0.0, f64::max) + 2.0 * MARGIN + TITLE_H;
        let width: f64 = sizes
            .iter()
            .map(|s| s.0 + 2.0 * MARGIN)
            .sum::<f64>()
            .max(360.0);
        let legend_h = 18.0 * self.legend.len() as f64;
        let mut doc = Doc::new(width, height + legend_h, 12.0);
        doc.text(
            width / 2.0,
            22.0,
            &self.title,
            r#"font-size="16" text-anchor="middle""#,
        );
        let mut x_off = 0.0;
        let k = self.unit.per_m();
        for ((&(a, b), bb), (w, h)) in self.views.iter().zip(&bounds).zip(&sizes) {
            let (ox, oy) = (x_off + MARGIN, TITLE_H + MARGIN);
            // world (unit) -> pixel: u to the right, v up
            let px = |p: &Vector3<f64>| -> (f64, f64) {
                (
                    ox + (p[a] * k - bb[0]) * scale,
                    oy + (bb[3] - p[b] * k) * scale,
                )
            };
            let name = format!("{}{}", AXIS[a], AXIS[b]);
            doc.open(&format!(r#"id="view-{name}" class="view""#));
            doc.rect(
                ox,
                oy,
                *w,
                *h,
                r#"fill="none" stroke="black" stroke-width="0.8""#,
            );
            self.ticks(&mut doc, bb, scale, (ox, oy, *w, *h), (AXIS[a], AXIS[b]));
            doc.text(
                ox + w / 2.0,
                oy - 8.0,
                &format!("{name} view"),
                r#"text-anchor="middle" font-size="13""#,
            );
            for item in &self.items {
                draw(&mut doc, item, &px);
            }
            doc.close();
            x_off += w + 2.0 * MARGIN;
        }
        let entries: Vec<(Swatch, &str, &str)> = self
            .legend
            .iter()
            .map(|l| (Swatch::Line, l.colour.as_str(), l.label.as_str()))
            .collect();
        Swatch::list(&mut doc, MARGIN, height, &entries);
        doc.finish()
    }

    /// Tick marks and labels on the left and bottom edges of a panel: one step for
    /// both axes (equal scales).
    fn ticks(
        &self,
        doc: &mut Doc,
        bb: &[f64; 4],
        scale: f64,
        (ox, oy, w, h): (f64, f64, f64, f64),
        (an, bn): (&str, &str),
    ) {
        let step = nice_step((bb[1] - bb[0]).max(bb[3] - bb[2]) / 5.0);
        let unit = self.unit.name();
        for u in ticks(bb[0], bb[1], step) {
            let x = ox + (u - bb[0]) * scale;
            doc.line((x, oy + h), (x, oy + h + 4.0), r#"stroke="black""#);
            doc.text(
                x,
                oy + h + 17.0,
                &tick_label(u, step),
                r#"text-anchor="middle""#,
            );
        }
        for v in ticks(bb[2], bb[3], step) {
            let y = oy + (bb[3] - v) * scale;
            doc.line((ox - 4.0, y), (ox, y), r#"stroke="black""#);
            doc.text(
                ox - 6.0,
                y + 4.0,
                &tick_label(v, step),
                r#"text-anchor="end""#,
            );
        }
        doc.text(
            ox + w / 2.0,
            oy + h + 34.0,
            &format!("{an} ({unit})"),
            r#"text-anchor="middle""#,
        );
        doc.text_up(
            ox - 40.0,
            oy + h / 2.0,
            &format!("{bn} ({unit})"),
            r#"text-anchor="middle""#,
        );
    }
}

/// One item in one view.
fn draw(doc: &mut Doc, item: &Item, px: &impl Fn(&Vector3<f64>) -> (f64, f64)) {
    match item {
        Item::Curve {
            points,
            colour,
            width,
            closed,
        } => {
            let p: Vec<(f64, f64)> = points.iter().map(px).collect();
            doc.path(
                &smooth_path(&p, *closed),
                &format!(
                    r#"fill="none" stroke="{colour}" stroke-width="{width}" stroke-linejoin="round""#
                ),
            );
        }
        Item::Polyline {
            points,
            colour,
            width,
        } => {
            let p: Vec<(f64, f64)> = points.iter().map(px).collect();
            doc.path(
                &straight_path(&p),
                &format!(r#"fill="none" stroke="{colour}" stroke-width="{width}""#),
            );
        }
        Item::Marker {
            at,
            shape,
            colour,
            size,
        } => {
            let (x, y) = px(at);
            match shape {
                Marker::Dot => doc.circle(x, y, *size, &format!(r#"fill="{colour}""#)),
                Marker::Cross => doc.path(
                    &cross_path(x, y, *size),
                    &format!(r#"stroke="{colour}" stroke-width="1.5""#),
                ),
            }
        }
    }
}
