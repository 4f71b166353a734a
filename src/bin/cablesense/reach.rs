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
//!
//! `--measured [--recording FILE]`: the recording's measured marker positions as
//! targets (the scene's `[calibration]` columns, mapped to the base frame by its
//! `capture_to_base`), each less the marker offset turned by the model's tip
//! orientation at the row's recorded readings (the measured orientation is not
//! recorded), those readings conditioned as `track` and `validate` condition them
//! (the scene's `[readings]` time offset and backlash, row to row); without `--recording`, with the embedded scene, its val.csv. The model's
//! error seen from the other side: how far the closest reachable tip lies from
//! each measured one, beside the forward error at the recorded readings.
//!
//! The targets are solved as a chain (`cablesense::command::ik::IkChain`): warm
//! from the previous row when it was reached, else from the last reached row, and a
//! row that ends out of budget or more than 0.5 mm away solved once more from zero
//! readings, the better end kept.

use anyhow::{bail, Context};
use cablesense::calibrate::RigidTransform;
use cablesense::command::ik::IkChain;
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
    /// Targets: the measured tips of a recording (the scene's `[calibration]`
    /// columns): `--recording FILE`, or with the embedded scene its val.csv.
    #[arg(long, conflicts_with = "targets")]
    measured: bool,
    /// The recording whose measured tips `--measured` takes as targets.
    #[arg(long, value_name = "FILE", requires = "measured")]
    recording: Option<PathBuf>,
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

/// The measured tips of a recording as targets (module docs), and per row the
/// forward error at the recorded readings (m: the model's marker point less the
/// measured one) and whether the model's orientation there was available (the
/// forward solve converged; else the last converged row's is used).
struct Measured {
    targets: Vec<IkTarget>,
    forward_error_m: Vec<f64>,
    no_orientation: usize,
}

fn measured_targets(scene: &Scene, text: &str, file: &str) -> anyhow::Result<Measured> {
    let cal = scene.calibration.clone().with_context(|| {
        format!("--measured: the scene has no [calibration] table (its measured columns and capture_to_base) to read {file} with")
    })?;
    let frame = RigidTransform::from_spec(&cal.capture_to_base);
    let offset = Vector3::from(cal.marker_offset_m);
    // the recorded readings as `track` and `validate` solve them: conditioned by the
    // scene's `[readings]` time offset and backlash, warm from row to row
    let mut chain = TrackChain::for_scene(scene, scene.tendon_workspace()?);
    let mut parser = scene.readings_parser(chain.workspace());
    let mut out = Measured {
        targets: Vec::new(),
        forward_error_m: Vec::new(),
        no_orientation: 0,
    };
    let mut rotation = cablesense::nalgebra::Matrix3::identity();
    for (i, l) in text.lines().enumerate() {
        let row = match parser.line(i + 1, l) {
            Ok(Some(r)) => r,
            Ok(None) => continue,
            Err(e) => bail!("{file}: {e}"),
        };
        let Some(m) = row.measured_tip_m else {
            bail!(
                "{file}:{}: no measured tip (the scene's [calibration] columns) on this row",
                i + 1
            );
        };
        let marker = frame.apply(&Vector3::from(m));
        let step = chain
            .step_at(row.t_s, &row.readings_m)
            .with_context(|| format!("{file}:{}: readings", i + 1))?;
        if step.report.status.is_converged() {
            let pose = *chain.workspace_mut().workspace_mut().solution().tip();
            rotation = pose.rotation;
            out.forward_error_m
                .push((pose.position + pose.rotation * offset - marker).norm());
        } else {
            out.no_orientation += 1;
            out.forward_error_m.push(f64::NAN);
        }
        out.targets
            .push(IkTarget::position(marker - rotation * offset));
    }
    if out.targets.is_empty() {
        bail!("{file}: no rows with readings and a measured tip");
    }
    Ok(out)
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
    let mut measured = None;
    let targets = match (&a.targets, a.measured, &a.scene) {
        (Some(f), _, _) => {
            let text =
                std::fs::read_to_string(f).with_context(|| format!("reading {}", f.display()))?;
            parse_targets(&text, &f.display().to_string())?
        }
        (None, true, scene_arg) => {
            let (text, file) = match (&a.recording, scene_arg) {
                (Some(f), _) => (
                    std::fs::read_to_string(f)
                        .with_context(|| format!("reading {}", f.display()))?,
                    f.display().to_string(),
                ),
                (None, None) => (VAL_CSV.to_string(), "val.csv (embedded)".to_string()),
                (None, Some(_)) => bail!("--measured needs --recording FILE for {name}"),
            };
            let m = measured_targets(&scene, &text, &file)?;
            let t = m.targets.clone();
            measured = Some((m, file));
            t
        }
        (None, false, None) => val_tips(&scene)?,
        (None, false, Some(_)) => {
            bail!("give --targets FILE (x_m,y_m,z_m per row) or --measured --recording FILE for {name}")
        }
    };
    let settings = IkSettings {
        objective,
        tolerance_m: a.tolerance_mm * 1e-3,
        ..IkSettings::default()
    };
    let mut ik = IkChain::new(
        IkWorkspace::from_scene(&scene, settings)
            .with_context(|| format!("{name}: building the inverse solver"))?,
    );
    let spec = scene.readings.clone().unwrap_or_default();
    let (scale, backlash) = (spec.scale_m, spec.backlash_m);
    let columns = ik.workspace().tendon_workspace().columns().to_vec();
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
        let row = ik.solve(t)?;
        times.push(s.elapsed().as_secs_f64());
        reports.push(row);
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
            "row,status,tip_x_m,tip_y_m,tip_z_m,distance_m,ik_distance_m,iterations,forward_solves,start,attempts\n",
        );
        for (k, ((row, tip), t)) in reports.iter().zip(&solved).zip(&targets).enumerate() {
            let r = &row.report;
            let (tip, d) = match tip {
                Some(tip) => (*tip, (t.position_m - tip).norm()),
                None => (Vector3::repeat(f64::NAN), f64::NAN),
            };
            writeln!(
                rep,
                "{k},{},{},{},{},{},{},{},{},{},{}",
                r.status.name(),
                tip.x,
                tip.y,
                tip.z,
                d,
                r.distance_m,
                r.iterations,
                r.forward_solves,
                row.start.name(),
                row.attempts
            )?;
        }
        std::fs::write(p, rep).with_context(|| format!("writing {}", p.display()))?;
    }
    // summary (standard error: standard output may be the readings)
    let mut counts = [0usize; 3];
    let mut dist = Vec::new();
    let (mut worst_agree, mut not_converged) = (0.0f64, 0);
    let mut retried = 0;
    for (row, tip) in reports.iter().zip(&solved) {
        let r = &row.report;
        retried += usize::from(row.attempts > 1);
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
    eprintln!("{retried} targets solved again from zero readings (out of budget or more than 0.5 mm away from the first start)");
    if let Some((m, file)) = &measured {
        let mut f: Vec<f64> = m
            .forward_error_m
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        f.sort_by(f64::total_cmp);
        let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        eprintln!(
            "measured tips of {file}: forward error at the recorded readings, conditioned as `track` conditions them (mm): RMSE {:.3}, median {:.3}, max {:.3} ({} rows without a converged forward solve); reached distance RMS {:.3} mm",
            rms(&f) * 1e3,
            percentile(&f, 0.5) * 1e3,
            percentile(&f, 1.0) * 1e3,
            m.no_orientation,
            rms(&dist) * 1e3
        );
    }
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
