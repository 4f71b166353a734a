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
//!   flags, tip position, section end poses and cable path lengths; and the
//!   inverse: [`cs_tendons_ik`], the readings that put the tip at a target within
//!   the scene's `[robot.limits]` (`cablesense::command::IkWorkspace`, warm from the
//!   previous call, its own state beside the readings solves'; the tensions there:
//!   [`cs_tendons_ik_tensions`]).
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
//! nor does a warm [`cs_tendons_solve`], nor [`cs_tendons_ik`] beyond what the
//! library's inverse solve allocates (`capi/tests/alloc.rs`); [`cs_model_section_poses`], [`cs_model_tip_pose`] and
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

use cablesense::command::{IkObjective, IkSettings, IkStatus, IkTarget, IkWorkspace};
use cablesense::estimate::{EstimateStatus, Estimator};
use cablesense::nalgebra::Vector3;
use cablesense::robot::ActuatorLimits;
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

/// Settings of the inverse solve ([`cs_tendons_ik`]; the library's `IkSettings`,
/// whose documentation has the details). [`cs_ik_settings_default`] fills the
/// defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct CsIkSettings {
    /// Secondary objective that chooses among the solutions: 0 closest (readings
    /// closest to the call's start; default), 1 least pull (least total pull), 2
    /// least tension (least sum of squared tensions).
    pub objective: i32,
    /// Weight of the secondary objective (>= 0, dimensionless). Default 1e-6.
    pub secondary_weight: f64,
    /// A tip within this distance of the target is reached (m, > 0). Default 1e-5.
    pub tolerance_m: f64,
    /// A direction within this angle of the target's is reached (rad, > 0).
    /// Default 1e-3.
    pub angle_tolerance_rad: f64,
    /// A direction error of 1 rad counts as this much position error (m, > 0).
    /// Default 0.01.
    pub direction_weight_m: f64,
    /// Largest change of any reading in a call's first step (m, > 0). Default 0.002.
    pub trust_radius_m: f64,
    /// Gauss-Newton iterations per call (>= 1). Default 30.
    pub max_iterations: u32,
    /// Forward solves per call (>= 1). Default 100.
    pub max_forward_solves: u32,
}

/// The code of an objective in [`CsIkSettings::objective`] and [`CsIkInfo`].
fn objective_code(o: IkObjective) -> i32 {
    match o {
        IkObjective::Closest => 0,
        IkObjective::LeastPull => 1,
        IkObjective::LeastTension => 2,
    }
}

impl From<&IkSettings> for CsIkSettings {
    fn from(s: &IkSettings) -> Self {
        Self {
            objective: objective_code(s.objective),
            secondary_weight: s.secondary_weight,
            tolerance_m: s.tolerance_m,
            angle_tolerance_rad: s.angle_tolerance_rad,
            direction_weight_m: s.direction_weight_m,
            trust_radius_m: s.trust_radius_m,
            max_iterations: s.max_iterations.min(u32::MAX as usize) as u32,
            max_forward_solves: s.max_forward_solves.min(u32::MAX as usize) as u32,
        }
    }
}

impl CsIkSettings {
    /// The library's settings (checked: the error names the field).
    fn to_settings(self) -> Result<IkSettings, (CsCode, String)> {
        let objective = match self.objective {
            0 => IkObjective::Closest,
            1 => IkObjective::LeastPull,
            2 => IkObjective::LeastTension,
            o => {
                return Err(bad(format!(
                    "ik.objective = {o}: give 0 (closest), 1 (least pull) or 2 (least tension)"
                )))
            }
        };
        let s = IkSettings {
            objective,
            secondary_weight: self.secondary_weight,
            tolerance_m: self.tolerance_m,
            angle_tolerance_rad: self.angle_tolerance_rad,
            direction_weight_m: self.direction_weight_m,
            trust_radius_m: self.trust_radius_m,
            max_iterations: self.max_iterations as usize,
            max_forward_solves: self.max_forward_solves as usize,
            ..IkSettings::default()
        };
        s.validate().map_err(|e| bad(e.to_string()))?;
        Ok(s)
    }
}

/// Outcome of an inverse solve ([`cs_tendons_ik`]; the library's `IkReport`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct CsIkInfo {
    /// 0 reached; 1 unreachable (the closest tip found, at a constrained stationary
    /// point: the target is outside the workspace); 2 budget exhausted (the best
    /// readings found). The readings are usable (inside the limits) in every case.
    pub status: i32,
    /// The secondary objective that chose the solution (as
    /// [`CsIkSettings::objective`]).
    pub objective: i32,
    /// Gauss-Newton iterations.
    pub iterations: u32,
    /// Jacobians evaluated (the other iterations use Broyden updates).
    pub jacobians: u32,
    /// Forward (readings) solves.
    pub forward_solves: u32,
    /// Bounded least-squares steps solved.
    pub qp_solves: u32,
    /// Tendons slack at the returned readings.
    pub slack: u32,
    /// Tip at the returned readings (m).
    pub tip_m: [f64; 3],
    /// Distance of that tip to the target (m).
    pub distance_m: f64,
    /// Angle between the tip axis and the target direction (rad; 0 without one).
    pub angle_rad: f64,
    /// First-order measure at the last linearisation (0 at a constrained
    /// stationary point; NaN when none was built).
    pub first_order: f64,
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
    /// The scene's `[robot.limits]` (m; unbounded without).
    limits: ActuatorLimits,
    /// The inverse solver, built by the first [`cs_tendons_ik_configure`] or
    /// [`cs_tendons_ik`] (its own forward model and warm state).
    ik: Option<Box<IkWorkspace>>,
}

impl CsTendons {
    /// The inverse solver, built with `settings` (defaults when `None`) from a copy
    /// of the readings model when there is none yet; else its settings replaced
    /// (when given), keeping its warm state.
    fn ik(&mut self, settings: Option<IkSettings>) -> Result<&mut IkWorkspace, (CsCode, String)> {
        match &mut self.ik {
            Some(ik) => {
                if let Some(s) = settings {
                    ik.set_settings(s).map_err(|e| bad(e.to_string()))?;
                }
            }
            None => {
                let ik = IkWorkspace::new(
                    self.ws.clone(),
                    self.limits.clone(),
                    settings.unwrap_or_default(),
                )
                .map_err(|e| (CsCode::BadScene, e.to_string()))?;
                self.ik = Some(Box::new(ik));
            }
        }
        self.ik
            .as_deref_mut()
            .ok_or_else(|| bad("the inverse solver could not be built"))
    }
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

/// A caller's buffer of `n` readings against the `p` displacement-driven tendons.
fn reading_count(n: usize, p: usize) -> Result<(), (CsCode, String)> {
    if n != p {
        return Err(bad(format!(
            "n = {n} readings for {p} displacement-driven tendons"
        )));
    }
    Ok(())
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
        let limits = scene
            .actuator_limits()
            .map_err(|e| (CsCode::BadScene, e.to_string()))?;
        let h = CsTendons {
            columns: c_names(ws.columns())?,
            readings: vec![0.0; ws.driven().len()],
            limits,
            ik: None,
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
        reading_count(n, h.readings.len())?;
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

/// The default inverse-solve settings into `*out`.
///
/// # Safety
/// `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn cs_ik_settings_default(out: *mut CsIkSettings) -> CsCode {
    guard(|| {
        // SAFETY: null or writable.
        let out = unsafe { out.as_mut() }.ok_or_else(|| bad("out is null"))?;
        *out = CsIkSettings::from(&IkSettings::default());
        Ok(())
    })
}

/// Actuator limits of the driven tendons (the scene's `[robot.limits]`, m):
/// `min[n]`, `max[n]`, `n` = [`cs_tendons_count`]; `-inf`/`inf` where the scene sets
/// none. No allocation.
///
/// # Safety
/// `t` is a live handle; `min` and `max` hold `n` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_limits(
    t: *const CsTendons,
    min: *mut f64,
    max: *mut f64,
    n: usize,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { t.as_ref() }.ok_or_else(|| bad("tendons is null"))?;
        let p = h.readings.len();
        if n != p {
            return Err(bad(format!("n = {n} for {p} displacement-driven tendons")));
        }
        // SAFETY: n doubles each per the contract.
        unsafe {
            out_slice(min, n)?.copy_from_slice(&h.limits.min_m);
            out_slice(max, n)?.copy_from_slice(&h.limits.max_m);
        }
        Ok(())
    })
}

/// Set up the inverse solver of [`cs_tendons_ik`] with `settings` (null: the
/// defaults). The first call builds it (allocates; a copy of the handle's readings
/// model, with its budget of [`cs_tendons_set_budget`] at that time, solved at zero
/// readings); a later one replaces the settings and keeps its warm state. A bad
/// value is `CS_CODE_BAD_ARGUMENT` naming the field (`ik.tolerance_m ...`) and
/// changes nothing.
///
/// # Safety
/// `t` is a live handle; `settings` is null or readable.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_ik_configure(
    t: *mut CsTendons,
    settings: *const CsIkSettings,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { t.as_mut() }.ok_or_else(|| bad("tendons is null"))?;
        // SAFETY: null or readable.
        let s = match unsafe { settings.as_ref() } {
            Some(s) => s.to_settings()?,
            None => IkSettings::default(),
        };
        h.ik(Some(s))?;
        Ok(())
    })
}

/// Move the start of the next [`cs_tendons_ik`] to `readings[n]` (m, inside the
/// limits): one forward solve (building the inverse solver with the defaults if
/// there is none yet). A reading outside the limits or not finite is
/// `CS_CODE_BAD_ARGUMENT` naming it (`readings[0] (servo_4_mm) ...`).
///
/// # Safety
/// `t` is a live handle; `readings` holds `n` doubles.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_ik_start(
    t: *mut CsTendons,
    readings: *const f64,
    n: usize,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { t.as_mut() }.ok_or_else(|| bad("tendons is null"))?;
        reading_count(n, h.readings.len())?;
        if readings.is_null() {
            return Err(bad("readings is null"));
        }
        // SAFETY: n doubles per the contract.
        let q = unsafe { std::slice::from_raw_parts(readings, n) };
        h.ik(None)?.set_readings(q).map_err(|e| bad(e.to_string()))
    })
}

/// Tensions `tensions[n]` (N) and, unless null, taut flags `taut[n]` (1 taut, 0
/// slack) of the driven tendons at the readings of the last [`cs_tendons_ik`] (or
/// [`cs_tendons_ik_start`]), `n` = [`cs_tendons_count`]: e.g. to check the
/// least-tension objective's choice. `CS_CODE_BAD_ARGUMENT` before the inverse
/// solver exists. No allocation.
///
/// # Safety
/// `t` is a live handle; `tensions` (and `taut` unless null) hold `n` elements.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_ik_tensions(
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
        let ik = h.ik.as_deref().ok_or_else(|| {
            bad("no inverse solve yet: call cs_tendons_ik (or cs_tendons_ik_configure) first")
        })?;
        let ws = ik.tendon_workspace();
        // SAFETY: n doubles per the contract.
        unsafe { out_slice(tensions, n)? }.copy_from_slice(ws.tensions());
        if !taut.is_null() {
            // SAFETY: n ints per the contract (checked non-null).
            let flags = unsafe { std::slice::from_raw_parts_mut(taut, n) };
            for (f, &k) in flags.iter_mut().zip(ws.taut()) {
                *f = i32::from(k);
            }
        }
        Ok(())
    })
}

/// Inverse kinematics: the readings `readings[n]` (m, one per driven tendon, `n` =
/// [`cs_tendons_count`]) that put the tip at `target[3]` (m, base frame), and its
/// axis along `direction[3]` (any non-zero length; null: position only), inside the
/// scene's `[robot.limits]`, warm from the previous call (or from
/// [`cs_tendons_ik_start`]; the first call starts at zero readings). The outcome is
/// in `*info` (may be null): a target outside the workspace is status 1
/// (unreachable) with the closest tip found, not an error. A NaN or infinite
/// target or direction, a zero-length direction or a wrong `n` is
/// `CS_CODE_BAD_ARGUMENT` with a message naming it (`target.position_m[2] ...`,
/// `target.direction ...`) and changes nothing. The first call builds the inverse
/// solver with the defaults unless [`cs_tendons_ik_configure`] did (allocates);
/// after it the call allocates nothing of its own (the library's bounded
/// least-squares step, clarabel, allocates once per step until the library removes
/// that: `capi/tests/alloc.rs`). The handle's readings solves
/// ([`cs_tendons_solve`], [`cs_tendons_tip_position`], ...) are not affected: the
/// inverse solver keeps its own state; `info->tip_m` is the tip at the returned
/// readings.
///
/// # Safety
/// `t` is a live handle; `target` holds 3 doubles; `direction` is null or holds 3
/// doubles; `readings` holds `n` writable doubles; `info` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn cs_tendons_ik(
    t: *mut CsTendons,
    target: *const f64,
    direction: *const f64,
    readings: *mut f64,
    n: usize,
    info: *mut CsIkInfo,
) -> CsCode {
    guard(|| {
        // SAFETY: live handle or null.
        let h = unsafe { t.as_mut() }.ok_or_else(|| bad("tendons is null"))?;
        reading_count(n, h.readings.len())?;
        if target.is_null() {
            return Err(bad("target is null"));
        }
        // SAFETY: 3 doubles each per the contract (direction checked non-null).
        let position_m =
            Vector3::from_column_slice(unsafe { std::slice::from_raw_parts(target, 3) });
        let direction = (!direction.is_null()).then(|| {
            // SAFETY: 3 doubles per the contract.
            Vector3::from_column_slice(unsafe { std::slice::from_raw_parts(direction, 3) })
        });
        // SAFETY: n writable doubles per the contract.
        let out = unsafe { out_slice(readings, n)? };
        let target = IkTarget {
            position_m,
            direction,
        };
        target.validate().map_err(|e| bad(e.to_string()))?;
        let ik = h.ik(None)?;
        let r = ik.solve(&target).map_err(|e| bad(e.to_string()))?;
        out.copy_from_slice(ik.readings());
        // SAFETY: null or writable.
        if let Some(info) = unsafe { info.as_mut() } {
            let count = |v: usize| v.min(u32::MAX as usize) as u32;
            *info = CsIkInfo {
                status: match r.status {
                    IkStatus::Reached => 0,
                    IkStatus::Unreachable { .. } => 1,
                    IkStatus::BudgetExhausted => 2,
                },
                objective: objective_code(r.objective),
                iterations: count(r.iterations),
                jacobians: count(r.jacobians),
                forward_solves: count(r.forward_solves),
                qp_solves: count(r.qp_solves),
                slack: count(r.slack),
                tip_m: [r.tip_m.x, r.tip_m.y, r.tip_m.z],
                distance_m: r.distance_m,
                angle_rad: r.angle_rad,
                first_order: r.first_order,
            };
        }
        Ok(())
    })
}
