//! `cablesense solve SCENE`: forward statics.

use crate::output::{mm, tangent, write_samples_csv};
use anyhow::Context;
use cablesense::{Scene, Start, Workspace};
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `solve`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene file (.toml or .json). Default: the shipped demo robot.
    #[arg(default_value = "data/scenes/demo_two_section.toml")]
    scene: PathBuf,
    /// Print JSON (schema in the README) instead of text.
    #[arg(long)]
    json: bool,
    /// Write the backbone samples as CSV to this file.
    #[arg(long)]
    samples: Option<PathBuf>,
}

/// Run `solve`. Exit code 0 when converged, 1 when the solver did not converge.
pub fn run(a: Args) -> anyhow::Result<ExitCode> {
    let scene = Scene::load(&a.scene)?;
    let robot = scene.build_robot()?;
    let mut ws = Workspace::new(robot, scene.loads.clone(), scene.numerics.clone())?;
    let started = std::time::Instant::now();
    let report = ws.solve(Start::Cold);
    let elapsed = started.elapsed();
    let sol = ws.solution();
    if let Some(p) = &a.samples {
        write_samples_csv(p, &sol.samples).with_context(|| format!("writing {}", p.display()))?;
    }
    if a.json {
        let out = serde_json::json!({
            "scene": a.scene.display().to_string(),
            "units": {"length": "m", "force": "N", "moment": "N m", "time": "s"},
            "solve_time_s": elapsed.as_secs_f64(),
            "solution": sol,
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!("scene: {}", a.scene.display());
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
    Ok(if report.status.is_converged() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
