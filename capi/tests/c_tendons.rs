//! Compiles `examples/c/tendons.c` as C11 with the system C compiler (`$CC` or `cc`)
//! against this crate's static library (so the generated header is valid C, not
//! only C++) and runs it on the textbook two-segment TDCR: every tick converges,
//! pulling tendon 0 makes it the most loaded and bends the tip towards its hole
//! (+x), and every bad call prints an error naming the value.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The static library built with this test (same profile directory).
fn staticlib() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    for dir in [deps, deps.parent().unwrap()] {
        let lib = dir.join("libcablesense_capi.a");
        if lib.exists() {
            return lib;
        }
    }
    panic!("libcablesense_capi.a not found next to {}", exe.display());
}

fn numbers(stdout: &str, prefix: &str) -> Vec<f64> {
    stdout
        .lines()
        .find_map(|l| l.strip_prefix(prefix))
        .unwrap_or_else(|| panic!("no `{prefix}` line in\n{stdout}"))
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect()
}

#[test]
fn c_tendon_loop_runs_on_the_two_segment_tdcr() {
    let out_dir = std::env::temp_dir().join(format!("cablesense-capi-c-{}", std::process::id()));
    std::fs::create_dir_all(&out_dir).unwrap();
    let exe = out_dir.join("tendons");
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let build = Command::new(&cc)
        .args([
            "-O2",
            "-std=c11",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-pedantic",
        ])
        .arg("-I")
        .arg(root().join("capi/include"))
        .arg(root().join("examples/c/tendons.c"))
        .arg(staticlib())
        .args(["-lpthread", "-ldl", "-lm", "-o"])
        .arg(&exe)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {cc}: {e}"));
    assert!(
        build.status.success(),
        "{cc} failed:\n{}",
        String::from_utf8_lossy(&build.stderr)
    );
    let run = Command::new(&exe)
        .arg(root().join("data/scenes/tdcr_two_segment.toml"))
        .arg("100")
        .output()
        .unwrap();
    // with an 80 mm amplitude the pull does not converge from the second tick on
    // (5 mm on s1a with s1c held: the backbone is compressed, tensions ~100 N): the
    // first such tick prints why through `cs_tendons_diagnosis`, naming the pull
    let far = Command::new(&exe)
        .arg(root().join("data/scenes/tdcr_two_segment.toml"))
        .args(["30", "0.08"])
        .output()
        .unwrap();
    let _ = std::fs::remove_dir_all(&out_dir);
    let far_err = String::from_utf8_lossy(&far.stderr);
    assert!(
        far_err.contains("did not converge: not converged")
            && far_err.contains("the readings pull in: readings column s1a = "),
        "{far_err}"
    );
    assert_eq!(far_err.matches("did not converge").count(), 1, "{far_err}");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    println!("{stdout}");
    assert!(stdout.contains("ticks: 100  converged: 100"), "{stdout}");
    assert!(stdout.contains("tick time (us): p50 "), "{stdout}");
    // at the peak pull of tendon 0 (1 mm): the most loaded, all tendons accounted
    let tension = numbers(&stdout, "peak tensions (N):");
    assert_eq!(tension.len(), 6);
    let max = tension.iter().cloned().fold(f64::MIN, f64::max);
    assert_eq!(tension[0], max, "{tension:?}");
    assert!(tension.iter().all(|t| *t >= 0.0), "{tension:?}");
    let taut = numbers(&stdout, "peak taut:");
    assert!(taut.iter().all(|f| *f == 0.0 || *f == 1.0) && taut[0] == 1.0);
    // tendon 0 is routed at angle 0 (+x): the tip bends towards +x
    let tip = numbers(&stdout, "peak tip (mm):");
    assert!(tip[0] > 1.0 && tip[2] > 150.0, "{tip:?}");
    for (what, names) in [
        ("NaN reading", "readings[1] (s1b) must be finite, got NaN"),
        (
            "short buffer",
            "n = 5 readings for 6 displacement-driven tendons",
        ),
        ("null handle", "tendons is null"),
        (
            "bad scene",
            "robot.sections[0].length_m must be > 0, got -0.1",
        ),
    ] {
        let line = stdout
            .lines()
            .find(|l| l.starts_with(&format!("bad call ({what})")))
            .unwrap_or_else(|| panic!("no bad call ({what}) in\n{stdout}"));
        assert!(line.contains(names), "{line}");
    }
}
