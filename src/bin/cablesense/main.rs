//! `cablesense`: forward statics, validation and estimation for cable-driven
//! continuum robots. See the README for the commands and `docs/` for the file formats.

mod calibrate;
mod crossval;
mod demo;
mod estimate;
mod output;
mod pareto;
mod plot_track;
mod progress;
mod reach;
mod readings;
mod solve;
mod stability;
mod stream;
mod tendon_estimate;
mod track;
mod validate;
mod workspace;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "cablesense",
    version,
    about = "Cosserat-rod statics and load/shape estimation for cable-driven continuum robots"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Solve the forward statics of a scene: tip poses, guide poses, cable lengths.
    Solve(solve::Args),
    /// Compare the model with the thesis tables shipped in data/thesis.
    Validate(validate::Args),
    /// Fit named scene parameters to observed or predicted table columns.
    Calibrate(Box<calibrate::Args>),
    /// Grouped cross-validation of candidate calibrations on a training recording.
    Crossval(crossval::Args),
    /// Estimate loads and shape from a file of cable length changes.
    Estimate(estimate::Args),
    /// Streaming estimation: encoder rows in (stdin or --input), JSON lines out.
    Track(track::Args),
    /// Chart speed against accuracy of every rung of the model ladder (CSV + SVG).
    Pareto(pareto::Args),
    /// Map where each shooting setting and estimation method stops converging.
    Stability(stability::Args),
    /// The shipped scenes and data embedded in this binary: list them or copy them out.
    Demo(demo::Args),
    /// Servo readings that put the tip at each target (inverse kinematics), as a
    /// readings file for `solve --readings`.
    Reach(reach::Args),
    /// The reachable workspace over the actuator limits: tip cloud, convex hull and
    /// volume, SVG views, the coverage of a recording.
    Workspace(workspace::Args),
}

/// The command line with negative numbers taken as values in every subcommand
/// (`--noise -1` reaches the option's range check instead of clap's "unexpected
/// argument '-1'").
fn command() -> clap::Command {
    fn negatives(c: clap::Command) -> clap::Command {
        let subs: Vec<String> = c
            .get_subcommands()
            .map(|s| s.get_name().to_string())
            .collect();
        let mut c = c.allow_negative_numbers(true);
        for s in subs {
            c = c.mut_subcommand(s, negatives);
        }
        c
    }
    negatives(Cli::command())
}

fn main() -> std::process::ExitCode {
    output::quiet_on_broken_pipe();
    let cli = Cli::from_arg_matches(&command().get_matches()).unwrap_or_else(|e| e.exit());
    // `println!` panics when stdout is a closed pipe (`cablesense ... | head`): the
    // hook above keeps that panic quiet, and it ends here as a quiet exit
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match cli.command {
        Command::Solve(a) => solve::run(a),
        Command::Validate(a) => validate::run(a),
        Command::Calibrate(a) => calibrate::run(*a),
        Command::Crossval(a) => crossval::run(a),
        Command::Estimate(a) => estimate::run(a),
        Command::Track(a) => track::run(a),
        Command::Pareto(a) => pareto::run(a),
        Command::Stability(a) => stability::run(a),
        Command::Demo(a) => demo::run(a),
        Command::Reach(a) => reach::run(a),
        Command::Workspace(a) => workspace::run(a),
    }));
    let result = match result {
        Ok(r) => r,
        Err(_) if output::stdout_was_closed() => return std::process::ExitCode::SUCCESS,
        Err(payload) => std::panic::resume_unwind(payload),
    };
    match result {
        Ok(code) => code,
        // a stream command's `writeln!(stdout)` returned the closed pipe as an error
        Err(e) if output::is_broken_pipe(&e) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}
