//! `cablesense stability [SCENE]`: argument parsing, terminal summary and heat map of
//! [`cablesense::experiments::stability`] (where each method stops converging; on a
//! tendon-driven robot also along its readings).

use crate::pareto::on_bar;
use crate::progress;
use anyhow::Context;
use cablesense::experiments::stability::{
    self, Outcome, RegionCell, StabilityMap, StabilitySettings,
};
use cablesense::experiments::write;
use cablesense::files::svg::Doc;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// Arguments of `stability`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene file. Default: the shipped track demo (thesis-like rod, 3 cables). A scene
    /// with displacement-driven tendons (e.g. `demo:scenes/tdcr_two_segment.toml`) is
    /// mapped on its tension form and along its readings.
    #[arg(default_value = cablesense::files::demo::TRACK_SCENE)]
    scene: PathBuf,
    /// Output directory for stability.csv and stability.svg.
    #[arg(long, default_value = "out/stability")]
    out: PathBuf,
    /// No progress bar or status lines on stderr.
    #[arg(long, short)]
    quiet: bool,
}

/// Run `stability`.
pub fn run(a: Args) -> anyhow::Result<ExitCode> {
    let scene = cablesense::files::demo::DataRef::parse(&a.scene)?.scene()?;
    let robot = scene.build_robot()?;
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let t_all = Instant::now();
    let settings = StabilitySettings::default();
    let pb = progress::bar(stability::step_count(&robot, &settings) as u64, a.quiet);
    let map = stability::run(&scene, &settings, &mut on_bar(&pb, a.quiet))?;
    pb.finish_and_clear();
    let csv = a.out.join("stability.csv");
    std::fs::File::create(&csv)
        .map(std::io::BufWriter::new)
        .and_then(|f| write::stability_csv(f, &map.points))
        .with_context(|| format!("writing {}", csv.display()))?;
    let svg = a.out.join("stability.svg");
    heat_map(&map, &svg).with_context(|| format!("writing {}", svg.display()))?;
    summary(&map);
    println!(
        "\nwrote {} and {} ({:.1} s)",
        csv.display(),
        svg.display(),
        t_all.elapsed().as_secs_f64()
    );
    Ok(ExitCode::SUCCESS)
}

/// Per row (method, start) and direction: the largest magnitude up to which every
/// point is `Ok`, and what happens beyond.
fn summary(map: &StabilityMap) {
    println!("\nlargest magnitude with every point converged to the reference branch (PL^2/EI, TrL/EI for tension, rad per section for readings):");
    print!("  {:<36} {:<13}", "method", "start");
    for d in &map.directions {
        print!(" {:>9}", d.short());
    }
    println!();
    for ((_, m, s), cells) in stability::region(map) {
        print!("  {:<36} {:<13}", m, s.as_str());
        for c in cells {
            let text = match c {
                RegionCell::Missing => "-".to_string(),
                RegionCell::None => "none".to_string(),
                RegionCell::UpTo(v) => format!("{v}"),
                RegionCell::All(v) => format!("{v}+"),
            };
            print!(" {text:>9}");
        }
        println!();
    }
}

fn colour(o: Outcome) -> &'static str {
    match o {
        Outcome::Ok => "rgb(90,180,90)",
        Outcome::Far => "rgb(240,170,40)",
        Outcome::Failed => "rgb(210,50,50)",
    }
}

/// One panel per direction: rows = (kind, method, start), columns = magnitude; cell
/// colour = outcome (green: converged to the reference branch, orange: converged
/// elsewhere, red: failed), text = iterations.
fn heat_map(map: &StabilityMap, path: &Path) -> anyhow::Result<()> {
    let (dirs, points) = (&map.directions, &map.points);
    let mut rows = Vec::new();
    for p in points {
        let key = (p.kind, p.method.clone(), p.start);
        if !rows.contains(&key) {
            rows.push(key);
        }
    }
    let (cell_w, cell_h, label_w, head_h) = (30.0, 16.0, 330.0, 48.0);
    let panel_w = 13.0 * cell_w + 20.0;
    let width = label_w + panel_w * dirs.len() as f64 + 20.0;
    let height = head_h + cell_h * rows.len() as f64 + 60.0;
    let mut doc = Doc::new(width, height, 8.9);
    // text is placed by its top edge: the baseline 0.76 font sizes lower
    let (font, small) = ((r#""#, 6.8), (r#"font-size="7.3""#, 5.5));
    doc.text(
        10.0,
        6.0 + font.1,
        "stability map: green = converged to the reference branch, orange = converged elsewhere (>5% L off; CC: model error), red = failed; number = iterations",
        font.0,
    );
    for (r, (kind, m, s)) in rows.iter().enumerate() {
        let y = head_h + r as f64 * cell_h;
        let label = format!("{}: {m} [{}]", kind.as_str(), s.as_str());
        doc.text(6.0, y + 3.0 + small.1, &label, small.0);
    }
    for (di, d) in dirs.iter().enumerate() {
        let x0 = label_w + di as f64 * panel_w;
        doc.text(x0, 22.0 + font.1, d.name(), font.0);
        for (c, g) in d.grid().iter().enumerate() {
            let x = x0 + c as f64 * cell_w + 2.0;
            doc.text(x, 36.0 + small.1, &format!("{g}"), small.0);
        }
        for (r, (kind, m, s)) in rows.iter().enumerate() {
            let y = head_h + r as f64 * cell_h;
            for p in points
                .iter()
                .filter(|p| p.kind == *kind && &p.method == m && p.start == *s && p.dir == *d)
            {
                let c = d.grid().iter().position(|g| *g == p.magnitude).unwrap_or(0) as f64;
                let x = x0 + c * cell_w;
                let fill = format!(r#"fill="{}""#, colour(p.outcome));
                doc.rect(x, y, cell_w - 1.0, cell_h - 1.0, &fill);
                let iterations = format!("{}", p.iterations);
                doc.text(x + 3.0, y + 3.0 + small.1, &iterations, small.0);
            }
        }
    }
    std::fs::write(path, doc.finish())?;
    Ok(())
}
