//! Check of the `capi` fuzz target, shared with `capi/tests/fuzz_regressions.rs`:
//! arbitrary bytes through the C ABI (`capi/`, `cablesense_capi`): scene text into
//! `cs_model_new`, `cs_estimator_new` and `cs_tendons_new`, then solves, ticks and
//! readings rows with numbers from the input, every getter with the right and a wrong
//! length, null handles and null buffers.
//!
//! Input layout: byte 0, flags (bit 0 model, bit 1 estimator, bit 2 tendons, bit 3
//! warm starts, bit 4 null `info` pointers, bit 5 getters also called with a wrong
//! length, bit 6 getters also called with null buffers, bit 7 noise given to ticks);
//! then the scene text up to the first NUL byte (a C string); after the NUL, numbers
//! of two bytes each ([`Numbers`]: a value within +-32.8 mm, or NaN, +-inf, +-1e300,
//! a subnormal).
//!
//! A scene that the library refuses (not UTF-8, does not parse, invalid) is given to
//! the three constructors as it is: each must return `CS_BAD_SCENE` with the
//! library's own message. A valid scene goes to `cs_model_new` as it is (no solve
//! there), and to the solving calls with its numerics capped ([`MAX_ITERATIONS`] and
//! the like, as `shared.rs` caps the `scene_*` targets' solves; re-written with
//! `Scene::to_toml_string`), when the robot is small ([`MAX_SECTIONS`]).
//!
//! Invariants: no call returns `CS_PANIC` (a panic caught at the boundary) and no
//! panic unwinds out of one; every failing call sets a non-empty `cs_last_error`
//! and leaves `*out` null; a length or null-buffer mistake is `CS_BAD_ARGUMENT`;
//! status codes are in their documented ranges; after a converged solve every
//! output is finite, tensions are >= 0 and a tendon with tension is flagged taut;
//! an estimate stays finite after every tick.

#![allow(dead_code)]

use cablesense::{Integrator, Scene, Workspace};
use cablesense_capi::*;
use std::ffi::{CStr, CString};
use std::path::Path;
use std::ptr::{null, null_mut};

/// Solving calls are skipped for robots larger than this (as in `shared.rs`).
const MAX_SECTIONS: usize = 6;
/// See [`MAX_SECTIONS`].
const MAX_GUIDES: usize = 24;
/// See [`MAX_SECTIONS`].
const MAX_CABLES: usize = 12;
/// Budget caps on the numerics of the scene given to the solving calls.
const MAX_ITERATIONS: usize = 10;
/// See [`MAX_ITERATIONS`].
const MAX_CONTINUATION_STEPS: usize = 4;
/// See [`MAX_ITERATIONS`].
const MAX_RK4_STEPS: usize = 32;
/// See [`MAX_ITERATIONS`].
const MAX_ADAPTIVE_STEPS: usize = 1500;
/// See [`MAX_ITERATIONS`].
const MIN_ADAPTIVE_TOL: f64 = 1e-8;
/// See [`MAX_ITERATIONS`]: estimator iterations per tick.
const MAX_ESTIMATE_ITERATIONS: usize = 4;
/// Solves, ticks and rows per handle.
const CALLS: usize = 2;

const MODEL: u8 = 1;
const ESTIMATOR: u8 = 2;
const TENDONS: u8 = 4;
const WARM: u8 = 8;
const NULL_INFO: u8 = 16;
const WRONG_LEN: u8 = 32;
const NULL_BUF: u8 = 64;
const SIGMA: u8 = 128;

/// Numbers after the scene text, two bytes each (missing bytes read as zero).
pub struct Numbers<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Numbers<'_> {
    fn next(&mut self) -> f64 {
        let b = |i: usize| self.bytes.get(i).copied().unwrap_or(0);
        let (k, v) = (b(self.at), b(self.at + 1));
        self.at += 2;
        match k {
            0xf0 => f64::NAN,
            0xf1 => f64::INFINITY,
            0xf2 => f64::NEG_INFINITY,
            0xf3 => 1e300,
            0xf4 => -1e300,
            0xf5 => f64::from(v) * 1e-310,
            _ => f64::from(i16::from_le_bytes([k, v])) * 1e-6,
        }
    }
    fn take(&mut self, n: usize) -> Vec<f64> {
        (0..n).map(|_| self.next()).collect()
    }
}

fn last_error() -> String {
    let p = cs_last_error();
    assert!(!p.is_null(), "cs_last_error returned null");
    // SAFETY: a NUL-terminated string owned by the library's thread-local.
    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
}

/// `code` is one of `allowed`; a failure has set a message.
#[track_caller]
fn expect(code: CsCode, allowed: &[CsCode], call: &str) {
    assert!(
        code != CsCode::Panic,
        "{call}: panic caught at the C boundary: {}",
        last_error()
    );
    assert!(
        allowed.contains(&code),
        "{call}: {code:?} not in {allowed:?}: {}",
        last_error()
    );
    if code != CsCode::Ok {
        assert!(
            !last_error().is_empty(),
            "{call}: {code:?} without a message"
        );
    }
}

#[track_caller]
fn ok(code: CsCode, call: &str) {
    expect(code, &[CsCode::Ok], call);
}

#[track_caller]
fn bad_arg(code: CsCode, call: &str) {
    expect(code, &[CsCode::BadArgument], call);
}

fn finite(xs: &[f64]) -> bool {
    xs.iter().all(|x| x.is_finite())
}

/// Run the check; panics on a broken invariant.
pub fn check_capi(data: &[u8]) {
    let flags = data.first().copied().unwrap_or(0);
    let rest = data.get(1..).unwrap_or(&[]);
    let (text, numbers) = match rest.iter().position(|&b| b == 0) {
        Some(i) => (&rest[..i], &rest[i + 1..]),
        None => (rest, &[][..]),
    };
    let mut nums = Numbers {
        bytes: numbers,
        at: 0,
    };
    let c_text = CString::new(text).expect("no NUL in the text");
    null_arguments(&c_text);
    let parsed = std::str::from_utf8(text)
        .map_err(|e| format!("scene text is not UTF-8: {e}"))
        .and_then(|s| {
            Scene::parse_validated(s, Path::new("<scene>"), false).map_err(|e| e.to_string())
        });
    let scene = match parsed {
        Ok(scene) => scene,
        Err(msg) => {
            for (code, out) in [
                model_new(&c_text),
                estimator_new(&c_text),
                tendons_new(&c_text),
            ] {
                expect(code, &[CsCode::BadScene], "constructor on a refused scene");
                assert!(out, "a failed constructor wrote *out");
                assert_eq!(last_error(), msg, "message is not the library's");
            }
            return;
        }
    };
    // the raw text through cs_model_new (it does not solve): agrees with the library
    let mut m = null_mut();
    // SAFETY: NUL-terminated text, writable out.
    let code = unsafe { cs_model_new(c_text.as_ptr(), &mut m) };
    let built = scene
        .build_robot()
        .and_then(|r| Workspace::new(r, scene.loads.clone(), scene.numerics.clone()));
    match built {
        Ok(_) => ok(code, "cs_model_new on a valid scene"),
        Err(e) => {
            expect(code, &[CsCode::BadScene], "cs_model_new");
            assert_eq!(last_error(), e.to_string());
            assert!(m.is_null());
        }
    }
    // SAFETY: a handle from cs_model_new, or null.
    unsafe { cs_model_free(m) };
    let Ok(robot) = scene.build_robot() else {
        return;
    };
    if robot.sections().len() > MAX_SECTIONS
        || robot.guides().len() > MAX_GUIDES
        || robot.cables().len() > MAX_CABLES
    {
        return;
    }
    let Ok(capped) = CString::new(capped(&scene).to_toml_string()) else {
        return;
    };
    if flags & MODEL != 0 {
        model(&capped, flags);
    }
    if flags & ESTIMATOR != 0 {
        estimator(&capped, flags, &mut nums);
    }
    if flags & TENDONS != 0 {
        tendons(&capped, flags, &mut nums);
    }
}

/// The scene with its numerics and estimator iterations capped.
fn capped(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    let n = &mut s.numerics;
    n.integrator = match n.integrator {
        Integrator::Rk4 { steps_per_section } => Integrator::Rk4 {
            steps_per_section: steps_per_section.min(MAX_RK4_STEPS),
        },
        Integrator::Adaptive { tol, max_steps } => Integrator::Adaptive {
            tol: tol.max(MIN_ADAPTIVE_TOL),
            max_steps: max_steps.min(MAX_ADAPTIVE_STEPS),
        },
    };
    n.max_iterations = n.max_iterations.min(MAX_ITERATIONS);
    n.max_continuation_steps = n.max_continuation_steps.min(MAX_CONTINUATION_STEPS);
    if let Some(e) = s.estimate.as_mut() {
        e.max_iterations = e.max_iterations.min(MAX_ESTIMATE_ITERATIONS);
    }
    s
}

/// Constructors: code, and whether `*out` stayed null (freed otherwise).
fn model_new(text: &CStr) -> (CsCode, bool) {
    let mut out = null_mut();
    // SAFETY: NUL-terminated text, writable out.
    let code = unsafe { cs_model_new(text.as_ptr(), &mut out) };
    let stayed = out.is_null();
    // SAFETY: a handle or null.
    unsafe { cs_model_free(out) };
    (code, stayed)
}

fn estimator_new(text: &CStr) -> (CsCode, bool) {
    let mut out = null_mut();
    // SAFETY: NUL-terminated text, writable out.
    let code = unsafe { cs_estimator_new(text.as_ptr(), &mut out) };
    let stayed = out.is_null();
    // SAFETY: a handle or null.
    unsafe { cs_estimator_free(out) };
    (code, stayed)
}

fn tendons_new(text: &CStr) -> (CsCode, bool) {
    let mut out = null_mut();
    // SAFETY: NUL-terminated text, writable out.
    let code = unsafe { cs_tendons_new(text.as_ptr(), &mut out) };
    let stayed = out.is_null();
    // SAFETY: a handle or null.
    unsafe { cs_tendons_free(out) };
    (code, stayed)
}

/// Null handles, null text and null `out`: `CS_BAD_ARGUMENT` (counts 0), no crash.
fn null_arguments(text: &CStr) {
    let mut buf = [0.0; 16];
    let mut taut = [0i32; 4];
    // SAFETY: the functions accept null handles and report them; buffers are large
    // enough for any length passed here.
    unsafe {
        bad_arg(cs_model_new(null(), &mut null_mut()), "cs_model_new(null)");
        bad_arg(
            cs_model_new(text.as_ptr(), null_mut()),
            "cs_model_new(out null)",
        );
        bad_arg(
            cs_estimator_new(text.as_ptr(), null_mut()),
            "cs_estimator_new(out null)",
        );
        bad_arg(
            cs_tendons_new(text.as_ptr(), null_mut()),
            "cs_tendons_new(out null)",
        );
        assert_eq!(cs_model_section_count(null()), 0);
        assert_eq!(cs_model_cable_count(null()), 0);
        assert_eq!(cs_estimator_unknown_count(null()), 0);
        assert_eq!(cs_estimator_cable_count(null()), 0);
        assert_eq!(cs_tendons_count(null()), 0);
        assert_eq!(cs_tendons_cable_count(null()), 0);
        assert_eq!(cs_tendons_section_count(null()), 0);
        bad_arg(
            cs_model_solve(null_mut(), 0, null_mut()),
            "cs_model_solve(null)",
        );
        bad_arg(
            cs_model_tip_pose(null_mut(), buf.as_mut_ptr(), buf.as_mut_ptr()),
            "cs_model_tip_pose(null)",
        );
        bad_arg(
            cs_estimator_tick(null_mut(), buf.as_ptr(), null(), 1, null_mut()),
            "cs_estimator_tick(null)",
        );
        bad_arg(
            cs_estimator_values(null(), buf.as_mut_ptr(), null_mut(), 1),
            "cs_estimator_values(null)",
        );
        bad_arg(
            cs_tendons_solve(null_mut(), buf.as_ptr(), 1, 0, null_mut()),
            "cs_tendons_solve(null)",
        );
        bad_arg(
            cs_tendons_tensions(null(), buf.as_mut_ptr(), taut.as_mut_ptr(), 1),
            "cs_tendons_tensions(null)",
        );
        cs_model_free(null_mut());
        cs_estimator_free(null_mut());
        cs_tendons_free(null_mut());
    }
}

fn info_ptr<T>(flags: u8, info: &mut T) -> *mut T {
    if flags & NULL_INFO != 0 {
        null_mut()
    } else {
        info
    }
}

fn model(text: &CStr, flags: u8) {
    let mut m = null_mut();
    // SAFETY: NUL-terminated text, writable out.
    let code = unsafe { cs_model_new(text.as_ptr(), &mut m) };
    expect(
        code,
        &[CsCode::Ok, CsCode::BadScene],
        "cs_model_new (capped)",
    );
    if code != CsCode::Ok {
        assert!(m.is_null());
        return;
    }
    // SAFETY: a live handle from here to cs_model_free; buffers sized for the lengths
    // passed (a wrong length is one more than the right one, and the buffers hold it).
    unsafe {
        let n = cs_model_section_count(m);
        let c = cs_model_cable_count(m);
        assert!(n >= 1);
        let mut converged = false;
        for k in 0..CALLS {
            let mut info = CsSolveInfo {
                status: -1,
                ..CsSolveInfo::default()
            };
            let warm = i32::from(k > 0 && flags & WARM != 0);
            ok(
                cs_model_solve(m, warm, info_ptr(flags, &mut info)),
                "cs_model_solve",
            );
            if flags & NULL_INFO == 0 {
                assert!((0..=5).contains(&info.status), "{info:?}");
                converged = info.status == 0;
            }
        }
        let (mut p, mut r) = (vec![0.0; 3 * (n + 1)], vec![0.0; 9 * (n + 1)]);
        ok(
            cs_model_tip_pose(m, p.as_mut_ptr(), r.as_mut_ptr()),
            "cs_model_tip_pose",
        );
        assert!(!converged || finite(&p[..3]) && finite(&r[..9]));
        ok(
            cs_model_section_poses(m, p.as_mut_ptr(), r.as_mut_ptr(), n),
            "cs_model_section_poses",
        );
        assert!(!converged || finite(&p[..3 * n]) && finite(&r[..9 * n]));
        let mut l = vec![0.0; c + 1];
        ok(
            cs_model_cable_lengths(m, l.as_mut_ptr(), c),
            "cs_model_cable_lengths",
        );
        assert!(!converged || finite(&l[..c]), "{l:?}");
        if flags & WRONG_LEN != 0 {
            bad_arg(
                cs_model_section_poses(m, p.as_mut_ptr(), r.as_mut_ptr(), n + 1),
                "cs_model_section_poses(n + 1)",
            );
            bad_arg(
                cs_model_cable_lengths(m, l.as_mut_ptr(), c + 1),
                "cs_model_cable_lengths(c + 1)",
            );
        }
        if flags & NULL_BUF != 0 {
            bad_arg(
                cs_model_tip_pose(m, null_mut(), r.as_mut_ptr()),
                "cs_model_tip_pose(null)",
            );
            bad_arg(
                cs_model_section_poses(m, p.as_mut_ptr(), null_mut(), n),
                "cs_model_section_poses(null)",
            );
            if c > 0 {
                bad_arg(
                    cs_model_cable_lengths(m, null_mut(), c),
                    "cs_model_cable_lengths(null)",
                );
            }
        }
        cs_model_free(m);
    }
}

fn estimator(text: &CStr, flags: u8, nums: &mut Numbers) {
    let mut e = null_mut();
    // SAFETY: NUL-terminated text, writable out.
    let code = unsafe { cs_estimator_new(text.as_ptr(), &mut e) };
    expect(
        code,
        &[CsCode::Ok, CsCode::BadScene],
        "cs_estimator_new (capped)",
    );
    if code != CsCode::Ok {
        assert!(e.is_null());
        return;
    }
    // SAFETY: a live handle until cs_estimator_free; buffers sized for the lengths
    // passed (one more than the right one).
    unsafe {
        let p = cs_estimator_unknown_count(e);
        let c = cs_estimator_cable_count(e);
        for _ in 0..CALLS {
            let mut changes = nums.take(c + 1);
            let sigma = if flags & SIGMA != 0 {
                nums.take(c + 1)
            } else {
                Vec::new()
            };
            let sigma_ptr = if sigma.is_empty() {
                null()
            } else {
                sigma.as_ptr()
            };
            let mut info = CsEstimateInfo {
                status: -1,
                ..CsEstimateInfo::default()
            };
            // the strict boundary: an infinite change, or a sigma that is not finite
            // and > 0, is a bad argument (NaN changes are missing ones)
            let valid = changes[..c].iter().all(|x| !x.is_infinite())
                && (sigma.is_empty() || sigma[..c].iter().all(|s| s.is_finite() && *s > 0.0));
            expect(
                cs_estimator_tick(
                    e,
                    changes.as_ptr(),
                    sigma_ptr,
                    c,
                    info_ptr(flags, &mut info),
                ),
                if valid {
                    &[CsCode::Ok]
                } else {
                    &[CsCode::BadArgument]
                },
                "cs_estimator_tick",
            );
            if valid && flags & NULL_INFO == 0 {
                assert!((0..=6).contains(&info.status), "{info:?}");
                assert!(info.poor_fit == 0 || info.poor_fit == 1, "{info:?}");
            }
            if flags & WRONG_LEN != 0 {
                bad_arg(
                    cs_estimator_tick(e, changes.as_ptr(), sigma_ptr, c + 1, null_mut()),
                    "cs_estimator_tick(c + 1)",
                );
            }
            if flags & NULL_BUF != 0 {
                bad_arg(
                    cs_estimator_tick(e, null(), sigma_ptr, c, null_mut()),
                    "cs_estimator_tick(null)",
                );
            }
            let (mut v, mut cov) = (vec![0.0; p + 1], vec![0.0; (p + 1) * (p + 1)]);
            ok(
                cs_estimator_values(e, v.as_mut_ptr(), cov.as_mut_ptr(), p),
                "cs_estimator_values",
            );
            assert!(finite(&v[..p]), "non-finite estimate {v:?}");
            let mut tip = [0.0; 3];
            ok(
                cs_estimator_tip_position(e, tip.as_mut_ptr()),
                "cs_estimator_tip_position",
            );
            ok(
                cs_estimator_cable_lengths(e, changes.as_mut_ptr(), c),
                "cs_estimator_cable_lengths",
            );
            if flags & WRONG_LEN != 0 {
                bad_arg(
                    cs_estimator_values(e, v.as_mut_ptr(), null_mut(), p + 1),
                    "cs_estimator_values(p + 1)",
                );
                bad_arg(
                    cs_estimator_cable_lengths(e, changes.as_mut_ptr(), c + 1),
                    "cs_estimator_cable_lengths(c + 1)",
                );
            }
            if flags & NULL_BUF != 0 {
                bad_arg(
                    cs_estimator_tip_position(e, null_mut()),
                    "cs_estimator_tip_position(null)",
                );
            }
        }
        cs_estimator_free(e);
    }
}

fn tendons(text: &CStr, flags: u8, nums: &mut Numbers) {
    let mut t = null_mut();
    // SAFETY: NUL-terminated text, writable out.
    let code = unsafe { cs_tendons_new(text.as_ptr(), &mut t) };
    expect(
        code,
        &[CsCode::Ok, CsCode::BadScene],
        "cs_tendons_new (capped)",
    );
    if code != CsCode::Ok {
        assert!(t.is_null());
        return;
    }
    // SAFETY: a live handle until cs_tendons_free; buffers sized for the lengths
    // passed (one more than the right one).
    unsafe {
        let p = cs_tendons_count(t);
        let c = cs_tendons_cable_count(t);
        let k = cs_tendons_section_count(t);
        assert!(
            p >= 1 && c >= p && k >= 1,
            "{p} tendons, {c} cables, {k} sections"
        );
        for row in 0..CALLS {
            let readings = nums.take(p + 1);
            let mut info = CsTendonInfo {
                status: -1,
                ..CsTendonInfo::default()
            };
            let warm = i32::from(row > 0 && flags & WARM != 0);
            let code = cs_tendons_solve(t, readings.as_ptr(), p, warm, info_ptr(flags, &mut info));
            expect(code, &[CsCode::Ok, CsCode::BadArgument], "cs_tendons_solve");
            if code != CsCode::Ok {
                let msg = last_error();
                assert!(
                    msg.contains("readings["),
                    "a refused row that names no reading: {msg} ({readings:?})"
                );
                continue;
            }
            assert!(
                finite(&readings[..p]),
                "non-finite readings accepted: {readings:?}"
            );
            let converged = flags & NULL_INFO == 0 && info.status == 0;
            if flags & NULL_INFO == 0 {
                assert!((0..=5).contains(&info.status), "{info:?}");
            }
            let (mut ten, mut taut) = (vec![0.0; p + 1], vec![-1i32; p + 1]);
            ok(
                cs_tendons_tensions(t, ten.as_mut_ptr(), taut.as_mut_ptr(), p),
                "cs_tendons_tensions",
            );
            assert!(taut[..p].iter().all(|f| *f == 0 || *f == 1), "{taut:?}");
            let mut tip = [0.0; 3];
            ok(
                cs_tendons_tip_position(t, tip.as_mut_ptr()),
                "cs_tendons_tip_position",
            );
            let mut l = vec![0.0; c + 1];
            ok(
                cs_tendons_cable_lengths(t, l.as_mut_ptr(), c),
                "cs_tendons_cable_lengths",
            );
            let (mut sp, mut sr) = (vec![0.0; 3 * (k + 1)], vec![0.0; 9 * (k + 1)]);
            ok(
                cs_tendons_section_poses(t, sp.as_mut_ptr(), sr.as_mut_ptr(), k),
                "cs_tendons_section_poses",
            );
            if converged {
                for (x, f) in ten[..p].iter().zip(&taut[..p]) {
                    assert!(x.is_finite() && *x >= 0.0, "tension {x}");
                    assert!(
                        *x == 0.0 || *f == 1,
                        "tension {x} on a tendon flagged slack"
                    );
                }
                assert!(finite(&tip), "{tip:?}");
                assert!(finite(&l[..c]), "{l:?}");
                assert!(finite(&sp[..3 * k]) && finite(&sr[..9 * k]));
            }
            if flags & WRONG_LEN != 0 {
                bad_arg(
                    cs_tendons_solve(t, readings.as_ptr(), p + 1, warm, null_mut()),
                    "cs_tendons_solve(p + 1)",
                );
                bad_arg(
                    cs_tendons_tensions(t, ten.as_mut_ptr(), null_mut(), p + 1),
                    "cs_tendons_tensions(p + 1)",
                );
                bad_arg(
                    cs_tendons_cable_lengths(t, l.as_mut_ptr(), c + 1),
                    "cs_tendons_cable_lengths(c + 1)",
                );
                bad_arg(
                    cs_tendons_section_poses(t, sp.as_mut_ptr(), sr.as_mut_ptr(), k + 1),
                    "cs_tendons_section_poses(k + 1)",
                );
            }
            if flags & NULL_BUF != 0 {
                bad_arg(
                    cs_tendons_solve(t, null(), p, warm, null_mut()),
                    "cs_tendons_solve(null)",
                );
                bad_arg(
                    cs_tendons_tensions(t, null_mut(), null_mut(), p),
                    "cs_tendons_tensions(null)",
                );
                bad_arg(
                    cs_tendons_tip_position(t, null_mut()),
                    "cs_tendons_tip_position(null)",
                );
            }
        }
        cs_tendons_free(t);
    }
}
