//! `cablesense validate`: the thesis tables (being written).

/// Arguments of `validate`.
#[derive(clap::Args)]
pub struct Args {}

/// Run `validate`.
pub fn run(_a: Args) -> anyhow::Result<std::process::ExitCode> {
    anyhow::bail!("validate is being implemented")
}
