//! The thread rule of the C ABI (capi/src/lib.rs, "Threads"): two tendon handles
//! solved on two threads at once give exactly what one thread gives on one handle,
//! and each thread's `cs_last_error` is its own. Also `cs_version` and the name
//! accessors, and that the handles are `Send` (may move between threads).

use cablesense_capi::*;
use std::ffi::{CStr, CString};
use std::path::Path;

fn scene(path: &str) -> CString {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path);
    CString::new(std::fs::read_to_string(p).unwrap()).unwrap()
}

/// A handle owned by one thread at a time.
struct Handle(*mut CsTendons);
// SAFETY: the documented rule: a handle may move to another thread, used by one
// thread at a time (each handle here is used by exactly one thread).
unsafe impl Send for Handle {}

fn assert_send<T: Send>() {}

/// 200 warm rows of a slow sweep on the two-segment TDCR: tip bits per row.
fn run(h: &Handle, phase: f64) -> Vec<u64> {
    let mut out = Vec::new();
    for k in 0..200 {
        let a = 1.0e-3 * ((k as f64) * 0.05 + phase).sin();
        let q = [a.max(0.0), 0.0, (-a).max(0.0), 0.0, 0.5 * a.abs(), 0.0];
        let (mut info, mut tip) = (CsTendonInfo::default(), [0.0; 3]);
        // SAFETY: live handle used by this thread only; buffers of the stated sizes.
        unsafe {
            assert_eq!(
                cs_tendons_solve(h.0, q.as_ptr(), 6, 1, &mut info),
                CsCode::Ok
            );
            assert_eq!(cs_tendons_tip_position(h.0, tip.as_mut_ptr()), CsCode::Ok);
        }
        out.extend(tip.iter().map(|v| v.to_bits()));
    }
    // a failing call on this thread: its own message
    let bad = [f64::NAN; 6];
    // SAFETY: live handle.
    let code = unsafe { cs_tendons_solve(h.0, bad.as_ptr(), 6, 1, std::ptr::null_mut()) };
    assert_eq!(code, CsCode::BadArgument);
    // SAFETY: never null, NUL-terminated.
    let msg = unsafe { CStr::from_ptr(cs_last_error()) }
        .to_string_lossy()
        .into_owned();
    assert!(msg.contains("readings[0] (s1a)"), "{msg}");
    out
}

fn new_handle() -> Handle {
    let text = scene("data/scenes/tdcr_two_segment.toml");
    let mut t = std::ptr::null_mut();
    // SAFETY: valid string and out pointer.
    assert_eq!(unsafe { cs_tendons_new(text.as_ptr(), &mut t) }, CsCode::Ok);
    Handle(t)
}

#[test]
fn two_handles_on_two_threads_match_one_thread() {
    assert_send::<CsTendons>();
    assert_send::<CsEstimator>();
    assert_send::<CsModel>();
    let serial: Vec<Vec<u64>> = [0.0, 1.0]
        .iter()
        .map(|&phase| {
            let h = new_handle();
            let r = run(&h, phase);
            // SAFETY: owned handle, not used afterwards.
            unsafe { cs_tendons_free(h.0) };
            r
        })
        .collect();
    let threads: Vec<_> = [0.0, 1.0]
        .into_iter()
        .map(|phase| {
            let h = new_handle();
            std::thread::spawn(move || {
                let r = run(&h, phase);
                // SAFETY: owned handle, not used afterwards.
                unsafe { cs_tendons_free(h.0) };
                r
            })
        })
        .collect();
    let parallel: Vec<Vec<u64>> = threads.into_iter().map(|t| t.join().unwrap()).collect();
    assert_eq!(serial, parallel);
}

#[test]
fn version_and_names() {
    // SAFETY: static NUL-terminated string.
    let v = unsafe { CStr::from_ptr(cs_version()) }.to_str().unwrap();
    assert_eq!(v, env!("CARGO_PKG_VERSION"));
    let h = new_handle();
    // SAFETY: live handle until the free; out-of-range and null give null.
    unsafe {
        let names: Vec<String> = (0..cs_tendons_count(h.0))
            .map(|i| {
                CStr::from_ptr(cs_tendons_column_name(h.0, i))
                    .to_string_lossy()
                    .into()
            })
            .collect();
        assert_eq!(names, ["s1a", "s1b", "s1c", "s2a", "s2b", "s2c"]);
        assert!(cs_tendons_column_name(h.0, 6).is_null());
        assert!(cs_tendons_column_name(std::ptr::null(), 0).is_null());
        cs_tendons_free(h.0);
    }
    let text = scene("data/scenes/track_demo.toml");
    let mut e = std::ptr::null_mut();
    // SAFETY: valid string and out pointer; live handle until the free.
    unsafe {
        assert_eq!(cs_estimator_new(text.as_ptr(), &mut e), CsCode::Ok);
        let p = cs_estimator_unknown_count(e);
        let names: Vec<String> = (0..p)
            .map(|i| {
                CStr::from_ptr(cs_estimator_unknown_name(e, i))
                    .to_string_lossy()
                    .into()
            })
            .collect();
        assert_eq!(names.len(), 2);
        assert!(names.iter().all(|n| !n.is_empty()), "{names:?}");
        eprintln!("track demo unknowns: {names:?}");
        assert!(cs_estimator_unknown_name(e, p).is_null());
        // the strict boundary: an infinite change, a zero sigma, a null changes
        let c = cs_estimator_cable_count(e);
        let ok = vec![1e-4; c];
        let mut inf = ok.clone();
        inf[1] = f64::INFINITY;
        assert_eq!(
            cs_estimator_tick(e, inf.as_ptr(), std::ptr::null(), c, std::ptr::null_mut()),
            CsCode::BadArgument
        );
        let msg = CStr::from_ptr(cs_last_error())
            .to_string_lossy()
            .into_owned();
        assert!(msg.contains("changes[1]") && msg.contains("inf"), "{msg}");
        let zero = vec![0.0; c];
        assert_eq!(
            cs_estimator_tick(e, ok.as_ptr(), zero.as_ptr(), c, std::ptr::null_mut()),
            CsCode::BadArgument
        );
        let msg = CStr::from_ptr(cs_last_error())
            .to_string_lossy()
            .into_owned();
        assert!(msg.contains("sigma[0] must be > 0, got 0"), "{msg}");
        let neg = vec![-1e-5; c];
        assert_eq!(
            cs_estimator_tick(e, ok.as_ptr(), neg.as_ptr(), c, std::ptr::null_mut()),
            CsCode::BadArgument
        );
        let nan = vec![f64::NAN; c];
        assert_eq!(
            cs_estimator_tick(e, ok.as_ptr(), nan.as_ptr(), c, std::ptr::null_mut()),
            CsCode::BadArgument
        );
        assert_eq!(
            cs_estimator_tick(
                e,
                std::ptr::null(),
                std::ptr::null(),
                c,
                std::ptr::null_mut()
            ),
            CsCode::BadArgument
        );
        let msg = CStr::from_ptr(cs_last_error())
            .to_string_lossy()
            .into_owned();
        assert_eq!(msg, "changes is null");
        // a NaN change is still a missing one
        let mut missing = ok.clone();
        missing[0] = f64::NAN;
        assert_eq!(
            cs_estimator_tick(
                e,
                missing.as_ptr(),
                std::ptr::null(),
                c,
                std::ptr::null_mut()
            ),
            CsCode::Ok
        );
        cs_estimator_free(e);
    }
}

/// The header compiles as C99 and as C++17 (each when its compiler, `$CC`/`cc` and
/// `$CXX`/`c++`, is found), warnings as errors.
#[test]
fn header_compiles_as_c99_and_cpp17() {
    let include = Path::new(env!("CARGO_MANIFEST_DIR")).join("include");
    let dir = std::env::temp_dir().join(format!("cablesense-header-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let src = "#include \"cablesense.h\"\nint main(void) { return cs_version() == 0 \
               && CS_CODE_BAD_ARGUMENT == 1; }\n";
    let mut compiled = 0;
    for (var, default, file, std) in [
        ("CC", "cc", "h.c", "-std=c99"),
        ("CXX", "c++", "h.cpp", "-std=c++17"),
    ] {
        let cc = std::env::var(var).unwrap_or_else(|_| default.into());
        if std::process::Command::new(&cc)
            .arg("--version")
            .output()
            .is_err()
        {
            eprintln!("no `{cc}`: {std} skipped");
            continue;
        }
        std::fs::write(dir.join(file), src).unwrap();
        let out = std::process::Command::new(&cc)
            .args([
                std,
                "-pedantic",
                "-Wall",
                "-Wextra",
                "-Werror",
                "-fsyntax-only",
                "-I",
            ])
            .arg(&include)
            .arg(dir.join(file))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{cc} {std}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        compiled += 1;
    }
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!("header compiled {compiled} ways");
}
