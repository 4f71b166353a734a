//! `cablesense pareto [SCENES...]`: every rung and setting of the model ladder on a
//! sweep of loads: time per forward solve and per estimator tick against the error
//! (tip position, cable length) from the reference (full Cosserat, accurate guide
//! mass, adaptive tol 1e-12), and against the thesis's observed tip points where the
//! scene models a thesis table. CSV + one SVG chart per scene (log-log, one marker per
//! setting, the Pareto front drawn) + a terminal table. The estimator runs on every
//! rung (the curvature rungs through their exact fixed-point sensitivities), so each
//! setting also gets its time per estimator tick and its estimate error.

use crate::progress;
use anyhow::Context;
use cablesense::estimate::{Axis, EstimateSpec, Estimator, UnknownSpec};
use cablesense::files::demo::{self, DataRef, DataSource};
use cablesense::ladder::{self, ForwardModel, Rung};
use cablesense::nalgebra::Vector3;
use cablesense::validation::{TableData, ThesisTable, FITTED_FILE};
use cablesense::{Loads, PointLoad, Robot, Scene, Start};
use plotters::prelude::*;
use std::io::Write;
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
    /// Timed repetitions per rung and load (median reported).
    #[arg(long, default_value_t = 7)]
    reps: usize,
    /// Skip the estimator ticks (forward solves only).
    #[arg(long)]
    no_estimator: bool,
    /// No progress bar or status lines on stderr.
    #[arg(long, short)]
    quiet: bool,
}

/// One row of the result.
struct Row {
    scene: String,
    rung: Rung,
    loads_converged: usize,
    loads_total: usize,
    tip_err: f64,
    cable_err: f64,
    cold_s: f64,
    warm_s: f64,
    tick_s: f64,
    est_err: f64,
    obs_err: f64,
}

fn default_scenes() -> Vec<PathBuf> {
    ["scenes", "thesis"]
        .into_iter()
        .flat_map(demo::under)
        .filter(|f| f.path.ends_with(".toml") && !f.path.ends_with(FITTED_FILE))
        .map(|f| PathBuf::from(format!("{}{}", demo::PREFIX, f.path)))
        .collect()
}

/// Unit vector across the rod at the base: along gravity's component normal to the
/// base tangent, else the base's local x.
pub fn across(robot: &Robot, loads: &Loads) -> Vector3<f64> {
    let t = robot.base_rotation() * Vector3::z();
    let g = Vector3::from(loads.gravity_m_s2);
    let gn = g - t * t.dot(&g);
    if gn.norm() > 1e-9 * g.norm().max(1.0) && gn.norm() > 0.0 {
        gn.normalize()
    } else {
        robot.base_rotation() * Vector3::x()
    }
}

/// `loads` plus a tip force of non-dimensional magnitude `p L^2 / EI` along `dir`.
pub fn with_tip_force(robot: &Robot, loads: &Loads, nondim: f64, dir: Vector3<f64>) -> Loads {
    let l = robot.length();
    let ei = robot.sections()[0].stiffness.bend_twist.x;
    let f = dir * (nondim * ei / (l * l));
    let mut out = loads.clone();
    let tip = robot.sections().len() - 1;
    match out
        .point
        .iter_mut()
        .find(|p| p.section == tip && p.frame == cablesense::Frame::World)
    {
        Some(p) => {
            for i in 0..3 {
                p.force_n[i] += f[i];
            }
        }
        None => out.point.push(PointLoad {
            section: tip,
            force_n: f.into(),
            ..Default::default()
        }),
    }
    out
}

/// The load sweep of a scene: its loads scaled by 0.5, 1, 1.5, and its loads plus a
/// tip force of PL^2/EI = 1 and 3 across the rod.
fn sweep(robot: &Robot, loads: &Loads) -> Vec<(String, Loads)> {
    let dir = across(robot, loads);
    let mut v: Vec<(String, Loads)> = [0.5, 1.0, 1.5]
        .iter()
        .map(|&f| (format!("x{f}"), ladder::scale_loads(loads, f)))
        .collect();
    for a in [1.0, 3.0] {
        v.push((
            format!("+tip PL2/EI={a}"),
            with_tip_force(robot, loads, a, dir),
        ));
    }
    v
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

struct Measured {
    tips: Vec<Vector3<f64>>,
    lengths: Vec<Vec<f64>>,
    converged: Vec<bool>,
    cold_s: f64,
    warm_s: f64,
}

fn measure(
    model: &mut dyn ForwardModel,
    loads: &[(String, Loads)],
    reps: usize,
) -> anyhow::Result<Measured> {
    let nc = model.robot().cables().len();
    let mut out = Measured {
        tips: Vec::new(),
        lengths: Vec::new(),
        converged: Vec::new(),
        cold_s: f64::NAN,
        warm_s: f64::NAN,
    };
    let (mut cold, mut warm) = (Vec::new(), Vec::new());
    for (i, (_, l)) in loads.iter().enumerate() {
        let t0 = Instant::now();
        let rep = model.solve(l, Start::Cold)?;
        let first = t0.elapsed().as_secs_f64();
        out.converged.push(rep.status.is_converged());
        out.tips.push(model.tip_position());
        let mut len = vec![0.0; nc];
        model.cable_lengths_into(&mut len);
        out.lengths.push(len);
        // slow settings get fewer repetitions (the median of 3 is still robust)
        let reps = if first > 5e-3 { reps.min(3) } else { reps };
        for _ in 0..reps {
            let t0 = Instant::now();
            model.solve(l, Start::Cold)?;
            cold.push(t0.elapsed().as_secs_f64());
        }
        // warm: from the previous sweep load's solution
        let prev = &loads[if i == 0 {
            1.min(loads.len() - 1)
        } else {
            i - 1
        }]
        .1;
        for _ in 0..reps {
            model.solve(prev, Start::Cold)?;
            let t0 = Instant::now();
            model.solve(l, Start::Warm)?;
            warm.push(t0.elapsed().as_secs_f64());
        }
    }
    out.cold_s = median(&mut cold);
    out.warm_s = median(&mut warm);
    Ok(out)
}

/// Estimator on `rung` (any rung of the ladder): unknown tip force components on the
/// (up to two) world axes most normal to the base tangent; measurements from the
/// reference along a ramp of tip forces up to PL^2/EI = 1 (8 samples). The ramp is run
/// `reps` times (once when a tick takes over 5 ms), each from a fresh start at zero.
/// Returns (median tick time, final estimate error in N).
fn estimator_ticks(
    robot: &Robot,
    scene: &Scene,
    rung: &Rung,
    reference: &mut dyn ForwardModel,
    reps: usize,
) -> anyhow::Result<(f64, f64)> {
    let nc = robot.cables().len();
    let n_unknowns = nc.min(2);
    if n_unknowns == 0 {
        return Ok((f64::NAN, f64::NAN));
    }
    let dir = across(robot, &scene.loads);
    let t = robot.base_rotation() * Vector3::z();
    let mut axes: Vec<usize> = (0..3).collect();
    axes.sort_by(|&a, &b| t[a].abs().total_cmp(&t[b].abs()));
    axes.truncate(n_unknowns);
    let tip = robot.sections().len() - 1;
    let spec = EstimateSpec::new(
        axes.iter()
            .map(|&a| UnknownSpec::force(tip, [Axis::X, Axis::Y, Axis::Z][a]))
            .collect(),
    );
    let mut est = match Estimator::on_rung(robot.clone(), scene.loads.clone(), rung, spec) {
        Ok(e) => e,
        Err(_) => return Ok((f64::NAN, f64::INFINITY)),
    };
    // measured changes: reference at the ramp minus reference at the scene loads
    let mut l0 = vec![0.0; nc];
    reference.solve(&scene.loads, Start::Cold)?;
    reference.cable_lengths_into(&mut l0);
    let ei = robot.sections()[0].stiffness.bend_twist.x;
    let mut samples = Vec::new();
    let mut l = vec![0.0; nc];
    for k in 1..=8 {
        let a = k as f64 / 8.0;
        let loads = with_tip_force(robot, &scene.loads, a, dir);
        let rep = reference.solve(&loads, Start::Warm)?;
        if !rep.status.is_converged() {
            reference.solve(&loads, Start::Cold)?;
        }
        reference.cable_lengths_into(&mut l);
        let changes: Vec<f64> = (0..nc).map(|j| l[j] - l0[j]).collect();
        let f = dir * (a * ei / (robot.length() * robot.length()));
        samples.push((changes, f));
    }
    let mut times = Vec::new();
    let mut err = f64::NAN;
    let zero = vec![0.0; axes.len()];
    for r in 0..reps.max(1) {
        est.set_theta(&zero);
        for (changes, f) in &samples {
            let t0 = Instant::now();
            est.tick(changes, None);
            times.push(t0.elapsed().as_secs_f64());
            err = axes
                .iter()
                .zip(est.theta())
                .map(|(&ax, th)| (th - f[ax]).powi(2))
                .sum::<f64>()
                .sqrt();
        }
        if r == 0 && median(&mut times.clone()) > 5e-3 {
            break;
        }
    }
    Ok((median(&mut times), err))
}

/// RMS distance (m) of the rung's tracked points from the thesis's observed points.
fn observed_error(model: &mut dyn ForwardModel, data: &TableData) -> anyhow::Result<f64> {
    let mut sum = 0.0;
    let mut n = 0usize;
    for row in 0..data.rows {
        let loads = data.row_loads(&data.scene, row)?;
        let rep = model.solve(&loads, Start::Warm)?;
        if !rep.status.is_converged() && !model.solve(&loads, Start::Cold)?.status.is_converged() {
            return Ok(f64::INFINITY);
        }
        let out = model.output();
        for (p, obs) in data.spec.points.iter().zip(&data.observed) {
            let q = out.section_tips[p.section].position;
            sum += (q.x - obs[row][0]).powi(2) + (q.y - obs[row][1]).powi(2);
            n += 1;
        }
    }
    Ok(if n > 0 {
        (sum / n as f64).sqrt()
    } else {
        f64::NAN
    })
}

/// The thesis table (with tip points) whose scene is `scene_path`, read from the
/// scene's directory (embedded for `demo:thesis/...`). `Ok(None)` when the scene is
/// not a thesis table's; an error when it is but its table cannot be read.
fn table_for(scene_path: &Path) -> anyhow::Result<Option<TableData>> {
    let Some(name) = scene_path.file_name().and_then(|n| n.to_str()) else {
        return Ok(None);
    };
    let Some(t) = ThesisTable::ALL
        .into_iter()
        .find(|t| t.spec().scene == name && !t.spec().points.is_empty())
    else {
        return Ok(None);
    };
    let src = match DataRef::parse(scene_path)? {
        DataRef::Demo(f) if f.path.starts_with("thesis/") => DataSource::THESIS,
        DataRef::Demo(_) => return Ok(None),
        DataRef::Path(p) => DataSource::Dir(
            p.parent()
                .filter(|d| !d.as_os_str().is_empty())
                .unwrap_or(Path::new("."))
                .to_path_buf(),
        ),
    };
    Ok(Some(TableData::load_from(&src, t).with_context(|| {
        format!(
            "{} is the scene of thesis table {t}, whose data did not load",
            scene_path.display()
        )
    })?))
}

/// Run `pareto`.
pub fn run(a: Args) -> anyhow::Result<ExitCode> {
    let scenes = if a.scenes.is_empty() {
        default_scenes()
    } else {
        a.scenes.clone()
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
        .map(|(_, _, _, r)| ladder::full_ladder(r).len())
        .sum();
    let pb = progress::bar(total as u64, a.quiet);
    for line in &skipped {
        progress::note(&pb, a.quiet, line);
    }
    for (si, path, scene, robot) in loaded {
        let name = path
            .file_stem()
            .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
        let loads = sweep(&robot, &scene.loads);
        let table = table_for(path)?;
        let mut reference = Rung::reference().build(&robot)?;
        let refm = measure(reference.as_mut(), &loads, 1)?;
        let ladder = ladder::full_ladder(&robot);
        let mut scene_rows = Vec::new();
        let t_scene = Instant::now();
        for rung in &ladder {
            pb.set_message(format!("[{}/{n_scenes}] {name}: {}", si + 1, rung.label()));
            let mut model = rung.build(&robot)?;
            let m = measure(model.as_mut(), &loads, a.reps.max(1))?;
            let mut tip_err: f64 = 0.0;
            let mut cable_err: f64 = 0.0;
            let mut ok = 0;
            for i in 0..loads.len() {
                if !refm.converged[i] {
                    continue;
                }
                if !m.converged[i] {
                    tip_err = f64::INFINITY;
                    cable_err = f64::INFINITY;
                    continue;
                }
                ok += 1;
                tip_err = tip_err.max((m.tips[i] - refm.tips[i]).norm());
                for (x, y) in m.lengths[i].iter().zip(&refm.lengths[i]) {
                    cable_err = cable_err.max((x - y).abs());
                }
            }
            let (tick_s, est_err) = if a.no_estimator {
                (f64::NAN, f64::NAN)
            } else {
                estimator_ticks(&robot, &scene, rung, reference.as_mut(), a.reps.min(3))?
            };
            let obs_err = match &table {
                Some(t) => observed_error(model.as_mut(), t)?,
                None => f64::NAN,
            };
            scene_rows.push(Row {
                scene: name.clone(),
                rung: rung.clone(),
                loads_converged: ok,
                loads_total: loads.len(),
                tip_err,
                cable_err,
                cold_s: m.cold_s,
                warm_s: m.warm_s,
                tick_s,
                est_err,
                obs_err,
            });
            pb.inc(1);
        }
        progress::note(
            &pb,
            a.quiet,
            &format!(
                "[{}/{n_scenes}] {name}: {} settings in {:.1} s",
                si + 1,
                ladder.len(),
                t_scene.elapsed().as_secs_f64()
            ),
        );
        pb.suspend(|| print_table(&name, &scene_rows, &loads));
        let svg = a.out.join(format!("pareto_{name}.svg"));
        chart(&name, &scene_rows, &svg).with_context(|| format!("writing {}", svg.display()))?;
        rows.extend(scene_rows);
    }
    pb.finish_and_clear();
    let csv = a.out.join("pareto.csv");
    write_csv(&csv, &rows).with_context(|| format!("writing {}", csv.display()))?;
    println!(
        "\nwrote {} and {}/pareto_*.svg",
        csv.display(),
        a.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// Indices on the Pareto front of (time, error): no other point is both faster and
/// at least as accurate.
fn front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut best = f64::INFINITY;
    let mut out = Vec::new();
    for i in idx {
        if points[i].1 < best {
            best = points[i].1;
            out.push(i);
        }
    }
    out
}

fn print_table(name: &str, rows: &[Row], loads: &[(String, Loads)]) {
    println!(
        "\n{name}: loads {}",
        loads
            .iter()
            .map(|(n, _)| n.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
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

fn write_csv(path: &Path, rows: &[Row]) -> anyhow::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        f,
        "scene,rung,family,loads_converged,loads_total,tip_err_m,cable_err_m,cold_solve_s,warm_solve_s,estimator_tick_s,estimate_err_n,observed_rms_err_m,on_tip_front,on_cable_front"
    )?;
    let mut by_scene: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    by_scene.dedup();
    for s in by_scene {
        let sub: Vec<&Row> = rows.iter().filter(|r| r.scene == s).collect();
        let ft = front(
            &sub.iter()
                .map(|r| (r.warm_s, r.tip_err))
                .collect::<Vec<_>>(),
        );
        let fc = front(
            &sub.iter()
                .map(|r| (r.warm_s, r.cable_err))
                .collect::<Vec<_>>(),
        );
        for (i, r) in sub.iter().enumerate() {
            writeln!(
                f,
                "{},{},{},{},{},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{},{}",
                r.scene,
                r.rung.label(),
                r.rung.family(),
                r.loads_converged,
                r.loads_total,
                r.tip_err,
                r.cable_err,
                r.cold_s,
                r.warm_s,
                r.tick_s,
                r.est_err,
                r.obs_err,
                ft.contains(&i),
                fc.contains(&i)
            )?;
        }
    }
    Ok(())
}

fn family_style(family: &str) -> RGBColor {
    match family {
        "cc" => RGBColor(230, 120, 20),
        "pcc" => RGBColor(40, 160, 60),
        "kirchhoff" => RGBColor(40, 90, 220),
        _ => RGBColor(200, 30, 60),
    }
}

/// Three log-log panels, one marker per setting: tip error and cable error against
/// warm solve time, and the estimate error against the time per estimator tick.
fn chart(name: &str, rows: &[Row], path: &Path) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (1800, 520)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(
        &format!(
            "{name}: error against the reference vs time per forward solve and per estimator tick"
        ),
        ("sans-serif", 18),
    )?;
    let panels = root.split_evenly((1, 3));
    let floor = 1e-15;
    for (k, panel) in panels.iter().enumerate() {
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
        let mut chart = ChartBuilder::on(panel)
            .caption(
                match k {
                    0 => "tip position error (m)",
                    1 => "cable length error (m)",
                    _ => "estimator: tip force error (N)",
                },
                ("sans-serif", 15),
            )
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(60)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
        chart
            .configure_mesh()
            .x_desc(if k < 2 {
                "warm solve time (us)"
            } else {
                "median time per estimator tick (us)"
            })
            .y_desc(if k < 2 {
                "max error over the load sweep (m)"
            } else {
                "error at the end of the ramp (N)"
            })
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()?;
        for fam in ["cc", "pcc", "kirchhoff", "cosserat"] {
            let c = family_style(fam);
            let series: Vec<(f64, f64)> = rows
                .iter()
                .zip(&pts)
                .filter(|(r, p)| r.rung.family() == fam && p.0.is_finite() && p.1.is_finite())
                .map(|(_, p)| *p)
                .collect();
            if series.is_empty() {
                continue;
            }
            chart
                .draw_series(series.iter().map(|p| Circle::new(*p, 4, c.filled())))?
                .label(fam)
                .legend(move |(x, y)| Circle::new((x + 8, y), 4, c.filled()));
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
        chart
            .draw_series(LineSeries::new(stairs, BLACK.stroke_width(1)))?
            .label("Pareto front")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK.stroke_width(1)));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
    }
    root.present()?;
    Ok(())
}

fn log_bounds(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for x in v {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return (1e-1, 1e1);
    }
    if hi <= lo * 1.01 {
        hi = lo * 10.0;
    }
    (lo / 2.0, hi * 2.0)
}
