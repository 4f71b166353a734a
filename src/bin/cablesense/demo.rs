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
        /// Target directory (created if missing; existing files are overwritten).
        dir: PathBuf,
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
        Action::Write { dir } => {
            for p in demo::write_all(&dir)? {
                println!("wrote {}", p.display());
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
