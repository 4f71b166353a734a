//! The C ABI's per-tick calls do not allocate after warm-up (a counting global
//! allocator), and a bad scene or a bad call is an error code with a message, not
//! a crash.

use cablesense_capi::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::ffi::{CStr, CString};

struct Counting;

thread_local! {
    // per thread: the tests of this file run in parallel
    static ALLOCS: Cell<usize> = const { Cell::new(0) };
}

fn allocs() -> usize {
    ALLOCS.with(Cell::get)
}

// SAFETY: forwards to the system allocator, counting calls.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        ALLOCS.with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        ALLOCS.with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(p, l, n) }
    }
}

#[global_allocator]
static A: Counting = Counting;

fn scene(path: &str) -> CString {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(path);
    CString::new(std::fs::read_to_string(p).unwrap()).unwrap()
}

fn last_error() -> String {
    // SAFETY: never null, NUL-terminated.
    unsafe { CStr::from_ptr(cs_last_error()) }
        .to_string_lossy()
        .into_owned()
}

#[test]
fn estimator_ticks_without_allocating() {
    let text = scene("data/scenes/track_demo.toml");
    let mut e = std::ptr::null_mut();
    // SAFETY: valid string and out pointer.
    assert_eq!(
        unsafe { cs_estimator_new(text.as_ptr(), &mut e) },
        CsCode::Ok
    );
    // SAFETY: live handle from here to the free below.
    let (c, p) = unsafe { (cs_estimator_cable_count(e), cs_estimator_unknown_count(e)) };
    assert_eq!((c, p), (3, 2));
    // a small force ramp: changes from the demo's first rows
    let samples = [
        [1.66819249e-3, -2.44597466e-3, 2.51324066e-4],
        [1.75305037e-3, -2.51105002e-3, 2.15248435e-4],
        [1.84344417e-3, -2.55305649e-3, 1.01207286e-4],
    ];
    let (mut values, mut cov, mut tip, mut len) = ([0.0; 2], [0.0; 4], [0.0; 3], [0.0; 3]);
    let mut info = CsEstimateInfo::default();
    let mut tick = |k: usize| unsafe {
        // SAFETY: buffers of the stated sizes, live handle.
        let s = &samples[k % samples.len()];
        assert_eq!(
            cs_estimator_tick(e, s.as_ptr(), std::ptr::null(), c, &mut info),
            CsCode::Ok
        );
        assert_eq!(
            cs_estimator_values(e, values.as_mut_ptr(), cov.as_mut_ptr(), p),
            CsCode::Ok
        );
        assert_eq!(cs_estimator_tip_position(e, tip.as_mut_ptr()), CsCode::Ok);
        assert_eq!(
            cs_estimator_cable_lengths(e, len.as_mut_ptr(), c),
            CsCode::Ok
        );
    };
    for k in 0..5 {
        tick(k);
    }
    let before = allocs();
    for k in 0..50 {
        tick(k);
    }
    let n = allocs() - before;
    assert_eq!(n, 0, "{n} allocations in 50 warm ticks");
    assert_eq!(info.status, 0);
    assert_eq!(info.poor_fit, 0);
    assert!(info.rms_sigma < 3.0, "{}", info.rms_sigma);
    assert!(cov[0] > 0.0 && tip[0] > 0.3);
    // SAFETY: owned handle.
    unsafe { cs_estimator_free(e) };
}

#[test]
fn forward_model_solves_and_reports() {
    let text = scene("data/scenes/demo_two_section.toml");
    let mut m = std::ptr::null_mut();
    // SAFETY: valid string and out pointer; the handle lives until the free below.
    unsafe {
        assert_eq!(cs_model_new(text.as_ptr(), &mut m), CsCode::Ok);
        let mut info = CsSolveInfo::default();
        assert_eq!(cs_model_solve(m, 0, &mut info), CsCode::Ok);
        assert_eq!(info.status, 0, "{info:?}");
        let n = cs_model_section_count(m);
        let (mut pos, mut rot) = (vec![0.0; 3 * n], vec![0.0; 9 * n]);
        assert_eq!(
            cs_model_section_poses(m, pos.as_mut_ptr(), rot.as_mut_ptr(), n),
            CsCode::Ok
        );
        let (mut tp, mut tr) = ([0.0; 3], [0.0; 9]);
        assert_eq!(
            cs_model_tip_pose(m, tp.as_mut_ptr(), tr.as_mut_ptr()),
            CsCode::Ok
        );
        // the same shape (recomputed: equal to rounding)
        for (a, b) in pos[3 * (n - 1)..]
            .iter()
            .chain(&rot[9 * (n - 1)..])
            .zip(tp.iter().chain(&tr))
        {
            assert!((a - b).abs() < 1e-12, "{a} {b}");
        }
        let c = cs_model_cable_count(m);
        let mut len = vec![0.0; c];
        assert_eq!(cs_model_cable_lengths(m, len.as_mut_ptr(), c), CsCode::Ok);
        assert!(len.iter().all(|l| *l > 0.1), "{len:?}");
        // wrong buffer length: an error with a message
        assert_eq!(
            cs_model_cable_lengths(m, len.as_mut_ptr(), c + 1),
            CsCode::BadArgument
        );
        assert!(last_error().contains("cables"), "{}", last_error());
        cs_model_free(m);
    }
}

#[test]
fn bad_scenes_are_errors_with_the_field_path() {
    let bad = CString::new(
        std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/scenes/track_demo.toml"),
        )
        .unwrap()
        .replacen("length_m = 0.39", "length_m = -0.39", 1),
    )
    .unwrap();
    let mut e = std::ptr::null_mut();
    // SAFETY: valid string and out pointer.
    assert_eq!(
        unsafe { cs_estimator_new(bad.as_ptr(), &mut e) },
        CsCode::BadScene
    );
    assert!(e.is_null());
    let msg = last_error();
    assert_eq!(
        msg.matches("robot.sections[0].length_m must be > 0, got -0.39")
            .count(),
        1,
        "{msg}"
    );
    let no_estimate = scene("data/scenes/demo_two_section.toml");
    // SAFETY: valid string and out pointer.
    assert_eq!(
        unsafe { cs_estimator_new(no_estimate.as_ptr(), &mut e) },
        CsCode::BadScene
    );
    assert!(last_error().contains("[estimate]"));
    // SAFETY: null arguments are checked.
    assert_eq!(
        unsafe { cs_model_new(std::ptr::null(), &mut std::ptr::null_mut()) },
        CsCode::BadArgument
    );
}

#[test]
fn tendon_readers_do_not_allocate_and_the_solve_adds_none() {
    let text = scene("data/scenes/tdcr_two_segment.toml");
    let mut t = std::ptr::null_mut();
    // SAFETY: valid string and out pointer; the handle lives until the free below.
    unsafe {
        assert_eq!(cs_tendons_new(text.as_ptr(), &mut t), CsCode::Ok);
        let (p, c) = (cs_tendons_count(t), cs_tendons_cable_count(t));
        assert_eq!((p, c), (6, 6));
        let (mut tension, mut taut, mut tip, mut len) = ([0.0; 6], [0i32; 6], [0.0; 3], [0.0; 6]);
        let mut info = CsTendonInfo::default();
        // a slow pull of s1a against s1b (m), as a servo loop would send it
        let mut solve = |k: usize| {
            let x = 1e-3 * (k as f64 * 0.3).sin();
            let q = [x.max(0.0), (-x).max(0.0), 0.0, 0.2e-3, 0.0, 0.0];
            assert_eq!(cs_tendons_solve(t, q.as_ptr(), p, 1, &mut info), CsCode::Ok);
            assert_eq!(info.status, 0, "{info:?}");
            assert_eq!(
                cs_tendons_tensions(t, tension.as_mut_ptr(), taut.as_mut_ptr(), p),
                CsCode::Ok
            );
            assert_eq!(cs_tendons_tip_position(t, tip.as_mut_ptr()), CsCode::Ok);
            assert_eq!(cs_tendons_cable_lengths(t, len.as_mut_ptr(), c), CsCode::Ok);
        };
        for k in 0..3 {
            solve(k);
        }
        // the solve: neither the C layer nor the core allocates per warm solve
        let before = allocs();
        for k in 3..23 {
            solve(k);
        }
        let n = allocs() - before;
        assert_eq!(
            n, 0,
            "{n} allocations in 20 warm tendon solves ({p} tendons)"
        );
        // the readers allocate nothing
        let before = allocs();
        for _ in 0..20 {
            assert_eq!(
                cs_tendons_tensions(t, tension.as_mut_ptr(), taut.as_mut_ptr(), p),
                CsCode::Ok
            );
            assert_eq!(cs_tendons_tip_position(t, tip.as_mut_ptr()), CsCode::Ok);
            assert_eq!(cs_tendons_cable_lengths(t, len.as_mut_ptr(), c), CsCode::Ok);
        }
        assert_eq!(allocs() - before, 0, "allocations in the readers");
        assert!(
            tip[2] > 0.19 && tension.iter().all(|x| *x >= 0.0),
            "{tip:?} {tension:?}"
        );
        cs_tendons_free(t);
    }
}

/// `cs_tendons_ik` (and the `cs_tendons_ik_tensions` reader after it) on the
/// calibrated FTDCR v4, targets = the model's tips at consecutive val rows (as the
/// library's `tests/ik_alloc.rs`): after 10 warm-up calls, 40 warm calls allocate
/// exactly what the library's `IkWorkspace::solve`
/// allocates for the same targets (the C layer adds none), and at most the
/// library test's ceiling: clarabel's `solve` allocates once per QP today (at most
/// 8 per QP there) plus 10. Once the library's warm tick allocates nothing, the
/// bound below becomes `assert_eq!(abi, 0, ...)`.
#[test]
fn ik_warm_calls_allocate_no_more_than_the_library() {
    use cablesense::command::{IkSettings, IkTarget, IkWorkspace};
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let path = root.join("data/calibration/ftdcr_v4_calibrated.toml");
    let sc = cablesense::Scene::load(&path).unwrap();
    let val = std::fs::read_to_string(root.join("data/hardware/ftdcr_v4/val.csv")).unwrap();
    let targets = sc.model_tips(&val, 50).unwrap();
    let mut lib = IkWorkspace::from_scene(&sc, IkSettings::default()).unwrap();
    let text = scene("data/calibration/ftdcr_v4_calibrated.toml");
    let mut t = std::ptr::null_mut();
    let (mut q, mut info) = ([0.0; 9], CsIkInfo::default());
    let (mut tension, mut taut) = ([0.0; 9], [0i32; 9]);
    let (mut abi, mut library, mut qps) = (0, 0, 0);
    // SAFETY: valid string and out pointer; the handle lives until the free below;
    // buffers of the stated sizes.
    unsafe {
        assert_eq!(cs_tendons_new(text.as_ptr(), &mut t), CsCode::Ok);
        assert_eq!(cs_tendons_ik_configure(t, std::ptr::null()), CsCode::Ok);
        for (i, target) in targets.iter().enumerate() {
            let x = [target.x, target.y, target.z];
            let before = allocs();
            let code = cs_tendons_ik(
                t,
                x.as_ptr(),
                std::ptr::null(),
                q.as_mut_ptr(),
                9,
                &mut info,
            );
            assert_eq!(code, CsCode::Ok, "{}", last_error());
            let code = cs_tendons_ik_tensions(t, tension.as_mut_ptr(), taut.as_mut_ptr(), 9);
            let n_abi = allocs() - before;
            assert_eq!(code, CsCode::Ok, "{}", last_error());
            let goal = IkTarget::position(*target);
            let before = allocs();
            let r = lib.solve(&goal).unwrap();
            let n_lib = allocs() - before;
            assert_eq!(r.qp_solves, info.qp_solves as usize, "call {i}");
            if i >= 10 {
                assert_eq!(
                    n_abi, n_lib,
                    "call {i}: the C layer allocates {n_abi} vs {n_lib}"
                );
                abi += n_abi;
                library += n_lib;
                qps += r.qp_solves;
            }
        }
        cs_tendons_free(t);
    }
    eprintln!(
        "40 warm cs_tendons_ik calls: {abi} allocations (library {library}), {qps} QP solves"
    );
    // the library's warm IK step QP is allocation-free (its own active-set method;
    // clarabel only as a counted fallback): none through the C layer either
    assert_eq!(abi, 0, "{abi} allocations in 40 warm calls with {qps} QPs");
}
