//! The shipped demo scenes and data, embedded in the library so that every command
//! that defaults to them works from any directory and after `cargo install`.
//!
//! Each file keeps its repository path relative to `data/` (`scenes/track_demo.toml`,
//! `thesis/table_4_3.csv`, ...). A [`DataRef`] names either a file on disk or an
//! embedded one (`demo:scenes/track_demo.toml`); a [`DataSource`] is a directory of
//! such files (the thesis tables and their scenes), on disk or embedded.
//! [`write_all`] copies the embedded files out (`cablesense demo write DIR`).

use crate::files::thesis::{Table, TableError};
use crate::scene::{Scene, SceneError};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// One embedded file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DemoFile {
    /// Path relative to the repository's `data/` directory, `/`-separated.
    pub path: &'static str,
    /// What the file is for (one line).
    pub about: &'static str,
    /// Contents.
    pub text: &'static str,
}

/// Prefix of an embedded file's name where a path is expected.
pub const PREFIX: &str = "demo:";

macro_rules! demo {
    ($path:literal, $about:literal) => {
        DemoFile {
            path: $path,
            about: $about,
            text: include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/data/", $path)),
        }
    };
}

/// Every embedded file, in `demo list` order.
pub const FILES: &[DemoFile] = &[
    demo!(
        "scenes/demo_two_section.toml",
        "two sections, six cables, two tensioned, a payload (`solve` default)"
    ),
    demo!(
        "scenes/track_demo.toml",
        "thesis-like rod with an estimation problem (`track`, `estimate`, `stability` default)"
    ),
    demo!(
        "measurements/track_demo.csv",
        "encoder recording of the track demo (`track`, `estimate` default input)"
    ),
    demo!(
        "scenes/ftdcr_v4.toml",
        "the real three-segment, nine-tendon FTDCR v4 (displacement-driven tendons; `solve --readings`, `track`)"
    ),
    demo!(
        "scenes/daru.toml",
        "a one-segment, three-cable robot (data/hardware/daru, MIT): the starting scene of its calibration"
    ),
    demo!(
        "scenes/tdcr_modeling.toml",
        "the two-segment robot of the C++ project tdcr-modeling (exact against condensed coupling)"
    ),
    demo!(
        "scenes/till_tendon_robot.toml",
        "John Till's example tendon robot: four straight continuous tendons (Rucker & Webster 2011 routing)"
    ),
    demo!(
        "scenes/till_tendon_readings.toml",
        "Till's robot with its continuous tendons displacement-driven (`solve --readings`)"
    ),
    demo!(
        "measurements/till_tendon_readings.csv",
        "servo readings for Till's displacement-driven robot (`solve demo:scenes/till_tendon_readings.toml --readings ..`)"
    ),
    demo!(
        "scenes/tdcr_two_segment.toml",
        "textbook two-segment tendon-driven robot (displacement-driven tendons)"
    ),
    demo!(
        "measurements/tdcr_two_segment_readings.csv",
        "servo readings for the two-segment TDCR (`track demo:scenes/tdcr_two_segment.toml --input ..`)"
    ),
    demo!(
        "hardware/ftdcr_v4/val.csv",
        "FTDCR v4 held-out recording (MIT, see hardware/ftdcr_v4/LICENSE): servo readings and motion-capture tips"
    ),
    demo!("hardware/ftdcr_v4/LICENSE", "licence of the FTDCR v4 recordings (MIT)"),
    demo!("thesis/README.md", "provenance of the thesis tables"),
    demo!(
        "thesis/fitted.toml",
        "fitted parameter values (`validate`, `calibrate`)"
    ),
    demo!("thesis/table_4_1.csv", "thesis table 4.1 (bare rod)"),
    demo!("thesis/table_4_1.toml", "scene of table 4.1"),
    demo!("thesis/table_4_2.csv", "thesis table 4.2 (bare rod)"),
    demo!("thesis/table_4_2.toml", "scene of table 4.2"),
    demo!("thesis/table_4_3.csv", "thesis table 4.3 (rod with guides)"),
    demo!("thesis/table_4_3.toml", "scene of tables 4.3 and 4.5"),
    demo!(
        "thesis/table_4_3_measured_mass.toml",
        "scene of table 4.3 with the measured guide mass"
    ),
    demo!("thesis/table_4_4.csv", "thesis table 4.4 (rod with guides)"),
    demo!("thesis/table_4_4.toml", "scene of table 4.4"),
    demo!(
        "thesis/table_4_5.csv",
        "thesis table 4.5 (cable length changes)"
    ),
];

/// The demo scene `solve` uses by default.
pub const SOLVE_SCENE: &str = "demo:scenes/demo_two_section.toml";
/// The estimation demo scene (`track`, `estimate`, `stability` default).
pub const TRACK_SCENE: &str = "demo:scenes/track_demo.toml";
/// The encoder recording of the estimation demo.
pub const TRACK_INPUT: &str = "demo:measurements/track_demo.csv";

/// The embedded file at `path` (relative to `data/`), if any.
pub fn get(path: &str) -> Option<&'static DemoFile> {
    FILES.iter().find(|f| f.path == path)
}

/// Embedded files under `dir` (relative to `data/`, e.g. `scenes`), sorted by path.
pub fn under(dir: &str) -> Vec<&'static DemoFile> {
    let mut v: Vec<_> = FILES
        .iter()
        .filter(|f| {
            f.path
                .strip_prefix(dir)
                .is_some_and(|rest| rest.starts_with('/'))
        })
        .collect();
    v.sort_by_key(|f| f.path);
    v
}

/// Why shipped-style data could not be read.
#[derive(Debug, Error)]
pub enum DataError {
    /// A file on disk could not be read.
    #[error("cannot read {path}: {cause}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause (part of the message; not repeated as a `source`).
        cause: std::io::Error,
    },
    /// `demo:NAME` names no embedded file.
    #[error("no embedded file `{PREFIX}{name}` (see `cablesense demo list`)")]
    NoSuchDemo {
        /// The name after `demo:`.
        name: String,
    },
    /// Writing a copy failed.
    #[error("cannot write {path}: {cause}")]
    Write {
        /// File.
        path: PathBuf,
        /// Cause (part of the message; not repeated as a `source`).
        cause: std::io::Error,
    },
}

/// A file argument: a path on disk, or `demo:NAME` for an embedded file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DataRef {
    /// A file on disk.
    Path(PathBuf),
    /// An embedded file.
    Demo(&'static DemoFile),
}

impl DataRef {
    /// Parse a command-line argument: `demo:NAME` is embedded (an error if unknown),
    /// anything else a path.
    pub fn parse(arg: &Path) -> Result<Self, DataError> {
        match arg.to_str().and_then(|s| s.strip_prefix(PREFIX)) {
            Some(name) => get(name)
                .map(Self::Demo)
                .ok_or_else(|| DataError::NoSuchDemo {
                    name: name.to_string(),
                }),
            None => Ok(Self::Path(arg.to_path_buf())),
        }
    }

    /// How to print it: the path, or `demo:NAME`.
    pub fn display(&self) -> String {
        match self {
            Self::Path(p) => p.display().to_string(),
            Self::Demo(f) => format!("{PREFIX}{}", f.path),
        }
    }

    /// The text of the file.
    pub fn read(&self) -> Result<String, DataError> {
        match self {
            Self::Path(p) => std::fs::read_to_string(p).map_err(|cause| DataError::Io {
                path: p.clone(),
                cause,
            }),
            Self::Demo(f) => Ok(f.text.to_string()),
        }
    }

    /// Parse and validate a scene (as [`Scene::load`]; embedded scenes are TOML).
    pub fn scene(&self) -> Result<Scene, SceneError> {
        match self {
            Self::Path(p) => Scene::load(p),
            Self::Demo(f) => Scene::parse_validated(f.text, Path::new(&self.display()), false),
        }
    }
}

/// A directory of tables and scenes: on disk, or the embedded `data/thesis`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DataSource {
    /// A directory on disk.
    Dir(PathBuf),
    /// Embedded files under this directory name (relative to `data/`, e.g. `thesis`).
    Embedded(&'static str),
}

impl DataSource {
    /// The embedded thesis tables (`data/thesis`).
    pub const THESIS: Self = Self::Embedded("thesis");

    /// The file `name` in this directory.
    pub fn file(&self, name: &str) -> Result<DataRef, DataError> {
        match self {
            Self::Dir(d) => Ok(DataRef::Path(d.join(name))),
            Self::Embedded(dir) => {
                let path = format!("{dir}/{name}");
                get(&path)
                    .map(DataRef::Demo)
                    .ok_or(DataError::NoSuchDemo { name: path })
            }
        }
    }

    /// A directory on disk that exists and is a directory, else an error naming it.
    pub fn dir(path: impl Into<PathBuf>) -> Result<Self, DataError> {
        let path = path.into();
        match std::fs::metadata(&path) {
            Ok(m) if m.is_dir() => Ok(Self::Dir(path)),
            Ok(_) => Err(DataError::Io {
                cause: std::io::Error::other("not a directory"),
                path,
            }),
            Err(cause) => Err(DataError::Io { path, cause }),
        }
    }

    /// How to print it.
    pub fn display(&self) -> String {
        match self {
            Self::Dir(d) => d.display().to_string(),
            Self::Embedded(dir) => format!("{PREFIX}{dir} (embedded)"),
        }
    }

    /// Read and parse a scene.
    pub fn scene(&self, name: &str) -> Result<Scene, SceneError> {
        match self.file(name) {
            Ok(r) => r.scene(),
            Err(e) => Err(SceneError::Io {
                path: name.into(),
                cause: std::io::Error::new(std::io::ErrorKind::NotFound, e.to_string()),
            }),
        }
    }

    /// Read and parse a table.
    pub fn table(&self, name: &str) -> Result<Table, TableError> {
        match self.file(name) {
            Ok(DataRef::Path(p)) => Table::load(p),
            Ok(r @ DataRef::Demo(f)) => Table::parse(f.text, &r.display()),
            Err(e) => Err(TableError::Io {
                path: name.into(),
                cause: std::io::Error::new(std::io::ErrorKind::NotFound, e.to_string()),
            }),
        }
    }

    /// The text of `name`; `Ok(None)` when it does not exist.
    pub fn optional_text(&self, name: &str) -> Result<Option<(String, String)>, DataError> {
        match self.file(name) {
            Ok(DataRef::Path(p)) => match std::fs::read_to_string(&p) {
                Ok(t) => Ok(Some((t, p.display().to_string()))),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
                Err(cause) => Err(DataError::Io { path: p, cause }),
            },
            Ok(r @ DataRef::Demo(f)) => Ok(Some((f.text.to_string(), r.display()))),
            Err(DataError::NoSuchDemo { .. }) => Ok(None),
            Err(e) => Err(e),
        }
    }
}

/// Copy every embedded file into `dir` (keeping the `scenes/`, `measurements/`,
/// `thesis/` layout); existing files are overwritten. Returns the written paths.
pub fn write_all(dir: &Path) -> Result<Vec<PathBuf>, DataError> {
    let mut out = Vec::with_capacity(FILES.len());
    for f in FILES {
        let path = f.path.split('/').fold(dir.to_path_buf(), |p, c| p.join(c));
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(|cause| DataError::Write {
                path: parent.to_path_buf(),
                cause,
            })?;
        }
        std::fs::write(&path, f.text).map_err(|cause| DataError::Write {
            path: path.clone(),
            cause,
        })?;
        out.push(path);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every embedded scene parses and validates, and every table parses.
    #[test]
    fn embedded_files_parse() {
        for f in FILES {
            let r = DataRef::Demo(f);
            if f.path.ends_with(".toml") && !f.path.ends_with("fitted.toml") {
                r.scene().unwrap_or_else(|e| panic!("{}: {e}", f.path));
            } else if f.path.ends_with(".csv") && f.path.starts_with("thesis/") {
                Table::parse(f.text, f.path).unwrap_or_else(|e| panic!("{}: {e}", f.path));
            }
        }
    }

    /// The embedded copies are the files in `data/` (the list is complete for the
    /// directories it covers).
    #[test]
    fn registry_covers_the_data_directories() {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
        for dir in ["scenes", "measurements", "thesis"] {
            let mut on_disk: Vec<String> = std::fs::read_dir(data.join(dir))
                .unwrap()
                .map(|e| format!("{dir}/{}", e.unwrap().file_name().to_string_lossy()))
                .collect();
            on_disk.sort();
            let embedded: Vec<String> = under(dir).iter().map(|f| f.path.to_string()).collect();
            assert_eq!(on_disk, embedded, "data/{dir}");
        }
    }

    #[test]
    fn refs_parse() {
        assert!(matches!(
            DataRef::parse(Path::new(TRACK_SCENE)).unwrap(),
            DataRef::Demo(_)
        ));
        let e = DataRef::parse(Path::new("demo:nope.toml")).unwrap_err();
        assert!(e.to_string().contains("demo:nope.toml"), "{e}");
        assert!(matches!(
            DataRef::parse(Path::new("a/b.toml")).unwrap(),
            DataRef::Path(_)
        ));
    }
}
