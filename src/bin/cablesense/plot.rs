//! SVG figures of `validate` (`cablesense::files::svg`).

use cablesense::files::svg::{extent, ramp, Axis, Doc, Figure, Item, LegendEntry, Marker, Panel};
use cablesense::files::svg::{Swatch, Unit};
use cablesense::nalgebra::Vector3;
use cablesense::validation::Comparison;
use std::path::Path;

/// Predicted backbones (x, y in cm) of every row over the observed and the
/// thesis-predicted tip points: one `xy` view with equal axis scales, smooth paths
/// with sub-pixel coordinates (`cablesense::files::svg`).
pub fn backbones(c: &Comparison, title: &str, path: &Path) -> anyhow::Result<()> {
    let mut fig = Figure::new(title, Unit::Cm, &[(0, 1)]);
    fig.panel_px = 820.0;
    let n = c.solutions.len();
    for (k, sol) in c.solutions.iter().enumerate() {
        fig.items.push(Item::Curve {
            points: sol.samples.iter().map(|s| s.r).collect(),
            colour: ramp(k, n),
            width: 2.0,
            closed: false,
        });
    }
    for (k, row) in c.rows.iter().enumerate() {
        for p in &row.points {
            fig.items.push(Item::Marker {
                at: Vector3::new(p.observed[0], p.observed[1], 0.0),
                shape: Marker::Dot,
                colour: ramp(k, n),
                size: 4.0,
            });
            fig.items.push(Item::Marker {
                at: Vector3::new(p.thesis[0], p.thesis[1], 0.0),
                shape: Marker::Cross,
                colour: "black".into(),
                size: 5.0,
            });
        }
    }
    fig.legend = vec![
        LegendEntry {
            label: "ours (backbone), light to heavy load: blue to red".into(),
            colour: ramp(0, 2),
        },
        LegendEntry {
            label: "observed tip (dots), thesis predicted (black crosses)".into(),
            colour: "black".into(),
        },
    ];
    std::fs::write(path, fig.to_svg())?;
    Ok(())
}

/// Cable length change against tip mass: observed, thesis model, ours.
pub fn length_changes(c: &Comparison, title: &str, path: &Path) -> anyhow::Result<()> {
    let mass: Vec<f64> = c
        .rows
        .iter()
        .map(|r| r.loads.first().copied().unwrap_or(0.0) * 1e3)
        .collect();
    let mut vals = vec![0.0];
    for r in &c.rows {
        for l in &r.lengths {
            vals.extend([
                l.observed_delta * 100.0,
                l.thesis_delta * 100.0,
                l.ours_delta * 100.0,
            ]);
        }
    }
    let mut doc = Doc::new(700.0, 460.0, 12.0);
    doc.text(350.0, 26.0, title, r#"font-size="15" text-anchor="middle""#);
    let panel = Panel::new([76.0, 48.0, 600.0, 350.0], padded(&mass), padded(&vals));
    panel.frame(&mut doc, "", "tip mass (g)", "cable length change (cm)");
    let k = 0; // one tracked cable in the thesis tables
    let series = |f: fn(&cablesense::validation::LengthRow) -> f64| -> Vec<(f64, f64)> {
        c.rows
            .iter()
            .zip(&mass)
            .map(|(r, m)| (*m, f(&r.lengths[k]) * 100.0))
            .collect()
    };
    let (red, blue) = ("rgb(200,40,40)", "rgb(40,60,230)");
    let ours = series(|l| l.ours_delta);
    panel.polyline(
        &mut doc,
        &ours,
        &format!(r#"stroke="{red}" stroke-width="2""#),
    );
    panel.dots(&mut doc, &ours, 3.0, &format!(r#"fill="{red}""#));
    let thesis = series(|l| l.thesis_delta);
    panel.crosses(&mut doc, &thesis, 6.0, r#"stroke="black" stroke-width="1""#);
    let obs = series(|l| l.observed_delta);
    panel.dots(&mut doc, &obs, 5.0, &format!(r#"fill="{blue}""#));
    let legend = [
        (Swatch::Line, red, "ours"),
        (Swatch::Cross, "black", "thesis predicted"),
        (Swatch::Dot, blue, "observed"),
    ];
    panel.legend(&mut doc, &legend, false);
    std::fs::write(path, doc.finish())?;
    Ok(())
}

/// A linear axis over the values, 5 % wider on each side.
fn padded(v: &[f64]) -> Axis {
    let (lo, hi) = extent(v.iter().copied()).unwrap_or((0.0, 1.0));
    let pad = 0.05 * (hi - lo).max(1e-9);
    Axis::linear(lo - pad, hi + pad)
}
