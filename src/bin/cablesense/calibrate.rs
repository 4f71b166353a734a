//! `cablesense calibrate`: least-squares fit of named scene parameters to the
//! observed or thesis-predicted columns of the thesis tables.

use crate::validate::{data_dir, fitted_file, parse_tables};
use anyhow::Context;
use cablesense::files::demo::DataSource;
use cablesense::validation::{
    fit, FitMethod, FitProblem, FitSettings, ParamPath, TableData, Target, FITTED_FILE,
};
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `calibrate`.
#[derive(clap::Args)]
pub struct Args {
    /// Table(s) to fit to (4.1, 4.2, 4.3, 4.3m, 4.4, 4.5, 4.5acc); repeatable. All
    /// must use the same scene file (4.3 with 4.5; 4.4 with 4.5acc).
    #[arg(long = "table", required = true)]
    tables: Vec<String>,
    /// Parameter path into the scene, e.g. `robot/sections/*/youngs_modulus_pa`
    /// (`*` = every element gets the same value); repeatable.
    #[arg(long = "param", required = true)]
    params: Vec<String>,
    /// Columns to fit: `predicted` (the thesis's model) or `observed` (the experiment).
    #[arg(long, default_value = "predicted")]
    target: String,
    /// `lm` (Levenberg-Marquardt, default) or `gn` (argmin's Gauss-Newton).
    #[arg(long, default_value = "lm")]
    method: String,
    /// Iteration limit.
    #[arg(long, default_value_t = 50)]
    max_iterations: usize,
    /// Start from the scene file's values instead of the stored fit of this target.
    #[arg(long)]
    from_scene: bool,
    /// Directory with the thesis tables, scenes and fitted.toml (default as `validate`).
    #[arg(long)]
    data: Option<PathBuf>,
    /// Fitted values file. Default: DATA/fitted.toml.
    #[arg(long)]
    fitted: Option<PathBuf>,
    /// Store the fitted values in the fitted values file.
    #[arg(long)]
    write: bool,
    /// Print every residual.
    #[arg(long)]
    residuals: bool,
}

/// Run `calibrate`. Exit code 0 when the fit converged, 1 otherwise.
pub fn run(a: Args) -> anyhow::Result<ExitCode> {
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
        max_iterations: a.max_iterations,
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
