//! Inverse kinematics through the C ABI (`cs_tendons_ik`): on the calibrated FTDCR
//! v4, targets = the model's tips at consecutive val rows, the ABI returns the
//! library's `IkWorkspace` readings bit for bit and reaches the tips within 0.05 mm;
//! a target outside the workspace is status 1 (unreachable), not an error; bad
//! calls are `CS_CODE_BAD_ARGUMENT` with a message naming the value and change
//! nothing. Run from Rust, and as `tests/c/ik.c` compiled as C99 with the system C
//! compiler (`$CC` or `cc`) against the static library. Allocations per warm call:
//! `tests/alloc.rs`.

use cablesense::command::{IkSettings, IkStatus, IkTarget, IkWorkspace};
use cablesense::Scene;
use cablesense_capi::*;
use std::ffi::{CStr, CString};
use std::path::{Path, PathBuf};
use std::process::Command;

const FTDCR: &str = "data/calibration/ftdcr_v4_calibrated.toml";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

fn last_error() -> String {
    // SAFETY: never null, NUL-terminated.
    unsafe { CStr::from_ptr(cs_last_error()) }
        .to_string_lossy()
        .into_owned()
}

fn handle() -> *mut CsTendons {
    let text = std::fs::read_to_string(root().join(FTDCR)).unwrap();
    let text = CString::new(text).unwrap();
    let mut t = std::ptr::null_mut();
    // SAFETY: valid string and out pointer.
    assert_eq!(
        unsafe { cs_tendons_new(text.as_ptr(), &mut t) },
        CsCode::Ok,
        "{}",
        last_error()
    );
    t
}

/// The model's tips at the first `n` val rows (the library's `Scene::model_tips`).
fn targets(n: usize) -> Vec<[f64; 3]> {
    let scene = Scene::load(root().join(FTDCR)).unwrap();
    let text = std::fs::read_to_string(root().join("data/hardware/ftdcr_v4/val.csv")).unwrap();
    scene
        .model_tips(&text, n)
        .unwrap()
        .into_iter()
        .map(|t| [t.x, t.y, t.z])
        .collect()
}

/// One `cs_tendons_ik` call: readings and info.
fn ik(t: *mut CsTendons, target: &[f64; 3], direction: Option<&[f64; 3]>) -> ([f64; 9], CsIkInfo) {
    let (mut q, mut info) = ([0.0; 9], CsIkInfo::default());
    let dir = direction.map_or(std::ptr::null(), |d| d.as_ptr());
    // SAFETY: live handle; buffers of the stated sizes.
    let code = unsafe { cs_tendons_ik(t, target.as_ptr(), dir, q.as_mut_ptr(), 9, &mut info) };
    assert_eq!(code, CsCode::Ok, "{}", last_error());
    (q, info)
}

#[test]
fn the_abi_returns_the_librarys_readings_and_reaches_the_model_tips() {
    let targets = targets(30);
    let scene = Scene::load(root().join(FTDCR)).unwrap();
    let mut lib = IkWorkspace::from_scene(&scene, IkSettings::default()).unwrap();
    let t = handle();
    let (mut lo, mut hi) = ([0.0; 9], [0.0; 9]);
    // SAFETY: live handle; buffers of 9.
    unsafe {
        assert_eq!(
            cs_tendons_limits(t, lo.as_mut_ptr(), hi.as_mut_ptr(), 9),
            CsCode::Ok
        );
        assert_eq!(cs_tendons_ik_configure(t, std::ptr::null()), CsCode::Ok);
    }
    assert_eq!(lo.to_vec(), lib.limits().min_m);
    assert_eq!(hi.to_vec(), lib.limits().max_m);
    // shipped limits of segment 0: [-10.5, 5.5] mm
    assert!((lo[0] + 10.5e-3).abs() < 1e-15 && (hi[0] - 5.5e-3).abs() < 1e-15);
    let mut within = 0;
    for (i, target) in targets.iter().enumerate() {
        let (q, info) = ik(t, target, None);
        let r = lib.solve(&IkTarget::position((*target).into())).unwrap();
        assert_eq!(q.to_vec(), lib.readings(), "row {i}: the ABI's readings");
        assert_eq!(info.distance_m.to_bits(), r.distance_m.to_bits(), "row {i}");
        assert_eq!(info.tip_m, [r.tip_m.x, r.tip_m.y, r.tip_m.z]);
        assert_eq!(info.qp_solves as usize, r.qp_solves);
        assert_eq!(info.objective, 0);
        let code = match r.status {
            IkStatus::Reached => 0,
            IkStatus::Unreachable { .. } => 1,
            IkStatus::BudgetExhausted => 2,
        };
        assert_eq!(info.status, code, "row {i}: {r:?}");
        within += usize::from(info.distance_m <= 5e-5);
        for k in 0..9 {
            assert!(
                q[k] >= lo[k] && q[k] <= hi[k],
                "row {i}: reading {k} outside its limits"
            );
        }
    }
    assert!(within >= 29, "{within} of 30 within 0.05 mm");
    // a direction target and another objective through the settings
    let mut s = CsIkSettings {
        objective: 0,
        secondary_weight: 0.0,
        tolerance_m: 0.0,
        angle_tolerance_rad: 0.0,
        direction_weight_m: 0.0,
        trust_radius_m: 0.0,
        max_iterations: 0,
        max_forward_solves: 0,
    };
    // SAFETY: writable struct; live handle.
    unsafe {
        assert_eq!(cs_ik_settings_default(&mut s), CsCode::Ok);
        assert_eq!((s.tolerance_m, s.max_iterations), (1e-5, 30));
        s.objective = 1;
        assert_eq!(cs_tendons_ik_configure(t, &s), CsCode::Ok);
    }
    let (_, info) = ik(t, &targets[29], None);
    assert_eq!((info.status, info.objective), (0, 1), "{info:?}");
    // the tensions at the returned readings: the library's
    lib.set_settings(IkSettings {
        objective: cablesense::command::IkObjective::LeastPull,
        ..IkSettings::default()
    })
    .unwrap();
    lib.solve(&IkTarget::position(targets[29].into())).unwrap();
    let (mut tension, mut taut) = ([0.0; 9], [0i32; 9]);
    // SAFETY: live handle; buffers of 9.
    unsafe {
        let code = cs_tendons_ik_tensions(t, tension.as_mut_ptr(), taut.as_mut_ptr(), 9);
        assert_eq!(code, CsCode::Ok, "{}", last_error());
    }
    assert_eq!(tension.to_vec(), lib.tendon_workspace().tensions());
    let flags: Vec<bool> = taut.iter().map(|f| *f == 1).collect();
    assert_eq!(flags, lib.tendon_workspace().taut());
    assert_eq!(info.slack as usize, flags.iter().filter(|f| !**f).count());
    // a direction target: the library's result bit for bit, and reached
    let axis = lib.tip_axis();
    let with = IkTarget {
        position_m: targets[29].into(),
        direction: Some(axis * 2.0),
    };
    let (q, info) = ik(
        t,
        &targets[29],
        Some(&[2.0 * axis.x, 2.0 * axis.y, 2.0 * axis.z]),
    );
    let r = lib.solve(&with).unwrap();
    assert_eq!(q.to_vec(), lib.readings());
    assert_eq!(info.angle_rad.to_bits(), r.angle_rad.to_bits());
    assert_eq!(info.status, 0, "{info:?}");
    assert!(info.angle_rad <= 1e-3, "{info:?}");
    // SAFETY: owned handle.
    unsafe { cs_tendons_free(t) };
}

#[test]
fn unreachable_targets_are_a_status_and_bad_calls_change_nothing() {
    let targets = targets(3);
    let t = handle();
    let (mut tip, zero) = ([0.0; 3], [0.0; 9]);
    // SAFETY: live handle; buffers of the stated sizes.
    unsafe {
        assert_eq!(
            cs_tendons_solve(t, zero.as_ptr(), 9, 1, std::ptr::null_mut()),
            CsCode::Ok
        );
        assert_eq!(cs_tendons_tip_position(t, tip.as_mut_ptr()), CsCode::Ok);
    }
    // 10 cm beyond the straight tip: longer than the robot can stretch
    let far = [tip[0], tip[1], tip[2] + 0.1];
    let (_, info) = ik(t, &far, None);
    assert_eq!(info.status, 1, "{info:?}");
    assert!(
        info.distance_m > 0.09 && info.first_order <= 1e-2,
        "{info:?}"
    );
    // bad calls leave the warm state as it was: handle b, with them, gives the
    // readings of handle c, without them, bit for bit
    let (b, c) = (handle(), handle());
    let (mut q, mut info) = ([0.0; 9], CsIkInfo::default());
    for h in [b, c] {
        ik(h, &far, None);
        ik(h, &targets[0], None);
    }
    // SAFETY: live handles; buffers of the stated sizes (or deliberately short/null).
    unsafe {
        let nan = [0.0, f64::NAN, 0.18];
        let code = cs_tendons_ik(
            b,
            nan.as_ptr(),
            std::ptr::null(),
            q.as_mut_ptr(),
            9,
            &mut info,
        );
        assert_eq!(code, CsCode::BadArgument);
        assert!(
            last_error().contains("target.position_m[1]"),
            "{}",
            last_error()
        );
        let zero_dir = [0.0; 3];
        let code = cs_tendons_ik(
            b,
            targets[1].as_ptr(),
            zero_dir.as_ptr(),
            q.as_mut_ptr(),
            9,
            &mut info,
        );
        assert_eq!(code, CsCode::BadArgument);
        assert!(last_error().contains("target.direction") && last_error().contains("zero length"));
        let code = cs_tendons_ik(
            b,
            targets[1].as_ptr(),
            std::ptr::null(),
            q.as_mut_ptr(),
            8,
            &mut info,
        );
        assert_eq!(code, CsCode::BadArgument);
        assert!(
            last_error().contains("n = 8 readings for 9"),
            "{}",
            last_error()
        );
        let code = cs_tendons_ik(
            b,
            std::ptr::null(),
            std::ptr::null(),
            q.as_mut_ptr(),
            9,
            &mut info,
        );
        assert_eq!(code, CsCode::BadArgument);
        assert!(last_error().contains("target is null"));
        let code = cs_tendons_ik(
            b,
            targets[1].as_ptr(),
            std::ptr::null(),
            std::ptr::null_mut(),
            9,
            &mut info,
        );
        assert_eq!(code, CsCode::BadArgument);
        let code = cs_tendons_ik(
            std::ptr::null_mut(),
            targets[1].as_ptr(),
            std::ptr::null(),
            q.as_mut_ptr(),
            9,
            &mut info,
        );
        assert_eq!(code, CsCode::BadArgument);
        assert!(last_error().contains("tendons is null"));
        let mut s = CsIkSettings::from(&IkSettings::default());
        s.tolerance_m = 0.0;
        assert_eq!(cs_tendons_ik_configure(b, &s), CsCode::BadArgument);
        assert!(last_error().contains("ik.tolerance_m"), "{}", last_error());
        s.tolerance_m = 1e-5;
        s.objective = 3;
        assert_eq!(cs_tendons_ik_configure(b, &s), CsCode::BadArgument);
        assert!(
            last_error().contains("ik.objective = 3"),
            "{}",
            last_error()
        );
        // no inverse solve on a fresh handle yet: the tensions reader says so
        let fresh = handle();
        let mut tension = [0.0; 9];
        let code = cs_tendons_ik_tensions(fresh, tension.as_mut_ptr(), std::ptr::null_mut(), 9);
        assert_eq!(code, CsCode::BadArgument);
        assert!(
            last_error().contains("no inverse solve yet"),
            "{}",
            last_error()
        );
        cs_tendons_free(fresh);
        let out = [0.02, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(cs_tendons_ik_start(b, out.as_ptr(), 9), CsCode::BadArgument);
        assert!(last_error().contains("servo_4_mm") && last_error().contains("actuator limits"));
    }
    for (i, target) in targets.iter().enumerate().skip(1) {
        let (qb, ib) = ik(b, target, None);
        let (qc, ic) = ik(c, target, None);
        assert_eq!(qb, qc, "row {i}");
        assert_eq!(ib.distance_m.to_bits(), ic.distance_m.to_bits(), "row {i}");
        assert_eq!(ib.status, 0, "row {i}: {ib:?}");
    }
    // SAFETY: owned handles.
    unsafe {
        cs_tendons_free(t);
        cs_tendons_free(b);
        cs_tendons_free(c);
    }
}

/// The same from a C program (skipped when no C compiler is found): 40 val rows'
/// model tips reached, the readings solved again within 0.05 mm, the far target
/// unreachable, and every bad call an error naming the value.
#[test]
fn c_program_reaches_the_model_tips() {
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    if Command::new(&cc).arg("--version").output().is_err() {
        eprintln!("no C compiler `{cc}`: skipped");
        return;
    }
    let dir = std::env::temp_dir().join(format!("cablesense-ik-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = Scene::load(root().join(FTDCR)).unwrap();
    let ws = scene.tendon_workspace().unwrap();
    let text = std::fs::read_to_string(root().join("data/hardware/ftdcr_v4/val.csv")).unwrap();
    let rows: String = scene
        .readings_parser(&ws)
        .good_rows(&text)
        .iter()
        .take(40)
        .map(|r| {
            let cells: Vec<String> = r.readings_m.iter().map(|v| format!("{v:e}")).collect();
            cells.join(" ") + "\n"
        })
        .collect();
    std::fs::write(dir.join("rows.txt"), rows).unwrap();
    let exe = dir.join("ik");
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
        .arg(root().join("capi/tests/c/ik.c"))
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
    let run = Command::new(&exe)
        .arg(root().join(FTDCR))
        .arg(dir.join("rows.txt"))
        .output()
        .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let out = String::from_utf8_lossy(&run.stdout);
    println!("{out}");
    assert!(
        run.status.success(),
        "{out}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let nums = |prefix: &str| -> Vec<f64> {
        let line = out
            .lines()
            .find(|l| l.starts_with(prefix))
            .unwrap_or_else(|| panic!("no `{prefix}` in\n{out}"));
        line.split_whitespace()
            .filter_map(|w| w.parse().ok())
            .collect()
    };
    // rows N reached R within_50um W resolved_50um V max_um M
    let r = nums("rows ");
    assert_eq!(r[0], 40.0, "{out}");
    assert!(r[2] >= 39.0 && r[3] >= 39.0, "{out}");
    let u = nums("unreachable status ");
    assert_eq!(u[0], 1.0, "{out}");
    assert!(u[1] > 90.0, "{out}");
    for (what, names) in [
        ("nan target", "target.position_m[2] must be finite"),
        ("zero direction", "target.direction"),
        ("short buffer", "n = 8 readings for 9"),
        ("null handle", "tendons is null"),
        ("bad settings", "ik.tolerance_m"),
        ("bad objective", "ik.objective = 7"),
        ("start outside the limits", "readings[0] (servo_4_mm)"),
    ] {
        let line = out
            .lines()
            .find(|l| l.starts_with(&format!("bad call ({what})")))
            .unwrap_or_else(|| panic!("no bad call ({what}) in\n{out}"));
        assert!(line.contains("code 1") && line.contains(names), "{line}");
    }
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
