//! `cablesense demo list | write DIR`: the shipped scenes and data embedded in the
//! binary (`cablesense::files::demo`), listed or copied out.

use cablesense::files::demo;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `demo`.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    action: Action,
}

#[derive(clap::Subcommand)]
enum Action {
    /// List the embedded files (use them as `demo:NAME` wherever a file is expected).
    List,
    /// Copy every embedded file into DIR (scenes/, measurements/, thesis/).
    Write {
        /// Target directory (created if missing).
        dir: PathBuf,
        /// Overwrite files that exist (without it, an existing file is an error and
        /// nothing is written).
        #[arg(long)]
        force: bool,
    },
}

/// Run `demo`.
pub fn run(a: Args) -> anyhow::Result<ExitCode> {
    match a.action {
        Action::List => {
            for f in demo::FILES {
                println!("{}{:<40} {}", demo::PREFIX, f.path, f.about);
            }
        }
        Action::Write { dir, force } => {
            if !force {
                let existing: Vec<PathBuf> = demo::FILES
                    .iter()
                    .map(|f| f.path.split('/').fold(dir.clone(), |p, c| p.join(c)))
                    .filter(|p| p.exists())
                    .collect();
                if let Some(first) = existing.first() {
                    anyhow::bail!(
                        "{}: {} of the demo files exist already (first: {}); nothing written (--force overwrites them)",
                        dir.display(),
                        existing.len(),
                        first.display()
                    );
                }
            }
            for p in demo::write_all(&dir)? {
                println!("wrote {}", p.display());
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
