//! SVG figures of `validate` (plotters, SVG backend: text needs no system fonts).

use cablesense::validation::Comparison;
use plotters::prelude::*;
use std::path::Path;

/// Predicted backbones (x, y in cm) of every row over the observed and the
/// thesis-predicted tip points: one `xy` view with equal axis scales, smooth paths
/// with sub-pixel coordinates (`cablesense::files::svg`).
pub fn backbones(c: &Comparison, title: &str, path: &Path) -> anyhow::Result<()> {
    use cablesense::files::svg::{ramp, Figure, Item, LegendEntry, Marker, Unit};
    use cablesense::nalgebra::Vector3;
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
    let root = SVGBackend::new(path, (700, 460)).into_drawing_area();
    root.fill(&WHITE)?;
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
    let (m0, m1) = bounds(&mass);
    let (d0, d1) = bounds(&vals);
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(52)
        .build_cartesian_2d(m0..m1, d0..d1)?;
    chart
        .configure_mesh()
        .x_desc("tip mass (g)")
        .y_desc("cable length change (cm)")
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    let k = 0; // one tracked cable in the thesis tables
    let series = |f: fn(&cablesense::validation::LengthRow) -> f64| -> Vec<(f64, f64)> {
        c.rows
            .iter()
            .zip(&mass)
            .map(|(r, m)| (*m, f(&r.lengths[k]) * 100.0))
            .collect()
    };
    let ours = series(|l| l.ours_delta);
    let thesis = series(|l| l.thesis_delta);
    let obs = series(|l| l.observed_delta);
    let red = RGBColor(200, 40, 40);
    chart
        .draw_series(LineSeries::new(ours.clone(), red.stroke_width(2)))?
        .label("ours")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], red.stroke_width(2)));
    chart.draw_series(ours.iter().map(|p| Circle::new(*p, 3, red.filled())))?;
    chart
        .draw_series(
            thesis
                .iter()
                .map(|p| Cross::new(*p, 6, BLACK.stroke_width(1))),
        )?
        .label("thesis predicted")
        .legend(|(x, y)| Cross::new((x + 10, y), 6, BLACK.stroke_width(1)));
    let blue = RGBColor(40, 60, 230);
    chart
        .draw_series(obs.iter().map(|p| Circle::new(*p, 5, blue.filled())))?
        .label("observed")
        .legend(move |(x, y)| Circle::new((x + 10, y), 5, blue.filled()));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

fn bounds(v: &[f64]) -> (f64, f64) {
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let pad = 0.05 * (hi - lo).max(1e-9);
    (lo - pad, hi + pad)
}
