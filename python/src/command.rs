//! Commanding the robot from Python: `IkSolver` (inverse kinematics,
//! `cablesense::command::IkWorkspace`: which readings put the tip at a target, inside
//! the scene's `[robot.limits]`) and `workspace` (the reachable tips of the actuator
//! box, `cablesense::command::sample_workspace`, and their convex hull). Only
//! translates types and errors; the GIL is released inside every solve.
//!
//! `IkSolver` is a class of its own, not a method of `TendonSolver`: the inverse
//! solver keeps its own forward model (without the row rollback of `TendonSolver`),
//! its accepted readings between calls, its actuator limits and its settings, as the
//! library's `IkWorkspace` does beside `TendonWorkspace`; one object with two warm
//! states would leave unclear which one a call starts from.

use crate::{field_of, from_model_error, read_f64s, read_rows, readings_err, scene_err, Scene};
use cablesense::command::{
    sample_workspace, Hull, IkObjective, IkReport, IkSettings, IkStatus, IkTarget, IkWorkspace,
    SampleStatus, WorkspaceSettings,
};
use cablesense::nalgebra::Vector3;
use cablesense::ModelError;
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A Python `TargetError` with the message and `field` attribute.
fn target_err(py: Python<'_>, msg: String, field: Option<String>) -> PyErr {
    let err = crate::TargetError::new_err(msg);
    let _ = err.value(py).setattr("field", field);
    err
}

/// A target error of the library (`target.position_m[k]`, `target.direction[k]`,
/// `target.direction`) named by the Python arguments: `{pos}[k]`, `{dir}[k]`, `{dir}`
/// (e.g. `target[2]`, `direction`; in a batch `targets[4][2]`, `directions[4]`).
fn named_target_err(py: Python<'_>, e: &ModelError, pos: &str, dir: &str) -> PyErr {
    let field = field_of(e).map(|f| {
        f.replace("target.position_m", pos)
            .replace("target.direction", dir)
    });
    let mut msg = e.to_string();
    if let Some(f) = field_of(e) {
        if let Some(new) = &field {
            msg = msg.replacen(&f, new, 1);
        }
    }
    target_err(py, msg, field)
}

/// The objective named `name` (`closest`, `least_pull`, `least_tension`).
fn objective(name: &str) -> Result<IkObjective, ModelError> {
    [
        IkObjective::Closest,
        IkObjective::LeastPull,
        IkObjective::LeastTension,
    ]
    .into_iter()
    .find(|o| o.name() == name)
    .ok_or_else(|| ModelError::Invalid {
        field: "ik.objective".into(),
        why: format!("unknown objective {name:?}: give closest, least_pull or least_tension"),
    })
}

/// Status code of an IK outcome in the arrays of `ik_many` (and the C ABI's
/// `CsIkInfo::status`): 0 reached, 1 unreachable, 2 budget exhausted; -1 a row
/// whose target was invalid.
fn status_code(s: &IkStatus) -> i8 {
    match s {
        IkStatus::Reached => 0,
        IkStatus::Unreachable { .. } => 1,
        IkStatus::BudgetExhausted => 2,
    }
}

/// Inverse kinematics of a scene's displacement-driven tendons: which readings put
/// the tip at a target, inside the scene's `[robot.limits]`.
///
/// Built once per scene (validates it and its limits, solves reading 0); every
/// call starts warm from the readings of the previous one (or of `set_readings`).
/// The GIL is released inside every solve.
#[pyclass(module = "cablesense")]
pub struct IkSolver {
    ik: IkWorkspace,
    /// The settings of the constructor (a call's overrides apply to that call).
    base: IkSettings,
    /// The target and direction of one call (reused).
    target: Vec<f64>,
    direction: Vec<f64>,
    scale_m: f64,
}

/// One solved target, copied out inside the GIL-free section.
struct Solved {
    report: IkReport,
    readings: Vec<f64>,
    tensions: Vec<f64>,
    taut: Vec<bool>,
}

impl Solved {
    fn take(ik: &IkWorkspace, report: IkReport) -> Self {
        Self {
            report,
            readings: ik.readings().to_vec(),
            tensions: ik.tendon_workspace().tensions().to_vec(),
            taut: ik.tendon_workspace().taut().to_vec(),
        }
    }
}

fn result_dict<'py>(py: Python<'py>, s: &Solved) -> PyResult<Bound<'py, PyDict>> {
    let r = &s.report;
    let d = PyDict::new(py);
    d.set_item("status", r.status.name())?;
    d.set_item("reached", r.status == IkStatus::Reached)?;
    d.set_item("distance_m", r.distance_m)?;
    d.set_item("tip", PyArray1::from_slice(py, r.tip_m.as_slice()))?;
    d.set_item("angle_rad", r.angle_rad)?;
    d.set_item("objective", r.objective.name())?;
    d.set_item("iterations", r.iterations)?;
    d.set_item("jacobians", r.jacobians)?;
    d.set_item("forward_solves", r.forward_solves)?;
    d.set_item("qp_solves", r.qp_solves)?;
    d.set_item("slack", r.slack)?;
    d.set_item("first_order", r.first_order)?;
    d.set_item("tensions", PyArray1::from_slice(py, &s.tensions))?;
    d.set_item("taut", PyArray1::from_slice(py, &s.taut))?;
    Ok(d)
}

impl IkSolver {
    /// The settings of one call: the constructor's with the given overrides.
    fn call_settings(
        &self,
        objective_name: Option<&str>,
        secondary_weight: Option<f64>,
        direction_weight_m: Option<f64>,
        tolerance_m: Option<f64>,
    ) -> Result<IkSettings, ModelError> {
        let mut s = self.base.clone();
        if let Some(o) = objective_name {
            s.objective = objective(o)?;
        }
        if let Some(w) = secondary_weight {
            s.secondary_weight = w;
        }
        if let Some(w) = direction_weight_m {
            s.direction_weight_m = w;
        }
        if let Some(t) = tolerance_m {
            s.tolerance_m = t;
        }
        s.validate()?;
        Ok(s)
    }

    /// Read a 3-vector argument into `buf` (`TypeError` for a value that is not a
    /// sequence of floats, `TargetError` naming `what` for a wrong length).
    fn read3(
        py: Python<'_>,
        obj: &Bound<'_, PyAny>,
        buf: &mut Vec<f64>,
        what: &str,
        expected: &'static str,
    ) -> PyResult<Vector3<f64>> {
        read_f64s(obj, buf, what, || expected.to_string())?;
        if buf.len() != 3 {
            return Err(target_err(
                py,
                format!("{what}: expected {expected}, got {} values", buf.len()),
                Some(what.to_string()),
            ));
        }
        Ok(Vector3::new(buf[0], buf[1], buf[2]))
    }
}

#[pymethods]
impl IkSolver {
    /// Build the inverse solver of `scene` (displacement-driven tendons; the limits
    /// of `[robot.limits]`, none without it). Settings (defaults of the library's
    /// `IkSettings`): `objective` the secondary objective that chooses among the
    /// solutions (`closest`: readings closest to the call's start, `least_pull`:
    /// least total pull, `least_tension`: least sum of squared tensions);
    /// `secondary_weight` its weight (>= 0, dimensionless, 1e-6); `rest_weight` the
    /// weight of the rest term that draws the readings toward zero within the
    /// redundancy so a long warm chain does not drift (>= 0, 1e-3; 0 turns it off);
    /// `tolerance_m` a tip
    /// within it is reached (1e-5 m); `angle_tolerance_rad` the same for a direction
    /// (1e-3); `direction_weight_m` a direction error of 1 rad counts as this much
    /// position error (0.01 m); `trust_radius_m` the first step's largest reading
    /// change (0.002 m); `max_iterations` (30) and `max_forward_solves` (100) the
    /// budget of one call. A bad value raises `SceneError` whose `field` names it
    /// (`ik.tolerance_m`, `ik.objective`, ...), as do limits that exclude reading 0.
    #[new]
    #[pyo3(signature = (
        scene,
        objective = "closest",
        secondary_weight = None,
        tolerance_m = None,
        angle_tolerance_rad = None,
        rest_weight = None,
        direction_weight_m = None,
        trust_radius_m = None,
        max_iterations = None,
        max_forward_solves = None,
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        scene: &Scene,
        objective: &str,
        secondary_weight: Option<f64>,
        tolerance_m: Option<f64>,
        angle_tolerance_rad: Option<f64>,
        rest_weight: Option<f64>,
        direction_weight_m: Option<f64>,
        trust_radius_m: Option<f64>,
        max_iterations: Option<usize>,
        max_forward_solves: Option<usize>,
    ) -> PyResult<Self> {
        let d = IkSettings::default();
        let settings = IkSettings {
            objective: self::objective(objective).map_err(|e| from_model_error(py, e))?,
            secondary_weight: secondary_weight.unwrap_or(d.secondary_weight),
            tolerance_m: tolerance_m.unwrap_or(d.tolerance_m),
            angle_tolerance_rad: angle_tolerance_rad.unwrap_or(d.angle_tolerance_rad),
            rest_weight: rest_weight.unwrap_or(d.rest_weight),
            direction_weight_m: direction_weight_m.unwrap_or(d.direction_weight_m),
            trust_radius_m: trust_radius_m.unwrap_or(d.trust_radius_m),
            max_iterations: max_iterations.unwrap_or(d.max_iterations),
            max_forward_solves: max_forward_solves.unwrap_or(d.max_forward_solves),
            ..d
        };
        settings.validate().map_err(|e| from_model_error(py, e))?;
        let s = &scene.inner;
        let has_driven = s
            .robot
            .cables
            .iter()
            .any(|c| c.actuation == cablesense::robot::Actuation::Displacement);
        if !has_driven {
            return Err(scene_err(
                py,
                "the scene has no displacement-driven tendon (actuation = \"displacement\")".into(),
                Some("robot.cables".into()),
            ));
        }
        let base = settings.clone();
        let ik = py
            .detach(|| IkWorkspace::from_scene(s, settings))
            .map_err(|e| from_model_error(py, e))?;
        Ok(Self {
            ik,
            base,
            target: Vec::with_capacity(3),
            direction: Vec::with_capacity(3),
            scale_m: s.readings_scale_m(),
        })
    }

    /// Readings column of each driven tendon (the order of the readings).
    #[getter]
    fn columns(&self) -> Vec<String> {
        self.ik.tendon_workspace().columns().to_vec()
    }

    /// Metres per unit of a readings file's tendon columns (`[readings] scale_m`,
    /// default 1). The readings here are in metres.
    #[getter]
    fn scale_m(&self) -> f64 {
        self.scale_m
    }

    /// Actuator limits (p, 2): `[min, max]` of each reading (m; -inf/inf where the
    /// scene sets none).
    #[getter]
    fn limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let l = self.ik.limits();
        let flat: Vec<f64> = l
            .min_m
            .iter()
            .zip(&l.max_m)
            .flat_map(|(a, b)| [*a, *b])
            .collect();
        PyArray1::from_vec(py, flat).reshape([l.len(), 2])
    }

    /// The readings the next `ik` starts from: those of the last call (m).
    #[getter]
    fn readings<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.ik.readings())
    }

    /// The tip at `readings` (m).
    #[getter]
    fn tip<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.ik.tip_position().as_slice())
    }

    /// The settings of the constructor, as a dict (`objective`, `secondary_weight`,
    /// `tolerance_m`, ...).
    #[getter]
    fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = &self.base;
        let d = PyDict::new(py);
        d.set_item("objective", s.objective.name())?;
        d.set_item("secondary_weight", s.secondary_weight)?;
        d.set_item("rest_weight", s.rest_weight)?;
        d.set_item("tolerance_m", s.tolerance_m)?;
        d.set_item("angle_tolerance_rad", s.angle_tolerance_rad)?;
        d.set_item("direction_weight_m", s.direction_weight_m)?;
        d.set_item("trust_radius_m", s.trust_radius_m)?;
        d.set_item("max_iterations", s.max_iterations)?;
        d.set_item("max_forward_solves", s.max_forward_solves)?;
        Ok(d)
    }

    /// Move the start of the next `ik` to `readings` (m, `columns` order, inside the
    /// limits): one forward solve. A reading outside the limits, NaN, or of the
    /// wrong count raises `ReadingsError` naming it (`readings[0] (servo_4_mm)`);
    /// the start stays where it was.
    fn set_readings(&mut self, py: Python<'_>, readings: &Bound<'_, PyAny>) -> PyResult<()> {
        let p = self.ik.readings().len();
        let mut q = Vec::with_capacity(p);
        read_f64s(readings, &mut q, "readings", || format!("{p} readings (m)"))?;
        let ik = &mut self.ik;
        py.detach(|| ik.set_readings(&q))
            .map_err(|e| readings_err(py, e, None))
    }

    /// Readings that put the tip at `target` (3,) m, optionally with the tip axis
    /// along `direction` (3,) (any non-zero length), warm from the previous call.
    /// `objective`, `secondary_weight`, `direction_weight_m` and `tolerance_m`
    /// override the constructor's for this call only. Returns `(readings, result)`:
    /// the readings (p,) m, inside the limits, and {status (`reached`,
    /// `unreachable`: the closest tip found, at a constrained stationary point;
    /// `budget_exhausted`), reached, distance_m, tip (3,), angle_rad, objective (the
    /// secondary objective that chose the solution), iterations, jacobians,
    /// forward_solves, qp_solves, slack, first_order, tensions (p,) N, taut (p,)}.
    /// An unreachable target is a status, never an exception. A target with a NaN
    /// or infinite coordinate, a zero-length direction or a wrong length raises
    /// `TargetError` whose `field` names it (`target[2]`, `direction`); a value that
    /// is not a sequence of floats `TypeError`; a bad override `SceneError`
    /// (`ik.secondary_weight`). After an error the solver is as before.
    #[pyo3(signature = (
        target,
        direction = None,
        *,
        objective = None,
        secondary_weight = None,
        direction_weight_m = None,
        tolerance_m = None,
    ))]
    #[allow(clippy::too_many_arguments)]
    fn ik<'py>(
        &mut self,
        py: Python<'py>,
        target: &Bound<'py, PyAny>,
        direction: Option<&Bound<'py, PyAny>>,
        objective: Option<&str>,
        secondary_weight: Option<f64>,
        direction_weight_m: Option<f64>,
        tolerance_m: Option<f64>,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyDict>)> {
        let settings = self
            .call_settings(objective, secondary_weight, direction_weight_m, tolerance_m)
            .map_err(|e| from_model_error(py, e))?;
        let position_m = Self::read3(py, target, &mut self.target, "target", "3 coordinates (m)")?;
        let direction = match direction {
            Some(d) => Some(Self::read3(
                py,
                d,
                &mut self.direction,
                "direction",
                "3 components",
            )?),
            None => None,
        };
        let t = IkTarget {
            position_m,
            direction,
        };
        t.validate()
            .map_err(|e| named_target_err(py, &e, "target", "direction"))?;
        let changed = settings != *self.ik.settings();
        let (ik, base) = (&mut self.ik, &self.base);
        let solved = py.detach(|| {
            if changed {
                ik.set_settings(settings)?;
            }
            let r = ik.solve(&t);
            if changed {
                ik.set_settings(base.clone())?;
            }
            Ok::<_, ModelError>(Solved::take(ik, r?))
        });
        let solved = solved.map_err(|e| named_target_err(py, &e, "target", "direction"))?;
        let d = result_dict(py, &solved)?;
        Ok((PyArray1::from_vec(py, solved.readings), d))
    }

    /// `ik` for every row of `targets` (n, 3) m in order, each warm from the last
    /// (and the first from the previous call), with the GIL released for the whole
    /// batch; `directions` (n, 3) optional. A bad row (a NaN target, a zero-length
    /// direction) does not stop the batch: its status is `invalid`, its `errors`
    /// entry says why, its readings, tip and distance are NaN, and the next row
    /// starts from the last good one. Returns {readings (n, p) m, tip (n, 3),
    /// distance_m (n,), angle_rad (n,), status [n] (`reached`, `unreachable`,
    /// `budget_exhausted`, `invalid`), status_code (n,) int8 (0, 1, 2, -1), reached
    /// (n,) bool, iterations (n,), forward_solves (n,), objective, errors [n] (None
    /// for a good row)}. `targets` that numpy cannot make an (n, 3) float array
    /// raise `TypeError`, a wrong column count or `directions` of another shape
    /// `TargetError` naming the argument.
    #[pyo3(signature = (targets, directions = None))]
    fn ik_many<'py>(
        &mut self,
        py: Python<'py>,
        targets: &Bound<'py, PyAny>,
        directions: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let t = read_rows(py, targets, 3, "targets", "3 coordinates (m)")?;
        if t.cols != 3 {
            return Err(target_err(
                py,
                format!("targets: {} columns, expected 3 ({})", t.cols, t.shape_msg),
                Some("targets".into()),
            ));
        }
        let n = t.n;
        let dirs = match directions {
            Some(d) => {
                let d = read_rows(py, d, 3, "directions", "3 components")?;
                if d.cols != 3 || d.n != n {
                    return Err(target_err(
                        py,
                        format!(
                            "directions: shape ({}, {}), expected ({n}, 3) like targets",
                            d.n, d.cols
                        ),
                        Some("directions".into()),
                    ));
                }
                Some(d.data)
            }
            None => None,
        };
        let p = self.ik.readings().len();
        let ik = &mut self.ik;
        let rows: Vec<Result<(IkReport, Vec<f64>), ModelError>> = py.detach(|| {
            (0..n)
                .map(|i| {
                    let v = |a: &[f64]| Vector3::new(a[3 * i], a[3 * i + 1], a[3 * i + 2]);
                    let target = IkTarget {
                        position_m: v(&t.data),
                        direction: dirs.as_deref().map(v),
                    };
                    let r = ik.solve(&target)?;
                    Ok((r, ik.readings().to_vec()))
                })
                .collect()
        });
        let nan3 = [f64::NAN; 3];
        let mut readings = Vec::with_capacity(n * p);
        let mut tips = Vec::with_capacity(3 * n);
        let (mut dist, mut angle) = (Vec::with_capacity(n), Vec::with_capacity(n));
        let (mut status, mut code, mut reached) = (Vec::new(), Vec::new(), Vec::new());
        let (mut iterations, mut solves, mut errors) = (Vec::new(), Vec::new(), Vec::new());
        for (i, row) in rows.iter().enumerate() {
            match row {
                Ok((r, q)) => {
                    readings.extend_from_slice(q);
                    tips.extend_from_slice(r.tip_m.as_slice());
                    dist.push(r.distance_m);
                    angle.push(r.angle_rad);
                    status.push(r.status.name().to_string());
                    code.push(status_code(&r.status));
                    reached.push(r.status == IkStatus::Reached);
                    iterations.push(r.iterations as u64);
                    solves.push(r.forward_solves as u64);
                    errors.push(None);
                }
                Err(e) => {
                    readings.extend(std::iter::repeat_n(f64::NAN, p));
                    tips.extend_from_slice(&nan3);
                    dist.push(f64::NAN);
                    angle.push(f64::NAN);
                    status.push("invalid".to_string());
                    code.push(-1);
                    reached.push(false);
                    iterations.push(0);
                    solves.push(0);
                    let err = named_target_err(
                        py,
                        e,
                        &format!("targets[{i}]"),
                        &format!("directions[{i}]"),
                    );
                    errors.push(Some(err.value(py).to_string()));
                }
            }
        }
        let d = PyDict::new(py);
        d.set_item(
            "readings",
            PyArray1::from_vec(py, readings).reshape([n, p])?,
        )?;
        d.set_item("tip", PyArray1::from_vec(py, tips).reshape([n, 3])?)?;
        d.set_item("distance_m", PyArray1::from_vec(py, dist))?;
        d.set_item("angle_rad", PyArray1::from_vec(py, angle))?;
        d.set_item("status", status)?;
        d.set_item("status_code", PyArray1::from_vec(py, code))?;
        d.set_item("reached", PyArray1::from_vec(py, reached))?;
        d.set_item("iterations", PyArray1::from_vec(py, iterations))?;
        d.set_item("forward_solves", PyArray1::from_vec(py, solves))?;
        d.set_item("objective", self.ik.settings().objective.name())?;
        d.set_item("errors", errors)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "IkSolver(tendons {:?}, objective {})",
            self.ik.tendon_workspace().columns(),
            self.base.objective.name()
        )
    }
}

/// Status code of a workspace sample (`workspace()["status"]`): its index in
/// `status_names` (a new status is appended, so that the codes stay).
const SAMPLE_STATUS: [SampleStatus; 5] = [
    SampleStatus::Converged,
    SampleStatus::ConvergedStepped,
    SampleStatus::ConvergedCold,
    SampleStatus::Failed,
    SampleStatus::ConvergedNeighbour,
];

/// The reachable workspace of `scene`'s displacement-driven tendons within its
/// `[robot.limits]` (finite limits for every driven tendon): `samples` points of
/// the actuator box (Halton sequence), chained by nearest neighbour so that each
/// solve is warm, on `threads` threads (0: every core; the result does not depend
/// on it), with the GIL released. `progress(done)` (optional) is called with the
/// number of samples done after each one (from the sampling threads; an exception it
/// raises is raised after the sampling). `marker_offset` (3,) m, a point fixed to
/// the tip body in its local frame (e.g. a calibration's `marker_offset_m`): each
/// solved sample records that point too, in `markers`, to set a recording's measured
/// markers against. Returns {columns [p], limits (p, 2) m, readings (n, p) m, tips
/// (n, 3) m (NaN for a sample that did not solve), markers (n, 3) m or None, status
/// (n,) uint8 (index into status_names: converged, converged_stepped,
/// converged_cold, failed, converged_neighbour), solved (n,) bool, solved_count, failed_count,
/// sampling_s, hull_volume_m3 (the convex hull of the solved tips; None when it has
/// no volume, hull_error says why), hull_vertices (v, 3) m, hull_triangles (t, 3)
/// (indices into hull_vertices, counter-clockwise from outside)}. A convex hull
/// over-states a workspace that is not convex (docs/command.md). Bad settings or
/// missing limits raise `SceneError` naming the field (`robot.limits
/// (servo_4_mm)`, `workspace.samples`). The calibrated FTDCR v4 took about 67 ms a
/// sample on a shared 2-core machine (docs/command.md).
#[pyfunction]
#[pyo3(signature = (scene, samples = 20_000, threads = 0, progress = None, marker_offset = None))]
pub(crate) fn workspace<'py>(
    py: Python<'py>,
    scene: &Scene,
    samples: usize,
    threads: usize,
    progress: Option<Bound<'py, PyAny>>,
    marker_offset: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let s = &scene.inner;
    let marker_offset_m = match marker_offset {
        Some(m) => {
            let mut buf = Vec::with_capacity(3);
            read_f64s(m, &mut buf, "marker_offset", || "3 coordinates (m)".into())?;
            if buf.len() != 3 {
                return Err(scene_err(
                    py,
                    format!(
                        "marker_offset: expected 3 coordinates (m), got {} values",
                        buf.len()
                    ),
                    Some("workspace.marker_offset_m".into()),
                ));
            }
            Some(Vector3::new(buf[0], buf[1], buf[2]))
        }
        None => None,
    };
    let settings = WorkspaceSettings {
        samples,
        threads,
        marker_offset_m,
        ..WorkspaceSettings::default()
    };
    settings.validate().map_err(|e| from_model_error(py, e))?;
    let tw = py
        .detach(|| s.tendon_workspace())
        .map_err(|e| from_model_error(py, e))?;
    let limits = s.actuator_limits().map_err(|e| from_model_error(py, e))?;
    let callback: Option<Py<PyAny>> = progress.map(Bound::unbind);
    let callback_error: std::sync::Mutex<Option<PyErr>> = std::sync::Mutex::new(None);
    let report = |done: usize| {
        if let Some(cb) = &callback {
            Python::attach(|py| {
                if let Err(e) = cb.call1(py, (done,)) {
                    if let Ok(mut slot) = callback_error.lock() {
                        slot.get_or_insert(e);
                    }
                }
            });
        }
    };
    let t0 = std::time::Instant::now();
    let (cloud, hull) = py
        .detach(|| {
            let cloud = sample_workspace(&tw, &limits, &settings, &report)?;
            let hull = Hull::of(&cloud.solved_tips());
            Ok::<_, ModelError>((cloud, hull))
        })
        .map_err(|e| from_model_error(py, e))?;
    let sampling_s = t0.elapsed().as_secs_f64();
    if let Some(e) = callback_error.into_inner().ok().flatten() {
        return Err(e);
    }
    let n = cloud.len();
    let p = cloud.columns.len();
    let d = PyDict::new(py);
    d.set_item("columns", cloud.columns.clone())?;
    let lim: Vec<f64> = limits
        .min_m
        .iter()
        .zip(&limits.max_m)
        .flat_map(|(a, b)| [*a, *b])
        .collect();
    d.set_item("limits", PyArray1::from_vec(py, lim).reshape([p, 2])?)?;
    d.set_item(
        "readings",
        PyArray1::from_slice(py, &cloud.readings_m).reshape([n, p])?,
    )?;
    let tips: Vec<f64> = cloud
        .tips_m
        .iter()
        .flat_map(|t| t.iter().copied())
        .collect();
    d.set_item("tips", PyArray1::from_vec(py, tips).reshape([n, 3])?)?;
    if marker_offset_m.is_some() {
        let m: Vec<f64> = cloud
            .markers_m
            .iter()
            .flat_map(|t| t.iter().copied())
            .collect();
        d.set_item("markers", PyArray1::from_vec(py, m).reshape([n, 3])?)?;
    } else {
        d.set_item("markers", None::<Vec<f64>>)?;
    }
    let codes: Vec<u8> = cloud
        .status
        .iter()
        .map(|s| SAMPLE_STATUS.iter().position(|x| x == s).unwrap_or(3) as u8)
        .collect();
    d.set_item("status", PyArray1::from_vec(py, codes))?;
    d.set_item(
        "status_names",
        SAMPLE_STATUS.iter().map(|s| s.name()).collect::<Vec<_>>(),
    )?;
    let solved: Vec<bool> = cloud.status.iter().map(|s| s.is_solved()).collect();
    d.set_item("solved", PyArray1::from_vec(py, solved))?;
    d.set_item("solved_count", n - cloud.failed())?;
    d.set_item("failed_count", cloud.failed())?;
    d.set_item("sampling_s", sampling_s)?;
    match hull {
        Ok(h) => {
            let v: Vec<f64> = h.vertices.iter().flat_map(|x| x.iter().copied()).collect();
            let t: Vec<u64> = h
                .triangles
                .iter()
                .flat_map(|t| t.iter().map(|&i| i as u64))
                .collect();
            d.set_item("hull_volume_m3", h.volume_m3)?;
            d.set_item(
                "hull_vertices",
                PyArray1::from_vec(py, v).reshape([h.vertices.len(), 3])?,
            )?;
            d.set_item(
                "hull_triangles",
                PyArray1::from_vec(py, t).reshape([h.triangles.len(), 3])?,
            )?;
            d.set_item("hull_error", None::<String>)?;
        }
        Err(e) => {
            d.set_item("hull_volume_m3", None::<f64>)?;
            d.set_item(
                "hull_vertices",
                PyArray1::from_vec(py, Vec::<f64>::new()).reshape([0, 3])?,
            )?;
            d.set_item(
                "hull_triangles",
                PyArray1::from_vec(py, Vec::<u64>::new()).reshape([0, 3])?,
            )?;
            d.set_item("hull_error", e.to_string())?;
        }
    }
    Ok(d)
}
