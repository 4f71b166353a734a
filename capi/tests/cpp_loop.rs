//! Compiles `examples/c/loop.cpp` with the system C++ compiler against this crate's
//! static library and runs it over the shipped encoder demo: it must tick every
//! sample without error, estimate the demo's first sample (truth F_y = -0.05 N,
//! F_z = 0.04 N, noise ~2e-4 N) and print the per-tick time percentiles.

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

#[test]
fn cpp_control_loop_runs_over_the_demo() {
    let out_dir = std::env::temp_dir().join(format!("cablesense-capi-{}", std::process::id()));
    std::fs::create_dir_all(&out_dir).unwrap();
    let exe = out_dir.join("loop");
    let cxx = std::env::var("CXX").unwrap_or_else(|_| "c++".into());
    let build = Command::new(&cxx)
        .args(["-O2", "-std=c++17", "-Wall", "-Wextra", "-Werror"])
        .arg("-I")
        .arg(root().join("capi/include"))
        .arg(root().join("examples/c/loop.cpp"))
        .arg(staticlib())
        .args(["-lpthread", "-ldl", "-lm", "-o"])
        .arg(&exe)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {cxx}: {e}"));
    assert!(
        build.status.success(),
        "{cxx} failed:\n{}",
        String::from_utf8_lossy(&build.stderr)
    );
    let run = Command::new(&exe)
        .arg(root().join("data/scenes/track_demo.toml"))
        .arg(root().join("data/measurements/track_demo.csv"))
        .arg("1000")
        .output()
        .unwrap();
    let _ = std::fs::remove_dir_all(&out_dir);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    println!("{stdout}");
    assert!(stdout.contains("ticks: 1000  rows: 37"), "{stdout}");
    assert!(stdout.contains("bad call: changes is null"), "{stdout}");
    assert!(stdout.contains("tick time (us): p50 "), "{stdout}");
    let first: Vec<f64> = stdout
        .lines()
        .find_map(|l| l.strip_prefix("first estimate:"))
        .unwrap()
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(first.len(), 2);
    assert!((first[0] + 0.05).abs() < 1e-3, "{first:?}");
    assert!((first[1] - 0.04).abs() < 1e-3, "{first:?}");
    let converged: usize = stdout
        .split("converged: ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .unwrap()
        .parse()
        .unwrap();
    assert!(converged >= 950, "{stdout}");
}
