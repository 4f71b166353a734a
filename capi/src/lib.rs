//! C ABI of `cablesense` for control loops (header: `capi/include/cablesense.h`).
//!
//! Three opaque handles, each created from a scene TOML string:
//! * [`CsModel`]: the forward statics of the scene (its loads, its `[numerics]`):
//!   solve, then read the tip pose, section end poses and cable lengths;
//! * [`CsEstimator`]: the scene's `[estimate]` problem: one tick per sample of
//!   cable length changes, then read the estimate, its covariance, the tip position
//!   and the predicted cable lengths;
//! * [`CsTendons`]: a robot with displacement-driven tendons solved from servo
//!   readings (warm-started from the previous row), then read the tensions, taut
//!   flags, tip position, section end poses and cable path lengths.
//!
//! Every entry point returns a [`CsCode`] (0 = OK) and catches panics
//! (`catch_unwind`), so no unwind crosses the boundary; the message of the last
//! failure on the calling thread is [`cs_last_error`]. Numerical outcomes (a solve
//! that did not converge, a stalled estimate) are not failures: they come back as
//! status codes in the info structs. After the first tick, [`cs_estimator_tick`],
//! [`cs_estimator_values`], [`cs_estimator_tip_position`] and
//! [`cs_estimator_cable_lengths`] do not allocate (LM and Gauss-Newton methods;
//! `capi/tests/alloc.rs` counts), nor do [`cs_tendons_tensions`],
//! [`cs_tendons_tip_position`] and [`cs_tendons_cable_lengths`];
//! nor does a warm [`cs_tendons_solve`]; [`cs_model_section_poses`], [`cs_model_tip_pose`] and
//! [`cs_tendons_section_poses`] recompute the shape and allocate.
//!
//! Threads: a handle is used by one thread at a time. Calls on the same handle from
//! two threads at once need a lock around them (the handle's warm state is mutated
//! by every solve and tick, with no lock inside); different handles on different
//! threads run concurrently without any (handles share no state, and the
//! last-error message is per thread: `cs_last_error` gives the calling thread's).
//! A handle may move between threads. [`cs_version`] is callable from any thread.
//! `capi/tests/threads.rs` runs two handles on two threads against one thread's
//! results.
//!
//! Rollback: a [`cs_tendons_solve`] that does not converge does not become the next
//! solve's warm start: the handle returns to its state before that solve (the
//! library's `TendonWorkspace::set_rollback`), so the rows after it give the
//! results they would without it (`capi/tests/rollback.rs`).
//!
//! The header `capi/include/cablesense.h` is generated from this file by cbindgen
//! (`capi/cbindgen.toml`); `capi/tests/header.rs` fails when it is out of date.

use cablesense::estimate::{EstimateStatus, Estimator};
use cablesense::tendons::TendonWorkspace;
use cablesense::{Scene, SolveStatus, Start, Workspace};
use std::cell::RefCell;
use std::ffi::{c_char, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Result code of every call.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CsCode {
    /// Success.
    Ok = 0,
    /// A null pointer, or a buffer of the wrong length.
    BadArgument = 1,
    /// The scene text is not UTF-8, does not parse or is invalid; or it has no
    /// `[estimate]` table for an estimator.
    BadScene = 2,
    /// A panic inside the library was caught (a bug: please report the message).
    Panic = 3,
}

/// Forward solve outcome (`SolveStatus`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct CsSolveInfo {
    /// 0 converged, 1 max_iterations, 2 stalled, 3 ill_conditioned, 4 non_finite,
    /// 5 unstable, 6 budget_exhausted (a tendon solve's
    /// `numerics.tendons.max_passes` or `time_budget_s` ran out). Only 0 is a usable
    /// shape.
    pub status: i32,
    /// Newton iterations.
    pub iterations: u32,
    /// Scaled boundary residual (-).
    pub residual: f64,
}

/// Estimator tick outcome.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct CsEstimateInfo {
    /// 0 converged, 1 unobservable, 2 max_iterations, 3 time_budget, 4 stalled,
    /// 5 forward_failed, 6 no_data (see `EstimateStatus`).
    pub status: i32,
    /// 1 when the RMS residual exceeds the scene's `poor_fit_rms_sigma`.
    pub poor_fit: i32,
    /// RMS over the measured cables of `residual / sigma` (-).
    pub rms_sigma: f64,
}

/// Outcome of a solve from tendon readings (`TendonReport`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct CsTendonInfo {
    /// 0 converged, 1 max_iterations, 2 stalled, 3 ill_conditioned, 4 non_finite,
    /// 5 unstable, 6 budget_exhausted (as [`CsSolveInfo`]). Only 0 is a usable shape.
    pub status: i32,
    /// Newton iterations on the tensions.
    pub iterations: u32,
    /// Tendons slack at the returned point.
    pub slack: u32,
    /// `max_i |G_i|`, the length mismatch of the tendon conditions (m).
    pub residual_m: f64,
}

/// Forward model handle.
pub struct CsModel {
    ws: Workspace,
}

/// Estimator handle; buffers sized once.
pub struct CsEstimator {
    est: Estimator,
    /// Unknown names, NUL-terminated ([`cs_estimator_unknown_name`]).
    names: Vec<CString>,
    lengths: Vec<f64>,
    changes: Vec<f64>,
    sigma: Vec<f64>,
}

/// Tendon readings solver handle; the readings buffer is sized once.
pub struct CsTendons {
    ws: TendonWorkspace,
    /// Readings column names, NUL-terminated ([`cs_tendons_column_name`]).
    columns: Vec<CString>,
    readings: Vec<f64>,
}

/// Names as C strings (a name with a NUL byte cannot be one: a scene error).
fn c_names(names: &[String]) -> Result<Vec<CString>, (CsCode, String)> {
    names
        .iter()
        .map(|n| {
            CString::new(n.as_str())
                .map_err(|_| (CsCode::BadScene, format!("name {n:?} contains a NUL byte")))
        })
        .collect()
}

/// The `i`th name of `names` as a C string pointer, null when out of range.
fn name_ptr(names: Option<&[CString]>, i: usize) -> *const c_char {
    names
        .and_then(|n| n.get(i))
        .map_or(std::ptr::null(), |n| n.as_ptr())
}

/// The version of this library (`MAJOR.MINOR.PATCH`), a static NUL-terminated
/// string (never null, never freed).
#[no_mangle]
pub extern "C" fn cs_version() -> *const c_char {
    concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr().cast()
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_error(msg: &str) {
    let c = CString::new(msg.replace('\0', " ")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = c);
}

/// Run `f`, turning `Err` and panics into a code and the last error message.
fn guard(f: impl FnOnce() -> Result<(), (CsCode, String)>) -> CsCode {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => CsCode::Ok,
        Ok(Err((code, msg))) => {
            set_error(&msg);
            code
        }
        Err(payload) => {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            set_error(&format!("panic in cablesense: {msg}"));
            CsCode::Panic
        }
    }
}

fn bad(msg: impl Into<String>) -> (CsCode, String) {
    (CsCode::BadArgument, msg.into())
}

fn scene_from(text: *const c_char) -> Result<Scene, (CsCode, String)> {
    if text.is_null() {
        return Err(bad("scene text is null"));
    }
    // SAFETY: the caller passes a NUL-terminated string (header contract).
    let s = unsafe { CStr::from_ptr(text) }
        .to_str()
        .map_err(|e| (CsCode::BadScene, format!("scene text is not UTF-8: {e}")))?;
    Scene::parse_validated(s, std::path::Path::new("<scene>"), false)
        .map_err(|e| (CsCode::BadScene, e.to_string()))
}

/// `&mut [f64]` of `len` from a caller buffer (null only when `len == 0`).
///
/// # Safety
/// `ptr` must point to `len` writable doubles.
unsafe fn out_slice<'a>(ptr: *mut f64, len: usize) -> Result<&'a mut [f64], (CsCode, String)> {
    if len == 0 {
        return Ok(&mut []);
    }
    if ptr.is_null() {
        return Err(bad("output buffer is null"));
    }
    // SAFETY: checked non-null; length per the caller's contract.
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, len) })
}

fn solve_code(s: SolveStatus) -> i32 {
    match s {
        SolveStatus::Converged => 0,
        SolveStatus::MaxIterations => 1,
        SolveStatus::Stalled => 2,
        SolveStatus::IllConditioned => 3,
        SolveStatus::NonFinite => 4,
        SolveStatus::Unstable => 5,
        SolveStatus::BudgetExhausted => 6,
    }
}

fn estimate_code(s: EstimateStatus) -> i32 {
    match s {
        EstimateStatus::Converged => 0,
        EstimateStatus::Unobservable => 1,
        EstimateStatus::MaxIterations => 2,
        EstimateStatus::TimeBudget => 3,
        EstimateStatus::Stalled => 4,
        EstimateStatus::ForwardFailed => 5,
        EstimateStatus::NoData => 6,
    }
}

/// Message of the last failed call on this thread (empty if none). Valid until the
/// next failing call on the same thread; never null.
#[no_mangle]
pub extern "C" fn cs_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// Create a forward model from scene TOML text. On success `*out` owns the handle
/// (free it with [`cs_model_free`]).
///
/// # Safety
/// `scene_toml` is a NUL-terminated string; `out` points to a writable pointer.
#[no_mangle]
pub unsafe extern "C" fn cs_model_new(scene_toml: *const c_char, out: *mut *mut CsModel) -> CsCode {
    guard(|| {
        if out.is_null() {
            return Err(bad("out is null"));
        }
        let scene = scene_from(scene_toml)?;
        let robot = scene
            .build_robot()
            .map_err(|e| (CsCode::BadScene, e.to_string()))?;
        let ws = Workspace::new(robot, scene.loads, scene.numerics)
            .map_err(|e| (CsCode::BadScene, e.to_string()))?;
        // SAFETY: checked non-null.
        unsafe { *out = Box::into_raw(Box::new(CsModel { ws })) };
        Ok(())
    })
}

/// Free a model (null is ignored).
///
/// # Safety
/// `m` comes from [`cs_model_new`] and is not used afterwards.
#[no_mangle]
pub unsafe extern "C" fn cs_model_free(m: *mut CsModel) {
    if !m.is_null() {
        let _ = catch_unwind(AssertUnwindSafe(|| {
            // SAFETY: owned handle from cs_model_new.
            drop(unsafe { Box::from_raw(m) })
        }));
    }
}

/// Number of sections, or 0 for a null handle.
///
/// # Safety
/// `m` is a live handle or null.
#[no_mangle]
pub unsafe extern "C" fn cs_model_section_count(m: *const CsModel) -> usize {
    // SAFETY: live handle or null.
    unsafe { m.as_ref() }.map_or(0, |m| m.ws.robot().sections().len())
}

/// Number of cables, or 0 for a null handle.
///
/// # Safety
/// `m` is a live handle or null.
#[no_mangle]
pub unsafe extern "C" fn cs_model_cable_count(m: *const CsModel) -> usize {
    // SAFETY: live handle or null.
    unsafe { m.as_ref() }.map_or(0, |m| m.ws.robot().cables().len())
}

/// Solve the statics with the scene's loads: `warm != 0` starts from the previous
/// solution. The outcome is in `*info` (may be null).
///
/// # Safety
/// `m` is a live handle; `info` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn cs_model_solve(
    m: *mut CsModel,
    warm: i32,
    info: *mut CsSolveInfo,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let m = unsafe { m.as_mut() }.ok_or_else(|| bad("model is null"))?;
        let r =
            m.ws.solve(if warm != 0 { Start::Warm } else { Start::Cold });
        // SAFETY: null or writable.
        if let Some(info) = unsafe { info.as_mut() } {
            *info = CsSolveInfo {
                status: solve_code(r.status),
                iterations: r.iterations as u32,
                residual: r.residual,
            };
        }
        Ok(())
    })
}

/// Copy `msg` into `buf` (`len` bytes, NUL-terminated, cut at `len - 1` bytes; a
/// null `buf` or `len` 0 writes nothing) and set `*needed` (unless null) to the
/// bytes the whole message takes with its NUL.
fn write_message(msg: &str, buf: *mut c_char, len: usize, needed: *mut usize) {
    // SAFETY (callers): `buf` is null or holds `len` writable bytes; `needed` is
    // null or writable.
    if let Some(n) = unsafe { needed.as_mut() } {
        *n = msg.len() + 1;
    }
    if buf.is_null() || len == 0 {
        return;
    }
    let k = msg.len().min(len - 1);
    // SAFETY: `k + 1 <= len` bytes, per the callers' contract.
    unsafe {
        std::ptr::copy_nonoverlapping(msg.as_ptr().cast::<c_char>(), buf, k);
        *buf.add(k) = 0;
    }
}

/// Why the last solve ended as it did (`Workspace::diagnose`: the load intensity
/// split by the load that causes it, each named by its scene field, and what to
/// change), as text in `buf` (`len` bytes, NUL-terminated, cut to fit); `*needed`
/// (unless null) gets the bytes the whole text takes. Meant for a solve whose
/// status is not 0. Allocates.
///
/// # Safety
/// `m` is a live handle; `buf` is null or holds `len` writable bytes; `needed` is
/// null or writable.
#[no_mangle]
pub unsafe extern "C" fn cs_model_diagnosis(
    m: *const CsModel,
    buf: *mut c_char,
    len: usize,
    needed: *mut usize,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let m = unsafe { m.as_ref() }.ok_or_else(|| bad("model is null"))?;
        write_message(&m.ws.diagnose().to_string(), buf, len, needed);
        Ok(())
    })
}

/// Tip position `[3]` (m) and rotation `[9]` (column-major) of the last solve.
/// Allocates (recomputes the shape).
///
/// # Safety
/// `m` is a live handle; `position` has 3 and `rotation` 9 writable doubles.
#[no_mangle]
pub unsafe extern "C" fn cs_model_tip_pose(
    m: *mut CsModel,
    position: *mut f64,
    rotation: *mut f64,
) -> CsCode {
    guard(|| {
        let n = unsafe { cs_model_section_count(m) };
        if n == 0 {
            return Err(bad("model is null"));
        }
        // SAFETY: live handle (n > 0).
        let m = unsafe { &mut *m };
        let tip = *m.ws.solution().tip();
        // SAFETY: buffer sizes per the contract.
        let (p, r) = unsafe { (out_slice(position, 3)?, out_slice(rotation, 9)?) };
        p.copy_from_slice(tip.position.as_slice());
        r.copy_from_slice(tip.rotation.as_slice());
        Ok(())
    })
}

/// Section end poses of the last solve: `positions[3 n]` (m), `rotations[9 n]`
/// (column-major each), `n` = [`cs_model_section_count`]. Allocates.
///
/// # Safety
/// `m` is a live handle; the buffers hold `3 n` and `9 n` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn cs_model_section_poses(
    m: *mut CsModel,
    positions: *mut f64,
    rotations: *mut f64,
    n: usize,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let m = unsafe { m.as_mut() }.ok_or_else(|| bad("model is null"))?;
        let k = m.ws.robot().sections().len();
        if n != k {
            return Err(bad(format!("n = {n}, the robot has {k} sections")));
        }
        let sol = m.ws.solution();
        // SAFETY: buffer sizes per the contract.
        let (p, r) = unsafe { (out_slice(positions, 3 * n)?, out_slice(rotations, 9 * n)?) };
        for (i, t) in sol.section_tips.iter().enumerate() {
            p[3 * i..3 * i + 3].copy_from_slice(t.position.as_slice());
            r[9 * i..9 * i + 9].copy_from_slice(t.rotation.as_slice());
        }
        Ok(())
    })
}

/// Cable lengths of the last solve (m), `n` = [`cs_model_cable_count`]. No allocation.
///
/// # Safety
/// `m` is a live handle; `out` holds `n` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn cs_model_cable_lengths(
    m: *const CsModel,
    out: *mut f64,
    n: usize,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let m = unsafe { m.as_ref() }.ok_or_else(|| bad("model is null"))?;
        let c = m.ws.robot().cables().len();
        if n != c {
            return Err(bad(format!("n = {n}, the robot has {c} cables")));
        }
        // SAFETY: buffer size per the contract.
        m.ws.cable_lengths_into(unsafe { out_slice(out, n)? });
        Ok(())
    })
}

/// Create an estimator from scene TOML text with an `[estimate]` table.
///
/// # Safety
/// `scene_toml` is a NUL-terminated string; `out` points to a writable pointer.
#[no_mangle]
pub unsafe extern "C" fn cs_estimator_new(
    scene_toml: *const c_char,
    out: *mut *mut CsEstimator,
) -> CsCode {
    guard(|| {
        if out.is_null() {
            return Err(bad("out is null"));
        }
        let scene = scene_from(scene_toml)?;
        let spec = scene
            .estimate
            .clone()
            .ok_or_else(|| (CsCode::BadScene, "the scene has no [estimate] table".into()))?;
        let robot = scene
            .build_robot()
            .map_err(|e| (CsCode::BadScene, e.to_string()))?;
        let c = robot.cables().len();
        let est = Estimator::new(robot, scene.loads, scene.numerics, spec)
            .map_err(|e| (CsCode::BadScene, e.to_string()))?;
        let names = c_names(est.names())?;
        let h = CsEstimator {
            names,
            est,
            lengths: vec![0.0; c],
            changes: vec![0.0; c],
            sigma: vec![0.0; c],
        };
        // SAFETY: checked non-null.
        unsafe { *out = Box::into_raw(Box::new(h)) };
        Ok(())
    })
}

/// Free an estimator (null is ignored).
///
/// # Safety
/// `e` comes from [`cs_estimator_new`] and is not used afterwards.
#[no_mangle]
pub unsafe extern "C" fn cs_estimator_free(e: *mut CsEstimator) {
    if !e.is_null() {
        let _ = catch_unwind(AssertUnwindSafe(|| {
            // SAFETY: owned handle from cs_estimator_new.
            drop(unsafe { Box::from_raw(e) })
        }));
    }
}

/// Number of unknowns, or 0 for a null handle.
///
/// # Safety
/// `e` is a live handle or null.
#[no_mangle]
pub unsafe extern "C" fn cs_estimator_unknown_count(e: *const CsEstimator) -> usize {
    // SAFETY: live handle or null.
    unsafe { e.as_ref() }.map_or(0, |e| e.est.theta().len())
}

/// Name of unknown `i` (`0 <= i <` [`cs_estimator_unknown_count`], the order of
/// the values of [`cs_estimator_values`]), e.g. `tip_force_x`: a NUL-terminated
/// string owned by the handle (valid until [`cs_estimator_free`]), or null for a
/// null handle or `i` out of range.
///
/// # Safety
/// `e` is a live handle or null.
#[no_mangle]
pub unsafe extern "C" fn cs_estimator_unknown_name(
    e: *const CsEstimator,
    i: usize,
) -> *const c_char {
    // SAFETY: live handle or null.
    name_ptr(unsafe { e.as_ref() }.map(|e| &e.names[..]), i)
}

/// Number of cables, or 0 for a null handle.
///
/// # Safety
/// `e` is a live handle or null.
#[no_mangle]
pub unsafe extern "C" fn cs_estimator_cable_count(e: *const CsEstimator) -> usize {
    // SAFETY: live handle or null.
    unsafe { e.as_ref() }.map_or(0, |e| e.lengths.len())
}

/// One sample: `changes[n]` cable length changes (m; NaN = missing, an infinite
/// one is `CS_CODE_BAD_ARGUMENT`), `sigma[n]` noise per cable (m; each finite and
/// positive, else `CS_CODE_BAD_ARGUMENT` naming it) or null (the scene's `noise_m`
/// for every cable). A null `changes` is reported as such. The outcome is in
/// `*info` (may be null). No allocation after the first tick.
///
/// # Safety
/// `e` is a live handle; `changes` (and `sigma` unless null) hold `n` doubles.
#[no_mangle]
pub unsafe extern "C" fn cs_estimator_tick(
    e: *mut CsEstimator,
    changes: *const f64,
    sigma: *const f64,
    n: usize,
    info: *mut CsEstimateInfo,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { e.as_mut() }.ok_or_else(|| bad("estimator is null"))?;
        let c = h.lengths.len();
        if changes.is_null() {
            return Err(bad("changes is null"));
        }
        if n != c {
            return Err(bad(format!("n = {n} changes for {c} cables")));
        }
        // SAFETY: n doubles per the contract.
        h.changes
            .copy_from_slice(unsafe { std::slice::from_raw_parts(changes, n) });
        let with_sigma = !sigma.is_null();
        if with_sigma {
            // SAFETY: n doubles per the contract.
            h.sigma
                .copy_from_slice(unsafe { std::slice::from_raw_parts(sigma, n) });
        }
        // the strict boundary (`Estimator::check_sample`): no allocation unless it fails
        h.est
            .check_sample(&h.changes, with_sigma.then_some(&h.sigma[..]))
            .map_err(|e| bad(e.to_string()))?;
        let status = h.est.tick(&h.changes, with_sigma.then_some(&h.sigma[..]));
        // RMS of the weighted residuals, as `Estimate::rms_sigma`
        h.est.model().cable_lengths_into(&mut h.lengths);
        let noise = h.est.spec().noise_m;
        let (mut chi2, mut count) = (0.0, 0usize);
        for j in 0..c {
            let s = if with_sigma && h.sigma[j].is_finite() && h.sigma[j] > 0.0 {
                h.sigma[j]
            } else {
                noise
            };
            let r = h.lengths[j] - h.est.reference_lengths()[j] - h.changes[j];
            if r.is_finite() {
                chi2 += (r / s) * (r / s);
                count += 1;
            }
        }
        let rms = if count > 0 {
            (chi2 / count as f64).sqrt()
        } else {
            0.0
        };
        // SAFETY: null or writable.
        if let Some(info) = unsafe { info.as_mut() } {
            *info = CsEstimateInfo {
                status: estimate_code(status),
                poor_fit: i32::from(rms > h.est.spec().poor_fit_rms_sigma),
                rms_sigma: rms,
            };
        }
        Ok(())
    })
}

/// The estimate `values[p]` (SI) and, unless null, its covariance `cov[p p]`
/// (row-major; from the sensitivities the tick ended with). No allocation.
///
/// # Safety
/// `e` is a live handle; `values` holds `p` and `cov` (unless null) `p p` doubles.
#[no_mangle]
pub unsafe extern "C" fn cs_estimator_values(
    e: *const CsEstimator,
    values: *mut f64,
    cov: *mut f64,
    p: usize,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { e.as_ref() }.ok_or_else(|| bad("estimator is null"))?;
        let k = h.est.theta().len();
        if p != k {
            return Err(bad(format!("p = {p}, the estimator has {k} unknowns")));
        }
        // SAFETY: buffer sizes per the contract.
        unsafe { out_slice(values, p)? }.copy_from_slice(h.est.theta());
        if !cov.is_null() {
            // SAFETY: p*p doubles per the contract.
            unsafe { out_slice(cov, p * p)? }.copy_from_slice(h.est.covariance());
        }
        Ok(())
    })
}

/// Tip position `[3]` (m) of the current estimate. No allocation.
///
/// # Safety
/// `e` is a live handle; `position` holds 3 writable doubles.
#[no_mangle]
pub unsafe extern "C" fn cs_estimator_tip_position(
    e: *const CsEstimator,
    position: *mut f64,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { e.as_ref() }.ok_or_else(|| bad("estimator is null"))?;
        // SAFETY: 3 doubles per the contract.
        unsafe { out_slice(position, 3)? }.copy_from_slice(h.est.tip_position().as_slice());
        Ok(())
    })
}

/// Predicted cable lengths (m, absolute) at the current estimate, `n` cables. No
/// allocation.
///
/// # Safety
/// `e` is a live handle; `out` holds `n` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn cs_estimator_cable_lengths(
    e: *mut CsEstimator,
    out: *mut f64,
    n: usize,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { e.as_mut() }.ok_or_else(|| bad("estimator is null"))?;
        if n != h.lengths.len() {
            return Err(bad(format!("n = {n} for {} cables", h.lengths.len())));
        }
        // SAFETY: n doubles per the contract.
        h.est
            .model()
            .cable_lengths_into(unsafe { out_slice(out, n)? });
        Ok(())
    })
}

/// Create a tendon readings solver from scene TOML text whose robot has
/// displacement-driven tendons (validates the scene and solves the reference at
/// the pretensions). On success `*out` owns the handle (free it with
/// [`cs_tendons_free`]).
///
/// # Safety
/// `scene_toml` is a NUL-terminated string; `out` points to a writable pointer.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_new(
    scene_toml: *const c_char,
    out: *mut *mut CsTendons,
) -> CsCode {
    guard(|| {
        if out.is_null() {
            return Err(bad("out is null"));
        }
        let scene = scene_from(scene_toml)?;
        let ws = scene
            .tendon_workspace()
            .map_err(|e| (CsCode::BadScene, e.to_string()))?;
        if ws.driven().is_empty() {
            return Err((
                CsCode::BadScene,
                "robot.cables: no displacement-driven tendon (actuation = \"displacement\")".into(),
            ));
        }
        let h = CsTendons {
            columns: c_names(ws.columns())?,
            readings: vec![0.0; ws.driven().len()],
            ws,
        };
        // SAFETY: checked non-null.
        unsafe { *out = Box::into_raw(Box::new(h)) };
        Ok(())
    })
}

/// Free a tendon solver (null is ignored).
///
/// # Safety
/// `t` comes from [`cs_tendons_new`] and is not used afterwards.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_free(t: *mut CsTendons) {
    if !t.is_null() {
        let _ = catch_unwind(AssertUnwindSafe(|| {
            // SAFETY: owned handle from cs_tendons_new.
            drop(unsafe { Box::from_raw(t) })
        }));
    }
}

/// Number of displacement-driven tendons (readings per row), or 0 for a null
/// handle. Their order is the cables' order in the scene.
///
/// # Safety
/// `t` is a live handle or null.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_count(t: *const CsTendons) -> usize {
    // SAFETY: live handle or null.
    unsafe { t.as_ref() }.map_or(0, |t| t.readings.len())
}

/// Readings column of driven tendon `i` (`0 <= i <` [`cs_tendons_count`], the
/// order of the readings [`cs_tendons_solve`] takes), e.g. `s1a`: a
/// NUL-terminated string owned by the handle (valid until [`cs_tendons_free`]), or
/// null for a null handle or `i` out of range.
///
/// # Safety
/// `t` is a live handle or null.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_column_name(t: *const CsTendons, i: usize) -> *const c_char {
    // SAFETY: live handle or null.
    name_ptr(unsafe { t.as_ref() }.map(|t| &t.columns[..]), i)
}

/// Number of cables (driven or not), or 0 for a null handle.
///
/// # Safety
/// `t` is a live handle or null.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_cable_count(t: *const CsTendons) -> usize {
    // SAFETY: live handle or null.
    unsafe { t.as_ref() }.map_or(0, |t| t.ws.workspace().robot().cables().len())
}

/// Number of sections, or 0 for a null handle.
///
/// # Safety
/// `t` is a live handle or null.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_section_count(t: *const CsTendons) -> usize {
    // SAFETY: live handle or null.
    unsafe { t.as_ref() }.map_or(0, |t| t.ws.workspace().robot().sections().len())
}

/// Solve one row of readings: `readings[n]` (m, positive = pulled in, one per
/// driven tendon, `n` = [`cs_tendons_count`]). `warm != 0` starts from the previous
/// solve. A reading that is not finite or pulls in more than the whole tendon is
/// `CS_CODE_BAD_ARGUMENT` with a message naming it (`readings[2] (s1c) ...`), and the
/// solver keeps its previous state. The outcome is in `*info` (may be null). The
/// warm solve allocates nothing.
///
/// # Safety
/// `t` is a live handle; `readings` holds `n` doubles; `info` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_solve(
    t: *mut CsTendons,
    readings: *const f64,
    n: usize,
    warm: i32,
    info: *mut CsTendonInfo,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { t.as_mut() }.ok_or_else(|| bad("tendons is null"))?;
        let p = h.readings.len();
        if n != p {
            return Err(bad(format!(
                "n = {n} readings for {p} displacement-driven tendons"
            )));
        }
        if readings.is_null() {
            return Err(bad("readings is null"));
        }
        // SAFETY: n doubles per the contract.
        h.readings
            .copy_from_slice(unsafe { std::slice::from_raw_parts(readings, n) });
        let start = if warm != 0 { Start::Warm } else { Start::Cold };
        let r =
            h.ws.solve_readings_from(&h.readings, start)
                .map_err(|e| bad(e.to_string()))?;
        // SAFETY: null or writable.
        if let Some(info) = unsafe { info.as_mut() } {
            *info = CsTendonInfo {
                status: solve_code(r.status),
                iterations: r.iterations as u32,
                slack: r.slack as u32,
                residual_m: r.residual_m,
            };
        }
        Ok(())
    })
}

/// Set the budget of every later [`cs_tendons_solve`] on this handle (the
/// scene's `numerics.tendons.max_passes` and `time_budget_s`): at most
/// `max_passes` rod evaluations (0: no limit) and `time_budget_s` seconds of wall
/// time (0: no limit) per call. A call that runs out returns status 6
/// (`budget_exhausted`) in [`CsTendonInfo`] at about the budget (overshoot: one
/// evaluation, or one Jacobian sweep and the evaluation after it), allocates
/// nothing, and is rolled back like any solve that does not converge. A budgeted
/// call does not run the nested fallback (docs/control-loop-budget.md).
/// `max_passes` above 100 000 or a negative or non-finite `time_budget_s` is
/// `CS_CODE_BAD_ARGUMENT` and changes nothing.
///
/// # Safety
/// `t` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_set_budget(
    t: *mut CsTendons,
    max_passes: usize,
    time_budget_s: f64,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { t.as_mut() }.ok_or_else(|| bad("tendons is null"))?;
        let settings = cablesense::tendons::TendonSettings {
            max_passes: (max_passes != 0).then_some(max_passes),
            time_budget_s: (time_budget_s != 0.0).then_some(time_budget_s),
            ..*h.ws.tendon_settings()
        };
        h.ws.set_tendon_settings(settings)
            .map_err(|e| bad(e.to_string()))
    })
}

/// Why the last solve from readings ended as it did
/// (`TendonWorkspace::diagnose`: as [`cs_model_diagnosis`], with each pulled-in
/// tendon named by its readings column and the bend its pull asks for), as text in
/// `buf` (`len` bytes, NUL-terminated, cut to fit); `*needed` (unless null) gets the
/// bytes the whole text takes. Meant for a solve whose status is not 0. Allocates.
///
/// # Safety
/// `t` is a live handle; `buf` is null or holds `len` writable bytes; `needed` is
/// null or writable.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_diagnosis(
    t: *const CsTendons,
    buf: *mut c_char,
    len: usize,
    needed: *mut usize,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { t.as_ref() }.ok_or_else(|| bad("tendons is null"))?;
        write_message(&h.ws.diagnose().to_string(), buf, len, needed);
        Ok(())
    })
}

/// Tensions `tensions[n]` (N) and, unless null, taut flags `taut[n]` (1 taut, 0
/// slack) of the driven tendons at the last solve, `n` = [`cs_tendons_count`]. No
/// allocation.
///
/// # Safety
/// `t` is a live handle; `tensions` (and `taut` unless null) hold `n` elements.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_tensions(
    t: *const CsTendons,
    tensions: *mut f64,
    taut: *mut i32,
    n: usize,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { t.as_ref() }.ok_or_else(|| bad("tendons is null"))?;
        let p = h.readings.len();
        if n != p {
            return Err(bad(format!("n = {n} for {p} displacement-driven tendons")));
        }
        // SAFETY: n doubles per the contract.
        unsafe { out_slice(tensions, n)? }.copy_from_slice(h.ws.tensions());
        if !taut.is_null() {
            // SAFETY: n ints per the contract (checked non-null).
            let flags = unsafe { std::slice::from_raw_parts_mut(taut, n) };
            for (f, &k) in flags.iter_mut().zip(h.ws.taut()) {
                *f = i32::from(k);
            }
        }
        Ok(())
    })
}

/// Tip position `[3]` (m) of the last solve. No allocation.
///
/// # Safety
/// `t` is a live handle; `position` holds 3 writable doubles.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_tip_position(
    t: *const CsTendons,
    position: *mut f64,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { t.as_ref() }.ok_or_else(|| bad("tendons is null"))?;
        // SAFETY: 3 doubles per the contract.
        unsafe { out_slice(position, 3)? }.copy_from_slice(h.ws.tip_position().as_slice());
        Ok(())
    })
}

/// Path lengths (m) of every cable at the last solve, `n` =
/// [`cs_tendons_cable_count`]. No allocation.
///
/// # Safety
/// `t` is a live handle; `out` holds `n` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_cable_lengths(
    t: *const CsTendons,
    out: *mut f64,
    n: usize,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { t.as_ref() }.ok_or_else(|| bad("tendons is null"))?;
        let c = h.ws.lengths().len();
        if n != c {
            return Err(bad(format!("n = {n}, the robot has {c} cables")));
        }
        // SAFETY: n doubles per the contract.
        unsafe { out_slice(out, n)? }.copy_from_slice(h.ws.lengths());
        Ok(())
    })
}

/// Section end poses of the last solve: `positions[3 n]` (m), `rotations[9 n]`
/// (column-major each), `n` = [`cs_tendons_section_count`]. Allocates (recomputes
/// the shape).
///
/// # Safety
/// `t` is a live handle; the buffers hold `3 n` and `9 n` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_section_poses(
    t: *mut CsTendons,
    positions: *mut f64,
    rotations: *mut f64,
    n: usize,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { t.as_mut() }.ok_or_else(|| bad("tendons is null"))?;
        let k = h.ws.workspace().robot().sections().len();
        if n != k {
            return Err(bad(format!("n = {n}, the robot has {k} sections")));
        }
        // SAFETY: buffer sizes per the contract.
        let (p, r) = unsafe { (out_slice(positions, 3 * n)?, out_slice(rotations, 9 * n)?) };
        let sol = h.ws.workspace_mut().solution();
        for (i, s) in sol.section_tips.iter().enumerate() {
            p[3 * i..3 * i + 3].copy_from_slice(s.position.as_slice());
            r[9 * i..9 * i + 9].copy_from_slice(s.rotation.as_slice());
        }
        Ok(())
    })
}
