//! `cablesense pareto [SCENES...]`: argument parsing, terminal table and charts of
//! [`cablesense::experiments::pareto`]: every rung and setting of the model ladder on a
//! sweep of loads (of readings on a tendon-driven robot): time per forward solve and per estimator tick against the error
//! (tip position, cable length) from the reference (full Cosserat, accurate guide
//! mass, adaptive tol 1e-12), and against the thesis's observed tip points where the
//! scene models a thesis table. CSV + one SVG chart per scene (log-log, one marker per
//! setting, the Pareto front drawn) + a terminal table. The estimator runs on every
//! rung (the curvature rungs through their exact fixed-point sensitivities), so each
//! setting also gets its time per estimator tick and its estimate error.

use crate::progress;
use anyhow::Context;
use cablesense::experiments::pareto::{self, ParetoRow, ParetoScene, ParetoSettings};
use cablesense::experiments::{front, write, Progress};
use cablesense::files::demo::DataRef;
use cablesense::files::svg::{extent, Axis, Doc, Panel, Swatch};
use indicatif::ProgressBar;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// Arguments of `pareto`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene files (paths or `demo:NAME`). Default: the shipped scenes, `demo:scenes/*.toml`
    /// and `demo:thesis/*.toml` (embedded in the binary).
    scenes: Vec<PathBuf>,
    /// Output directory for pareto.csv and the SVG charts.
    #[arg(long, default_value = "out/pareto")]
    out: PathBuf,
    /// Timed repetitions per rung and load (median reported); at least 1.
    #[arg(long, default_value_t = 7, value_parser = parse_reps)]
    reps: usize,
    /// Skip the estimator ticks (forward solves only).
    #[arg(long)]
    no_estimator: bool,
    /// No progress bar or status lines on stderr.
    #[arg(long, short)]
    quiet: bool,
}

/// `--reps`: a whole number of at least 1 (the median of no timed repetition is
/// undefined, so 0 is refused rather than raised to 1).
fn parse_reps(s: &str) -> Result<usize, String> {
    let n: usize = s
        .trim()
        .parse()
        .map_err(|e| format!("`{s}` is not a whole number of repetitions ({e})"))?;
    if n == 0 {
        return Err(
            "0 repetitions: at least 1 is needed (the median of no timed solve is undefined)"
                .into(),
        );
    }
    Ok(n)
}

/// Progress of a library experiment on the bar (shared with `stability`).
pub fn on_bar<'a>(pb: &'a ProgressBar, quiet: bool) -> impl FnMut(Progress) + 'a {
    move |p| match p {
        Progress::Step(m) => pb.set_message(m),
        Progress::Done => pb.inc(1),
        Progress::Note(line) => progress::note(pb, quiet, &line),
    }
}

/// Run `pareto`.
pub fn run(a: Args) -> anyhow::Result<ExitCode> {
    let scenes = if a.scenes.is_empty() {
        pareto::default_scenes()
    } else {
        a.scenes.clone()
    };
    let settings = ParetoSettings {
        reps: a.reps,
        estimator: !a.no_estimator,
        rungs: None,
    };
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let mut rows = Vec::new();
    let n_scenes = scenes.len();
    // load every scene first so that the bar knows the whole sweep
    let mut loaded = Vec::new();
    let mut skipped = Vec::new();
    for (si, path) in scenes.iter().enumerate() {
        let scene = DataRef::parse(path)
            .map_err(anyhow::Error::from)
            .and_then(|r| Ok(r.scene()?));
        match scene {
            Ok(scene) => {
                let robot = scene.build_robot()?;
                loaded.push((si, path, scene, robot));
            }
            Err(e) => skipped.push(format!(
                "[{}/{n_scenes}] skipping {}: {e}",
                si + 1,
                path.display()
            )),
        }
    }
    if loaded.is_empty() {
        anyhow::bail!(
            "no scene could be loaded, nothing to measure:\n{}",
            skipped.join("\n")
        );
    }
    let total: usize = loaded
        .iter()
        .map(|(_, _, _, r)| pareto::rung_count(r, &settings))
        .sum();
    let pb = progress::bar(total as u64, a.quiet);
    for line in &skipped {
        progress::note(&pb, a.quiet, line);
    }
    for (si, path, scene, _) in loaded {
        let name = path
            .file_stem()
            .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
        let table = pareto::thesis_table_for(path).with_context(|| {
            format!(
                "{} is the scene of a thesis table, whose data did not load",
                path.display()
            )
        })?;
        let t_scene = Instant::now();
        let res = pareto::run_scene(
            &name,
            &scene,
            table.as_ref(),
            &settings,
            &mut on_bar(&pb, a.quiet),
        )?;
        progress::note(
            &pb,
            a.quiet,
            &format!(
                "[{}/{n_scenes}] {name}: {} settings in {:.1} s",
                si + 1,
                res.rows.len(),
                t_scene.elapsed().as_secs_f64()
            ),
        );
        pb.suspend(|| print_table(&res));
        let svg = a.out.join(format!("pareto_{name}.svg"));
        chart(&name, &res.rows, &svg).with_context(|| format!("writing {}", svg.display()))?;
        rows.extend(res.rows);
    }
    pb.finish_and_clear();
    let csv = a.out.join("pareto.csv");
    std::fs::File::create(&csv)
        .map(std::io::BufWriter::new)
        .and_then(|f| write::pareto_csv(f, &rows))
        .with_context(|| format!("writing {}", csv.display()))?;
    println!(
        "\nwrote {} and {}/pareto_*.svg",
        csv.display(),
        a.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

fn print_table(res: &ParetoScene) {
    let rows = &res.rows;
    println!("\n{}: sweep {}", res.name, res.sweep.join(", "));
    println!(
        "  {:<36} {:>5} {:>11} {:>11} {:>10} {:>10} {:>10} {:>10} {:>10}  front",
        "rung",
        "conv",
        "tip err m",
        "cable err m",
        "cold us",
        "warm us",
        "tick us",
        "est err N",
        "obs err mm"
    );
    let pts: Vec<(f64, f64)> = rows.iter().map(|r| (r.warm_s, r.tip_err)).collect();
    let f = front(&pts);
    let mut order: Vec<usize> = (0..rows.len()).collect();
    order.sort_by(|&a, &b| rows[a].warm_s.total_cmp(&rows[b].warm_s));
    for i in order {
        let r = &rows[i];
        println!(
            "  {:<36} {:>2}/{:<2} {:>11.3e} {:>11.3e} {:>10.1} {:>10.1} {:>10.1} {:>10.2e} {:>10.3}  {}",
            r.rung.label(),
            r.loads_converged,
            r.loads_total,
            r.tip_err,
            r.cable_err,
            r.cold_s * 1e6,
            r.warm_s * 1e6,
            r.tick_s * 1e6,
            r.est_err,
            r.obs_err * 1e3,
            if f.contains(&i) { "*" } else { "" }
        );
    }
}

fn family_colour(family: &str) -> &'static str {
    match family {
        "cc" => "rgb(230,120,20)",
        "pcc" => "rgb(40,160,60)",
        "kirchhoff" => "rgb(40,90,220)",
        _ => "rgb(200,30,60)",
    }
}

/// Three log-log panels, one marker per setting: tip error and cable error against
/// warm solve time, and the estimate error against the time per estimator tick.
fn chart(name: &str, rows: &[ParetoRow], path: &Path) -> anyhow::Result<()> {
    let mut doc = Doc::new(1800.0, 520.0, 12.0);
    let title = format!(
        "{name}: error against the reference vs time per forward solve and per estimator tick"
    );
    doc.text(
        900.0,
        26.0,
        &title,
        r#"font-size="18" text-anchor="middle""#,
    );
    let floor = 1e-15;
    for k in 0..3 {
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .map(|r| match k {
                0 => (r.warm_s * 1e6, r.tip_err.max(floor)),
                1 => (r.warm_s * 1e6, r.cable_err.max(floor)),
                _ => (r.tick_s * 1e6, r.est_err.max(floor)),
            })
            .collect();
        let good: Vec<&(f64, f64)> = pts
            .iter()
            .filter(|p| p.0.is_finite() && p.1.is_finite() && p.0 > 0.0)
            .collect();
        if good.is_empty() {
            continue;
        }
        let (x0, x1) = log_bounds(good.iter().map(|p| p.0));
        let (y0, y1) = log_bounds(good.iter().map(|p| p.1));
        let panel = Panel::new(
            [90.0 + 600.0 * k as f64, 80.0, 480.0, 380.0],
            Axis::log(x0, x1),
            Axis::log(y0, y1),
        );
        let (caption, xdesc, ydesc) = match k {
            0 => (
                "tip position error (m)",
                "warm solve time (us)",
                "max error over the load sweep (m)",
            ),
            1 => (
                "cable length error (m)",
                "warm solve time (us)",
                "max error over the load sweep (m)",
            ),
            _ => (
                "estimator: tip force error (N)",
                "median time per estimator tick (us)",
                "error at the end of the ramp (N)",
            ),
        };
        panel.frame(&mut doc, caption, xdesc, ydesc);
        let mut legend = Vec::new();
        for fam in ["cc", "pcc", "kirchhoff", "cosserat"] {
            let c = family_colour(fam);
            let series: Vec<(f64, f64)> = rows
                .iter()
                .zip(&pts)
                .filter(|(r, p)| r.rung.family() == fam && p.0.is_finite() && p.1.is_finite())
                .map(|(_, p)| *p)
                .collect();
            if series.is_empty() {
                continue;
            }
            panel.dots(&mut doc, &series, 4.0, &format!(r#"fill="{c}""#));
            legend.push((Swatch::Dot, c, fam));
        }
        let f = front(&pts);
        let line: Vec<(f64, f64)> = f.iter().map(|&i| pts[i]).collect();
        let mut stairs = Vec::new();
        for (j, p) in line.iter().enumerate() {
            if j > 0 {
                stairs.push((p.0, line[j - 1].1));
            }
            stairs.push(*p);
        }
        panel.polyline(&mut doc, &stairs, r#"stroke="black" stroke-width="1""#);
        legend.push((Swatch::Line, "black", "Pareto front"));
        panel.legend(&mut doc, &legend, true);
    }
    std::fs::write(path, doc.finish())?;
    Ok(())
}

fn log_bounds(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let Some((lo, mut hi)) = extent(v) else {
        return (1e-1, 1e1);
    };
    if hi <= lo * 1.01 {
        hi = lo * 10.0;
    }
    (lo / 2.0, hi * 2.0)
}
