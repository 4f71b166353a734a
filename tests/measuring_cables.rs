//! Passive (measuring) cables in readings files: the `length_<cable>` columns of
//! `files::readings` (length change of a passive cable from the reference state,
//! unit `[readings] length_scale_m`, default `scale_m`), fed to
//! `estimate::TendonLoadEstimator` by `cablesense estimate`/`track`.
//!
//! The robot is the shipped load-cell demo (`data/load_cells/tdcr_load_cells.toml`:
//! two-segment TDCR, six displacement-driven tendons at 8 mm) with three passive
//! cables added on their own holes (6 mm, at 30, 150 and 270 degrees, to the tip),
//! servo and encoder columns in millimetres, and the tip force x, y as the unknowns
//! (the payload mass of the demo is dropped: three tip cables see it badly). Rows are
//! synthesised by the library's forward solve (`TendonLoadEstimator::predict`) at a
//! known tip force, so the round trip has no model error (see each test for its
//! tolerance).

use cablesense::estimate::{EstimateStatus, TendonLoadEstimator};
use cablesense::files::load_cells;
use cablesense::files::readings::ReadingsParser;
use cablesense::Scene;
use std::path::PathBuf;

const DEMO: &str = "data/load_cells/tdcr_load_cells.toml";
const PASSIVE: [&str; 3] = ["m30", "m150", "m270"];
const DRIVEN: [&str; 6] = ["s1a", "s1b", "s1c", "s2a", "s2b", "s2c"];

/// The demo scene with three passive cables, readings in mm, and the tip force x, y
/// as unknowns; `length_scale` sets `[readings] length_scale_m` when given.
fn scene_text(length_scale: Option<f64>) -> String {
    let mut text = std::fs::read_to_string(DEMO).unwrap();
    let mass = "[[estimate.unknowns]]\nkind = \"mass\"\nsection = 1\nmax = 0.5\n";
    assert!(text.contains(mass), "the demo's mass unknown moved");
    text = text.replace(mass, "");
    let mut readings = "[readings]\nscale_m = 0.001\n".to_string();
    if let Some(l) = length_scale {
        readings.push_str(&format!("length_scale_m = {l:e}\n"));
    }
    text = text.replace("[readings]\nscale_m = 1.0\n", &readings);
    for (name, angle) in PASSIVE.iter().zip([30.0, 150.0, 270.0]) {
        text.push_str(&format!(
            "\n[[robot.cables]]\nname = \"{name}\"\nrouting = {{ radius_m = 0.006, angle_deg = {angle} }}\nend_section = 1\nactuation = \"passive\"\n"
        ));
    }
    text
}

fn scene(length_scale: Option<f64>) -> Scene {
    Scene::from_toml_str(&scene_text(length_scale)).expect("scene with measuring cables")
}

/// The scene written where the command line can read it.
fn scene_file(tag: &str) -> PathBuf {
    let path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("measuring_{tag}.toml"));
    std::fs::write(&path, scene_text(None)).unwrap();
    path
}

/// The parser `cablesense estimate`/`track` use on `sc`.
fn parser(sc: &Scene) -> (TendonLoadEstimator, ReadingsParser) {
    let mut est = load_cells::estimator(sc).expect("estimator builds");
    let p = load_cells::parser(sc, &mut est);
    (est, p)
}

/// Readings (m): segment 1 pulls its first tendon by `d1` and releases the others by
/// half, segment 2 the same with `d2`.
fn pull(d1: f64, d2: f64) -> Vec<f64> {
    vec![d1, -0.5 * d1, -0.5 * d1, d2, -0.5 * d2, -0.5 * d2]
}

/// CSV header and `length_` columns: values scaled by `scale_m` (mm) by default and by
/// `length_scale_m` when set; an empty cell is not measured (NaN, not the last
/// value); driven tendons and unknown cables get NaN (exact: products of decimals
/// by the scale, compared to 1e-15 m).
#[test]
fn csv_length_columns_parse_with_the_scale() {
    for (scale, label) in [(None, "default = scale_m"), (Some(1e-6), "um")] {
        let sc = scene(scale);
        let unit = scale.unwrap_or(1e-3);
        let (_, mut p) = parser(&sc);
        assert_eq!(
            p.line(
                1,
                "t_s,s1a,s1b,s1c,s2a,s2b,s2c,length_m30,length_m270,label"
            )
            .unwrap(),
            None
        );
        let r = p
            .line(2, "0,0.4,-0.2,-0.2,0,0,0,1.25,-0.5,x")
            .unwrap()
            .unwrap();
        assert_eq!(r.length_changes_m.len(), 9, "{label}: one per robot cable");
        assert!((r.readings_m[0] - 0.4e-3).abs() < 1e-15, "{label}: {r:?}");
        let want = [(6, 1.25 * unit), (8, -0.5 * unit)];
        for (j, v) in want {
            assert!((r.length_changes_m[j] - v).abs() < 1e-15, "{label}: {r:?}");
        }
        assert!(r.length_changes_m[7].is_nan(), "m150 has no column");
        assert!(r.length_changes_m[..6].iter().all(|v| v.is_nan()));
        // an empty cell: not measured in this row (not carried from line 2)
        let r = p.line(3, "0.1,0.4,-0.2,-0.2,0,0,0,,2,x").unwrap().unwrap();
        assert!(r.length_changes_m[6].is_nan(), "{label}: {r:?}");
        assert!((r.length_changes_m[8] - 2.0 * unit).abs() < 1e-15);
        assert!(r.tensions_n.iter().all(|t| t.is_nan()));
    }
}

/// JSON lines: `length_<cable>` keys parse with the scale, `null` is not measured.
#[test]
fn json_length_keys_parse_with_the_scale() {
    let sc = scene(None);
    let (_, mut p) = parser(&sc);
    let r = p
        .line(
            1,
            r#"{"t_s": 0, "s1a": 0.1, "s1b": 0, "s1c": 0, "s2a": 0, "s2b": 0, "s2c": 0, "length_m150": -0.75, "length_m270": null, "tension_s1a": 1.5}"#,
        )
        .unwrap()
        .unwrap();
    assert!((r.length_changes_m[7] + 0.75e-3).abs() < 1e-15, "{r:?}");
    assert!(r.length_changes_m[8].is_nan() && r.length_changes_m[6].is_nan());
    assert_eq!(r.tensions_n[0], 1.5);
    // a row without length keys: readings kept, lengths not measured
    let r = p.line(2, r#"{"length_m30": 3}"#).unwrap().unwrap();
    assert!((r.readings_m[0] - 0.1e-3).abs() < 1e-15);
    assert!((r.length_changes_m[6] - 3e-3).abs() < 1e-15, "{r:?}");
    assert!(r.length_changes_m[7].is_nan());
}

/// Each bad `length_` column in CSV: an unknown cable or a driven tendon's name is
/// reported on the header line naming the column (which is then ignored), NaN, inf
/// and text are errors for that row naming line and column; the following rows
/// parse.
#[test]
fn csv_bad_length_columns_are_named_and_the_stream_goes_on() {
    let sc = scene(None);
    let (_, mut p) = parser(&sc);
    let e = p
        .line(1, "s1a,s1b,s1c,s2a,s2b,s2c,length_m30,length_zz")
        .unwrap_err();
    assert_eq!((e.line, e.field.as_str()), (1, "length_zz"));
    assert!(
        e.why.contains("`zz`") && e.why.contains("m30, m150, m270"),
        "{e}"
    );
    // the header is used, its unknown column ignored
    let r = p.line(2, "0,0,0,0,0,0,1,99").unwrap().unwrap();
    assert!((r.length_changes_m[6] - 1e-3).abs() < 1e-15, "{r:?}");
    for (line, cell) in [(3, "NaN"), (4, "inf"), (5, "abc")] {
        let e = p.line(line, &format!("0,0,0,0,0,0,{cell},0")).unwrap_err();
        assert_eq!((e.line, e.field.as_str()), (line, "length_m30"), "{e}");
        assert!(e.to_string().contains(cell), "{e}");
    }
    assert!(p.line(6, "0,0,0,0,0,0,2,0").unwrap().is_some());
    // a driven tendon is not a measuring cable (a new header mid-stream)
    let e = p
        .line(7, "s1a,s1b,s1c,s2a,s2b,s2c,length_s2b,length_m270")
        .unwrap_err();
    assert_eq!((e.line, e.field.as_str()), (7, "length_s2b"));
    assert!(e.why.contains("displacement-driven"), "{e}");
    let r = p.line(8, "0,0,0,0,0,0,5,-1").unwrap().unwrap();
    assert!(r.length_changes_m[4].is_nan(), "{r:?}");
    assert!((r.length_changes_m[8] + 1e-3).abs() < 1e-15, "{r:?}");
}

/// The same bad cases in JSON lines: an error for that row naming line and key, and
/// the next row parses.
#[test]
fn json_bad_length_keys_are_named_and_the_stream_goes_on() {
    let sc = scene(None);
    let (_, mut p) = parser(&sc);
    let base = r#""s1a": 0, "s1b": 0, "s1c": 0, "s2a": 0, "s2b": 0, "s2c": 0"#;
    assert!(p.line(1, &format!("{{{base}}}")).unwrap().is_some());
    let cases = [
        (r#""length_zz": 1"#, "length_zz", "`zz`"),
        (r#""length_s1a": 1"#, "length_s1a", "displacement-driven"),
        (r#""length_m30": "NaN""#, "length_m30", "NaN"),
        (r#""length_m150": "inf""#, "length_m150", "inf"),
        (r#""length_m270": "ten""#, "length_m270", "ten"),
    ];
    for (k, (cell, field, says)) in cases.iter().enumerate() {
        let line = 2 + 2 * k;
        let e = p.line(line, &format!("{{{base}, {cell}}}")).unwrap_err();
        assert_eq!((e.line, e.field.as_str()), (line, *field), "{e}");
        assert!(e.to_string().contains(says), "{e}");
        let r = p
            .line(line + 1, &format!("{{{base}, \"length_m30\": 0.5}}"))
            .unwrap()
            .unwrap();
        assert!((r.length_changes_m[6] - 0.5e-3).abs() < 1e-15, "{r:?}");
    }
}

/// Synthetic rows: (readings, tip force x, y) -> CSV line with readings and the
/// passive cables' length changes in mm (shortest round-trip text, so no rounding
/// beyond the mm scale's).
fn synthesize(sc: &Scene, rows: &[(Vec<f64>, [f64; 2])]) -> String {
    let mut truth = load_cells::estimator(sc).unwrap();
    let mut text = format!(
        "t_s,{},{}\n",
        DRIVEN.join(","),
        PASSIVE.map(|c| format!("length_{c}")).join(",")
    );
    for (k, (q, f)) in rows.iter().enumerate() {
        let pred = truth.predict(f, q).unwrap();
        assert!(pred.status.is_converged(), "{pred:?}");
        let cells: Vec<String> = q
            .iter()
            .chain(&pred.length_changes_m[6..])
            .map(|v| format!("{:e}", v * 1e3))
            .collect();
        text.push_str(&format!("{},{}\n", k as f64 * 0.1, cells.join(",")));
    }
    text
}

fn run_cli(args: &[&str], stdin: Option<&str>) -> (bool, Vec<serde_json::Value>) {
    use std::io::Write;
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_cablesense"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let input = child.stdin.take().unwrap();
    if let Some(s) = stdin {
        let mut input = input;
        input.write_all(s.as_bytes()).unwrap();
    }
    let out = child.wait_with_output().unwrap();
    let records = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    (out.status.success(), records)
}

/// End to end through `cablesense estimate --json`: three measuring cables and no
/// load cell estimate the tip force of each row. Noise-free, the estimate returns
/// the force to the estimator's convergence (scene tolerance 1e-9 relative step) and
/// the file's text precision (17 digits); asserted |F_est - F| <= 1e-6 |F| + 1e-9 N
/// per component (|F| ~ 0.05 N; measured worst error printed by the test).
#[test]
fn cli_estimates_the_tip_force_from_measuring_cables_only() {
    let sc = scene(None);
    let rows = vec![
        (pull(0.0, 0.0), [0.05, -0.03]),
        (pull(3e-4, -2e-4), [0.05, -0.03]),
        (pull(4e-4, 1e-4), [-0.04, 0.06]),
        (pull(-2e-4, 3e-4), [0.02, 0.045]),
    ];
    let csv = synthesize(&sc, &rows);
    let data = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("measuring_rows.csv");
    std::fs::write(&data, &csv).unwrap();
    let path = scene_file("cli");
    let (ok, records) = run_cli(
        &[
            "estimate",
            path.to_str().unwrap(),
            "--measure",
            data.to_str().unwrap(),
            "--json",
        ],
        None,
    );
    assert!(ok, "every row converged with a good fit: {records:?}");
    assert_eq!(records.len(), rows.len());
    let mut worst = 0.0f64;
    for (r, (_, f)) in records.iter().zip(&rows) {
        assert_eq!(r["status"], "converged", "{r}");
        let norm = f[0].hypot(f[1]);
        for (key, truth) in ["force_x@s1", "force_y@s1"].iter().zip(f) {
            let v = r["estimate"][key].as_f64().unwrap();
            worst = worst.max((v - truth).abs() / norm);
            eprintln!("line {}: {key} {v:.12} vs {truth}", r["line"]);
            assert!(
                (v - truth).abs() <= 1e-6 * norm + 1e-9,
                "line {}: {key} = {v} vs {truth}",
                r["line"]
            );
        }
        // the three passive cables are the measurements, the tendons are not
        let measured: Vec<bool> = r["measured_length_change_m"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| !v.is_null())
            .collect();
        assert_eq!(measured, [vec![false; 6], vec![true; 3]].concat(), "{r}");
        assert!(r["measured_tension_n"]
            .as_array()
            .unwrap()
            .iter()
            .all(|v| v.is_null()));
        assert_eq!(r["redundancy"], 1, "{r}");
    }
    eprintln!("worst |F_est - F| / |F| = {worst:.3e}");

    // the library path the command line takes, on the same file
    let (mut est, mut p) = parser(&sc);
    for (i, line) in csv.lines().enumerate() {
        let Some(row) = p.line(i + 1, line).unwrap() else {
            continue;
        };
        let status = est
            .tick(&row.readings_m, &row.tensions_n, row.length_changes())
            .unwrap();
        assert_eq!(status, EstimateStatus::Converged);
        let f = rows[i - 1].1;
        let v = &est.estimate().estimate.values;
        let norm = f[0].hypot(f[1]);
        assert!((v[0] - f[0]).abs() <= 1e-6 * norm + 1e-9, "{v:?} vs {f:?}");
        assert!((v[1] - f[1]).abs() <= 1e-6 * norm + 1e-9, "{v:?} vs {f:?}");
    }
}

/// `cablesense track` on JSON lines: a row with neither load cells nor length
/// values (keys absent, or `null`) is `unobservable` with infinite standard
/// deviations and the held estimate (the previous row's), never an invented
/// value; a bad length value is named and the stream goes on.
#[test]
fn cli_row_without_measurements_is_unobservable() {
    let sc = scene(None);
    let f = [0.03, 0.02];
    let q = pull(2e-4, -1e-4);
    let csv = synthesize(&sc, &[(q.clone(), f)]);
    let line = csv.lines().nth(1).unwrap();
    let cells: Vec<&str> = line.split(',').collect();
    let readings: Vec<String> = DRIVEN
        .iter()
        .zip(&cells[1..7])
        .map(|(n, v)| format!("\"{n}\": {v}"))
        .collect();
    let readings = readings.join(", ");
    let lengths: Vec<String> = PASSIVE
        .iter()
        .zip(&cells[7..])
        .map(|(n, v)| format!("\"length_{n}\": {v}"))
        .collect();
    let stdin = format!(
        "{{{readings}, {}}}\n{{{readings}}}\n{{{readings}, \"length_m30\": null}}\n{{{readings}, \"length_m30\": \"NaN\"}}\n{{{readings}, {}}}\n",
        lengths.join(", "),
        lengths.join(", ")
    );
    let path = scene_file("track");
    let (_, records) = run_cli(&["track", path.to_str().unwrap()], Some(&stdin));
    assert_eq!(records.len(), 5, "{records:?}");
    let first = &records[0];
    assert_eq!(first["status"], "converged", "{first}");
    for r in &records[1..3] {
        assert_eq!(r["status"], "unobservable", "{r}");
        assert_eq!(r["rank"], 0, "{r}");
        for key in ["force_x@s1", "force_y@s1"] {
            // held, not invented: the previous row's value; infinite sigma -> null
            assert_eq!(r["estimate"][key], first["estimate"][key], "{r}");
            assert!(r["std_dev"][key].is_null(), "{r}");
        }
        let listed = r["unobservable"].to_string();
        assert!(
            listed.contains("force_x@s1") && listed.contains("force_y@s1"),
            "{r}"
        );
    }
    assert_eq!(
        (records[3]["line"].as_u64(), records[3]["field"].as_str()),
        (Some(4), Some("length_m30"))
    );
    assert_eq!(records[4]["status"], "converged", "{}", records[4]);
    let v = records[4]["estimate"]["force_x@s1"].as_f64().unwrap();
    assert!((v - f[0]).abs() <= 1e-6 * f[0].hypot(f[1]) + 1e-9, "{v}");
}

/// `files::load_cells::synthesize` on a scene with passive cables writes their
/// `length_<cable>` columns (with the scene's `noise_m`, in the scene's units: mm
/// here); read back through the parser without the load cells, every row converges
/// and its estimate is within 4 reported sigma of the true force (`true_*` columns):
/// 4 sigma over 80 (row, unknown) pairs fails with probability ~0.5 % for a correct
/// sigma, and the seed is fixed (measured worst: 2.55 sigma).
///
/// `noise_m = 1e-7` m: the stiff displacement-driven tendons leave the tip cables
/// ~1.5e-5..3.3e-5 m/N of sensitivity (printed by the test below), so 1e-7 m is
/// sigma ~2.6e-3 N against the 0.06 N amplitude. At the default 1e-5 m the force is
/// barely determined (measured sigma 0.14..0.26 N) and the second data row stops at
/// `max_iterations` (20); at 1e-6 m (sigma ~0.026 N) rows take 10..19 iterations and
/// line 11 stops at 20: the estimator's behaviour, not this file's subject.
#[test]
fn synthesized_recording_with_measuring_cables_is_estimated_within_its_sigma() {
    use cablesense::files::load_cells::{synthesize, Recipe};
    let mut sc = scene(None);
    sc.estimate.as_mut().unwrap().noise_m = 1e-7;
    let recipe = Recipe {
        load_amplitude: vec![0.06, -0.04],
        ..Recipe::default()
    };
    let text = synthesize(&sc, &recipe).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    for c in PASSIVE {
        assert!(
            header.contains(&format!("length_{c}").as_str()),
            "{header:?}"
        );
    }
    let truth: Vec<usize> = (0..header.len())
        .filter(|&i| header[i].starts_with("true_"))
        .collect();
    let (mut est, mut p) = parser(&sc);
    let mut worst = 0.0f64;
    for (i, line) in text.lines().enumerate() {
        let Some(row) = p.line(i + 1, line).unwrap() else {
            continue;
        };
        // drop the load cells: the measuring cables alone
        let none = vec![f64::NAN; row.tensions_n.len()];
        let status = est
            .tick(&row.readings_m, &none, row.length_changes())
            .unwrap();
        let e = est.estimate().estimate;
        eprintln!(
            "line {}: {status:?} it {} {:?} +- {:?} rms {:.3} fit {:?}",
            i + 1,
            e.iterations,
            e.values,
            e.std_dev,
            e.rms_sigma,
            e.fit
        );
        assert_eq!(status, EstimateStatus::Converged, "line {}", i + 1);
        let cells: Vec<f64> = line.split(',').map(|c| c.parse().unwrap()).collect();
        for (k, &c) in truth.iter().enumerate() {
            let z = (e.values[k] - cells[c]) / e.std_dev[k];
            worst = worst.max(z.abs());
            assert!(
                z.abs() < 4.0,
                "line {}: {} off by {z} sigma",
                i + 1,
                header[c]
            );
        }
    }
    eprintln!("worst |error| / sigma = {worst:.2}");
}

/// The measuring cables' exact length sensitivities (`TendonWorkspace::
/// load_sensitivities`) against central differences of converged solves, step 1e-4
/// N (the tolerance argument of `tests/estimate_tendon_loads.rs`: 1e-8 m/N absolute
/// + 1e-4 relative).
#[test]
fn measuring_cable_sensitivities_match_central_differences() {
    use cablesense::estimate::EstimationModel;
    use cablesense::Start;
    let sc = scene(None);
    let (mut est, _) = parser(&sc);
    let theta = [0.03, -0.02];
    est.predict(&theta, &pull(3e-4, -1e-4)).unwrap();
    let model = est.estimator().model();
    let c = model.channels();
    let mut g = vec![0.0; c * 2];
    let mut l0 = vec![0.0; c];
    assert!(model.length_sensitivities(&mut g, &mut l0));
    let h = 1e-4;
    let (mut lp, mut lm) = (vec![0.0; c], vec![0.0; c]);
    for k in 0..2 {
        for (sign, out) in [(1.0, &mut lp), (-1.0, &mut lm)] {
            let mut t = theta;
            t[k] += sign * h;
            model.set_theta(&t);
            assert!(model.solve(Start::Warm).status.is_converged());
            model.cable_lengths_into(out);
        }
        for j in 0..9 {
            let fd = (lp[j] - lm[j]) / (2.0 * h);
            let ex = g[j * 2 + k];
            eprintln!("cable {j}, unknown {k}: exact {ex:e} central {fd:e}");
            assert!(
                (fd - ex).abs() <= 1e-8 + 1e-4 * ex.abs(),
                "cable {j}, unknown {k}: exact {ex:e} vs central {fd:e}"
            );
        }
    }
}
