//! `cablesense reach SCENE --targets FILE`: servo readings that put the tip at each
//! target (inverse kinematics, `cablesense::command::IkWorkspace`), warm from target
//! to target, written as a readings file that `cablesense solve SCENE --readings`
//! accepts unchanged. Without arguments: the embedded calibrated FTDCR v4 scene, and
//! the model's tips at the readings of its held-out recording (val.csv) as targets
//! (a round trip).
//!
//! Targets: CSV with a header holding `x_m,y_m,z_m` (tip position, m, the scene's
//! base frame) and optionally `dx,dy,dz` (tip direction, any length); `#` lines and
//! other columns are ignored.
//!
//! Output: the scene's `[readings]` time column and one column per driven tendon
//! (its reading column, in the readings' units). The rows are stamped 10 s apart
//! (each row its own block, so a `[readings] time_offset_s` reads every row at its
//! own readings), and with a `[readings] backlash_m` the commands are pre-compensated
//! for the play (a command `q +- b/2` moves the tendon to `q` when it approaches from
//! below / above), so that `solve --readings` solves exactly the readings IK found.
//! The tips reported (`--report`) are those of that solve (the same chain as
//! `solve --readings`, run on the written text), so the two agree to the last digit;
//! IK's own tips differ from them by the forward solve's tolerance (two converged
//! solves of the same readings from different warm starts).

use anyhow::{bail, Context};
use cablesense::command::{IkObjective, IkSettings, IkStatus, IkTarget, IkWorkspace};
use cablesense::nalgebra::Vector3;
use cablesense::validation::{TrackChain, CALIBRATED_SCENE, VAL_CSV};
use cablesense::Scene;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

/// Seconds between written rows: above the 3 s that ends a block of rows.
const ROW_SPACING_S: f64 = 10.0;

#[derive(clap::Args)]
pub struct Args {
    /// Scene with displacement-driven tendons (a path, or `demo:NAME`). Default: the
    /// embedded calibrated FTDCR v4 scene.
    scene: Option<PathBuf>,
    /// Targets CSV (`x_m,y_m,z_m`, optional `dx,dy,dz`). Default with the embedded
    /// scene: the model's tips at the readings of its held-out recording.
    #[arg(long)]
    targets: Option<PathBuf>,
    /// Write the readings here (default: standard output).
    #[arg(long)]
    output: Option<PathBuf>,
    /// Write one CSV row per target here: status, the tip `solve --readings` gives
    /// for the written readings and its distance to the target, and IK's own
    /// distance.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Secondary objective: `closest` (to the previous readings), `least_pull`,
    /// `least_tension`.
    #[arg(long, default_value = "closest")]
    objective: String,
    /// A tip within this distance is reached (mm).
    #[arg(long = "tolerance-mm", default_value_t = 0.01)]
    tolerance_mm: f64,
}

/// Parse a targets CSV.
fn parse_targets(text: &str, file: &str) -> anyhow::Result<Vec<IkTarget>> {
    let csv = cablesense::files::rows::CsvText::parse(text, false).map_err(|(line, why)| {
        anyhow::anyhow!("{file}:{line}: {why} (expected columns x_m,y_m,z_m)")
    })?;
    let (cols, header) = (&csv.names, csv.names.join(","));
    let find = |name: &str| cols.iter().position(|c| *c == name);
    let pos = ["x_m", "y_m", "z_m"].map(find);
    let [Some(x), Some(y), Some(z)] = pos else {
        bail!("{file}: the header needs columns x_m, y_m and z_m (got `{header}`)");
    };
    let dir = match ["dx", "dy", "dz"].map(find) {
        [Some(a), Some(b), Some(c)] => Some([a, b, c]),
        [None, None, None] => None,
        _ => bail!("{file}: a direction needs all of dx, dy, dz"),
    };
    let mut out = Vec::new();
    for (line, cells) in &csv.rows {
        let num = |k: usize, name: &str| -> anyhow::Result<f64> {
            let c = cells
                .get(k)
                .with_context(|| format!("{file}:{line}: no `{name}` cell"))?;
            c.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .with_context(|| format!("{file}:{line}: `{name}` = `{c}` is not a finite number"))
        };
        let p = Vector3::new(num(x, "x_m")?, num(y, "y_m")?, num(z, "z_m")?);
        let direction = match dir {
            Some([a, b, c]) => Some(Vector3::new(num(a, "dx")?, num(b, "dy")?, num(c, "dz")?)),
            None => None,
        };
        let t = IkTarget {
            position_m: p,
            direction,
        };
        t.validate().with_context(|| format!("{file}:{line}"))?;
        out.push(t);
    }
    if out.is_empty() {
        bail!("{file}: no target rows");
    }
    Ok(out)
}

/// The model's tips at the readings of the embedded val recording.
fn val_tips(scene: &Scene) -> anyhow::Result<Vec<IkTarget>> {
    let tips = scene.model_tips(VAL_CSV, usize::MAX)?;
    Ok(tips.into_iter().map(IkTarget::position).collect())
}

fn percentile(sorted: &[f64], f: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * f).round() as usize]
}

/// The scene a command subcommand (`reach`, `workspace`) works on and its name for
/// messages: the one named (a path or `demo:` reference), else the embedded
/// calibrated FTDCR v4.
pub fn scene_or_calibrated(scene: Option<&std::path::Path>) -> anyhow::Result<(Scene, String)> {
    Ok(match scene {
        Some(p) => {
            let r = cablesense::files::demo::DataRef::parse(p)?;
            (r.scene()?, r.display())
        }
        None => (
            Scene::parse_validated(
                CALIBRATED_SCENE,
                std::path::Path::new("data/calibration/ftdcr_v4_calibrated.toml"),
                false,
            )?,
            "embedded calibrated FTDCR v4".to_string(),
        ),
    })
}

pub fn run(a: Args) -> anyhow::Result<ExitCode> {
    let (scene, name) = scene_or_calibrated(a.scene.as_deref())?;
    let objective = match a.objective.as_str() {
        "closest" => IkObjective::Closest,
        "least_pull" => IkObjective::LeastPull,
        "least_tension" => IkObjective::LeastTension,
        o => bail!("--objective `{o}`: use closest, least_pull or least_tension"),
    };
    if !(a.tolerance_mm.is_finite() && a.tolerance_mm > 0.0) {
        bail!("--tolerance-mm must be > 0, got {}", a.tolerance_mm);
    }
    let targets = match (&a.targets, &a.scene) {
        (Some(f), _) => {
            let text =
                std::fs::read_to_string(f).with_context(|| format!("reading {}", f.display()))?;
            parse_targets(&text, &f.display().to_string())?
        }
        (None, None) => val_tips(&scene)?,
        (None, Some(_)) => bail!("give --targets FILE (x_m,y_m,z_m per row) for {name}"),
    };
    let settings = IkSettings {
        objective,
        tolerance_m: a.tolerance_mm * 1e-3,
        ..IkSettings::default()
    };
    let mut ik = IkWorkspace::from_scene(&scene, settings)
        .with_context(|| format!("{name}: building the inverse solver"))?;
    let spec = scene.readings.clone().unwrap_or_default();
    let (scale, backlash) = (spec.scale_m, spec.backlash_m);
    let columns = ik.tendon_workspace().columns().to_vec();
    // IK, warm from target to target
    let t0 = std::time::Instant::now();
    let mut reports = Vec::with_capacity(targets.len());
    let mut times = Vec::with_capacity(targets.len());
    let mut text = String::new();
    writeln!(
        text,
        "# cablesense reach {name}: {} targets, objective {}; commands for `cablesense solve --readings`",
        targets.len(),
        objective.name()
    )?;
    writeln!(text, "{},{}", spec.time_column, columns.join(","))?;
    let mut play: Option<Vec<f64>> = None;
    for (k, t) in targets.iter().enumerate() {
        let s = std::time::Instant::now();
        let r = ik.solve(t)?;
        times.push(s.elapsed().as_secs_f64());
        reports.push(r);
        let q = ik.readings();
        // the command that puts the tendon at q through the play of width b
        let cmd: Vec<f64> = match play.as_mut() {
            Some(y) if backlash > 0.0 => q
                .iter()
                .zip(y.iter_mut())
                .map(|(&q, y)| {
                    let c = if q > *y {
                        q + 0.5 * backlash
                    } else if q < *y {
                        q - 0.5 * backlash
                    } else {
                        q
                    };
                    *y = y.clamp(c - 0.5 * backlash, c + 0.5 * backlash);
                    c
                })
                .collect(),
            _ => {
                play = Some(q.to_vec());
                q.to_vec()
            }
        };
        let cells: Vec<String> = cmd.iter().map(|c| format!("{}", c / scale)).collect();
        writeln!(text, "{},{}", k as f64 * ROW_SPACING_S, cells.join(","))?;
    }
    let ik_s = t0.elapsed().as_secs_f64();
    // the tips `solve --readings` gives for the written text (same parser, same chain)
    let mut chain = TrackChain::for_scene(&scene, scene.tendon_workspace()?);
    let mut parser = scene.readings_parser(chain.workspace());
    let mut solved = Vec::with_capacity(targets.len());
    for (i, l) in text.lines().enumerate() {
        if let Some(row) = parser
            .line(i + 1, l)
            .map_err(|e| anyhow::anyhow!("re-reading the written readings: {e}"))?
        {
            let st = chain.step_at(row.t_s, &row.readings_m)?;
            solved.push(
                st.report
                    .status
                    .is_converged()
                    .then(|| chain.workspace().tip_position()),
            );
        }
    }
    match &a.output {
        Some(p) => std::fs::write(p, &text).with_context(|| format!("writing {}", p.display()))?,
        None => print!("{text}"),
    }
    if let Some(p) = &a.report {
        let mut rep = String::from(
            "row,status,tip_x_m,tip_y_m,tip_z_m,distance_m,ik_distance_m,iterations,forward_solves\n",
        );
        for (k, ((r, tip), t)) in reports.iter().zip(&solved).zip(&targets).enumerate() {
            let (tip, d) = match tip {
                Some(tip) => (*tip, (t.position_m - tip).norm()),
                None => (Vector3::repeat(f64::NAN), f64::NAN),
            };
            writeln!(
                rep,
                "{k},{},{},{},{},{},{},{},{}",
                r.status.name(),
                tip.x,
                tip.y,
                tip.z,
                d,
                r.distance_m,
                r.iterations,
                r.forward_solves
            )?;
        }
        std::fs::write(p, rep).with_context(|| format!("writing {}", p.display()))?;
    }
    // summary (standard error: standard output may be the readings)
    let mut counts = [0usize; 3];
    let mut dist = Vec::new();
    let (mut worst_agree, mut not_converged) = (0.0f64, 0);
    for (r, tip) in reports.iter().zip(&solved) {
        counts[match r.status {
            IkStatus::Reached => 0,
            IkStatus::Unreachable { .. } => 1,
            IkStatus::BudgetExhausted => 2,
        }] += 1;
        match tip {
            Some(tip) => worst_agree = worst_agree.max((tip - r.tip_m).norm()),
            None => not_converged += 1,
        }
        dist.push(r.distance_m);
    }
    dist.sort_by(f64::total_cmp);
    times.sort_by(f64::total_cmp);
    eprintln!(
        "{} targets ({name}, objective {}): {} reached, {} unreachable, {} out of budget",
        targets.len(),
        objective.name(),
        counts[0],
        counts[1],
        counts[2]
    );
    eprintln!(
        "distance to target (mm): median {:.4}, 95 % {:.4}, 99 % {:.4}, max {:.4}; within 0.05 mm: {:.1} %",
        percentile(&dist, 0.5) * 1e3,
        percentile(&dist, 0.95) * 1e3,
        percentile(&dist, 0.99) * 1e3,
        percentile(&dist, 1.0) * 1e3,
        100.0 * dist.iter().filter(|d| **d <= 5e-5).count() as f64 / dist.len() as f64
    );
    eprintln!(
        "IK time per target: median {:.2} ms, max {:.2} ms ({:.2} s in all); the written readings solved again (as solve --readings does): largest difference from IK's own tips {:.3e} m (forward tolerance), {} rows not converged",
        percentile(&times, 0.5) * 1e3,
        percentile(&times, 1.0) * 1e3,
        ik_s,
        worst_agree,
        not_converged
    );
    Ok(if counts[0] == targets.len() && not_converged == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
