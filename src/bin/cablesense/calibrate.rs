//! `cablesense calibrate`: parameter fitting (being written).

/// Arguments of `calibrate`.
#[derive(clap::Args)]
pub struct Args {}

/// Run `calibrate`.
pub fn run(_a: Args) -> anyhow::Result<std::process::ExitCode> {
    anyhow::bail!("calibrate is being implemented")
}
