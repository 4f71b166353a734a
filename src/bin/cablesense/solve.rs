//! `cablesense solve SCENE`: forward statics, with the scene's own settings or a rung
//! of the model ladder (`--model`, including `auto`: the cheapest rung within
//! `--tol` / `--tol-cable`).

use crate::output::{mm, tangent, write_samples_csv};
use anyhow::Context;
use cablesense::ladder::{self, AutoChoice, AutoSettings, Rung};
use cablesense::{Scene, SolverSettings, Start, Workspace};
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `solve`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene file (.toml or .json), or `demo:NAME` for a shipped one (`cablesense demo
    /// list`). Default: the shipped demo robot.
    #[arg(default_value = cablesense::files::demo::SOLVE_SCENE)]
    scene: PathBuf,
    /// Print JSON (schema in docs/output-schema.md) instead of text.
    #[arg(long)]
    json: bool,
    /// Write the backbone samples as CSV to this file.
    #[arg(long)]
    samples: Option<PathBuf>,
    /// Draw backbone, disks and cables in the xy, xz and yz views to this SVG file
    /// (rod models).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Forward model: `scene` (the scene's [numerics], the default), `auto` (the
    /// cheapest rung of the ladder within --tol and --tol-cable), or a rung label such
    /// as `cc`, `pcc/point/16`, `kirchhoff/average/rk4-16`, `cosserat/accurate/adaptive-1e-8`.
    #[arg(long, default_value = "scene")]
    model: String,
    /// Tip position target for `--model auto` (a length with unit: m, cm, mm, um, nm).
    #[arg(long, default_value = "0.1mm", value_parser = parse_len)]
    tol: f64,
    /// Cable length target for `--model auto` (a length with unit).
    #[arg(long = "tol-cable", default_value = "1um", value_parser = parse_len)]
    tol_cable: f64,
    /// Solve every row of this readings file (CSV or JSON lines) of a scene with
    /// displacement-driven tendons, warm-started row to row: tip per row beside the
    /// measured one, tensions and slack flags (`--json`: one object per row;
    /// `--samples`: every row's backbone, with a `line` column). With `--model auto`
    /// the readings ladder (CC/PCC kinematics, rod rungs through the tendon solve) is
    /// ranked on up to `--probe-rows` evenly spaced rows of the file and the pick solves every row
    /// (`--json`: the choice is the first line, `{"model_choice": ...}`); `--model
    /// cc`, `pcc/none/16`, ... name a rung (the kinematics rungs report no tensions).
    #[arg(long)]
    readings: Option<PathBuf>,
    /// Rows of the readings file `--model auto` ranks the models on (evenly spaced,
    /// first and last included).
    #[arg(long = "probe-rows", default_value_t = ladder::PROBE_ROWS)]
    probe_rows: usize,
}

/// `solve SCENE --readings FILE`: exit 0 when every row converged. `--model scene`
/// solves with the scene's numerics; `auto` ranks the readings ladder on a sample of
/// the file's rows ([`ladder::choose_readings`]) and solves with the pick; a label
/// names a rung of the readings ladder (or any rod rung).
fn solve_readings(a: &Args, scene: &Scene, path: &std::path::Path) -> anyhow::Result<ExitCode> {
    use crate::readings::{is_tendon_scene, stream, stream_kinematics, Output};
    anyhow::ensure!(
        is_tendon_scene(scene),
        "{}: no cable has actuation = \"displacement\": --readings needs displacement-driven tendons",
        a.scene.display()
    );
    if let Some(p) = &a.plot {
        // one figure of one solve; a readings file has a shape per row
        anyhow::bail!(
            "--plot {}: draws a single solve, not the rows of --readings (--samples FILE writes every row's backbone)",
            p.display()
        );
    }
    // a path, or `demo:NAME` for a shipped file (as `track --input`)
    let open = || crate::stream::open_input(path);
    let output = if a.json { Output::Json } else { Output::Text };
    let rung = match a.model.as_str() {
        "scene" => Rung::Rod(scene.numerics.clone()),
        "auto" => {
            let choice = choose_for_readings(a, scene, open()?)?;
            match output {
                Output::Json => println!("{}", serde_json::json!({ "model_choice": choice })),
                Output::Text => print_choice(&choice, a.tol, a.tol_cable, "probe rows"),
            }
            choice.rung
        }
        label => readings_rung_by_label(&scene.build_robot()?, label)?,
    };
    // (an empty file, or a header alone, is an error below: nothing was solved)
    let (reader, content) = crate::stream::open_watched(path)?;
    let (solved, converged, bad) = match rung {
        Rung::Rod(numerics) => {
            let mut samples = match &a.samples {
                Some(p) => Some(std::io::BufWriter::new(
                    std::fs::File::create(p)
                        .with_context(|| format!("creating {}", p.display()))?,
                )),
                None => None,
            };
            let scene = Scene {
                numerics,
                ..scene.clone()
            };
            stream(
                &scene,
                &a.scene,
                reader,
                output,
                samples.as_mut().map(|w| w as &mut dyn std::io::Write),
            )?
        }
        other => {
            if a.samples.is_some() {
                eprintln!(
                    "note: --samples needs a rod rung; {} has no backbone samples",
                    other.label()
                );
            }
            stream_kinematics(scene, &a.scene, &other, reader, output)?
        }
    };
    if let Some(why) = crate::stream::no_rows(path, solved + bad, &content) {
        eprintln!("error: {why}");
        return Ok(ExitCode::from(1));
    }
    if !a.json {
        println!("{solved} rows solved, {converged} converged, {bad} bad rows");
    }
    Ok(if converged == solved && bad == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// `--model auto` on a readings file: the readings ladder ranked on up to
/// [`ladder::PROBE_ROWS`] rows of the file, evenly spaced (rows the parser rejects
/// are skipped here; the stream reports them).
fn choose_for_readings(
    a: &Args,
    scene: &Scene,
    reader: Box<dyn std::io::BufRead>,
) -> anyhow::Result<AutoChoice> {
    use std::io::BufRead;
    anyhow::ensure!(
        a.probe_rows >= 1,
        "--probe-rows 0: the models are ranked on at least one row"
    );
    let ws = scene.tendon_workspace()?;
    let mut parser = scene.readings_parser(&ws);
    let mut rows = Vec::new();
    for (i, line) in reader.lines().enumerate() {
        // a line that is not UTF-8 is skipped like a bad row (the stream reports it)
        let Ok(line) = crate::stream::stream_line(line, i + 1)? else {
            continue;
        };
        if let Ok(Some(r)) = parser.line(i + 1, &line) {
            rows.push(r.readings_m);
        }
    }
    anyhow::ensure!(
        !rows.is_empty(),
        "{}: no usable row of readings to rank the models on",
        a.readings
            .as_ref()
            .map_or(String::new(), |p| p.display().to_string())
    );
    let robot = scene.build_robot()?;
    let settings = AutoSettings {
        tip_tolerance_m: a.tol,
        cable_tolerance_m: a.tol_cable,
        ..AutoSettings::default()
    };
    Ok(ladder::choose_readings(
        &robot,
        &scene.loads,
        &ladder::probe_rows(&rows, a.probe_rows),
        &settings,
        &ladder::readings_ladder(&robot),
    )?)
}

/// The rung with this label ([`Rung::from_label`]) for solving readings: CC, PCC
/// without guide mass (the kinematics has none) or any rod rung; the error names the
/// bad part of the label and lists the readings ladder's labels.
fn readings_rung_by_label(robot: &cablesense::Robot, label: &str) -> anyhow::Result<Rung> {
    let rung = Rung::from_label(label).map_err(|e| {
        anyhow::anyhow!(
            "unknown --model `{label}` for readings: {}; use scene, auto or one of: {}",
            label_why(e),
            labels(&ladder::readings_ladder(robot))
        )
    })?;
    if let Rung::PiecewiseConstantCurvature(p) = &rung {
        anyhow::ensure!(
            p.guide_mass == cablesense::GuideMass::None,
            "--model {label} for readings: the constant-curvature kinematics has no guide mass; use pcc/none/{}",
            p.pieces_per_section
        );
    }
    curvature_fits(robot, &rung)?;
    Ok(rung)
}

/// The rungs' labels, comma-separated (the error messages' lists).
fn labels(rungs: &[Rung]) -> String {
    rungs.iter().map(Rung::label).collect::<Vec<_>>().join(", ")
}

/// Why a label names no rung, without the list of spellings (the caller lists labels).
fn label_why(e: ladder::LadderError) -> String {
    match e {
        ladder::LadderError::Label { why, .. } => why,
        other => other.to_string(),
    }
}

/// A curvature rung (CC, PCC) on a robot with a continuously routed tendon it cannot
/// take: the error says why.
fn curvature_fits(robot: &cablesense::Robot, rung: &Rung) -> anyhow::Result<()> {
    if !matches!(rung, Rung::Rod(_)) {
        ladder::reject_continuous(robot)?;
    }
    Ok(())
}

fn parse_len(s: &str) -> Result<f64, String> {
    ladder::parse_length(s).map_err(|e| e.to_string())
}

/// The rung with this label (`cc`, `pcc/point/16`, ...; [`Rung::from_label`]); the
/// error names the bad part of the label and lists `extra` (the command's other
/// choices) and the full ladder's labels.
pub fn rung_by_label(robot: &cablesense::Robot, label: &str, extra: &str) -> anyhow::Result<Rung> {
    let rung = Rung::from_label(label).map_err(|e| {
        anyhow::anyhow!(
            "unknown --model `{label}`: {}; use {extra} or a rung label, {}; the ladder of this robot: {}",
            label_why(e),
            ladder::LABEL_SPELLINGS,
            labels(&ladder::full_ladder(robot))
        )
    })?;
    // not in this robot's ladder when a tendon is routed continuously: say why
    curvature_fits(robot, &rung)?;
    Ok(rung)
}

/// Run `solve`. Exit code 0 when converged, 1 when the solver did not converge.
pub fn run(a: Args) -> anyhow::Result<ExitCode> {
    let scene = cablesense::files::demo::DataRef::parse(&a.scene)?.scene()?;
    if let Some(path) = &a.readings {
        return solve_readings(&a, &scene, path);
    }
    let robot = scene.build_robot()?;
    let (rung, choice) = match a.model.as_str() {
        "scene" => (Rung::Rod(scene.numerics.clone()), None),
        "auto" => {
            let settings = AutoSettings {
                tip_tolerance_m: a.tol,
                cable_tolerance_m: a.tol_cable,
                ..AutoSettings::default()
            };
            let choice = ladder::choose(
                &robot,
                &scene.loads,
                &settings,
                &ladder::auto_ladder(&robot),
            )?;
            (choice.rung.clone(), Some(choice))
        }
        label => (rung_by_label(&robot, label, "scene, auto")?, None),
    };
    if let (Some(c), false) = (&choice, a.json) {
        print_choice(c, a.tol, a.tol_cable, "probe load factors");
    }
    match rung {
        Rung::Rod(settings) => solve_rod(&a, &scene, settings, choice.as_ref()),
        other => solve_curvature(&a, &scene, &other, choice.as_ref()),
    }
}

/// What `--model auto` picked and why the cheaper rungs were rejected; `probe` names
/// what `c.probe_factors` holds (load factors, or the positions of probe rows).
fn print_choice(c: &AutoChoice, tol: f64, tol_cable: f64, probe: &str) {
    println!(
        "model auto: targets tip {:.4} mm, cable {:.4} um; {probe} {:?}; errors against {} (its own error ~{:.1e} m tip, {:.1e} m cable)",
        tol * 1e3,
        tol_cable * 1e6,
        c.probe_factors,
        c.reference,
        c.reference_tip_error_m,
        c.reference_cable_error_m
    );
    println!(
        "  {:<34} {:>12} {:>12} {:>10}  verdict",
        "rung", "tip err mm", "cable err um", "time us"
    );
    let picked_time = c.picked_report().map_or(f64::INFINITY, |p| p.time_s);
    for r in &c.candidates {
        // show every rung that is cheaper than the pick (why it was rejected) and the pick
        if r.time_s <= picked_time || matches!(r.verdict, ladder::Verdict::Picked) {
            println!(
                "  {:<34} {:>12.5} {:>12.4} {:>10.1}  {}",
                r.label,
                r.tip_error_m * 1e3,
                r.cable_error_m * 1e6,
                r.time_s * 1e6,
                r.verdict
            );
        }
    }
    match c.picked_report() {
        Some(p) => println!(
            "picked {}: estimated error {:.4} mm tip, {:.4} um cable, {:.1} us per solve\n",
            p.label,
            p.tip_error_m * 1e3,
            p.cable_error_m * 1e6,
            p.time_s * 1e6
        ),
        None => println!(
            "no rung met the targets: using the reference {}\n",
            c.reference
        ),
    }
}

fn solve_curvature(
    a: &Args,
    scene: &Scene,
    rung: &Rung,
    choice: Option<&AutoChoice>,
) -> anyhow::Result<ExitCode> {
    let robot = scene.build_robot()?;
    let mut model = rung.build(&robot)?;
    let started = std::time::Instant::now();
    let report = model.solve(&scene.loads, Start::Cold)?;
    let elapsed = started.elapsed();
    let out = model.output();
    if a.samples.is_some() || a.plot.is_some() {
        eprintln!(
            "note: --samples and --plot need a rod rung; {} has no backbone samples",
            rung.label()
        );
    }
    if a.json {
        let json = serde_json::json!({
            "scene": a.scene.display().to_string(),
            "units": {"length": "m", "time": "s"},
            "model": rung.label(),
            "auto": choice,
            "solve_time_s": elapsed.as_secs_f64(),
            "output": out,
        });
        println!("{}", serde_json::to_string_pretty(&json)?);
    } else {
        println!("scene: {}  model: {}", a.scene.display(), rung.label());
        println!(
            "status: {:?}  iterations: {}  residual: {:.2e}  time: {:.1} us",
            report.status,
            report.iterations,
            report.residual,
            elapsed.as_secs_f64() * 1e6
        );
        println!("\nsection tips (mm; tangent = local z axis):");
        for (k, p) in out.section_tips.iter().enumerate() {
            println!("  {k:>8} {}   {}", mm(&p.position), tangent(p));
        }
        if !out.guides.is_empty() {
            println!("\nguide disks (mm):");
            for (g, p) in out.guides.iter().enumerate() {
                println!("  {g:>8} {}   {}", mm(&p.position), tangent(p));
            }
        }
        if !out.cable_lengths.is_empty() {
            println!("\ncable lengths from the base plate (mm):");
            for (c, l) in robot.cables().iter().zip(&out.cable_lengths) {
                println!("  {:<10} {:12.4}", c.name, l * 1e3);
            }
        }
    }
    Ok(if report.status.is_converged() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

fn solve_rod(
    a: &Args,
    scene: &Scene,
    settings: SolverSettings,
    choice: Option<&AutoChoice>,
) -> anyhow::Result<ExitCode> {
    let robot = scene.build_robot()?;
    let label = (a.model != "scene").then(|| Rung::Rod(settings.clone()).label());
    let mut ws = Workspace::new(robot, scene.loads.clone(), settings)?;
    let started = std::time::Instant::now();
    let report = ws.solve(Start::Cold);
    let elapsed = started.elapsed();
    let sol = ws.solution();
    if let Some(p) = &a.samples {
        write_samples_csv(p, &sol.samples).with_context(|| format!("writing {}", p.display()))?;
    }
    if let Some(p) = &a.plot {
        let title = format!("{} ({:?})", a.scene.display(), report.status);
        let svg = cablesense::files::svg::Figure::shape(title, ws.robot(), &sol).to_svg();
        std::fs::write(p, svg).with_context(|| format!("writing {}", p.display()))?;
    }
    if a.json {
        let mut out = serde_json::json!({
            "scene": a.scene.display().to_string(),
            "units": {"length": "m", "force": "N", "moment": "N m", "time": "s"},
            "solve_time_s": elapsed.as_secs_f64(),
            "solution": sol,
        });
        if let Some(label) = &label {
            out["model"] = serde_json::json!(label);
            out["auto"] = serde_json::json!(choice);
        }
        if !report.status.is_converged() {
            out["diagnosis"] = serde_json::json!(ws.diagnose());
        }
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        match &label {
            Some(l) => println!("scene: {}  model: {l}", a.scene.display()),
            None => println!("scene: {}", a.scene.display()),
        }
        if !scene.description.is_empty() {
            println!("  {}", scene.description);
        }
        println!(
            "status: {:?}  iterations: {}  residual: {:.2e}  unknowns: {}  rhs evals: {}  jacobians: {}  continuation steps: {}  time: {:.1} us",
            report.status,
            report.iterations,
            report.residual,
            report.unknowns,
            report.rhs_evals,
            report.jacobian_evals,
            report.continuation_steps,
            elapsed.as_secs_f64() * 1e6
        );
        println!("\nsection tips (mm; tangent = local z axis):");
        println!(
            "  {:>8} {:>32}   {:>26}",
            "section", "position x y z", "tangent"
        );
        for (k, p) in sol.section_tips.iter().enumerate() {
            println!("  {k:>8} {}   {}", mm(&p.position), tangent(p));
        }
        if !sol.guides.is_empty() {
            println!("\nguide disks (mm):");
            println!(
                "  {:>8} {:>6} {:>9} {:>32}   {:>26}",
                "section", "guide", "s", "position x y z", "normal"
            );
            for g in &sol.guides {
                println!(
                    "  {:>8} {:>6} {:>9.3} {}   {}",
                    g.section,
                    g.index,
                    g.s * 1e3,
                    mm(&g.pose.position),
                    tangent(&g.pose)
                );
            }
        }
        if !sol.cables.is_empty() {
            println!("\ncable lengths from the base plate (mm):");
            for (j, c) in sol.cables.iter().enumerate() {
                let tension = scene.loads.tension(j);
                println!(
                    "  {:<10} {:12.4}   tension {:.3} N   chords: {}",
                    c.name,
                    c.total_m * 1e3,
                    tension,
                    c.segments_m
                        .iter()
                        .map(|l| format!("{:.3}", l * 1e3))
                        .collect::<Vec<_>>()
                        .join(" ")
                );
            }
        }
        println!(
            "\nbase reaction: n(0) = [{:.4} {:.4} {:.4}] N, m(0) = [{:.5} {:.5} {:.5}] N m",
            sol.base_force.x,
            sol.base_force.y,
            sol.base_force.z,
            sol.base_moment.x,
            sol.base_moment.y,
            sol.base_moment.z
        );
    }
    if !report.status.is_converged() {
        // why, in the scene's terms (the shape above is the best iterate)
        eprintln!("error: {}", ws.diagnose());
    }
    Ok(if report.status.is_converged() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

#[cfg(test)]
mod tests {
    use super::{readings_rung_by_label, rung_by_label};
    use cablesense::{Robot, Scene};

    fn robot(path: &str) -> Robot {
        Scene::load(path).unwrap().build_robot().unwrap()
    }

    /// `--model LABEL` takes any label `Rung::from_label` reads, in the robot's ladder
    /// or not, and refuses a bad one naming the bad part, the other choices and the
    /// ladder's labels.
    #[test]
    fn any_valid_label_is_taken_and_a_bad_one_named() {
        let r = robot("data/scenes/ftdcr_v4.toml");
        for label in [
            "cosserat/point/rk4-10/arc",
            "pcc/none/8",
            "kirchhoff/accurate/rk4-16",
        ] {
            assert_eq!(rung_by_label(&r, label, "scene").unwrap().label(), label);
        }
        let e = rung_by_label(&r, "cosserat/heavy/rk4-8", "scene, auto")
            .unwrap_err()
            .to_string();
        for part in [
            "unknown --model `cosserat/heavy/rk4-8`",
            "`heavy` is not a guide-mass model",
            "use scene, auto",
            "kirchhoff/average/rk4-4",
        ] {
            assert!(e.contains(part), "{part}: {e}");
        }
    }

    /// On readings: any rod label and CC, PCC only without guide mass (the kinematics
    /// has none); a bad label lists the readings ladder.
    #[test]
    fn readings_labels_refuse_a_pcc_with_mass() {
        let r = robot("data/scenes/ftdcr_v4.toml");
        for label in [
            "cc",
            "pcc/none/16",
            "cosserat/point/rk4-10",
            "kirchhoff/none/rk4-8/exact",
        ] {
            assert_eq!(readings_rung_by_label(&r, label).unwrap().label(), label);
        }
        let e = readings_rung_by_label(&r, "pcc/point/16")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("no guide mass") && e.contains("pcc/none/16"),
            "{e}"
        );
        let e = readings_rung_by_label(&r, "nope").unwrap_err().to_string();
        assert!(
            e.contains("unknown --model `nope` for readings") && e.contains("pcc/none/16"),
            "{e}"
        );
    }

    /// CC and PCC refuse a helical continuous tendon by name, for both jobs; the rod
    /// rungs take it.
    #[test]
    fn curvature_labels_refuse_a_helical_tendon() {
        let text = std::fs::read_to_string("data/scenes/till_tendon_robot.toml")
            .unwrap()
            .replacen(
                "path = { straight = { radius_m = 0.01506, angle_deg = 0.0 } }",
                "path = { helical = { radius_m = 0.01506, start_angle_deg = 0.0, pitch_m_per_turn = 0.6 } }",
                1,
            );
        let r = Scene::from_toml_str(&text).unwrap().build_robot().unwrap();
        for label in ["cc", "pcc/none/8"] {
            let e = rung_by_label(&r, label, "scene").unwrap_err().to_string();
            assert!(e.contains("robot.cables[0].routing"), "{label}: {e}");
            let e = readings_rung_by_label(&r, label).unwrap_err().to_string();
            assert!(e.contains("robot.cables[0].routing"), "{label}: {e}");
        }
        assert!(rung_by_label(&r, "cosserat/none/rk4-16", "scene").is_ok());
    }
}
