//! `cablesense`: forward statics, validation and estimation for cable-driven
//! continuum robots. See the README for the commands and file formats.

mod calibrate;
mod output;
mod solve;
mod validate;

use clap::{Parser, Subcommand};

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
    Calibrate(calibrate::Args),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Solve(a) => solve::run(a),
        Command::Validate(a) => validate::run(a),
        Command::Calibrate(a) => calibrate::run(a),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}
