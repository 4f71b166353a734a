//! `cablesense reach`: the readings it writes, fed to `cablesense solve --readings`,
//! give the tips it reports (`--report`) to 1e-9 m; a target outside the workspace
//! is reported as unreachable (exit 1), a bad targets file is an error (exit 2).

use std::path::PathBuf;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_cablesense");
const SCENE: &str = "data/calibration/ftdcr_v4_calibrated.toml";

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cablesense-reach-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn reach_readings_reproduce_the_reported_tips_through_solve() {
    let d = tmp("roundtrip");
    // three reachable targets and one 10 cm above the straight tip
    let targets = "# test targets\nx_m,y_m,z_m\n0.005,0.004,0.185\n-0.01,0.0,0.184\n0.0,-0.008,0.1855\n0.0,0.0,0.3\n";
    std::fs::write(d.join("t.csv"), targets).unwrap();
    let (out, rep) = (d.join("q.csv"), d.join("rep.csv"));
    let o = Command::new(BIN)
        .args(["reach", SCENE, "--targets"])
        .arg(d.join("t.csv"))
        .arg("--output")
        .arg(&out)
        .arg("--report")
        .arg(&rep)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "one target is unreachable: {err}");
    assert!(err.contains("3 reached, 1 unreachable"), "{err}");
    let report = std::fs::read_to_string(&rep).unwrap();
    let rows: Vec<Vec<String>> = report
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    assert_eq!(rows.len(), 4);
    assert_eq!(rows[3][1], "unreachable");
    let o = Command::new(BIN)
        .args(["solve", SCENE, "--json", "--readings"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .filter(|v: &serde_json::Value| v.get("tip_position_m").is_some())
        .collect();
    assert_eq!(lines.len(), 4);
    for (k, v) in lines.iter().enumerate() {
        let tip: Vec<f64> = v["tip_position_m"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        for c in 0..3 {
            let reported: f64 = rows[k][2 + c].parse().unwrap();
            assert!(
                (tip[c] - reported).abs() <= 1e-9,
                "row {k}: {tip:?} vs {:?}",
                rows[k]
            );
        }
        if k < 3 {
            let d: f64 = rows[k][5].parse().unwrap();
            assert!(d <= 5e-5, "row {k} reached: {d}");
        }
    }
}

#[test]
fn reach_bad_targets_are_errors() {
    let d = tmp("bad");
    for (text, needle) in [
        ("x_m,y_m\n0,0\n", "x_m, y_m and z_m"),
        ("x_m,y_m,z_m\n0,nan,0.1\n", "`y_m` = `nan`"),
        ("x_m,y_m,z_m,dx,dy,dz\n0,0,0.18,0,0,0\n", "zero length"),
        ("x_m,y_m,z_m\n", "no target rows"),
    ] {
        std::fs::write(d.join("t.csv"), text).unwrap();
        let o = Command::new(BIN)
            .args(["reach", SCENE, "--targets"])
            .arg(d.join("t.csv"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{text}: {err}");
        assert!(err.contains(needle), "{text}: {err}");
    }
}

/// `reach --measured --recording FILE`: the recording's measured tips as targets (the scene's
/// `[calibration]` columns), every row counted in the summary and the report, the
/// forward error that of `track` (readings conditioned), the readings file written;
/// a scene without `[calibration]` is an error.
#[test]
fn reach_measured_counts_every_row() {
    let d = tmp("measured");
    let val = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").unwrap();
    let rows = 25;
    let text: String = val
        .lines()
        .take(rows + 1)
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(d.join("rec.csv"), &text).unwrap();
    let (out, rep) = (d.join("q.csv"), d.join("rep.csv"));
    let o = Command::new(BIN)
        .args(["reach", SCENE, "--measured", "--recording"])
        .arg(d.join("rec.csv"))
        .arg("--output")
        .arg(&out)
        .arg("--report")
        .arg(&rep)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{err}");
    assert!(err.contains(&format!("{rows} targets")), "{err}");
    // the forward error is that of `track` on the same rows (the scene's time
    // offset and backlash applied), as printed (3 decimals of a mm)
    let scene = cablesense::Scene::load(SCENE).unwrap();
    let track = cablesense::validation::track_errors(&scene, "rec.csv", &text).unwrap();
    let printed = format!("RMSE {:.3},", track.errors.raw.rmse_m * 1e3);
    assert!(
        err.contains("forward error at the recorded readings") && err.contains(&printed),
        "{printed}: {err}"
    );
    let counts: usize = ["reached", "unreachable", "out of budget"]
        .iter()
        .map(|s| {
            let i = err.find(&format!(" {s}")).unwrap();
            let head = &err[..i];
            head[head.rfind(' ').unwrap() + 1..]
                .trim_matches(',')
                .parse::<usize>()
                .unwrap()
        })
        .sum();
    assert_eq!(counts, rows, "{err}");
    let report = std::fs::read_to_string(&rep).unwrap();
    assert_eq!(report.lines().count(), rows + 1);
    let written = std::fs::read_to_string(&out).unwrap();
    assert_eq!(
        written.lines().filter(|l| !l.starts_with('#')).count(),
        rows + 1
    );
    // no [calibration]: an error naming it
    let o = Command::new(BIN)
        .args([
            "reach",
            "data/scenes/till_tendon_readings.toml",
            "--measured",
            "--recording",
        ])
        .arg(d.join("rec.csv"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("[calibration]"), "{err}");
}
