//! Rollback through the C ABI, as a C control loop sees it: the FTDCR v4 val rows
//! solved warm by `cs_tendons_solve` with and without an unreachable row between
//! them give bit-identical results on every good row (the library's
//! `TendonWorkspace` rollback; the Rust test is `tests/rollback.rs`). Run twice: the
//! functions called from Rust, and `tests/c/rollback.c` compiled as C99 with the
//! system C compiler (`$CC` or `cc`) against the static library.

use cablesense_capi::*;
use std::ffi::CString;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The val rows in m, in the handle's tendon order (the scene's readings parser).
fn val_rows() -> Vec<Vec<f64>> {
    let scene = cablesense::Scene::load(root().join("data/scenes/ftdcr_v4.toml")).unwrap();
    let ws = scene.tendon_workspace().unwrap();
    let mut p = scene.readings_parser(&ws);
    let text = std::fs::read_to_string(root().join("data/hardware/ftdcr_v4/val.csv")).unwrap();
    text.lines()
        .enumerate()
        .filter_map(|(i, l)| p.line(i + 1, l).ok().flatten())
        .map(|r| r.readings_m)
        .collect()
}

fn handle() -> *mut CsTendons {
    let text = std::fs::read_to_string(root().join("data/scenes/ftdcr_v4.toml")).unwrap();
    let text = CString::new(text).unwrap();
    let mut t = std::ptr::null_mut();
    // SAFETY: valid string and out pointer.
    assert_eq!(unsafe { cs_tendons_new(text.as_ptr(), &mut t) }, CsCode::Ok);
    t
}

/// (status, iterations, tip bits, tension bits) of one warm solve.
fn solve(t: *mut CsTendons, q: &[f64]) -> (i32, u32, Vec<u64>) {
    let mut info = CsTendonInfo::default();
    let (mut tip, mut tension, mut taut) = ([0.0; 3], [0.0; 9], [0i32; 9]);
    // SAFETY: live handle; buffers of the stated sizes.
    unsafe {
        assert_eq!(cs_tendons_solve(t, q.as_ptr(), 9, 1, &mut info), CsCode::Ok);
        assert_eq!(cs_tendons_tip_position(t, tip.as_mut_ptr()), CsCode::Ok);
        assert_eq!(
            cs_tendons_tensions(t, tension.as_mut_ptr(), taut.as_mut_ptr(), 9),
            CsCode::Ok
        );
    }
    let bits = tip.iter().chain(&tension).map(|v| v.to_bits()).collect();
    (info.status, info.iterations, bits)
}

#[test]
fn a_failed_row_does_not_change_the_following_rows() {
    let rows = val_rows();
    let (a, b) = (handle(), handle());
    // SAFETY: live handle.
    assert_eq!(unsafe { cs_tendons_count(a) }, 9);
    let bad = [0.05, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let mut converged = 0;
    for (i, q) in rows.iter().enumerate() {
        let ra = solve(a, q);
        let rb = solve(b, q);
        assert_eq!(ra, rb, "row {i}");
        converged += usize::from(ra.0 == 0);
        if i == 4 {
            // the case: this row, then row 5 warm, returned 2 (stalled)
            assert_ne!(solve(b, &bad).0, 0, "the unreachable row converged");
        }
    }
    assert_eq!(converged, rows.len());
    // SAFETY: owned handles, not used afterwards.
    unsafe {
        cs_tendons_free(a);
        cs_tendons_free(b);
    }
}

/// A budget per call through the C ABI (`cs_tendons_set_budget`): one rod
/// evaluation ends the unreachable row with status 6 (`budget_exhausted`), the
/// rows after it are bit-identical to a handle without it, 16 evaluations let
/// every val row converge, and a bad budget is `CS_CODE_BAD_ARGUMENT` naming the
/// field. 0 means no limit.
#[test]
fn a_budget_limited_call_returns_budget_exhausted() {
    let rows = &val_rows()[..40];
    let (a, b) = (handle(), handle());
    let bad = [0.05, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    // SAFETY: live handles.
    unsafe {
        assert_eq!(cs_tendons_set_budget(a, 16, 0.0), CsCode::Ok);
        assert_eq!(cs_tendons_set_budget(b, 16, 0.0), CsCode::Ok);
    }
    for (i, q) in rows.iter().enumerate() {
        let ra = solve(a, q);
        assert_eq!(ra, solve(b, q), "row {i}");
        assert_eq!(ra.0, 0, "row {i} within 16 evaluations");
        if i == 10 {
            // SAFETY: live handle.
            assert_eq!(unsafe { cs_tendons_set_budget(b, 1, 0.0) }, CsCode::Ok);
            assert_eq!(solve(b, &bad).0, 6, "budget_exhausted");
            // SAFETY: live handle.
            assert_eq!(unsafe { cs_tendons_set_budget(b, 16, 0.0) }, CsCode::Ok);
        }
    }
    // SAFETY: live handle; cs_last_error is never null.
    unsafe {
        assert_eq!(cs_tendons_set_budget(a, 0, -1.0), CsCode::BadArgument);
        let msg = std::ffi::CStr::from_ptr(cs_last_error()).to_string_lossy();
        assert!(msg.contains("time_budget_s"), "{msg}");
        assert_eq!(
            cs_tendons_set_budget(std::ptr::null_mut(), 1, 0.0),
            CsCode::BadArgument
        );
        // no limit again: the unreachable row runs to its own end (not 6)
        assert_eq!(cs_tendons_set_budget(a, 0, 0.0), CsCode::Ok);
        cs_tendons_free(a);
        cs_tendons_free(b);
    }
}

/// The same from a C program (skipped when no C compiler is found).
#[test]
fn c_program_sees_bit_identical_rows() {
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    if Command::new(&cc).arg("--version").output().is_err() {
        eprintln!("no C compiler `{cc}`: skipped");
        return;
    }
    let dir = std::env::temp_dir().join(format!("cablesense-rollback-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let rows: String = val_rows()
        .iter()
        .map(|r| {
            let cells: Vec<String> = r.iter().map(|v| format!("{v:e}")).collect();
            cells.join(" ") + "\n"
        })
        .collect();
    std::fs::write(dir.join("rows.txt"), rows).unwrap();
    let exe = dir.join("rollback");
    let build = Command::new(&cc)
        .args([
            "-O2",
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-pedantic",
        ])
        .arg("-I")
        .arg(root().join("capi/include"))
        .arg(root().join("capi/tests/c/rollback.c"))
        .arg(staticlib())
        .args(["-lpthread", "-ldl", "-lm", "-o"])
        .arg(&exe)
        .output()
        .unwrap();
    assert!(
        build.status.success(),
        "{}",
        String::from_utf8_lossy(&build.stderr)
    );
    for k in ["4", "220"] {
        let run = Command::new(&exe)
            .arg(root().join("data/scenes/ftdcr_v4.toml"))
            .arg(dir.join("rows.txt"))
            .arg(k)
            .output()
            .unwrap();
        let out = String::from_utf8_lossy(&run.stdout);
        println!("bad row after {k}: {out}");
        assert!(
            run.status.success(),
            "{out}{}",
            String::from_utf8_lossy(&run.stderr)
        );
        assert!(out.starts_with("rows 443 differing 0 bad_status "), "{out}");
    }
    let _ = std::fs::remove_dir_all(&dir);
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
