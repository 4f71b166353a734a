//! `cs_model_diagnosis` and `cs_tendons_diagnosis`, called as C would call them: after
//! a solve that does not converge the text names the input to reduce (the demo's
//! first cable at 500 N; 80 mm on the textbook TDCR's `s1a`), a short buffer gets a
//! NUL-terminated prefix, `needed` the whole length, and a null handle is an error.

use cablesense_capi::*;
use std::ffi::{c_char, CStr, CString};
use std::path::Path;

fn scene_text(path: &str) -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)).unwrap()
}

/// The diagnosis through `call` into a buffer of `len` bytes: (text, needed).
fn read(call: impl Fn(*mut c_char, usize, *mut usize) -> CsCode, len: usize) -> (String, usize) {
    let mut buf = vec![1 as c_char; len.max(1)];
    let mut needed = 0usize;
    assert_eq!(call(buf.as_mut_ptr(), len, &mut needed), CsCode::Ok);
    // SAFETY: the call NUL-terminated the buffer (len >= 1 here)
    let text = unsafe { CStr::from_ptr(buf.as_ptr()) }
        .to_string_lossy()
        .into_owned();
    (text, needed)
}

#[test]
fn an_unreachable_tension_is_diagnosed_through_the_c_abi() {
    let text = scene_text("data/scenes/demo_two_section.toml").replacen(
        "tensions_n = [1.5,",
        "tensions_n = [500.0,",
        1,
    );
    let text = CString::new(text).unwrap();
    let mut m = std::ptr::null_mut();
    // SAFETY: valid string and out pointer; live handle until the free; buffers of
    // the stated sizes.
    unsafe {
        assert_eq!(cs_model_new(text.as_ptr(), &mut m), CsCode::Ok);
        let mut info = CsSolveInfo::default();
        assert_eq!(cs_model_solve(m, 0, &mut info), CsCode::Ok);
        assert_ne!(info.status, 0, "{info:?}");
        let call = |b, l, n| cs_model_diagnosis(m, b, l, n);
        let (full, needed) = read(call, 4096);
        assert_eq!(needed, full.len() + 1, "{full}");
        assert!(full.contains("reduce loads.tensions_n[0]"), "{full}");
        // cut to fit, still NUL-terminated
        let (cut, needed_again) = read(call, 16);
        assert_eq!((cut.as_str(), needed_again), (&full[..15], needed));
        // nothing written, the length still reported
        let mut n = 0usize;
        assert_eq!(
            cs_model_diagnosis(m, std::ptr::null_mut(), 0, &mut n),
            CsCode::Ok
        );
        assert_eq!(n, needed);
        cs_model_free(m);
        let null = std::ptr::null();
        assert_eq!(
            cs_model_diagnosis(null, std::ptr::null_mut(), 0, std::ptr::null_mut()),
            CsCode::BadArgument
        );
    }
}

#[test]
fn an_unreachable_pull_is_diagnosed_through_the_c_abi() {
    let text = CString::new(scene_text("data/scenes/tdcr_two_segment.toml")).unwrap();
    let mut t = std::ptr::null_mut();
    // SAFETY: as above.
    unsafe {
        assert_eq!(cs_tendons_new(text.as_ptr(), &mut t), CsCode::Ok);
        let mut info = CsTendonInfo::default();
        let q = [0.0; 6];
        assert_eq!(cs_tendons_solve(t, q.as_ptr(), 6, 1, &mut info), CsCode::Ok);
        assert_eq!(info.status, 0);
        let q = [0.08, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(cs_tendons_solve(t, q.as_ptr(), 6, 1, &mut info), CsCode::Ok);
        assert_ne!(info.status, 0, "{info:?}");
        let (full, needed) = read(|b, l, n| cs_tendons_diagnosis(t, b, l, n), 4096);
        assert_eq!(needed, full.len() + 1);
        assert!(full.contains("readings column s1a = 80 mm"), "{full}");
        cs_tendons_free(t);
        let null = std::ptr::null();
        assert_eq!(
            cs_tendons_diagnosis(null, std::ptr::null_mut(), 0, std::ptr::null_mut()),
            CsCode::BadArgument
        );
    }
}
