//! SVG figures of `validate` (plotters, SVG backend: text needs no system fonts).

use cablesense::validation::Comparison;
use plotters::prelude::*;
use std::path::Path;

/// Colour of row `k` of `n`: from blue (light load) to red (heavy load).
fn row_colour(k: usize, n: usize) -> RGBColor {
    let t = if n > 1 {
        k as f64 / (n - 1) as f64
    } else {
        0.0
    };
    RGBColor((40.0 + 200.0 * t) as u8, 60, (230.0 - 190.0 * t) as u8)
}

/// Predicted backbones (x, y in cm) of every row over the observed and the
/// thesis-predicted tip points.
pub fn backbones(c: &Comparison, title: &str, path: &Path) -> anyhow::Result<()> {
    let to_cm = |v: f64| v * 100.0;
    let mut xs = vec![0.0f64, 40.0];
    let mut ys = vec![0.0f64, 1.0];
    for sol in &c.solutions {
        for s in &sol.samples {
            xs.push(to_cm(s.r.x));
            ys.push(to_cm(s.r.y));
        }
    }
    for row in &c.rows {
        for p in &row.points {
            xs.extend([to_cm(p.observed[0]), to_cm(p.thesis[0])]);
            ys.extend([to_cm(p.observed[1]), to_cm(p.thesis[1])]);
        }
    }
    let (x0, x1) = bounds(&xs);
    let (y0, y1) = bounds(&ys);
    // equal scales on both axes: the shape is not distorted
    let width = 900u32;
    let plot_w = (width - 90) as f64;
    let height = ((plot_w * (y1 - y0) / (x1 - x0)) as u32 + 110).clamp(260, 1000);
    let root = SVGBackend::new(path, (width, height)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(46)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc("x (cm)")
        .y_desc("y (cm)")
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    let n = c.solutions.len();
    for (k, sol) in c.solutions.iter().enumerate() {
        let colour = row_colour(k, n);
        let line = chart.draw_series(LineSeries::new(
            sol.samples.iter().map(|s| (to_cm(s.r.x), to_cm(s.r.y))),
            colour.stroke_width(2),
        ))?;
        if k == 0 {
            line.label("ours (backbone)").legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        }
    }
    for (k, row) in c.rows.iter().enumerate() {
        let colour = row_colour(k, n);
        for p in &row.points {
            let obs = (to_cm(p.observed[0]), to_cm(p.observed[1]));
            let th = (to_cm(p.thesis[0]), to_cm(p.thesis[1]));
            let first = k == 0 && p.observed == row.points[0].observed;
            let a = chart.draw_series(std::iter::once(Circle::new(obs, 5, colour.filled())))?;
            if first {
                a.label("observed tip")
                    .legend(move |(x, y)| Circle::new((x + 10, y), 5, colour.filled()));
            }
            let b = chart.draw_series(std::iter::once(Cross::new(th, 6, BLACK.stroke_width(1))))?;
            if first {
                b.label("thesis predicted")
                    .legend(|(x, y)| Cross::new((x + 10, y), 6, BLACK.stroke_width(1)));
            }
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
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
