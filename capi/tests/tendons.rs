//! The tendon readings entry points of the C ABI, called as C would call them: a
//! solve agrees with the Rust `TendonWorkspace` on the same readings, and every bad
//! call (null handle, bad scene text, NaN reading, wrong buffer length, null
//! buffer) is an error code whose message names the offending value.

use cablesense_capi::*;
use std::ffi::{CStr, CString};
use std::path::Path;

fn scene_text(path: &str) -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)).unwrap()
}

fn last_error() -> String {
    // SAFETY: never null, NUL-terminated.
    unsafe { CStr::from_ptr(cs_last_error()) }
        .to_string_lossy()
        .into_owned()
}

/// A live solver of the textbook two-segment TDCR (six driven tendons).
fn tendons() -> *mut CsTendons {
    let text = CString::new(scene_text("data/scenes/tdcr_two_segment.toml")).unwrap();
    let mut t = std::ptr::null_mut();
    // SAFETY: valid string and out pointer.
    assert_eq!(unsafe { cs_tendons_new(text.as_ptr(), &mut t) }, CsCode::Ok);
    assert!(!t.is_null());
    t
}

#[test]
fn solve_matches_the_rust_workspace() {
    let q = [1.0e-3, 0.0, 0.0, 0.0, 0.5e-3, 0.0];
    let scene =
        cablesense::Scene::from_toml_str(&scene_text("data/scenes/tdcr_two_segment.toml")).unwrap();
    let mut ws = scene.tendon_workspace().unwrap();
    let rep = ws.solve_readings(&q).unwrap();
    assert!(rep.status.is_converged());
    let t = tendons();
    // SAFETY: live handle until the free; buffers of the stated sizes.
    unsafe {
        let mut info = CsTendonInfo::default();
        assert_eq!(cs_tendons_solve(t, q.as_ptr(), 6, 1, &mut info), CsCode::Ok);
        assert_eq!(info.status, 0);
        assert_eq!(info.slack as usize, rep.slack);
        let (mut tension, mut taut, mut tip) = ([0.0; 6], [7i32; 6], [0.0; 3]);
        assert_eq!(
            cs_tendons_tensions(t, tension.as_mut_ptr(), taut.as_mut_ptr(), 6),
            CsCode::Ok
        );
        assert_eq!(cs_tendons_tip_position(t, tip.as_mut_ptr()), CsCode::Ok);
        // same code path, same start: equal to rounding
        for i in 0..6 {
            assert!((tension[i] - ws.tensions()[i]).abs() < 1e-9, "{i}");
            assert_eq!(taut[i], i32::from(ws.taut()[i]), "{i}");
        }
        assert!((dist(&tip, &ws.tip_position().into())) < 1e-12);
        // the pulled tendon carries more than its 1 N pretension
        assert!(tension[0] > 1.0, "{tension:?}");
        // section poses: the last section's end is the tip
        let k = cs_tendons_section_count(t);
        assert_eq!(k, 2);
        let (mut pos, mut rot) = ([0.0; 6], [0.0; 18]);
        assert_eq!(
            cs_tendons_section_poses(t, pos.as_mut_ptr(), rot.as_mut_ptr(), k),
            CsCode::Ok
        );
        assert!(dist(&pos[3..].try_into().unwrap(), &tip) < 1e-12);
        // taut flags are optional
        assert_eq!(
            cs_tendons_tensions(t, tension.as_mut_ptr(), std::ptr::null_mut(), 6),
            CsCode::Ok
        );
        cs_tendons_free(t);
    }
}

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}

#[test]
fn null_handle_is_named() {
    let q = [0.0; 6];
    let mut buf = [0.0; 6];
    // SAFETY: null handles are checked.
    unsafe {
        let null = std::ptr::null_mut();
        assert_eq!(
            cs_tendons_solve(null, q.as_ptr(), 6, 1, std::ptr::null_mut()),
            CsCode::BadArgument
        );
        assert_eq!(last_error(), "tendons is null");
        assert_eq!(
            cs_tendons_tensions(null, buf.as_mut_ptr(), std::ptr::null_mut(), 6),
            CsCode::BadArgument
        );
        assert_eq!(last_error(), "tendons is null");
        assert_eq!(
            cs_tendons_tip_position(null, buf.as_mut_ptr()),
            CsCode::BadArgument
        );
        assert_eq!(last_error(), "tendons is null");
        assert_eq!(cs_tendons_count(null), 0);
        cs_tendons_free(null);
        // a null out pointer and null scene text
        let text = CString::new(scene_text("data/scenes/tdcr_two_segment.toml")).unwrap();
        assert_eq!(
            cs_tendons_new(text.as_ptr(), std::ptr::null_mut()),
            CsCode::BadArgument
        );
        assert_eq!(last_error(), "out is null");
        let mut t = std::ptr::null_mut();
        assert_eq!(
            cs_tendons_new(std::ptr::null(), &mut t),
            CsCode::BadArgument
        );
        assert_eq!(last_error(), "scene text is null");
        assert!(t.is_null());
    }
}

#[test]
fn bad_scene_text_names_the_field_and_value() {
    let mut t = std::ptr::null_mut();
    let text = scene_text("data/scenes/tdcr_two_segment.toml");
    // an invalid value
    let bad =
        CString::new(text.replacen("stiffness_n = 2.0e4", "stiffness_n = -2.0e4", 1)).unwrap();
    // SAFETY: valid strings and out pointer.
    unsafe {
        assert_eq!(cs_tendons_new(bad.as_ptr(), &mut t), CsCode::BadScene);
        let msg = last_error();
        assert!(
            msg.contains("stiffness_n") && msg.contains("-20000"),
            "{msg}"
        );
        // not TOML
        let junk = CString::new("[[robot.sections]\nlength_m = ").unwrap();
        assert_eq!(cs_tendons_new(junk.as_ptr(), &mut t), CsCode::BadScene);
        assert!(last_error().contains("robot.sections"), "{}", last_error());
        // not UTF-8
        let latin1 = CString::new(vec![b'#', 0xe9, b'\n']).unwrap();
        assert_eq!(cs_tendons_new(latin1.as_ptr(), &mut t), CsCode::BadScene);
        assert!(last_error().contains("UTF-8"), "{}", last_error());
        // a valid scene without displacement-driven tendons
        let track = CString::new(scene_text("data/scenes/track_demo.toml")).unwrap();
        assert_eq!(cs_tendons_new(track.as_ptr(), &mut t), CsCode::BadScene);
        assert!(last_error().contains("displacement"), "{}", last_error());
        assert!(t.is_null());
    }
}

#[test]
fn bad_readings_name_the_reading_and_value() {
    let t = tendons();
    let mut info = CsTendonInfo::default();
    let (mut tension, mut tip) = ([0.0; 6], [0.0; 3]);
    // SAFETY: live handle until the free; buffers of at least the stated sizes.
    unsafe {
        let good = [0.5e-3, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(
            cs_tendons_solve(t, good.as_ptr(), 6, 1, &mut info),
            CsCode::Ok
        );
        assert_eq!(cs_tendons_tip_position(t, tip.as_mut_ptr()), CsCode::Ok);
        let before = tip;
        // NaN reading
        let nan = [0.0, 0.0, f64::NAN, 0.0, 0.0, 0.0];
        assert_eq!(
            cs_tendons_solve(t, nan.as_ptr(), 6, 1, &mut info),
            CsCode::BadArgument
        );
        let msg = last_error();
        assert!(
            msg.contains("readings[2] (s1c)") && msg.contains("NaN"),
            "{msg}"
        );
        // a reading pulling in more than the whole tendon
        let far = [0.0, 0.0, 0.0, 0.0, 5.0, 0.0];
        assert_eq!(
            cs_tendons_solve(t, far.as_ptr(), 6, 1, &mut info),
            CsCode::BadArgument
        );
        let msg = last_error();
        assert!(
            msg.contains("readings[4] (s2b)") && msg.contains('5'),
            "{msg}"
        );
        // wrong buffer lengths
        assert_eq!(
            cs_tendons_solve(t, good.as_ptr(), 3, 1, &mut info),
            CsCode::BadArgument
        );
        assert_eq!(
            last_error(),
            "n = 3 readings for 6 displacement-driven tendons"
        );
        assert_eq!(
            cs_tendons_tensions(t, tension.as_mut_ptr(), std::ptr::null_mut(), 5),
            CsCode::BadArgument
        );
        assert_eq!(last_error(), "n = 5 for 6 displacement-driven tendons");
        let mut len = [0.0; 8];
        assert_eq!(
            cs_tendons_cable_lengths(t, len.as_mut_ptr(), 8),
            CsCode::BadArgument
        );
        assert_eq!(last_error(), "n = 8, the robot has 6 cables");
        let (mut pos, mut rot) = ([0.0; 9], [0.0; 27]);
        assert_eq!(
            cs_tendons_section_poses(t, pos.as_mut_ptr(), rot.as_mut_ptr(), 3),
            CsCode::BadArgument
        );
        assert_eq!(last_error(), "n = 3, the robot has 2 sections");
        // null buffers
        assert_eq!(
            cs_tendons_solve(t, std::ptr::null(), 6, 1, &mut info),
            CsCode::BadArgument
        );
        assert_eq!(last_error(), "readings is null");
        assert_eq!(
            cs_tendons_tip_position(t, std::ptr::null_mut()),
            CsCode::BadArgument
        );
        assert_eq!(last_error(), "output buffer is null");
        // the failed calls left the last good solve in place
        assert_eq!(cs_tendons_tip_position(t, tip.as_mut_ptr()), CsCode::Ok);
        assert_eq!(tip, before);
        cs_tendons_free(t);
    }
}
