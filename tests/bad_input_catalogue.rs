//! Catalogue of bad inputs (issue 14, "Reliability for a control loop"): scene files,
//! encoder rows, servo-readings rows, calibration recordings and command-line
//! arguments, each run through the `cablesense` binary
//! (`env!("CARGO_BIN_EXE_cablesense")`). Every case asserts that
//! - the process neither panics nor aborts (no `panicked` on stderr, an exit code),
//! - the error names where the input is wrong: the field path, the line, the column
//!   or the value (the strings each case lists), and
//! - the exit code is the documented one: 2 for an input that stops the command, 1
//!   for a fatal stream header or a solve that fails, 0 for a stream whose bad rows
//!   are reported in line and the stream goes on.
//!
//! Tolerance: none; every assertion is an exact substring or an exact exit code. Source:
//! the README's "Scene files", "Tendon-driven robots" (readings files), "Output of
//! `solve --json`" (track rows) and "Calibration from a recording" sections.
//! (The Python and C bindings' bad inputs are covered by their own tests.)

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_cablesense");

/// A fresh, empty directory under the system temp dir (removed on drop).
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        use std::sync::atomic::{AtomicUsize, Ordering};
        static N: AtomicUsize = AtomicUsize::new(0);
        let dir = std::env::temp_dir().join(format!(
            "cablesense-bad-{tag}-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Self(dir)
    }
    /// Write `text` to `name` in the directory; its path.
    fn file(&self, name: &str, text: &str) -> String {
        let p = self.0.join(name);
        std::fs::write(&p, text).unwrap();
        p.display().to_string()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// What one run of the binary gave.
struct Run {
    code: i32,
    stdout: String,
    stderr: String,
}

/// Run the binary with `args` (and `stdin` when given), in the crate root.
fn run_with(args: &[&str], stdin: Option<&str>) -> Run {
    let mut cmd = Command::new(BIN);
    cmd.args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .stdin(if stdin.is_some() {
            Stdio::piped()
        } else {
            Stdio::null()
        });
    let mut child = cmd.spawn().expect("the binary starts");
    if let Some(text) = stdin {
        use std::io::Write;
        let mut pipe = child.stdin.take().unwrap();
        pipe.write_all(text.as_bytes()).unwrap();
    }
    let Output {
        status,
        stdout,
        stderr,
    } = child.wait_with_output().unwrap();
    let run = Run {
        code: status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&stdout).into_owned(),
        stderr: String::from_utf8_lossy(&stderr).into_owned(),
    };
    assert!(
        !run.stderr.contains("panicked") && !run.stdout.contains("panicked"),
        "{args:?} panicked:\n{}",
        run.stderr
    );
    assert_ne!(run.code, -1, "{args:?} was killed by a signal");
    assert!(
        run.code != 101,
        "{args:?} exit code 101 (a panic):\n{}",
        run.stderr
    );
    run
}

fn run(args: &[&str]) -> Run {
    run_with(args, None)
}

/// The command stopped with exit code 2 and an error naming every part.
#[track_caller]
fn assert_error(r: &Run, parts: &[&str]) {
    assert_eq!(
        r.code, 2,
        "exit code {} (stdout {}, stderr {})",
        r.code, r.stdout, r.stderr
    );
    assert!(
        r.stderr.starts_with("error: "),
        "no error line:\n{}",
        r.stderr
    );
    for p in parts {
        assert!(
            r.stderr.contains(p),
            "the error does not name `{p}`:\n{}",
            r.stderr
        );
    }
}

fn repo(path: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(path)
        .display()
        .to_string()
}

fn shipped(path: &str) -> String {
    std::fs::read_to_string(repo(path)).unwrap()
}

/// A shipped scene with the first occurrence of `old` replaced (it must occur).
fn scene_with(scene: &str, old: &str, new: &str) -> String {
    let text = shipped(scene);
    assert!(text.contains(old), "`{old}` not in {scene}");
    text.replacen(old, new, 1)
}

const TDCR: &str = "data/scenes/tdcr_two_segment.toml";
const DEMO: &str = "data/scenes/demo_two_section.toml";
const TRACK: &str = "data/scenes/track_demo.toml";
const CALIB: &str = "data/calibration/demo.toml";

/// `solve` on a scene file written from `text`.
fn solve_scene(tag: &str, name: &str, text: &str) -> Run {
    let dir = TempDir::new(tag);
    let path = dir.file(name, text);
    run(&["solve", &path])
}

// ---------------------------------------------------------------------------------
// Scene files
// ---------------------------------------------------------------------------------

#[test]
fn scene_negative_length_names_field_and_value() {
    let r = solve_scene(
        "neglen",
        "s.toml",
        &scene_with(TDCR, "length_m = 0.1", "length_m = -0.1"),
    );
    assert_error(&r, &["s.toml", "robot.sections[0].length_m", "-0.1"]);
}

#[test]
fn scene_nan_modulus_names_field_and_value() {
    let r = solve_scene(
        "nanE",
        "s.toml",
        &scene_with(
            TDCR,
            "youngs_modulus_pa = 60.0e9",
            "youngs_modulus_pa = nan",
        ),
    );
    assert_error(&r, &["robot.sections[0].youngs_modulus_pa", "NaN"]);
}

#[test]
fn scene_infinite_gravity_names_field_and_value() {
    let r = solve_scene(
        "infg",
        "s.toml",
        &scene_with(
            DEMO,
            "gravity_m_s2 = [0.0, -9.81, 0.0]",
            "gravity_m_s2 = [0.0, -inf, 0.0]",
        ),
    );
    assert_error(&r, &["gravity_m_s2", "inf"]);
}

#[test]
fn scene_displacement_tendon_without_stiffness_names_the_cable() {
    let r = solve_scene(
        "noEA",
        "s.toml",
        &scene_with(TDCR, "stiffness_n = 2.0e4", "# no stiffness"),
    );
    assert_error(&r, &["robot.cables[0].tendon.stiffness_n", "EA_t"]);
}

#[test]
fn scene_negative_tendon_stiffness_names_field_and_value() {
    let r = solve_scene(
        "negEA",
        "s.toml",
        &scene_with(TDCR, "stiffness_n = 2.0e4", "stiffness_n = -5.0"),
    );
    assert_error(&r, &["robot.tendons.stiffness_n", "-5"]);
}

#[test]
fn scene_negative_pretension_names_field_and_value() {
    let r = solve_scene(
        "negpre",
        "s.toml",
        &scene_with(TDCR, "pretension_n = 1.0", "pretension_n = -1.0"),
    );
    assert_error(&r, &["robot.tendons.pretension_n", "-1"]);
}

#[test]
fn scene_routing_hole_outside_its_disk_names_cable_and_disk() {
    let r = solve_scene(
        "hole",
        "s.toml",
        &scene_with(
            TDCR,
            "radius_m = 0.008, angle_deg = 120.0",
            "radius_m = 0.015, angle_deg = 120.0",
        ),
    );
    assert_error(
        &r,
        &[
            "robot.cables[1].routing.radius_m",
            "0.015",
            "disk 0 of section 0",
        ],
    );
}

#[test]
fn scene_guide_outside_its_section_names_guide_and_section() {
    let r = solve_scene(
        "guide",
        "s.toml",
        &scene_with(TDCR, "first_offset_m = 0.01", "first_offset_m = 0.2"),
    );
    assert_error(&r, &["guide 0 of section 0", "0.2", "outside the section"]);
}

#[test]
fn scene_negative_tension_names_field_and_value() {
    let r = solve_scene(
        "negT",
        "s.toml",
        &scene_with(DEMO, "tensions_n = [1.5,", "tensions_n = [-1.5,"),
    );
    assert_error(&r, &["loads.tensions_n[0]", "-1.5"]);
}

#[test]
fn scene_cable_end_section_past_the_robot_names_field_and_value() {
    let r = solve_scene(
        "endsec",
        "s.toml",
        &scene_with(TDCR, "end_section = 1", "end_section = 5"),
    );
    assert_error(&r, &["end_section", "5"]);
}

/// Found by audit 23: two cables of one name (or two tendons reading one column)
/// were accepted, and every readings row then failed with "s1a: missing" although
/// the column was there (the second cable of the name never got it).
#[test]
fn scene_duplicate_cable_name_or_reading_column_names_both_cables() {
    let r = solve_scene(
        "dupname",
        "s.toml",
        &scene_with(TDCR, "name = \"s1b\"", "name = \"s1a\""),
    );
    assert_error(
        &r,
        &["robot.cables[1].name", "`s1a`", "robot.cables[0]", "unique"],
    );
    let r = solve_scene(
        "dupreading",
        "s.toml",
        &scene_with(TDCR, "name = \"s1b\"", "name = \"s1b\"\nreading = \"s1a\""),
    );
    assert_error(&r, &["robot.cables[1].reading", "`s1a`", "robot.cables[0]"]);
}

/// Found by audit 23: a base axis whose squared length overflows (`[1e200, 0, 0]`)
/// normalised to zero and the base was silently left unrotated; one whose squared
/// length underflows (`[1e-170, 0, 0]`) was refused as "must be non-zero". Both are
/// the x axis.
#[test]
fn scene_base_axis_of_extreme_length_is_its_direction() {
    let tip = |axis: &str| {
        let dir = TempDir::new("axis");
        let text = shipped(TDCR).replace(
            "[loads]",
            &format!("[robot.base]\naxis = {axis}\nangle_deg = 90.0\n\n[loads]"),
        );
        let path = dir.file("s.toml", &text);
        let r = run(&["solve", &path, "--json"]);
        assert_eq!(r.code, 0, "{axis}: {}", r.stderr);
        let v: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
        let tips = v["solution"]["section_tips"].as_array().unwrap().clone();
        tips.last().unwrap()["position"].clone()
    };
    let unit = tip("[1.0, 0.0, 0.0]");
    // rotated by 90 degrees about x: the backbone runs along -y
    assert!(unit[1].as_f64().unwrap() < -0.1, "{unit}");
    assert_eq!(tip("[1e200, 0.0, 0.0]"), unit);
    assert_eq!(tip("[1e-170, 0.0, 0.0]"), unit);
}

#[test]
fn scene_zero_rk4_steps_names_field_and_value() {
    let r = solve_scene(
        "rk4",
        "s.toml",
        &scene_with(TDCR, "steps_per_section = 20", "steps_per_section = 0"),
    );
    assert_error(&r, &["numerics.integrator.rk4.steps_per_section", "0"]);
}

/// `numerics.arc_rounds` of 0 or above 100 (the shipped FTDCR v4 scene sets 2), named
/// with its value.
#[test]
fn scene_arc_rounds_out_of_range_names_field_and_value() {
    for bad in ["0", "101"] {
        let r = solve_scene(
            "arcrounds",
            "s.toml",
            &scene_with(
                "data/scenes/ftdcr_v4.toml",
                "arc_rounds = 2",
                &format!("arc_rounds = {bad}"),
            ),
        );
        assert_error(&r, &["numerics.arc_rounds", bad]);
    }
}

/// `[numerics.tendons]`: a non-positive tendon tolerance, a zero iteration limit and
/// a misspelt key, each named.
#[test]
fn scene_bad_tendon_solver_settings_name_the_field() {
    let text = shipped(TDCR);
    let r = solve_scene(
        "tendtol",
        "s.toml",
        &format!("{text}\n[numerics.tendons]\ntolerance_m = -1e-9\n"),
    );
    assert_error(&r, &["numerics.tendons.tolerance_m", "-0.000000001"]);
    let r = solve_scene(
        "tenditer",
        "s.toml",
        &format!("{text}\n[numerics.tendons]\nmax_iterations = 0\n"),
    );
    assert_error(&r, &["numerics.tendons.max_iterations", "0"]);
    let r = solve_scene(
        "tendkey",
        "s.toml",
        &format!("{text}\n[numerics.tendons]\ntolerance = 1e-9\n"),
    );
    assert_error(&r, &["tolerance", "tolerance_m"]);
}

#[test]
fn scene_misspelt_key_names_key_line_and_column() {
    let r = solve_scene(
        "typo",
        "s.toml",
        &scene_with(TDCR, "poisson_ratio = 0.3", "poison_ratio = 0.3"),
    );
    assert_error(&r, &["line 7, column 1", "poison_ratio"]);
}

#[test]
fn scene_toml_syntax_error_names_line_and_column() {
    let r = solve_scene(
        "syntax",
        "s.toml",
        &scene_with(TDCR, "count = 10", "count = = 10"),
    );
    assert_error(&r, &["line 11, column 9"]);
}

#[test]
fn scene_json_syntax_error_names_line_and_column() {
    let r = solve_scene(
        "json",
        "s.json",
        "{\"robot\": {\"sections\": [ {\"length_m\": 0.1,, }]}}",
    );
    assert_error(&r, &["s.json", "line 1 column 43"]);
}

#[test]
fn scene_json_wrong_type_names_the_value() {
    let r = solve_scene(
        "jsontype",
        "s.json",
        "{\"robot\": {\"sections\": [{\"length_m\": \"long\"}]}}",
    );
    assert_error(&r, &["s.json", "\"long\"", "line 1"]);
}

#[test]
fn scene_missing_file_names_the_path() {
    let r = run(&["solve", "no/such/scene.toml"]);
    assert_error(&r, &["no/such/scene.toml"]);
}

#[test]
fn scene_unknown_demo_names_it() {
    let r = run(&["solve", "demo:scenes/nope.toml"]);
    assert_error(&r, &["demo:scenes/nope.toml", "demo list"]);
}

/// Found by audit 23: the same load twice in `[[estimate.unknowns]]` was accepted;
/// every row then came out "stalled" with standard deviations `inf` (the encoders
/// see only the sum of the two), and the reports, keyed by name, showed one column
/// twice.
#[test]
fn scene_same_unknown_twice_names_both_unknowns() {
    let dir = TempDir::new("dupunknown");
    let rows = dir.file("m.csv", &format!("{ENC_HEADER}{ENC_GOOD}"));
    let path = dir.file("s.toml", &scene_with(TRACK, "axis = \"z\"", "axis = \"y\""));
    let r = run(&["estimate", &path, "--measure", &rows]);
    assert_error(
        &r,
        &["estimate.unknowns[1]", "estimate.unknowns[0]", "force_y@s0"],
    );
    let path = dir.file(
        "n.toml",
        &scene_with(TRACK, "axis = \"z\"", "axis = \"z\"\nname = \"force_y@s0\""),
    );
    let r = run(&["estimate", &path, "--measure", &rows]);
    assert_error(&r, &["estimate.unknowns[1].name", "`force_y@s0`", "unique"]);
}

/// Found by audit 23: a point force of 1e300 N overflowed the residual's round-off
/// floor to infinity, and the solve reported `Converged` (exit 0) at a residual of
/// 8.3e300 with the unloaded shape; then `NonFinite`, exit 1. Since session 26 a
/// point force that reaches the axial stiffness EA of a section carrying it (an
/// axial strain of magnitude 1) is refused, naming the field, as tensions and weights
/// are: 1e300 N, and 2e5 N on the demo's 1.56 mm rod (EA 1.2e5 N).
#[test]
fn scene_point_force_beyond_the_axial_stiffness_names_the_force() {
    for (tag, force, value) in [("f300", "1e300", "1e300"), ("f2e5", "2e5", "200000")] {
        let r = solve_scene(
            tag,
            "s.toml",
            &scene_with(
                DEMO,
                "section = 1\nmass_kg = 0.02",
                &format!("section = 1\nforce_n = [0, {force}, 0]"),
            ),
        );
        assert_error(
            &r,
            &[
                &format!("loads.point[0].force_n = {value}"),
                "axial stiffness EA",
                "section 0",
            ],
        );
        assert!(!r.stdout.contains("Converged"), "{}", r.stdout);
    }
}

/// Found by audit 23: a seventh tension for six cables was reported as
/// "loads.tensions_n = 6 refers to nothing: only 6 exist".
#[test]
fn scene_extra_tension_names_the_counts() {
    let r = solve_scene(
        "t7",
        "s.toml",
        &scene_with(DEMO, "0.8, 0.0]", "0.8, 0.0, 3.0]"),
    );
    assert_error(&r, &["loads.tensions_n", "7 values for 6 cables"]);
}

/// A tendon scene whose reference (the robot at its pretensions under the scene's
/// loads) cannot be solved because of its weight, not its pretension: the error names
/// the reference solve and every input it depends on, not the pretension alone. (A
/// density of 1e8 kg/m^3: 154 N of rod, heavy but below its axial stiffness EA, 47 kN,
/// which `scene_weight_beyond_the_axial_stiffness_names_the_density` refuses.)
#[test]
fn tendon_reference_failure_names_the_reference_not_only_the_pretension() {
    let dir = TempDir::new("refsolve");
    let scene = dir.file(
        "s.toml",
        &scene_with(TDCR, "density_kg_m3 = 6450.0", "density_kg_m3 = 1e8"),
    );
    let readings = repo("data/measurements/tdcr_two_segment_readings.csv");
    let r = run(&["solve", &scene, "--readings", &readings]);
    assert_error(
        &r,
        &[
            "tendon reference solve",
            "did not solve",
            "the loads",
            "mass",
        ],
    );
}

/// A load the solver cannot reach (a 15 kN cable pull on the 1.56 mm demo rod, below
/// its EA): `solve` reports a failure status and exits 1; nothing claims convergence,
/// and stderr says why in the scene's terms (`Workspace::diagnose`): the tension
/// named first with its value, the loads blamed (session 26; before, no reason).
#[test]
fn scene_unreachable_load_reports_a_failure_status() {
    let r = solve_scene(
        "huge",
        "s.toml",
        &scene_with(DEMO, "tensions_n = [1.5,", "tensions_n = [1.5e4,"),
    );
    assert_eq!(r.code, 1, "stdout {} stderr {}", r.stdout, r.stderr);
    let status = r
        .stdout
        .lines()
        .find(|l| l.starts_with("status:"))
        .unwrap_or_else(|| panic!("no status line:\n{}", r.stdout));
    assert!(!status.contains("Converged"), "{status}");
    assert!(
        [
            "NonFinite",
            "Stalled",
            "MaxIterations",
            "IllConditioned",
            "Unstable"
        ]
        .iter()
        .any(|s| status.contains(s)),
        "{status}"
    );
    for part in [
        "error: not converged",
        "largest: loads.tensions_n[0] = 15000 N",
        "reduce loads.tensions_n[0]",
    ] {
        assert!(r.stderr.contains(part), "no `{part}` in:\n{}", r.stderr);
    }
}

// ---------------------------------------------------------------------------------
// Encoder rows (`track` on the track demo: cables top, left, right)
// ---------------------------------------------------------------------------------

/// `track` of the track demo on `rows` from stdin; the JSON objects of stdout.
fn track_rows(rows: &str) -> (Run, Vec<serde_json::Value>) {
    let r = run_with(&["track", &repo(TRACK)], Some(rows));
    let lines = r
        .stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    (r, lines)
}

/// The error object for input line `line` names `field` and contains `parts`.
#[track_caller]
fn assert_row_error(rows: &[serde_json::Value], line: u64, field: &str, parts: &[&str]) {
    let row = rows
        .iter()
        .find(|r| r["line"] == line)
        .unwrap_or_else(|| panic!("no output for line {line}: {rows:?}"));
    let error = row["error"]
        .as_str()
        .unwrap_or_else(|| panic!("line {line} is not an error: {row}"));
    assert_eq!(row["field"], field, "{row}");
    for p in parts {
        assert!(error.contains(p), "line {line}: `{p}` not in `{error}`");
    }
}

const ENC_HEADER: &str = "t_s,top,left,right\n";
const ENC_GOOD: &str = "0.0,1.66819249e-3,-2.44597466e-3,2.51324066e-4\n";

/// The stream goes on: the good row after the bad one is estimated.
#[track_caller]
fn assert_good_row(rows: &[serde_json::Value], line: u64) {
    let row = rows
        .iter()
        .find(|r| r["line"] == line)
        .unwrap_or_else(|| panic!("no output for line {line}: {rows:?}"));
    assert_eq!(row["status"], "converged", "{row}");
}

#[test]
fn encoder_nan_cell_names_line_and_cable() {
    let (r, rows) = track_rows(&format!("{ENC_HEADER}0.0,NaN,0,0\n{ENC_GOOD}"));
    assert_eq!(r.code, 0);
    assert_row_error(&rows, 2, "top", &["line 2", "`NaN` is not finite"]);
    assert_good_row(&rows, 3);
}

#[test]
fn encoder_infinite_cell_names_line_and_cable() {
    let (r, rows) = track_rows(&format!("{ENC_HEADER}0.0,0,-inf,0\n{ENC_GOOD}"));
    assert_eq!(r.code, 0);
    assert_row_error(&rows, 2, "left", &["`-inf` is not finite"]);
    assert_good_row(&rows, 3);
}

#[test]
fn encoder_garbage_cell_names_line_cable_and_value() {
    let (r, rows) = track_rows(&format!("{ENC_HEADER}0.0,0,0,0x1F\n{ENC_GOOD}"));
    assert_eq!(r.code, 0);
    assert_row_error(&rows, 2, "right", &["`0x1F` is not a number"]);
    assert_good_row(&rows, 3);
}

#[test]
fn encoder_missing_and_extra_columns_name_the_count() {
    let (r, rows) = track_rows(&format!("{ENC_HEADER}0.0,0,0\n0.1,0,0,0,0\n{ENC_GOOD}"));
    assert_eq!(r.code, 0);
    assert_row_error(&rows, 2, "row", &["3 cells, header has 4"]);
    assert_row_error(&rows, 3, "row", &["5 cells, header has 4"]);
    assert_good_row(&rows, 4);
}

#[test]
fn encoder_empty_time_stamp_names_the_column() {
    let (_, rows) = track_rows(&format!("{ENC_HEADER},0,0,0\n{ENC_GOOD}"));
    assert_row_error(&rows, 2, "t_s", &["empty time stamp"]);
}

#[test]
fn encoder_non_positive_noise_names_column_and_value() {
    let (_, rows) = track_rows("t_s,top,left,right,sigma_left\n0.0,0,0,0,-1e-5\n");
    assert_row_error(&rows, 2, "sigma_left", &["-0.00001"]);
}

#[test]
fn encoder_unknown_header_stops_the_stream_naming_the_column() {
    let (r, rows) = track_rows(&format!("t_s,top,left,bogus\n{ENC_GOOD}"));
    assert_eq!(r.code, 1, "a bad header is fatal: {}", r.stderr);
    assert!(r.stderr.contains("header `bogus`"), "{}", r.stderr);
    assert_eq!(rows.len(), 1, "reported once: {rows:?}");
    assert_eq!(rows[0]["fatal"], true);
}

#[test]
fn encoder_json_line_with_wrong_count_names_the_field() {
    let (r, rows) = track_rows(
        "{\"t_s\": 0, \"changes_m\": [0, 0]}\n{\"t_s\": 0.1, \"changes_m\": [1.67e-3, -2.45e-3, 2.5e-4]}\n",
    );
    assert_eq!(r.code, 0);
    assert_row_error(&rows, 1, "changes_m", &["2 values for 3 cables"]);
    assert_good_row(&rows, 2);
}

#[test]
fn encoder_json_line_with_unknown_key_names_key_and_column() {
    let (_, rows) = track_rows("{\"t_s\": 0, \"changes_m\": [0, 0, 0], \"extra\": 1}\n");
    assert_row_error(&rows, 1, "json", &["unknown field `extra`", "column 42"]);
}

#[test]
fn encoder_json_garbage_names_line_and_column() {
    let (_, rows) = track_rows("{not json at all\n");
    assert_row_error(&rows, 1, "json", &["line 1 column 2"]);
}

#[test]
fn encoder_json_negative_noise_names_index_and_value() {
    let (_, rows) =
        track_rows("{\"t_s\": 0, \"changes_m\": [0, 0, 0], \"sigma_m\": [null, -1, null]}\n");
    assert_row_error(&rows, 1, "sigma_m[1]", &["got -1"]);
}

// ---------------------------------------------------------------------------------
// Servo-readings rows (`track` on the two-segment TDCR: tendons s1a..s2c)
// ---------------------------------------------------------------------------------

const RD_HEADER: &str = "t_s,s1a,s1b,s1c,s2a,s2b,s2c\n";

fn readings_rows(rows: &str) -> (Run, Vec<serde_json::Value>) {
    let r = run_with(&["track", &repo(TDCR)], Some(rows));
    assert_eq!(r.code, 0, "a readings stream goes on: {}", r.stderr);
    let lines = r
        .stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    (r, lines)
}

#[test]
fn readings_nan_and_inf_name_line_and_tendon() {
    let (_, rows) = readings_rows(&format!(
        "{RD_HEADER}0,0,NaN,0,0,0,0\n0.1,0,0,0,0,inf,0\n0.2,0.001,0,0,0,0,0\n"
    ));
    assert_row_error(&rows, 2, "s1b", &["`NaN` is not finite"]);
    assert_row_error(&rows, 3, "s2b", &["`inf` is not finite"]);
    assert_good_row(&rows, 4);
}

#[test]
fn readings_garbage_cell_names_line_tendon_and_value() {
    let (_, rows) = readings_rows(&format!("{RD_HEADER}0,0,0,0,0,0,twelve\n"));
    assert_row_error(&rows, 2, "s2c", &["`twelve` is not a number"]);
}

#[test]
fn readings_wrong_cell_count_names_the_count() {
    let (_, rows) = readings_rows(&format!(
        "{RD_HEADER}0,0,0,0\n0.1,0,0,0,0,0,0,0,0\n0.2,0,0,0,0,0,0\n"
    ));
    assert_row_error(&rows, 2, "row", &["4 cells, the header has 7"]);
    assert_row_error(&rows, 3, "row", &["9 cells, the header has 7"]);
    assert_good_row(&rows, 4);
}

/// README: "A missing or empty reading keeps the tendon's last value (on the first
/// row: an error for that row)".
#[test]
fn readings_missing_tendon_keeps_its_last_value_and_first_row_is_an_error() {
    let (_, rows) = readings_rows(&format!(
        "{RD_HEADER}0,,0,0,0,0,0\n0.1,0.001,0,0,0,0,0\n0.2,,0.0005,0,0,0,0\n"
    ));
    assert_row_error(&rows, 2, "s1a", &["missing", "no earlier row"]);
    assert_good_row(&rows, 3);
    let row = rows.iter().find(|r| r["line"] == 4).unwrap();
    assert_eq!(row["status"], "converged", "{row}");
    assert_eq!(row["readings_m"][0], 0.001, "kept from line 3: {row}");
    assert_eq!(row["readings_m"][1], 0.0005, "{row}");
}

#[test]
fn readings_pull_beyond_the_tendon_names_tendon_and_value() {
    let (_, rows) = readings_rows(&format!("{RD_HEADER}0,0,0,0.5,0,0,0\n0.1,0,0,0,0,0,0\n"));
    assert_row_error(
        &rows,
        2,
        "readings",
        &[
            "readings[2] (s1c)",
            "0.5",
            "pulls in more than the whole tendon",
        ],
    );
    assert_good_row(&rows, 3);
}

/// A pull no equilibrium reaches (80 mm on `s1a`: 10 rad of bend at its 8 mm hole
/// radius, and with `s1b`, `s1c` held a compression of the backbone far above its
/// Euler load between disks) is valid input but does not converge: the row says
/// why, naming the readings column, the bend it asks for and the compression
/// (`TendonWorkspace::diagnose`; before session 26 a bare `stalled`), and the stream
/// goes on.
#[test]
fn readings_unreachable_pull_is_diagnosed_by_column() {
    let (_, rows) = readings_rows(&format!(
        "{RD_HEADER}0,0,0,0,0,0,0\n0.1,0.08,0,0,0,0,0\n0.2,0.001,0,0,0,0,0\n"
    ));
    let row = rows
        .iter()
        .find(|r| r["line"] == 3)
        .unwrap_or_else(|| panic!("no output for line 3: {rows:?}"));
    assert_ne!(row["status"], "converged", "{row}");
    let why = row["diagnosis"].as_str().unwrap_or_else(|| panic!("{row}"));
    for part in [
        "the readings pull in: readings column s1a = 80 mm (at a 8 mm hole radius) 10.000 rad",
        // with s1b and s1c held, the pull mostly compresses the backbone
        "may buckle between disks",
        "reduce the mean pull of section 0's tendons (s1a, s1b, s1c)",
    ] {
        assert!(why.contains(part), "no `{part}` in {why}");
    }
    assert_good_row(&rows, 4);
    // a converged row carries none
    assert!(rows[0].get("diagnosis").is_none(), "{}", rows[0]);
}

#[test]
fn readings_header_without_tendon_column_names_the_expected_columns() {
    let (_, rows) = readings_rows(&format!("foo,bar\n1,2\n{RD_HEADER}0,0,0,0,0,0,0\n"));
    assert_row_error(&rows, 1, "header", &["no tendon column", "s1a"]);
    assert_good_row(&rows, 4);
}

#[test]
fn readings_on_a_scene_without_tendons_names_the_scene() {
    let dir = TempDir::new("rdnt");
    let rows = dir.file("r.csv", &format!("{RD_HEADER}0,0,0,0,0,0,0\n"));
    let r = run(&["solve", &repo(DEMO), "--readings", &rows]);
    assert_error(
        &r,
        &["demo_two_section.toml", "actuation = \"displacement\""],
    );
}

/// Run the binary with stdout and stderr in files, stdin from `stdin` (a path opened
/// for reading) or null, killed after `secs` seconds: for cases whose regression is
/// an endless loop. (code, stdout, stderr); code -1 if it had to be killed.
fn run_bounded(args: &[&str], stdin: Option<&str>, secs: u64) -> Run {
    let dir = TempDir::new("bounded");
    let out = dir.0.join("stdout");
    let err = dir.0.join("stderr");
    let mut child = Command::new(BIN)
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(match stdin {
            Some(p) => Stdio::from(std::fs::File::open(p).unwrap()),
            None => Stdio::null(),
        })
        .stdout(Stdio::from(std::fs::File::create(&out).unwrap()))
        .stderr(Stdio::from(std::fs::File::create(&err).unwrap()))
        .spawn()
        .expect("the binary starts");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(secs);
    let code = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status.code().unwrap_or(-2);
        }
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            break -1;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let head = |p: &Path| {
        let bytes = std::fs::read(p).unwrap_or_default();
        String::from_utf8_lossy(&bytes[..bytes.len().min(4000)]).into_owned()
    };
    Run {
        code,
        stdout: head(&out),
        stderr: head(&err),
    }
}

/// Found by audit 23: a directory given as the rows file (or as standard input) was
/// opened (Linux allows it), every read of it failed, and the stream reported
/// "unreadable line" for line 1, 2, 3, ... forever. Now an error naming the path
/// (a directory on standard input: the read error, once).
#[test]
fn rows_file_that_is_a_directory_is_an_error_not_an_endless_stream() {
    let dir = TempDir::new("rowsdir");
    let d = dir.0.display().to_string();
    let load_cells = repo("data/load_cells/tdcr_load_cells.toml");
    for args in [
        vec!["solve", TDCR, "--readings", &d],
        vec!["track", TDCR, "--input", &d],
        vec!["track", TRACK, "--input", &d],
        vec!["track", &load_cells, "--input", &d],
        vec!["estimate", TRACK, "--measure", &d],
        vec!["estimate", &load_cells, "--measure", &d],
    ] {
        let r = run_bounded(&args, None, 20);
        assert_ne!(r.code, -1, "{args:?} did not stop: {}", r.stdout);
        assert_error(&r, &[&d, "directory"]);
    }
    for scene in [TDCR, TRACK, &load_cells] {
        let r = run_bounded(&["track", scene], Some(&d), 20);
        assert_ne!(r.code, -1, "track {scene} < DIR did not stop: {}", r.stdout);
        assert_error(&r, &["reading line 1", "directory"]);
    }
}

// ---------------------------------------------------------------------------------
// Calibration recordings (`calibrate` of the shipped demo on a 19-row recording)
// ---------------------------------------------------------------------------------

/// The first 20 lines of the demo's training recording with `edit` applied.
fn recording(edit: impl Fn(usize, &str) -> Option<String>) -> String {
    shipped("data/calibration/train.csv")
        .lines()
        .take(20)
        .enumerate()
        .filter_map(|(i, l)| edit(i + 1, l))
        .map(|l| l + "\n")
        .collect()
}

/// Line `n` of a recording with cell `col` replaced by `value`.
fn set_cell(line: &str, col: usize, value: &str) -> String {
    let mut cells: Vec<&str> = line.split(',').collect();
    cells[col] = value;
    cells.join(",")
}

fn calibrate(tag: &str, text: &str, extra: &[&str]) -> Run {
    let dir = TempDir::new(tag);
    let data = dir.file("rec.csv", text);
    let out = dir.0.join("out").display().to_string();
    let mut args = vec!["calibrate", CALIB, "--data", &data, "--out", &out];
    args.extend_from_slice(extra);
    run(&args)
}

#[test]
fn recording_missing_marker_column_names_it_and_the_header() {
    let text = recording(|i, l| {
        Some(if i == 1 {
            l.replace("tip_y", "tip_q")
        } else {
            l.into()
        })
    });
    let r = calibrate("nocol", &text, &[]);
    assert_error(&r, &["rec.csv:1", "no column `tip_y`", "tip_q"]);
}

#[test]
fn recording_garbage_cell_names_file_line_and_column() {
    let text = recording(|i, l| {
        Some(if i == 5 {
            set_cell(l, 1, "abc")
        } else {
            l.into()
        })
    });
    let r = calibrate("garbage", &text, &[]);
    assert_error(&r, &["rec.csv:5", "column `tension_a`", "`abc`"]);
}

#[test]
fn recording_nan_cell_names_file_line_and_column() {
    let text = recording(|i, l| {
        Some(if i == 7 {
            set_cell(l, 5, "NaN")
        } else {
            l.into()
        })
    });
    let r = calibrate("nan", &text, &[]);
    assert_error(&r, &["rec.csv:7", "column `tip_y`", "NaN"]);
}

#[test]
fn recording_short_row_names_file_line_and_column() {
    let text = recording(|i, l| {
        Some(if i == 6 {
            l.rsplit_once(',').unwrap().0.into()
        } else {
            l.into()
        })
    });
    let r = calibrate("short", &text, &[]);
    assert_error(&r, &["rec.csv:6", "column `tip_z`", "missing"]);
}

/// Found by this catalogue: a recording row with more cells than the header was
/// accepted and its extra cells dropped (the calibration ran on, exit 0), so a
/// shifted row was fitted as if it were right; now an error naming file and line.
#[test]
fn recording_row_with_an_extra_cell_names_file_and_line() {
    let text = recording(|i, l| Some(if i == 6 { format!("{l},9") } else { l.into() }));
    let r = calibrate("extra", &text, &[]);
    assert_error(&r, &["rec.csv:6", "8 cells"]);
}

/// Found by audit 23: the same in a pull recording of `calibrate --identify`: a row
/// with a 15th cell under a 14-column header was read (exit 0).
#[test]
fn pull_recording_row_with_an_extra_cell_names_file_and_line() {
    let text: String = shipped("data/hardware/ftdcr_v4/tendon_pull.csv")
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i + 1 == 10 {
                format!("{l},7\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let dir = TempDir::new("pullextra");
    let path = dir.file("pull.csv", &text);
    let r = run(&["calibrate", "--identify", &path]);
    assert_error(&r, &["pull.csv:10", "15 cells where the header has 14"]);
}

#[test]
fn recording_without_data_rows_is_an_error() {
    let text = recording(|i, l| (i == 1).then(|| l.to_string()));
    let r = calibrate("empty", &text, &[]);
    assert_error(&r, &["rec.csv:1", "no data rows"]);
}

/// Found by audit 23: a single training row (`--train-rows 0..1`, `--every` larger
/// than the recording) was refused as a unit mismatch ("the unit is wrong (mm read
/// as m?)"): one row has no spread to judge a unit by. Now the row count is named.
#[test]
fn recording_with_too_few_training_rows_names_the_count_not_the_unit() {
    let text = recording(|_, l| Some(l.into()));
    for extra in [["--train-rows", "0..1"], ["--every", "1000"]] {
        let r = calibrate("onerow", &text, &extra);
        assert_error(&r, &["rec.csv", "1 training row(s)", "rows are needed"]);
        assert!(!r.stderr.contains("unit"), "{extra:?}: {}", r.stderr);
    }
}

/// Found by audit 23: `--marker-columns tip_x,tip_y,tip_x` (one column read as two
/// coordinates) was accepted and fitted (exit 1, `max_iterations`).
#[test]
fn recording_marker_column_given_twice_names_both() {
    let text = recording(|_, l| Some(l.into()));
    let r = calibrate("dupcols", &text, &["--marker-columns", "tip_x,tip_y,tip_x"]);
    assert_error(
        &r,
        &[
            "calibration.marker_columns[2]",
            "`tip_x`",
            "marker_columns[0]",
        ],
    );
}

#[test]
fn recording_negative_tension_names_line_field_and_value() {
    let text = recording(|i, l| {
        Some(if i == 4 {
            set_cell(l, 1, "-5")
        } else {
            l.into()
        })
    });
    let r = calibrate("negT", &text, &[]);
    assert_error(&r, &["line 4", "loads.tensions_n[0]", "-5"]);
}

#[test]
fn recording_missing_file_names_the_path() {
    let r = run(&["calibrate", CALIB, "--data", "no/such/rec.csv"]);
    assert_error(&r, &["no/such/rec.csv"]);
}

// ---------------------------------------------------------------------------------
// Command-line arguments
// ---------------------------------------------------------------------------------

#[test]
fn cli_unknown_flag_names_the_flag() {
    let r = run(&["solve", "--frobnicate"]);
    assert_error(&r, &["'--frobnicate'"]);
}

#[test]
fn cli_unknown_subcommand_names_it() {
    let r = run(&["solvee"]);
    assert_error(&r, &["'solvee'", "solve"]);
}

#[test]
fn cli_bad_length_unit_names_the_value() {
    let r = run(&["solve", "--model", "auto", "--tol", "3parsecs"]);
    assert_error(
        &r,
        &["'3parsecs'", "--tol", "unknown length unit `parsecs`"],
    );
}

#[test]
fn cli_unknown_model_label_names_it() {
    let r = run(&["solve", "--model", "cosserat/heavy/rk4-8"]);
    assert_error(&r, &["`cosserat/heavy/rk4-8`", "kirchhoff/"]);
}

#[test]
fn cli_track_unknown_model_label_names_it() {
    let r = run(&["track", "--model", "pcc/point/zero"]);
    assert_error(&r, &["`pcc/point/zero`"]);
}

#[test]
fn cli_missing_input_names_the_path() {
    let r = run(&["track", &repo(TRACK), "--input", "no/such/rows.csv"]);
    assert_error(&r, &["no/such/rows.csv"]);
}

#[test]
fn cli_track_without_estimate_table_names_the_scene() {
    let r = run(&["track", &repo(DEMO)]);
    assert_error(&r, &["demo_two_section.toml", "no [estimate] table"]);
}

/// Found by audit 23: options the readings streams do not use were accepted and
/// ignored (exit 0): `track` on a tendon scene with `--model bogus` or `--plot DIR`
/// (no figure written), `solve --readings` with `--plot` (no figure written), and
/// `--probe-rows 0`.
#[test]
fn cli_options_a_readings_stream_would_ignore_are_refused() {
    let dir = TempDir::new("ignored");
    let rows = dir.file("r.csv", &format!("{RD_HEADER}0,0,0,0,0,0,0\n"));
    let figs = dir.0.join("figs").display().to_string();
    let load_cells = repo("data/load_cells/tdcr_load_cells.toml");
    for scene in [TDCR, &load_cells] {
        let r = run(&["track", scene, "--input", &rows, "--model", "bogus"]);
        assert_error(&r, &["--model bogus", "--model scene"]);
        let r = run(&["track", scene, "--input", &rows, "--plot", &figs]);
        assert_error(&r, &["--plot", "figs", "displacement-driven"]);
    }
    let svg = dir.0.join("p.svg").display().to_string();
    let r = run(&["solve", TDCR, "--readings", &rows, "--plot", &svg]);
    assert_error(&r, &["--plot", "p.svg", "--samples"]);
    assert!(!dir.0.join("figs").exists() && !dir.0.join("p.svg").exists());
    let r = run(&[
        "solve",
        TDCR,
        "--readings",
        &rows,
        "--model",
        "auto",
        "--probe-rows",
        "0",
    ]);
    assert_error(&r, &["--probe-rows 0"]);
}

/// Found by audit 23: a line that is not UTF-8 stopped `estimate` (exit 2) and
/// `solve --readings --model auto` ("error: stream did not contain valid UTF-8",
/// naming no line), where `track` and `solve --readings` report it and go on.
#[test]
fn non_utf8_line_is_reported_and_the_rows_after_it_are_read() {
    let dir = TempDir::new("utf8");
    let enc = dir.0.join("enc.csv");
    let mut bytes = shipped("data/measurements/track_demo.csv")
        .lines()
        .take(5)
        .map(|l| format!("{l}\n"))
        .collect::<String>()
        .into_bytes();
    let good_rows = 3; // lines 3..=5: header on line 2 after the comment
    bytes.extend_from_slice(b"\xff\xfe,1,2\n");
    bytes.extend_from_slice(
        shipped("data/measurements/track_demo.csv")
            .lines()
            .nth(5)
            .unwrap()
            .as_bytes(),
    );
    bytes.push(b'\n');
    std::fs::write(&enc, bytes).unwrap();
    let enc = enc.display().to_string();
    let r = run(&["estimate", TRACK, "--measure", &enc, "--json"]);
    assert_eq!(r.code, 1, "a bad line is counted: {}", r.stderr);
    let rows: Vec<serde_json::Value> = r
        .stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_row_error(&rows, 6, "line", &["not", "UTF-8"]);
    let estimated = rows.iter().filter(|v| v.get("status").is_some()).count();
    assert_eq!(estimated, good_rows + 1, "{}", r.stdout);

    let rd = dir.0.join("rd.csv");
    let mut bytes = format!("{RD_HEADER}0,0,0,0,0,0,0\n").into_bytes();
    bytes.extend_from_slice(b"\xff\xfe\n0.1,0.001,0,0,0,0,0\n");
    std::fs::write(&rd, bytes).unwrap();
    let rd = rd.display().to_string();
    // (one probe row: ranking the ladder costs seconds a row)
    let r = run(&[
        "solve",
        TDCR,
        "--readings",
        &rd,
        "--model",
        "auto",
        "--probe-rows",
        "1",
        "--json",
    ]);
    assert_ne!(r.code, 2, "the stream goes on: {}", r.stderr);
    let rows: Vec<serde_json::Value> = r
        .stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert!(rows[0].get("model_choice").is_some(), "{}", r.stdout);
    assert_row_error(&rows, 3, "line", &["UTF-8"]);
    assert!(rows
        .iter()
        .any(|v| v["line"] == 4 && v.get("status").is_some()));
}

#[test]
fn cli_unwritable_output_names_the_path() {
    let r = run(&["solve", "--samples", "/nonexistent-dir/x/samples.csv"]);
    assert_error(&r, &["/nonexistent-dir/x/samples.csv"]);
}

#[test]
fn cli_empty_row_range_names_it() {
    let text = recording(|_, l| Some(l.into()));
    let r = calibrate("rows", &text, &["--train-rows", "10..5"]);
    assert_error(&r, &["`10..5`", "empty"]);
}

#[test]
fn cli_param_path_naming_nothing_names_path_and_index() {
    let text = recording(|_, l| Some(l.into()));
    let r = calibrate(
        "param",
        &text,
        &["--param", "robot/sections/7/youngs_modulus_pa"],
    );
    assert_error(&r, &["robot/sections/7/youngs_modulus_pa", "no index 7"]);
}

#[test]
fn cli_param_bound_not_a_number_names_the_value() {
    let text = recording(|_, l| Some(l.into()));
    let r = calibrate(
        "bound",
        &text,
        &["--param", "robot/sections/0/youngs_modulus_pa:abc:1"],
    );
    assert_error(&r, &["`abc` is not a number"]);
}

// ---------------------------------------------------------------------------------
// Audit 24
// ---------------------------------------------------------------------------------

/// Found by audit 24: a value of 1e300 in an error message printed as 301 digits;
/// extreme magnitudes now print in scientific form.
#[test]
fn scene_extreme_value_prints_in_scientific_form() {
    let r = solve_scene(
        "len300",
        "s.toml",
        &scene_with(TDCR, "length_m = 0.1", "length_m = -1e300"),
    );
    assert_error(&r, &["robot.sections[0].length_m", "got -1e300"]);
    assert!(!r.stderr.contains("0000000000"), "{}", r.stderr);
}

/// Found by audit 24: `pareto --reps 0` ran (0 was raised to 1 in silence); the
/// median of no timed repetition is undefined, so 0 is refused before any solve.
#[test]
fn cli_pareto_zero_reps_names_the_option_and_value() {
    let dir = TempDir::new("reps0");
    let out = dir.0.join("out").display().to_string();
    let r = run(&["pareto", TDCR, "--reps", "0", "--out", &out, "--quiet"]);
    assert_error(&r, &["--reps", "'0'", "at least 1"]);
    assert!(!dir.0.join("out").exists(), "nothing is measured");
}

/// Found by audit 24: `huber_sigma = 1e-300` was accepted and the fit reported
/// "Converged after 0 iterations"; a threshold below 1e-3 noise sigmas (and so
/// every subnormal one) is refused naming field and value.
#[test]
fn calibration_degenerate_huber_threshold_names_field_and_value() {
    let text = recording(|_, l| Some(l.into()));
    for (k, shown) in [
        ("1e-300", "1e-300"),
        ("5e-324", "5e-324"),
        ("0.0005", "0.0005"),
    ] {
        let r = calibrate("huber", &text, &["--huber", k]);
        assert_error(
            &r,
            &["calibration.huber_sigma", shown, "below 0.001 noise sigmas"],
        );
    }
}

/// Found by audit 24: `[readings] time_offset_s = 1e300` clamped every row to its
/// block's first reading (the tip frozen, exit 0); an offset beyond 10 s is refused.
#[test]
fn scene_time_offset_beyond_its_bound_names_field_and_value() {
    let dir = TempDir::new("toff");
    let rows = dir.file("r.csv", &format!("{RD_HEADER}0,0,0,0,0,0,0\n"));
    for (offset, shown) in [("1e300", "1e300"), ("-53.0", "-53")] {
        let scene = dir.file(
            "s.toml",
            &scene_with(
                TDCR,
                "[readings]\nscale_m = 1.0",
                &format!("[readings]\nscale_m = 1.0\ntime_offset_s = {offset}"),
            ),
        );
        let r = run(&["solve", &scene, "--readings", &rows]);
        assert_error(
            &r,
            &["s.toml", "readings.time_offset_s", shown, "at most 10 s"],
        );
    }
}

/// Found by audit 24: a JSON row with a key given twice took the last value in
/// silence. The row is refused naming the key (the stream goes on); a derived
/// struct (encoder rows, scene files) already refuses a repeated field; a JSON
/// recording stops `calibrate` naming file, line and key.
#[test]
fn json_row_with_a_repeated_key_is_refused_naming_the_key() {
    let (_, rows) = readings_rows(
        "{\"t_s\": 0, \"s1a\": 0.001, \"s1b\": 0, \"s1c\": 0, \"s2a\": 0, \"s2b\": 0, \"s2c\": 0, \"s1a\": 0.002}\n\
         {\"t_s\": 0.1, \"s1a\": 0.001, \"s1b\": 0, \"s1c\": 0, \"s2a\": 0, \"s2b\": 0, \"s2c\": 0}\n",
    );
    assert_row_error(&rows, 1, "json", &["duplicate key `s1a`", "column"]);
    assert_good_row(&rows, 2);

    let (r, rows) = track_rows(
        "{\"t_s\": 0, \"changes_m\": [0, 0, 0], \"changes_m\": [1, 1, 1]}\n\
         {\"t_s\": 0.1, \"changes_m\": [1.67e-3, -2.45e-3, 2.5e-4]}\n",
    );
    assert_eq!(r.code, 0);
    assert_row_error(&rows, 1, "json", &["duplicate field `changes_m`"]);
    assert_good_row(&rows, 2);

    let r = solve_scene(
        "jsondup",
        "s.json",
        "{\"robot\": {\"sections\": [{\"length_m\": 0.1, \"length_m\": 0.2}]}}",
    );
    assert_error(&r, &["s.json", "duplicate field `length_m`", "line 1"]);

    let csv = recording(|_, l| Some(l.into()));
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let json: String = lines
        .enumerate()
        .map(|(i, l)| {
            let mut cells: Vec<String> = header
                .iter()
                .zip(l.split(','))
                .map(|(h, v)| format!("\"{h}\": {v}"))
                .collect();
            if i == 2 {
                cells.push(format!("\"{}\": 1.0", header[1]));
            }
            format!("{{{}}}\n", cells.join(", "))
        })
        .collect();
    let r = calibrate("jsonrec", &json, &[]);
    assert_error(
        &r,
        &["rec.csv:3", &format!("duplicate key `{}`", header[1])],
    );
}

/// Found by audit 24: an empty rows file (`solve --readings`, `track --input`,
/// `estimate --measure`) exited 0 with nothing solved. A named file with no row
/// (empty, or a header alone) is fatal like a bad stream header: exit 1, the file
/// named; standard input with no row likewise (issue 43: `track` exited 0 there),
/// and `calibrate --data` stops (exit 2).
#[test]
fn rows_file_without_rows_is_an_error_naming_it() {
    let dir = TempDir::new("norows");
    let empty = dir.file("empty.csv", "");
    let blank = dir.file("blank.csv", "\n  \n");
    let header = dir.file("header.csv", RD_HEADER);
    let enc_header = dir.file("enc_header.csv", ENC_HEADER);
    let load_cells = repo("data/load_cells/tdcr_load_cells.toml");
    let cases: [(&[&str], &str, &str); 6] = [
        (
            &["solve", TDCR, "--readings", &empty],
            "empty.csv",
            "the file is empty",
        ),
        (
            &["solve", TDCR, "--readings", &header],
            "header.csv",
            "a header",
        ),
        (
            &["track", TDCR, "--input", &blank],
            "blank.csv",
            "the file is empty",
        ),
        (
            &["track", TRACK, "--input", &enc_header],
            "enc_header.csv",
            "a header",
        ),
        (
            &["estimate", TRACK, "--measure", &empty],
            "empty.csv",
            "the file is empty",
        ),
        (
            &["estimate", &load_cells, "--measure", &header],
            "header.csv",
            "a header",
        ),
    ];
    for (args, file, why) in cases {
        let r = run(args);
        assert_eq!(r.code, 1, "{args:?}: {} {}", r.stdout, r.stderr);
        assert!(r.stderr.starts_with("error: "), "{args:?}: {}", r.stderr);
        for p in [file, "no rows", why] {
            assert!(r.stderr.contains(p), "{args:?}: `{p}` not in {}", r.stderr);
        }
    }
    // standard input: nothing, or a header and no row, is an error too (exit 1),
    // naming standard input and why
    for (stdin, why) in [("", "the file is empty"), (RD_HEADER, "a header")] {
        let r = run_with(&["track", &repo(TDCR)], Some(stdin));
        assert_eq!(r.code, 1, "{stdin:?}: {}", r.stderr);
        assert!(r.stdout.is_empty(), "{}", r.stdout);
        for p in ["standard input", "no rows", why] {
            assert!(r.stderr.contains(p), "{stdin:?}: `{p}` not in {}", r.stderr);
        }
    }
    let r = calibrate("empty", "", &[]);
    assert_error(&r, &["rec.csv", "no header and no rows"]);
}

/// Found by audit 24: a section density of 1e300 solved to `Converged` with the rod
/// pressed past an axial strain of -1 (inverted). A weight that reaches a section's
/// axial stiffness EA is refused, naming the heaviest contribution.
#[test]
fn scene_weight_beyond_the_axial_stiffness_names_the_density() {
    let r = solve_scene(
        "rho300",
        "s.toml",
        &scene_with(TDCR, "density_kg_m3 = 6450.0", "density_kg_m3 = 1e300"),
    );
    assert_error(
        &r,
        &[
            "robot.sections[0].density_kg_m3 = 1e300",
            "axial stiffness EA",
            "section 0",
        ],
    );
    assert!(!r.stdout.contains("Converged"), "{}", r.stdout);
}

/// A cable tension of 1e6 N on the demo's 1.56 mm Nitinol rod (EA 1.2e5 N) ended
/// `Stalled` with an infinite residual and no reason. Tensions whose sum through a
/// section reaches its axial stiffness EA are refused, naming the largest one.
#[test]
fn scene_tension_beyond_the_axial_stiffness_names_the_tension() {
    let r = solve_scene(
        "t1e6",
        "s.toml",
        &scene_with(DEMO, "tensions_n = [1.5,", "tensions_n = [1e6,"),
    );
    assert_error(
        &r,
        &[
            "loads.tensions_n[0] = 1000000",
            "axial stiffness EA",
            "section 0",
        ],
    );
    assert!(!r.stdout.contains("Converged"), "{}", r.stdout);
}

// ---------------------------------------------------------------------------------
// Issue 43: values checked once at the boundary
// ---------------------------------------------------------------------------------

/// A base angle of 1e300 deg and a precurvature of 1e6 1/m were accepted and then
/// diagnosed as numerical trouble blaming the payload: now range errors naming
/// the field.
#[test]
fn scene_angle_and_precurvature_out_of_range_name_the_field() {
    let text = scene_with(DEMO, "angle_deg = 90.0", "angle_deg = 1e300");
    let r = solve_scene("angle", "s.toml", &text);
    assert_error(&r, &["robot.base.angle_deg", "out of range", "360"]);
    let text = scene_with(
        DEMO,
        "density_kg_m3 = 6800.0",
        "density_kg_m3 = 6800.0\nprecurvature_per_m = [1e6, 0.0, 0.0]",
    );
    let r = solve_scene("precurv", "s.toml", &text);
    assert_error(
        &r,
        &["robot.sections[0].precurvature_per_m", "two full turns"],
    );
    // a gentle precurvature (1 rad over the section) is fine
    let text = scene_with(
        DEMO,
        "density_kg_m3 = 6800.0",
        "density_kg_m3 = 6800.0\nprecurvature_per_m = [5.0, 0.0, 0.0]",
    );
    assert_eq!(solve_scene("precurv_ok", "s.toml", &text).code, 0);
}

/// `--noise -1` reached clap as "unexpected argument '-1'"; negative numbers are
/// values now and the option's range check names it.
#[test]
fn negative_option_values_reach_the_range_check() {
    let text = recording(|_, l| Some(l.into()));
    let r = calibrate("negnoise", &text, &["--noise", "-1"]);
    assert_error(&r, &["noise", "-1"]);
    assert!(!r.stderr.contains("unexpected argument"), "{}", r.stderr);
}

/// `--marker-s` beyond the robot and `--train-rows` beyond the data were clamped
/// silently; a start value outside `--param` bounds blamed `guides.mass_kg`.
#[test]
fn calibrate_options_outside_the_data_are_errors() {
    let ftdcr = repo("data/calibration/ftdcr_v4_calibrated.toml");
    let val = repo("data/hardware/ftdcr_v4/val.csv");
    let dir = TempDir::new("calopts");
    let out = dir.0.join("out").display().to_string();
    let base = ["calibrate", &ftdcr, "--data", &val, "--out", &out];
    let with = |extra: &[&str]| {
        let mut a = base.to_vec();
        a.extend_from_slice(extra);
        run(&a)
    };
    let r = with(&["--marker-s", "99"]);
    assert_error(&r, &["marker arc length 99 m is outside the robot"]);
    let r = with(&["--train-rows", "0..100000"]);
    assert_error(&r, &["--train-rows 0..100000", "outside the 443 data rows"]);
    let text = recording(|_, l| Some(l.into()));
    let r = calibrate(
        "parambounds",
        &text,
        &["--param", "robot/sections/0/youngs_modulus_pa:1:2"],
    );
    assert_error(
        &r,
        &[
            "parameter robot/sections/0/youngs_modulus_pa",
            "outside its bounds [1, 2]",
        ],
    );
    assert!(!r.stderr.contains("mass_kg"), "{}", r.stderr);
}

/// `demo write DIR` overwrote edited files without a word: now it refuses unless
/// `--force`, and writes nothing.
#[test]
fn demo_write_refuses_to_overwrite_without_force() {
    let dir = TempDir::new("demowrite");
    let target = dir.0.join("d").display().to_string();
    assert_eq!(run(&["demo", "write", &target]).code, 0);
    let scene = dir.0.join("d/scenes/demo_two_section.toml");
    std::fs::write(&scene, "# edited\n").unwrap();
    let r = run(&["demo", "write", &target]);
    assert_error(&r, &["exist already", "--force"]);
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), "# edited\n");
    assert_eq!(run(&["demo", "write", &target, "--force"]).code, 0);
    assert_ne!(std::fs::read_to_string(&scene).unwrap(), "# edited\n");
}

/// A duplicated column (`t_s,top,top,...`) silently used its last copy: now the
/// header is refused naming both positions (encoder stream: fatal; recording: the
/// calibration stops).
#[test]
fn duplicate_column_is_refused_naming_both_positions() {
    let (r, rows) = track_rows(&format!("t_s,top,left,top\n{ENC_GOOD}"));
    assert_eq!(r.code, 1, "{}", r.stderr);
    assert_row_error(
        &rows,
        1,
        "header",
        &["`top` is given twice (columns 2 and 4)"],
    );
    let text = recording(|i, l| {
        Some(if i == 1 {
            let mut cells: Vec<&str> = l.split(',').collect();
            let first = cells[1];
            cells.push(first);
            cells.join(",")
        } else {
            l.to_string() + ",0"
        })
    });
    let r = calibrate("dupcol", &text, &[]);
    assert_error(&r, &["rec.csv:1", "column given twice (columns 2 and "]);
}

/// A quoted `"0,001"` (a decimal comma) was split into two cells by the readings
/// reader and kept whole by the calibration reader: every reader now splits lines
/// the same way (`files::rows`, the `csv` crate), so the cell is one cell, refused as
/// a number, with the row's neighbours read; an open quote is an error, not a cell
/// that swallows the rest of the line.
#[test]
fn a_quoted_decimal_comma_is_one_cell_in_every_reader() {
    let (r, rows) = track_rows(&format!(
        "{ENC_HEADER}0.0,0,\"0,001\",0\n0.0,0,\"0,0\n{ENC_GOOD}"
    ));
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_row_error(&rows, 2, "left", &["`0,001` is not a number"]);
    assert_row_error(&rows, 3, "row", &["quote is not closed"]);
    assert_good_row(&rows, 4);
    let text = recording(|i, l| {
        Some(if i == 5 {
            set_cell(l, 1, "\"0,001\"")
        } else {
            l.into()
        })
    });
    let r = calibrate("quoted", &text, &[]);
    assert_error(&r, &["rec.csv:5", "`0,001` is not a number"]);
}

/// A 10 MB bad cell was echoed whole in the error line: now its start and length.
#[test]
fn long_bad_cell_is_shortened_in_the_message() {
    let cell = "x".repeat(100_000);
    let (r, rows) = track_rows(&format!("{ENC_HEADER}0.0,0,0,{cell}\n{ENC_GOOD}"));
    assert_eq!(r.code, 0);
    assert_row_error(
        &rows,
        2,
        "right",
        &["... (100000 characters)` is not a number"],
    );
    assert!(
        r.stdout.len() < 10_000,
        "{} bytes of output",
        r.stdout.len()
    );
    assert_good_row(&rows, 3);
}

// ---------------------------------------------------------------------------------
// Actuator limits and `reach` (issue 44)
// ---------------------------------------------------------------------------------

const FTDCR_LIMITS: &str = "sections = [[-10.5, 5.5], [-10.5, 9.0], [-10.5, 13.0]]";

#[test]
fn scene_limits_excluding_zero_name_the_tendon() {
    let text = scene_with(
        "data/scenes/ftdcr_v4.toml",
        FTDCR_LIMITS,
        "tendons = { servo_7_mm = [1.0, 5.0] }",
    );
    let r = solve_scene("limits0", "ftdcr.toml", &text);
    assert_error(
        &r,
        &["robot.limits.tendons.servo_7_mm", "excludes reading 0"],
    );
    let text = scene_with(
        "data/scenes/ftdcr_v4.toml",
        FTDCR_LIMITS,
        "tendons = { nope = [0.0, 1.0] }",
    );
    let r = solve_scene("limitsname", "ftdcr.toml", &text);
    assert_error(&r, &["robot.limits.tendons.nope", "servo_4_mm"]);
}

#[test]
fn reach_bad_inputs_are_errors() {
    let dir = TempDir::new("reach");
    let scene = repo("data/calibration/ftdcr_v4_calibrated.toml");
    let r = run(&["reach", &scene]);
    assert_error(&r, &["--targets"]);
    let t = dir.file("t.csv", "x_m,y_m,z_m\n0,0,0.18\n0,inf,0.18\n");
    let r = run(&["reach", &scene, "--targets", &t]);
    assert_error(&r, &["t.csv:3", "`y_m` = `inf`"]);
    let t = dir.file("u.csv", "x_m,y_m,z_m\n0,0,0.18\n");
    let r = run(&["reach", &scene, "--targets", &t, "--objective", "fastest"]);
    assert_error(&r, &["--objective `fastest`"]);
    let r = run(&["reach", &scene, "--targets", &t, "--tolerance-mm", "-1"]);
    assert_error(&r, &["--tolerance-mm"]);
}

#[test]
fn workspace_bad_inputs_are_errors() {
    let dir = TempDir::new("workspace");
    let scene = repo("data/calibration/ftdcr_v4_calibrated.toml");
    let out = dir.0.join("out").display().to_string();
    let r = run(&["workspace", &scene, "--samples", "0", "--output", &out]);
    assert_error(&r, &["--samples", "at least 1"]);
    // no limits: nothing bounds the box to sample
    let text = scene_with(
        "data/calibration/ftdcr_v4_calibrated.toml",
        FTDCR_LIMITS,
        "",
    );
    let s = dir.file("nolimits.toml", &text);
    let r = run(&["workspace", &s, "--samples", "4", "--output", &out]);
    assert_error(&r, &["robot.limits (servo_4_mm)", "finite limits"]);
    // limits that exclude zero are refused when the scene is read
    let text = scene_with(
        "data/calibration/ftdcr_v4_calibrated.toml",
        FTDCR_LIMITS,
        "sections = [[-10.5, 5.5], [-10.5, 9.0], [1.0, 13.0]]",
    );
    let s = dir.file("excl.toml", &text);
    let r = run(&["workspace", &s, "--samples", "4", "--output", &out]);
    assert_error(&r, &["robot.limits", "excludes reading 0"]);
    let r = run(&["workspace", &scene, "--val", &scene, "--output", &out]);
    assert_error(&r, &["--val needs --recording"]);
}
