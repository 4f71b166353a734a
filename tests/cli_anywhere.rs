//! The `cablesense` binary run from a directory outside the repository: shipped data
//! embedded (`demo:` files, no-argument defaults), errors printed with their cause
//! once, missing data a non-zero exit, BOM/CRLF encoder files, a bad CSV header
//! reported once, poor fits flagged.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_cablesense");

/// A fresh, empty directory under the system temp dir (removed on drop).
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        use std::sync::atomic::{AtomicUsize, Ordering};
        static N: AtomicUsize = AtomicUsize::new(0);
        let dir = std::env::temp_dir().join(format!(
            "cablesense-cli-{tag}-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Self(dir)
    }
    fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Run the binary in `dir` with `args`.
fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the binary runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// JSON lines of stdout.
fn json_lines(o: &Output) -> Vec<serde_json::Value> {
    text(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

#[test]
fn no_argument_commands_work_outside_the_repository() {
    let tmp = TempDir::new("defaults");
    let o = run(tmp.path(), &["solve"]);
    assert!(o.status.success(), "solve: {}", text(&o.stderr));
    assert!(text(&o.stdout).contains("status: Converged"));

    let o = run(tmp.path(), &["track"]);
    let lines = json_lines(&o);
    let samples = lines.iter().filter(|l| l.get("estimate").is_some()).count();
    assert!(o.status.success(), "track: {}", text(&o.stderr));
    // 42 lines: a comment, the header, 37 samples (one with a missing cable), 3
    // deliberately bad rows
    assert_eq!(samples, 37, "{}", text(&o.stdout));

    let o = run(tmp.path(), &["estimate", "--json"]);
    assert_eq!(json_lines(&o).len(), 40, "{}", text(&o.stderr));

    let o = run(
        tmp.path(),
        &["validate", "--no-plots", "--table", "4.1", "--table", "4.5"],
    );
    assert!(o.status.success(), "validate: {}", text(&o.stderr));
    assert!(text(&o.stdout).contains("Table 4.5 as an inverse experiment"));
    // nothing was written next to the user's files
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);
}

/// `demo:NAME` wherever a file is expected: the readings of `solve --readings`, and
/// the scene and recording of `calibrate` (they read paths only before session 23).
#[test]
fn demo_files_are_accepted_by_solve_readings_and_calibrate() {
    let tmp = TempDir::new("demo-args");
    let o = run(
        tmp.path(),
        &[
            "solve",
            "demo:scenes/till_tendon_readings.toml",
            "--readings",
            "demo:measurements/till_tendon_readings.csv",
        ],
    );
    assert!(o.status.success(), "solve --readings: {}", text(&o.stderr));
    assert!(
        text(&o.stdout).contains("6 rows solved, 6 converged, 0 bad rows"),
        "{}",
        text(&o.stdout)
    );
    // one LM iteration on the first 10 rows of the shipped val recording: the run
    // reads both demo files and reports both splits (its exit code is the fit's)
    let o = run(
        tmp.path(),
        &[
            "calibrate",
            "demo:scenes/ftdcr_v4.toml",
            "--data",
            "demo:hardware/ftdcr_v4/val.csv",
            "--train-rows",
            "0..10",
            "--max-iterations",
            "1",
        ],
    );
    let out = text(&o.stdout);
    assert!(
        out.contains("(10 rows)") && out.contains("(433 rows)"),
        "calibrate: {out}\n{}",
        text(&o.stderr)
    );
}

#[test]
fn demo_write_copies_the_shipped_files() {
    let tmp = TempDir::new("demo");
    let o = run(tmp.path(), &["demo", "list"]);
    assert!(text(&o.stdout).contains("demo:scenes/track_demo.toml"));
    let o = run(tmp.path(), &["demo", "write", "copy"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    for f in [
        "scenes/demo_two_section.toml",
        "scenes/track_demo.toml",
        "measurements/track_demo.csv",
        "thesis/fitted.toml",
        "thesis/table_4_5.csv",
    ] {
        let copy = std::fs::read(tmp.path().join("copy").join(f)).unwrap();
        assert_eq!(
            copy,
            std::fs::read(repo(&format!("data/{f}"))).unwrap(),
            "{f}"
        );
    }
    // the copies are usable as files
    let o = run(
        tmp.path(),
        &[
            "validate",
            "--no-plots",
            "--table",
            "4.2",
            "--data",
            "copy/thesis",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
}

/// Every error prints its cause once.
#[test]
fn errors_print_their_cause_once() {
    let tmp = TempDir::new("errors");
    let o = run(tmp.path(), &["solve", "missing.toml"]);
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert_eq!(
        err.trim_end(),
        "error: cannot read missing.toml: No such file or directory (os error 2)"
    );

    let scene = std::fs::read_to_string(repo("data/scenes/demo_two_section.toml")).unwrap();
    let bad = scene.replacen("length_m = 0.195", "length_m = -0.39", 1);
    assert_ne!(bad, scene, "the demo scene changed: adapt the test");
    std::fs::write(tmp.path().join("bad.toml"), bad).unwrap();
    let o = run(tmp.path(), &["solve", "bad.toml"]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        err.matches("length_m must be > 0, got -0.39").count(),
        1,
        "{err}"
    );
    assert!(
        err.starts_with("error: bad.toml: robot.sections[0].length_m"),
        "{err}"
    );

    let o = run(tmp.path(), &["track", "--input", "nope.csv"]);
    let err = text(&o.stderr);
    assert_ne!(o.status.code(), Some(0));
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");

    let o = run(tmp.path(), &["solve", "demo:scenes/nope.toml"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("no embedded file `demo:scenes/nope.toml`"));
}

/// Missing data is an error with a non-zero exit, never an empty success.
#[test]
fn missing_data_is_an_error() {
    let tmp = TempDir::new("missing");
    let o = run(tmp.path(), &["validate", "--data", "no/such/dir"]);
    assert_ne!(o.status.code(), Some(0), "{}", text(&o.stdout));
    assert!(text(&o.stderr).contains("no/such/dir"));

    let o = run(
        tmp.path(),
        &["pareto", "gone.toml", "--out", "p", "--quiet"],
    );
    assert_ne!(o.status.code(), Some(0), "{}", text(&o.stdout));
    assert!(text(&o.stderr).contains("gone.toml"), "{}", text(&o.stderr));
    assert!(!tmp.path().join("p/pareto.csv").exists());

    let o = run(tmp.path(), &["estimate", "--measure", "gone.csv"]);
    assert_ne!(o.status.code(), Some(0));
}

/// An encoder file with a UTF-8 byte-order mark and CRLF line endings is read like
/// the plain one.
#[test]
fn bom_and_crlf_encoder_files_are_accepted() {
    let tmp = TempDir::new("bom");
    let plain = std::fs::read_to_string(repo("data/measurements/track_demo.csv")).unwrap();
    let crlf = format!("\u{feff}{}", plain.replace('\n', "\r\n"));
    std::fs::write(tmp.path().join("bom.csv"), crlf).unwrap();
    std::fs::write(tmp.path().join("plain.csv"), &plain).unwrap();
    let strip = |o: &Output| -> Vec<serde_json::Value> {
        json_lines(o)
            .into_iter()
            .map(|mut v| {
                v.as_object_mut().unwrap().remove("elapsed_s");
                v
            })
            .collect()
    };
    let scene = "demo:scenes/track_demo.toml";
    let a = run(tmp.path(), &["track", scene, "--input", "bom.csv"]);
    let b = run(tmp.path(), &["track", scene, "--input", "plain.csv"]);
    assert!(a.status.success(), "{}", text(&a.stderr));
    let (a, b) = (strip(&a), strip(&b));
    assert_eq!(a.len(), 40);
    assert_eq!(a, b);
    assert!(!a
        .iter()
        .any(|l| l["field"].as_str().is_some_and(|f| f.contains("header"))));
}

/// A bad header is reported once and stops the stream with exit code 1.
#[test]
fn bad_header_is_reported_once() {
    let tmp = TempDir::new("header");
    let plain = std::fs::read_to_string(repo("data/measurements/track_demo.csv")).unwrap();
    std::fs::write(
        tmp.path().join("bad.csv"),
        plain.replace("t_s,top,left,right", "t_s,top,lefty,right"),
    )
    .unwrap();
    let o = run(
        tmp.path(),
        &["track", "demo:scenes/track_demo.toml", "--input", "bad.csv"],
    );
    assert_eq!(o.status.code(), Some(1));
    let lines = json_lines(&o);
    assert_eq!(lines.len(), 1, "{}", text(&o.stdout));
    assert_eq!(lines[0]["field"], "header `lefty`");
    assert_eq!(lines[0]["fatal"], true);
    assert_eq!(text(&o.stderr).matches("lefty").count(), 1);
}

/// A fit that leaves the residual far beyond the noise is flagged poor (JSON and
/// text); the shipped demo on its own model is not.
#[test]
fn poor_fits_are_flagged() {
    let tmp = TempDir::new("fit");
    let o = run(tmp.path(), &["estimate", "--json"]);
    let good: Vec<_> = json_lines(&o)
        .into_iter()
        .filter(|l| l.get("fit").is_some())
        .collect();
    assert_eq!(good.len(), 37);
    for l in &good {
        assert_ne!(l["fit"], "poor", "{l}");
        assert!(l["rms_sigma"].as_f64().unwrap() < 3.0, "{l}");
    }
    // constant curvature ignores gravity: the demo data are ~15 sigma off
    let o = run(tmp.path(), &["estimate", "--json", "--model", "cc"]);
    assert_eq!(o.status.code(), Some(1));
    let lines: Vec<_> = json_lines(&o)
        .into_iter()
        .filter(|l| l.get("fit").is_some() && l["redundancy"].as_u64() > Some(0))
        .collect();
    assert_eq!(lines.len(), 36);
    for l in &lines {
        assert_eq!(l["fit"], "poor", "{l}");
        assert!(l["rms_sigma"].as_f64().unwrap() > 3.0, "{l}");
    }
    let o = run(tmp.path(), &["estimate", "--model", "cc"]);
    assert!(
        text(&o.stdout).contains("Converged     Poor ("),
        "{}",
        text(&o.stdout)
    );
}

/// `solve --plot` and `track --plot` write three-view SVG figures.
#[test]
fn plots_are_written() {
    let tmp = TempDir::new("plot");
    let o = run(tmp.path(), &["solve", "--plot", "shape.svg"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let svg = std::fs::read_to_string(tmp.path().join("shape.svg")).unwrap();
    for v in ["view-xy", "view-xz", "view-yz"] {
        assert!(svg.contains(&format!("id=\"{v}\"")), "{v}");
    }
    let o = run(tmp.path(), &["track", "--plot", "figs"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let svg = std::fs::read_to_string(tmp.path().join("figs/track.svg")).unwrap();
    assert!(svg.contains("estimated tip path"));
    assert_eq!(svg.matches("class=\"view\"").count(), 3);
}
