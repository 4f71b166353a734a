//! `cablesense calibrate`: fit named scene parameters, in two modes.
//!
//! - **Recording** (`calibrate SCENE --data train.csv [--val val.csv] [--param PATH]...`):
//!   the scene's model driven by the recording's tension columns, fitted with the
//!   capture frame and marker offset to the measured marker positions
//!   (`cablesense::calibrate`); writes the calibrated scene, a residual CSV and an SVG.
//! - **Thesis tables** (`calibrate --table 4.3 --param PATH`): fit to the observed or
//!   thesis-predicted columns of the thesis tables (`cablesense::validation::fit`, whose
//!   Levenberg-Marquardt is `cablesense::calibrate::levenberg_marquardt`).

#[path = "calibrate_identify.rs"]
mod identify;

use crate::progress;
use crate::validate::{data_dir, fitted_file, parse_tables};
use anyhow::Context;
use cablesense::calibrate::{
    calibrate_scene, parse_row_range, scene_spec, write_report_svg, write_residuals_csv,
    CalibrationReport, ColumnMap, ParamSpec, Recording, RowWork, SceneCalibration, Stage,
};
use cablesense::files::demo::{DataRef, DataSource};
use cablesense::validation::{
    fit, FitMethod, FitProblem, FitSettings, ParamPath, TableData, Target, FITTED_FILE,
};
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `calibrate`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene file (recording mode); its `[calibration]` table maps the columns.
    /// With --identify: the scene whose tendons are matched (default the embedded
    /// FTDCR v4, `demo:scenes/ftdcr_v4.toml`).
    scene: Option<PathBuf>,
    /// Propose the servo-to-tendon mapping and per-segment angle offsets from a
    /// single-tendon pull recording (e.g. data/hardware/ftdcr_v4/tendon_pull.csv).
    #[arg(long)]
    identify: Option<PathBuf>,
    /// Recording mode: the training recording (CSV or JSON lines). Thesis mode: the
    /// directory with the thesis tables, scenes and fitted.toml (default as `validate`).
    #[arg(long)]
    data: Option<PathBuf>,
    /// Recording mode: a held-out validation recording.
    #[arg(long)]
    val: Option<PathBuf>,
    /// Recording mode: fit only these data rows (`A..B`, 0-based, end exclusive); the
    /// other rows of `--data` are the validation set (when no `--val` is given).
    #[arg(long)]
    train_rows: Option<String>,
    /// Recording mode: fit every N-th row of the training rows (after --train-rows);
    /// readings at shifted times (`readings/time_offset_s`) are still interpolated
    /// between neighbouring rows of the whole file.
    #[arg(long, default_value_t = 1)]
    every: usize,
    /// Parameter path into the scene, e.g. `robot/sections/*/youngs_modulus_pa`
    /// (`*` = every element gets the same value), optionally with bounds
    /// `PATH:MIN:MAX`; repeatable. Recording mode: added to the scene's
    /// `[[calibration.params]]`.
    #[arg(long = "param")]
    params: Vec<String>,
    /// Recording mode: marker position columns `x,y,z` (default from the scene, else
    /// `tip_x,tip_y,tip_z`).
    #[arg(long)]
    marker_columns: Option<String>,
    /// Recording mode: unit of the marker columns, `m` or `mm`.
    #[arg(long)]
    unit: Option<String>,
    /// Recording mode: capture noise std per coordinate, in m.
    #[arg(long)]
    noise: Option<f64>,
    /// Recording mode: Huber threshold in noise sigmas (robust loss).
    #[arg(long)]
    huber: Option<f64>,
    /// Recording mode: input columns `a,b,...` (default: every tension_*, force_*, mass_*).
    #[arg(long)]
    inputs: Option<String>,
    /// Recording mode: time column (s) (default from the scene, else `t_s` when present).
    #[arg(long)]
    time_column: Option<String>,
    /// Recording mode: arc length (m) of the body the marker is on (default: the tip).
    #[arg(long)]
    marker_s: Option<f64>,
    /// Recording mode: keep the capture frame fixed at the scene's value.
    #[arg(long)]
    fixed_frame: bool,
    /// Recording mode: keep the marker offset fixed at the scene's value.
    #[arg(long)]
    fixed_offset: bool,
    /// Recording mode: worker threads over row chunks.
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Recording mode: output directory (calibrated.toml, residuals.csv, report.svg,
    /// report.json with every fitted value, statistic and row).
    #[arg(long, default_value = "out/calibrate")]
    out: PathBuf,
    /// Recording mode: input column for the "error against input" plot.
    #[arg(long)]
    plot_input: Option<String>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Thesis mode: table(s) to fit to (4.1, 4.2, 4.3, 4.3m, 4.4, 4.5, 4.5acc);
    /// repeatable. All must use the same scene file (4.3 with 4.5; 4.4 with 4.5acc).
    #[arg(long = "table")]
    tables: Vec<String>,
    /// Thesis mode: columns to fit, `predicted` (the thesis's model) or `observed`.
    #[arg(long, default_value = "predicted")]
    target: String,
    /// Thesis mode: `lm` (Levenberg-Marquardt, default) or `gn` (argmin's Gauss-Newton).
    #[arg(long, default_value = "lm")]
    method: String,
    /// Iteration limit (thesis mode default 50; recording mode: the scene's, default 30).
    #[arg(long)]
    max_iterations: Option<usize>,
    /// Thesis mode: start from the scene file's values instead of the stored fit.
    #[arg(long)]
    from_scene: bool,
    /// Thesis mode: fitted values file. Default: DATA/fitted.toml.
    #[arg(long)]
    fitted: Option<PathBuf>,
    /// Thesis mode: store the fitted values in the fitted values file.
    #[arg(long)]
    write: bool,
    /// Thesis mode: print every residual.
    #[arg(long)]
    residuals: bool,
}

/// Run `calibrate`. Exit code 0 when the fit converged, 1 otherwise.
pub fn run(a: Args) -> anyhow::Result<ExitCode> {
    if let Some(f) = &a.identify {
        return identify::run(f, a.scene.as_deref());
    }
    if a.tables.is_empty() {
        return run_recording(a);
    }
    if a.params.is_empty() {
        anyhow::bail!("thesis mode (--table) needs at least one --param");
    }
    let max_iterations = a.max_iterations.unwrap_or(50);
    let dir = data_dir(a.data)?;
    // --write needs a file on disk: --fitted, or fitted.toml in a --data directory
    let fitted_path = match (&a.fitted, &dir) {
        (Some(p), _) => Some(p.clone()),
        (None, DataSource::Dir(d)) => Some(d.join(FITTED_FILE)),
        (None, DataSource::Embedded(_)) => None,
    };
    if a.write && fitted_path.is_none() {
        anyhow::bail!("--write needs a file to write: pass --fitted FILE, or --data DIR (e.g. a copy from `cablesense demo write DIR`, then --data DIR/thesis)");
    }
    let target: Target = a.target.parse()?;
    let method: FitMethod = a.method.parse()?;
    let tables = parse_tables(&a.tables)?;
    let data: Vec<TableData> = tables
        .iter()
        .map(|t| TableData::load_from(&dir, *t))
        .collect::<Result<_, _>>()?;
    let scene_name = data[0].spec.scene;
    if let Some(d) = data.iter().find(|d| d.spec.scene != scene_name) {
        anyhow::bail!(
            "tables {} and {} use different scenes ({} vs {}): fit them separately",
            data[0].table,
            d.table,
            scene_name,
            d.spec.scene
        );
    }
    let params: Vec<ParamPath> = a
        .params
        .iter()
        .map(|p| p.parse())
        .collect::<Result<_, _>>()?;
    let (mut fitted, _) = fitted_file(&dir, fitted_path.as_deref())?;
    // start from the stored fit of this target (other parameters stay fitted too)
    let scene = match fitted.get(scene_name, target) {
        Some(rec) if !a.from_scene => rec.apply(&data[0].scene)?,
        _ => data[0].scene.clone(),
    };
    let problem = FitProblem::new(scene, data, params, target)?;
    let settings = FitSettings {
        method,
        max_iterations,
        ..FitSettings::default()
    };
    let started = std::time::Instant::now();
    let report = fit(&problem, &settings)?;
    let table_names: Vec<String> = tables.iter().map(|t| t.name().to_string()).collect();
    println!(
        "fit of {} to the {} columns of table(s) {} (scene {})",
        report.params.join(", "),
        target,
        table_names.join(", "),
        scene_name
    );
    println!(
        "method {:?}: {:?} after {} iterations, {} residual evaluations, {:.2} s",
        report.method,
        report.status,
        report.iterations,
        report.evaluations,
        started.elapsed().as_secs_f64()
    );
    for (((p, x0), x), se) in report
        .params
        .iter()
        .zip(&report.initial)
        .zip(&report.values)
        .zip(&report.std_errors)
    {
        println!("  {p}: {x:.9e}  (start {x0:.6e}, formal std. error {se:.2e})");
    }
    println!(
        "residuals: {} values, rms {:.4} mm, max |r| {:.4} mm",
        report.residuals.len(),
        report.rms_m * 1e3,
        report.max_abs_m * 1e3
    );
    // Euclidean point errors (the metric for tip columns)
    let mut k = 0;
    let mut worst_point: f64 = 0.0;
    let mut worst_len: f64 = 0.0;
    while k < report.labels.len() {
        let l = &report.labels[k];
        if l.ends_with(" x") && k + 1 < report.labels.len() {
            worst_point = worst_point.max(report.residuals[k].hypot(report.residuals[k + 1]));
            k += 2;
        } else {
            worst_len = worst_len.max(report.residuals[k].abs());
            k += 1;
        }
    }
    if worst_point > 0.0 {
        println!("  largest tip-point distance: {:.4} mm", worst_point * 1e3);
    }
    if worst_len > 0.0 {
        println!("  largest cable-length residual: {:.4} mm", worst_len * 1e3);
    }
    if a.residuals {
        for (l, r) in report.labels.iter().zip(&report.residuals) {
            println!("  {l:<28} {:>9.4} mm", r * 1e3);
        }
    }
    if a.write {
        fitted.record(scene_name, target, &table_names, &report);
        if let Some(path) = &fitted_path {
            std::fs::write(path, fitted.to_toml_string())
                .with_context(|| format!("writing {}", path.display()))?;
            println!("wrote {}", path.display());
        }
    }
    Ok(
        if report.status == cablesense::validation::FitStatus::Converged {
            ExitCode::SUCCESS
        } else {
            ExitCode::from(1)
        },
    )
}

/// `PATH` or `PATH:MIN:MAX`.
fn param_arg(text: &str) -> anyhow::Result<ParamSpec> {
    let mut parts = text.split(':');
    let mut spec = ParamSpec::new(parts.next().unwrap_or_default().trim());
    let num = |p: Option<&str>| -> anyhow::Result<Option<f64>> {
        match p.map(str::trim) {
            None | Some("") => Ok(None),
            Some(x) => {
                Ok(Some(x.parse().with_context(|| {
                    format!("--param {text}: `{x}` is not a number")
                })?))
            }
        }
    };
    spec.min = num(parts.next())?;
    spec.max = num(parts.next())?;
    if parts.next().is_some() {
        anyhow::bail!("--param {text}: expected PATH or PATH:MIN:MAX");
    }
    Ok(spec)
}

/// A recording named on the command line: a path, or `demo:NAME` for a shipped one.
fn load_recording(arg: &std::path::Path, map: &ColumnMap) -> anyhow::Result<Recording> {
    Ok(match DataRef::parse(arg)? {
        DataRef::Path(p) => Recording::load(&p, map)?,
        f @ DataRef::Demo(_) => Recording::parse_str(&f.display(), &f.read()?, map)?,
    })
}

fn run_recording(a: Args) -> anyhow::Result<ExitCode> {
    let scene_path = a
        .scene
        .clone()
        .context("recording mode needs a SCENE (or use --table for the thesis tables)")?;
    let data = a.data.clone().context("recording mode needs --data FILE")?;
    let scene = DataRef::parse(&scene_path)?.scene()?;
    let mut spec = scene_spec(&scene);
    if let Some(c) = &a.marker_columns {
        let cols: Vec<String> = c.split(',').map(|x| x.trim().to_string()).collect();
        spec.marker_columns = cols
            .try_into()
            .map_err(|_| anyhow::anyhow!("--marker-columns: expected three names x,y,z"))?;
    }
    if let Some(u) = &a.unit {
        spec.unit = u.parse().map_err(|e: String| anyhow::anyhow!(e))?;
    }
    if let Some(n) = a.noise {
        spec.capture_noise_m = n;
    }
    if a.huber.is_some() {
        spec.huber_sigma = a.huber;
    }
    if let Some(i) = &a.inputs {
        spec.inputs = i.split(',').map(|x| x.trim().to_string()).collect();
    }
    if a.time_column.is_some() {
        spec.time_column = a.time_column.clone();
    }
    if a.marker_s.is_some() {
        spec.marker_s_m = a.marker_s;
    }
    if a.fixed_frame {
        spec.fit_capture_frame = false;
    }
    if a.fixed_offset {
        spec.fit_marker_offset = false;
    }
    if let Some(m) = a.max_iterations {
        spec.max_iterations = m;
    }
    for p in &a.params {
        spec.params.push(param_arg(p)?);
    }
    spec.validate()?;
    if spec.params.is_empty() && !spec.fit_capture_frame && !spec.fit_marker_offset {
        anyhow::bail!(
            "nothing to fit: no --param, no [[calibration.params]], frame and offset fixed"
        );
    }
    let map = ColumnMap::from_spec(&spec);
    let all = load_recording(&data, &map)?;
    let (train, val) = match (&a.val, &a.train_rows) {
        (Some(v), None) => (all, Some(load_recording(v, &map)?)),
        (None, Some(r)) => {
            let range = parse_row_range(r).map_err(|e| anyhow::anyhow!(e))?;
            // rows outside the data are an error, not clamped (`A..` reads to the end)
            let n = all.rows.len();
            anyhow::ensure!(
                range.start < n && (range.end == usize::MAX || range.end <= n),
                "--train-rows {r}: outside the {n} data rows of {} (0..{n})",
                data.display()
            );
            let (t, v) = all.split_rows(range);
            (t, if v.rows.is_empty() { None } else { Some(v) })
        }
        (None, None) => (all, None),
        (Some(_), Some(_)) => anyhow::bail!("give --val or --train-rows, not both"),
    };
    anyhow::ensure!(a.every >= 1, "--every must be >= 1");
    let train = if a.every > 1 {
        train.every(a.every)
    } else {
        train
    };
    println!(
        "calibrating {} on {} ({} rows{}), inputs {}",
        scene_path.display(),
        train.file,
        train.rows.len(),
        val.as_ref()
            .map(|v| format!("; validation {} rows of {}", v.rows.len(), v.file))
            .unwrap_or_default(),
        train.input_names.join(", ")
    );
    let pb = progress::bar(spec.max_iterations as u64, a.quiet);
    let started = std::time::Instant::now();
    let dog = progress::Watchdog::stderr("calibrate");
    let job = calibrate_scene(&scene, &spec, &train, val.as_ref(), a.threads, &mut |p| {
        let stage = match p.stage {
            Stage::Start => "start",
            Stage::Frame => "frame",
            Stage::Full => "all",
        };
        if p.stage == Stage::Full {
            pb.set_position(p.lm.iteration as u64);
        }
        let rows = match p.rows {
            Some(r) => format!(
                " | {} {}/{} rows",
                match r.work {
                    RowWork::Solve => "solve",
                    RowWork::Sensitivities => "sensitivities",
                },
                r.done,
                r.total
            ),
            None => String::new(),
        };
        let msg = if p.stage == Stage::Start {
            format!("model at the start values{rows}")
        } else {
            format!(
                "{stage}: iteration {}, cost {:.4e}, damping {:.1e}{rows}",
                p.lm.iteration, p.lm.cost, p.lm.damping
            )
        };
        dog.tick(&msg);
        pb.set_message(msg);
    });
    drop(dog);
    pb.finish_and_clear();
    let SceneCalibration {
        report,
        scene: out_scene,
    } = job?;
    print_report(&report, started.elapsed().as_secs_f64());
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let toml_path = a.out.join("calibrated.toml");
    std::fs::write(&toml_path, out_scene.to_toml_string())
        .with_context(|| format!("writing {}", toml_path.display()))?;
    let csv_path = a.out.join("residuals.csv");
    write_residuals_csv(&csv_path, &report)?;
    let svg_path = a.out.join("report.svg");
    let opts = cablesense::calibrate::SvgOptions {
        title: format!("calibration of {} on {}", scene_path.display(), train.file),
        input: a.plot_input.clone(),
    };
    write_report_svg(&svg_path, &report, &opts)?;
    let json_path = a.out.join("report.json");
    std::fs::write(&json_path, serde_json::to_string_pretty(&report)?)
        .with_context(|| format!("writing {}", json_path.display()))?;
    println!(
        "wrote {}, {}, {}, {}",
        toml_path.display(),
        csv_path.display(),
        svg_path.display(),
        json_path.display()
    );
    Ok(
        if report.status == cablesense::calibrate::LmStatus::Converged {
            ExitCode::SUCCESS
        } else {
            ExitCode::from(1)
        },
    )
}

fn print_report(r: &CalibrationReport, secs: f64) {
    println!(
        "status {:?} after {} iterations, {:.2} s; train residual {:.2} capture-noise sigmas RMS \
         (variance factor {:.3})",
        r.status, r.iterations, secs, r.rms_sigma, r.statistics.residual_variance
    );
    println!(
        "{:<44} {:>14} {:>14} {:>11}",
        "parameter", "start", "fitted", "std. error"
    );
    for p in &r.params {
        println!(
            "{:<44} {:>14.6e} {:>14.6e} {:>11.3e}{}",
            p.name,
            p.initial,
            p.value,
            p.std_error,
            if p.at_bound { "  (at bound)" } else { "" }
        );
    }
    let n = r.params.len();
    if n > 1 && n <= 16 {
        println!("correlation:");
        for i in 0..n {
            let row: Vec<String> = (0..n)
                .map(|j| format!("{:>6.2}", r.statistics.correlation[i * n + j]))
                .collect();
            println!("  {:>2} {}", i, row.join(" "));
        }
    }
    let len_mm = r.robot_length_m * 1e3;
    let show = |name: &str, e: &cablesense::calibrate::TipErrors| {
        for (label, s) in [
            ("raw", &e.raw),
            ("mean offset removed (upstream convention)", &e.mean_removed),
        ] {
            println!(
                "{name} tip error, {label}: RMSE {:.3} mm ({:.2} % of L), median {:.3} mm, p95 {:.3} mm, max {:.3} mm ({} rows)",
                s.rmse_m * 1e3,
                s.rmse_m * 1e3 / len_mm * 100.0,
                s.median_m * 1e3,
                s.p95_m * 1e3,
                s.max_m * 1e3,
                s.count
            );
        }
    };
    show("train", &r.train);
    if let Some(v) = &r.val {
        show("val", v);
    }
    if !r.failed_rows.is_empty() {
        println!("failed rows (left out: the forward solve failed even from cold):");
        for f in &r.failed_rows {
            println!(
                "  {:<5} line {:>6}: {} (residual {:.2e})",
                match f.split {
                    cablesense::calibrate::Split::Train => "train",
                    cablesense::calibrate::Split::Val => "val",
                },
                f.line,
                f.status_name(),
                f.residual
            );
        }
    }
    for w in &r.warnings {
        println!("warning: {w}");
    }
}
