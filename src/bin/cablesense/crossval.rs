//! `cablesense crossval`: grouped cross-validation of candidate calibrations on a
//! training recording (`cablesense::calibrate::cross_validate`). Each candidate is a
//! scene whose `[calibration]` table names the parameters it frees; the table
//! printed is the held-out RMSE per group and candidate, and the candidate with the
//! lowest pooled figure is the one the training data select. A validation recording
//! plays no part.

use anyhow::Context;
use cablesense::calibrate::{
    cross_validate, parse_families, row_labels, CalibrationSettings, CrossValidation, FitParam,
    Folds, FrameSetup, Recording, SceneModel, ServoModel,
};
use cablesense::files::demo::DataRef;
use cablesense::validation::ParamPath;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `crossval`.
#[derive(clap::Args)]
pub struct Args {
    /// Candidate scenes (each with a `[calibration]` table); at least one.
    #[arg(required = true)]
    scenes: Vec<PathBuf>,
    /// The training recording (CSV).
    #[arg(long)]
    data: PathBuf,
    /// Groups from a label column: `NAME=SUBSTRING|SUBSTRING;NAME=...` (a row joins
    /// the first group one of whose substrings its label contains), e.g.
    /// `single=seg|tendon;pair12=pair12;pair13=pair13;pair23=pair23`.
    #[arg(long, conflicts_with = "blocks")]
    groups: Option<String>,
    /// The label column for --groups.
    #[arg(long, default_value = "pattern_label")]
    group_column: String,
    /// Groups as this many contiguous blocks of rows (for recordings without labels).
    #[arg(long)]
    blocks: Option<usize>,
    /// Use every N-th row of the recording (after grouping by label).
    #[arg(long, default_value_t = 1)]
    every: usize,
    /// Iteration limit of each fit (default: each scene's own).
    #[arg(long)]
    max_iterations: Option<usize>,
    /// Worker threads over row chunks.
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Output directory (crossval.json).
    #[arg(long, default_value = "out/crossval")]
    out: PathBuf,
    /// No per-fit progress lines.
    #[arg(long)]
    quiet: bool,
}

/// One candidate's inputs to [`cross_validate`].
struct Candidate {
    name: String,
    model: SceneModel,
    params: Vec<FitParam>,
    names: Vec<String>,
    frame: FrameSetup,
    settings: CalibrationSettings,
    robot_length_m: f64,
    recording: Recording,
    /// The robot's base point and axis (for the deflection of the model-error term).
    base: (
        cablesense::nalgebra::Vector3<f64>,
        cablesense::nalgebra::Vector3<f64>,
    ),
}

fn candidate(path: &std::path::Path, a: &Args) -> anyhow::Result<Candidate> {
    let scene = DataRef::parse(path)?.scene()?;
    let mut spec = scene
        .calibration
        .clone()
        .with_context(|| format!("{}: no [calibration] table", path.display()))?;
    if spec.inputs.is_empty() {
        spec.inputs = ServoModel::reading_columns(&scene);
    }
    if let Some(m) = a.max_iterations {
        spec.max_iterations = m;
    }
    spec.validate()?;
    let map = cablesense::calibrate::ColumnMap::from_spec(&spec);
    let recording = Recording::load(&a.data, &map)?;
    let recording = if a.every > 1 {
        recording.every(a.every)
    } else {
        recording
    };
    let paths: Vec<ParamPath> = spec
        .params
        .iter()
        .map(|p| p.path.parse())
        .collect::<Result<_, _>>()?;
    let model = SceneModel::new(&scene, &paths, &recording.input_names, spec.marker_s_m)?;
    let robot = scene.build_robot()?;
    let base = (
        *robot.base_position(),
        robot.base_rotation() * cablesense::nalgebra::Vector3::z(),
    );
    let params = FitParam::all_from_spec(&spec, model.values());
    Ok(Candidate {
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| path.display().to_string()),
        robot_length_m: model.robot_length(),
        names: spec.params.iter().map(|p| p.path.clone()).collect(),
        params,
        frame: FrameSetup::from_spec(&spec),
        settings: CalibrationSettings::from_spec(&spec, a.threads),
        model,
        recording,
        base,
    })
}

pub fn run(a: Args) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(a.every >= 1, "--every must be >= 1, got {}", a.every);
    let candidates: Vec<Candidate> = a
        .scenes
        .iter()
        .map(|p| candidate(p, &a).with_context(|| format!("candidate {}", p.display())))
        .collect::<anyhow::Result<_>>()?;
    let first = &candidates[0].recording;
    let folds = match (&a.groups, a.blocks) {
        (Some(g), _) => {
            let text = std::fs::read_to_string(&a.data)
                .with_context(|| format!("reading {}", a.data.display()))?;
            let labels = row_labels(&text, &a.group_column, first)?;
            Folds::from_labels(&labels, &parse_families(g)?)?
        }
        (None, Some(k)) => Folds::time_blocks(first.rows.len(), k)?,
        (None, None) => anyhow::bail!(
            "give --groups NAME=SUBSTRING|...;... (groups from the `{}` column) or --blocks K",
            a.group_column
        ),
    };
    println!(
        "cross-validating {} candidate(s) on {} ({} rows), groups: {}",
        candidates.len(),
        a.data.display(),
        first.rows.len(),
        folds
            .names
            .iter()
            .enumerate()
            .map(|(g, n)| format!(
                "{n} ({})",
                folds.group_of.iter().filter(|k| **k == g).count()
            ))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut results: Vec<(String, Vec<String>, CrossValidation)> = Vec::new();
    let mut terms = Vec::new();
    for c in &candidates {
        anyhow::ensure!(
            c.recording.rows.len() == first.rows.len(),
            "candidate {}: {} rows, the first candidate {} (different columns?)",
            c.name,
            c.recording.rows.len(),
            first.rows.len()
        );
        let started = std::time::Instant::now();
        let dog = crate::progress::Watchdog::stderr("crossval");
        let cv = cross_validate(
            &c.model,
            &c.params,
            c.frame,
            &c.recording,
            &folds,
            &c.settings,
            c.robot_length_m,
            &mut |fold, p| {
                dog.tick(&format!(
                    "candidate {}, fold {}, LM iteration {}, cost {:.4e}",
                    c.name,
                    folds.names.get(fold).map(String::as_str).unwrap_or("?"),
                    p.lm.iteration,
                    p.lm.cost
                ))
            },
        )?;
        drop(dog);
        if !a.quiet {
            println!(
                "  {}: pooled {:.3} mm ({:.1} s)",
                c.name,
                cv.pooled_rmse_m * 1e3,
                started.elapsed().as_secs_f64()
            );
        }
        let source = format!(
            "cablesense crossval on {} ({} groups: {})",
            a.data
                .file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            folds.names.len(),
            folds.names.join(", ")
        );
        let term = cv.model_error(&c.base.0, &c.base.1, &source);
        match &term {
            Some(m) => println!(
                "  {}: model-error term sigma(d) = sqrt(({:.3} mm)^2 + ({:.4} d)^2) per coordinate, d the lateral deflection, from {} held-out rows; for the calibrated scene:\n    [calibration.model_error]\n    sigma_m = {:.6e}\n    per_deflection = {:.6e}\n    rows = {}\n    source = \"{}\"",
                c.name,
                m.sigma_m * 1e3,
                m.per_deflection,
                m.rows,
                m.sigma_m,
                m.per_deflection,
                m.rows,
                m.source
            ),
            None => println!("  {}: no model-error term (no held-out rows)", c.name),
        }
        terms.push(term);
        results.push((c.name.clone(), c.names.clone(), cv));
    }
    print_table(&folds, &results);
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let json: Vec<serde_json::Value> = results
        .iter()
        .zip(&terms)
        .map(|((name, params, cv), term)| {
            serde_json::json!({ "candidate": name, "params": params, "cross_validation": cv, "model_error": term })
        })
        .collect();
    let path = a.out.join("crossval.json");
    std::fs::write(&path, serde_json::to_string_pretty(&json)?)
        .with_context(|| format!("writing {}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(ExitCode::SUCCESS)
}

fn print_table(folds: &Folds, results: &[(String, Vec<String>, CrossValidation)]) {
    let best = results
        .iter()
        .enumerate()
        .min_by(|a, b| a.1 .2.pooled_rmse_m.total_cmp(&b.1 .2.pooled_rmse_m))
        .map(|(i, _)| i);
    println!("held-out RMSE (mm), each group's mean offset removed; rows unsolved in brackets");
    print!("{:<12}", "group");
    for (name, _, _) in results {
        print!(" {name:>16}");
    }
    println!();
    for (g, group) in folds.names.iter().enumerate() {
        print!("{group:<12}");
        for (_, _, cv) in results {
            let h = &cv.held_out[g];
            let cell = if h.unsolved > 0 {
                format!("{:.3} [{}]", h.errors.mean_removed.rmse_m * 1e3, h.unsolved)
            } else {
                format!("{:.3}", h.errors.mean_removed.rmse_m * 1e3)
            };
            print!(" {cell:>16}");
        }
        println!();
    }
    print!("{:<12}", "pooled");
    for (i, (_, _, cv)) in results.iter().enumerate() {
        let mark = if Some(i) == best { " *" } else { "" };
        print!(" {:>16}", format!("{:.3}{mark}", cv.pooled_rmse_m * 1e3));
    }
    println!();
    if let Some(i) = best {
        println!("lowest pooled held-out RMSE: {} (* above)", results[i].0);
        // candidates the data cannot tell apart: within 1 % of the lowest
        let lowest = results[i].2.pooled_rmse_m;
        let tied: Vec<&str> = results
            .iter()
            .filter(|r| r.2.pooled_rmse_m <= 1.01 * lowest)
            .map(|r| r.0.as_str())
            .collect();
        if tied.len() > 1 {
            println!(
                "within 1 % of it (not told apart by these data; prefer the fewest free \
                 parameters and values inside their physical ranges): {}",
                tied.join(", ")
            );
        }
    }
}
