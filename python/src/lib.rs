//! Python module `cablesense` (extension `cablesense._cablesense`): scenes, forward
//! solves with numpy arrays, a warm-started solver, the estimator, solves from tendon
//! readings (`tendons.rs`), inverse kinematics and the reachable workspace
//! (`command.rs`), calibration from a recording (`calibrate.rs`) and the
//! thesis validation (`validation.rs`). Only
//! translates types and errors; the GIL is released inside every solve and tick.

mod calibrate;
mod command;
mod tendons;
mod validation;

use cablesense::estimate::{Estimate, Estimator};
use cablesense::files::demo::DataRef;
use cablesense::loads::Loads;
use cablesense::{ModelError, Scene as CoreScene, Solution, Start, Workspace};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::Path;

create_exception!(
    cablesense,
    SceneError,
    PyValueError,
    "A scene could not be read or is invalid; `field` is the offending field path (or None)."
);
create_exception!(
    cablesense,
    ReadingsError,
    PyValueError,
    "Tendon readings are bad (wrong count, not finite, pulling in more than the tendon); \
     `field` names the reading (e.g. `readings[1] (s1b)`), `line` the file line (or None)."
);

create_exception!(
    cablesense,
    TargetError,
    PyValueError,
    "An inverse-kinematics target is bad (a NaN or infinite coordinate, a direction of \
     zero length, a wrong shape); `field` names it (e.g. `target[2]`, `direction`, \
     `targets`)."
);

/// The field path of a model error.
pub(crate) fn field_of(e: &ModelError) -> Option<String> {
    match e {
        ModelError::NonFinite { field, .. }
        | ModelError::NonPositive { field, .. }
        | ModelError::Negative { field, .. }
        | ModelError::OutOfRange { field, .. }
        | ModelError::BadIndex { field, .. }
        | ModelError::Invalid { field, .. } => Some(field.clone()),
        ModelError::GuideOutsideSection { section, .. }
        | ModelError::GuidesOverlap { section, .. } => {
            Some(format!("robot.sections[{section}].guides"))
        }
    }
}

/// A Python `SceneError` with the message and `field` attribute.
pub(crate) fn scene_err(py: Python<'_>, msg: String, field: Option<String>) -> PyErr {
    let err = SceneError::new_err(msg);
    let _ = err.value(py).setattr("field", field);
    err
}

fn from_scene_error(py: Python<'_>, e: cablesense::SceneError) -> PyErr {
    let field = match &e {
        cablesense::SceneError::Invalid { cause, .. } => field_of(cause),
        _ => None,
    };
    scene_err(py, e.to_string(), field)
}

pub(crate) fn from_model_error(py: Python<'_>, e: ModelError) -> PyErr {
    let field = field_of(&e);
    scene_err(py, e.to_string(), field)
}

/// A validated scene: robot, loads, numerics and optional `[estimate]`.
#[pyclass(module = "cablesense", frozen, eq)]
#[derive(Clone, PartialEq)]
pub(crate) struct Scene {
    pub(crate) inner: CoreScene,
}

#[pymethods]
impl Scene {
    /// Read a `.toml` or `.json` scene file, or an embedded demo scene named
    /// `demo:NAME` (e.g. `demo:scenes/ftdcr_v4.toml`; `cablesense.demo.names()`).
    #[staticmethod]
    fn from_file(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Self> {
        let r = DataRef::parse(&path).map_err(|e| scene_err(py, e.to_string(), None))?;
        r.scene()
            .map(|inner| Self { inner })
            .map_err(|e| from_scene_error(py, e))
    }
    /// Parse TOML text.
    #[staticmethod]
    fn from_toml(py: Python<'_>, text: &str) -> PyResult<Self> {
        CoreScene::parse_validated(text, Path::new("<toml>"), false)
            .map(|inner| Self { inner })
            .map_err(|e| from_scene_error(py, e))
    }
    /// A scene from a dict with the layout of the TOML file.
    #[staticmethod]
    fn from_dict(py: Python<'_>, d: &Bound<'_, PyDict>) -> PyResult<Self> {
        let text: String = py.import("json")?.call_method1("dumps", (d,))?.extract()?;
        CoreScene::parse_validated(&text, Path::new("<dict>"), true)
            .map(|inner| Self { inner })
            .map_err(|e| from_scene_error(py, e))
    }
    /// The scene as a dict with the layout of the TOML file (every field, defaults
    /// included): `Scene.from_dict(scene.to_dict()) == scene`.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = self.to_json(py)?;
        py.import("json")?.call_method1("loads", (text,))
    }
    /// The scene as TOML text (every field, defaults included), e.g. to save a
    /// calibrated scene: `Scene.from_toml(scene.to_toml()) == scene`.
    fn to_toml(&self, py: Python<'_>) -> PyResult<String> {
        toml::to_string_pretty(&self.inner)
            .map_err(|e| scene_err(py, format!("cannot write the scene as TOML: {e}"), None))
    }
    /// The scene as JSON text (what `to_dict` and pickling carry; floats round-trip
    /// exactly).
    fn to_json(&self, py: Python<'_>) -> PyResult<String> {
        serde_json::to_string(&self.inner)
            .map_err(|e| scene_err(py, format!("cannot write the scene as JSON: {e}"), None))
    }
    /// Parse JSON text (the layout of `to_json`, as a `.json` scene file).
    #[staticmethod]
    fn from_json(py: Python<'_>, text: &str) -> PyResult<Self> {
        CoreScene::parse_validated(text, Path::new("<json>"), true)
            .map(|inner| Self { inner })
            .map_err(|e| from_scene_error(py, e))
    }
    /// A copy of the scene with its `[loads]` table replaced by the keys of `loads`
    /// (the layout of the TOML table: `gravity_m_s2`, `point`, `tensions_n`); keys
    /// not given keep the scene's values. Validated like a scene.
    fn with_loads(&self, py: Python<'_>, loads: &Bound<'_, PyDict>) -> PyResult<Self> {
        let merged = merged_loads(py, &self.inner.loads, loads)?;
        let mut inner = self.inner.clone();
        inner.loads = merged;
        inner.validate().map_err(|e| from_model_error(py, e))?;
        Ok(Self { inner })
    }
    /// Pickling: the scene travels as its JSON text (floats exact) and is validated
    /// again on loading.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let f = py.get_type::<Scene>().getattr("from_json")?;
        Ok((f, (self.to_json(py)?,)))
    }
    fn __copy__(&self) -> Self {
        self.clone()
    }
    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> Self {
        self.clone()
    }
    /// Free-text description.
    #[getter]
    fn description(&self) -> String {
        self.inner.description.clone()
    }
    /// Cable names (`cable<j>` when unnamed).
    #[getter]
    fn cable_names(&self) -> Vec<String> {
        self.inner
            .robot
            .cables
            .iter()
            .enumerate()
            .map(|(j, c)| c.name.clone().unwrap_or_else(|| format!("cable{j}")))
            .collect()
    }
    fn __repr__(&self) -> String {
        format!(
            "Scene({} sections, {} cables)",
            self.inner.robot.sections.len(),
            self.inner.robot.cables.len()
        )
    }
}

/// `current` with the keys of the dict `d` (the layout of the `[loads]` table)
/// replacing its values; a bad key or value raises `SceneError` naming it.
pub(crate) fn merged_loads(
    py: Python<'_>,
    current: &Loads,
    d: &Bound<'_, PyDict>,
) -> PyResult<Loads> {
    let cur = serde_json::to_value(current)
        .map_err(|e| scene_err(py, format!("loads: {e}"), Some("loads".into())))?;
    // (JSON has no inf or NaN: json refuses them here, with the scene's error type)
    let kwargs = PyDict::new(py);
    kwargs.set_item("allow_nan", false)?;
    let given: String = py
        .import("json")?
        .call_method("dumps", (d,), Some(&kwargs))
        .map_err(|e| {
            scene_err(
                py,
                format!(
                    "loads: every value must be a finite number, list or table ({})",
                    e.value(py)
                ),
                Some("loads".into()),
            )
        })?
        .extract()?;
    let given: serde_json::Value = serde_json::from_str(&given)
        .map_err(|e| scene_err(py, format!("loads: {e}"), Some("loads".into())))?;
    let mut merged = cur;
    if let (Some(m), Some(g)) = (merged.as_object_mut(), given.as_object()) {
        for (k, v) in g {
            m.insert(k.clone(), v.clone());
        }
    }
    serde_json::from_value(merged)
        .map_err(|e| scene_err(py, format!("loads: {e}"), Some("loads".into())))
}

fn workspace(py: Python<'_>, scene: &CoreScene) -> PyResult<Workspace> {
    let robot = scene.build_robot().map_err(|e| from_model_error(py, e))?;
    Workspace::new(robot, scene.loads.clone(), scene.numerics.clone())
        .map_err(|e| from_model_error(py, e))
}

/// A Python `ReadingsError` with the message, `field` and `line` attributes.
pub(crate) fn readings_err(py: Python<'_>, e: ModelError, line: Option<usize>) -> PyErr {
    let field = field_of(&e);
    let msg = match line {
        Some(l) => format!("line {l}: {e}"),
        None => e.to_string(),
    };
    let err = ReadingsError::new_err(msg);
    let _ = err.value(py).setattr("field", field);
    let _ = err.value(py).setattr("line", line);
    err
}

/// How a Python value looks in a type error: `ndarray of shape (3, 9) and dtype
/// int64`, `list of 3 items`, or the type name.
pub(crate) fn describe(obj: &Bound<'_, PyAny>) -> String {
    let ty = obj
        .get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "object".into());
    if let (Ok(shape), Ok(dtype)) = (obj.getattr("shape"), obj.getattr("dtype")) {
        let shape: Vec<usize> = shape.extract().unwrap_or_default();
        let shape = match shape.len() {
            1 => format!("({},)", shape[0]),
            _ => format!(
                "({})",
                shape
                    .iter()
                    .map(|d| d.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        };
        return format!("{ty} of shape {shape} and dtype {dtype}");
    }
    match obj.len() {
        Ok(n) if !obj.is_instance_of::<pyo3::types::PyString>() => format!("{ty} of {n} items"),
        _ => ty,
    }
}

/// Copy a sequence of floats or a 1-D float array into `buf` (cleared first; no
/// allocation once `buf` has the capacity for a float64 array). `what` names the
/// argument and `expected` says its shape (e.g. `9 readings (m)`) in a `TypeError`
/// (called only then: no allocation on the good path).
pub(crate) fn read_f64s(
    obj: &Bound<'_, PyAny>,
    buf: &mut Vec<f64>,
    what: &str,
    expected: impl Fn() -> String,
) -> PyResult<()> {
    buf.clear();
    if let Ok(a) = obj.cast::<numpy::PyArray1<f64>>() {
        let a = a.readonly();
        if let Ok(s) = a.as_slice() {
            buf.extend_from_slice(s);
            return Ok(());
        }
        buf.extend(a.as_array().iter());
        return Ok(());
    }
    let type_err = |got: String| {
        pyo3::exceptions::PyTypeError::new_err(format!(
            "{what}: expected {} as a sequence of floats or a 1-D float array; got {got}",
            expected()
        ))
    };
    // (a type check, not a getattr: no exception object on the good path of a list)
    if let Ok(a) = obj.cast::<numpy::PyUntypedArray>() {
        if a.ndim() != 1 {
            return Err(type_err(describe(obj)));
        }
    }
    let items = obj.try_iter().map_err(|_| type_err(describe(obj)))?;
    for (i, item) in items.enumerate() {
        let item = item?;
        match item.extract::<f64>() {
            Ok(v) => buf.push(v),
            Err(_) => {
                return Err(type_err(format!(
                    "{}, whose item {i} is {}",
                    describe(obj),
                    describe(&item)
                )))
            }
        }
    }
    Ok(())
}

/// Rows read by [`read_rows`].
pub(crate) struct RowsIn {
    /// Row count.
    pub n: usize,
    /// Column count (the caller checks it).
    pub cols: usize,
    /// Row-major values.
    pub data: Vec<f64>,
    /// What was expected and what came (for the caller's column-count error).
    pub shape_msg: String,
}

/// A 2-D float64 array of `cols` columns from `obj` (an array of any real dtype or
/// nested sequences, converted by `numpy.asarray`).
/// `what` names the argument and `expected` a row (e.g. `9 readings (m)`); a value
/// numpy cannot convert, or of another dimension, raises `TypeError` saying what
/// was expected and what came. The column count is the caller's to check (the
/// returned message names shapes for it).
pub(crate) fn read_rows(
    py: Python<'_>,
    obj: &Bound<'_, PyAny>,
    cols: usize,
    what: &str,
    expected: &str,
) -> PyResult<RowsIn> {
    let msg = |got: String| {
        format!(
            "{what}: expected a 2-D float array of shape (n, {cols}), one row of {expected} per solve; got {got}"
        )
    };
    let arr = match obj.cast::<numpy::PyArray2<f64>>() {
        Ok(a) => a.clone(),
        Err(_) => {
            let np = py.import("numpy")?;
            let converted = np
                .call_method1("asarray", (obj, np.getattr("float64")?))
                .map_err(|e| {
                    pyo3::exceptions::PyTypeError::new_err(msg(format!(
                        "{} that numpy cannot convert to float64 ({})",
                        describe(obj),
                        e.value(py)
                    )))
                })?;
            converted
                .cast_into::<numpy::PyArray2<f64>>()
                .map_err(|_| pyo3::exceptions::PyTypeError::new_err(msg(describe(obj))))?
        }
    };
    let a = arr.readonly();
    let (n, c) = a.as_array().dim();
    Ok(RowsIn {
        n,
        cols: c,
        data: a.as_array().iter().copied().collect(),
        shape_msg: msg(describe(obj)),
    })
}

/// A status as the snake-case string of the Python API.
pub(crate) fn report_status(s: cablesense::SolveStatus) -> String {
    to_snake(&format!("{s:?}"))
}

/// A solution as a dict of numpy arrays.
pub(crate) fn solution_dict<'py>(py: Python<'py>, sol: &Solution) -> PyResult<Bound<'py, PyDict>> {
    let n = sol.samples.len();
    let d = PyDict::new(py);
    let s: Vec<f64> = sol.samples.iter().map(|x| x.s).collect();
    let mut r: Vec<f64> = Vec::with_capacity(3 * n);
    let mut rot: Vec<f64> = Vec::with_capacity(9 * n);
    for x in &sol.samples {
        r.extend(x.r.iter());
        // row-major (i, j) for numpy
        for i in 0..3 {
            for j in 0..3 {
                rot.push(x.rotation[(i, j)]);
            }
        }
    }
    d.set_item("s", s.into_pyarray(py))?;
    d.set_item("r", PyArray1::from_vec(py, r).reshape([n, 3])?)?;
    d.set_item("R", PyArray1::from_vec(py, rot).reshape([n, 3, 3])?)?;
    let k = sol.section_tips.len();
    let mut tips: Vec<f64> = Vec::with_capacity(3 * k);
    for t in &sol.section_tips {
        tips.extend(t.position.iter());
    }
    d.set_item(
        "section_tips",
        PyArray1::from_vec(py, tips).reshape([k, 3])?,
    )?;
    d.set_item(
        "tip",
        sol.tip()
            .position
            .iter()
            .copied()
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    let lengths: Vec<f64> = sol.cables.iter().map(|c| c.total_m).collect();
    d.set_item("cable_lengths", lengths.into_pyarray(py))?;
    let rep = PyDict::new(py);
    let r = &sol.report;
    let status = format!("{:?}", r.status);
    rep.set_item("status", to_snake(&status))?;
    rep.set_item("converged", r.status.is_converged())?;
    rep.set_item("iterations", r.iterations)?;
    rep.set_item("residual", r.residual)?;
    rep.set_item("rhs_evals", r.rhs_evals)?;
    rep.set_item("jacobian_evals", r.jacobian_evals)?;
    rep.set_item("continuation_steps", r.continuation_steps)?;
    d.set_item("report", rep)?;
    Ok(d)
}

/// `MaxIterations` -> `max_iterations`.
fn to_snake(s: &str) -> String {
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if c.is_ascii_uppercase() {
            if i > 0 {
                out.push('_');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

/// Forward statics of a scene with its own loads (a cold solve).
#[pyfunction]
fn solve<'py>(py: Python<'py>, scene: &Scene) -> PyResult<Bound<'py, PyDict>> {
    let mut ws = workspace(py, &scene.inner)?;
    let (sol, why) = py.detach(move || {
        ws.solve(Start::Cold);
        (ws.solution(), diagnosis(&ws))
    });
    with_diagnosis(solution_dict(py, &sol)?, why)
}

/// Why a solve that did not converge ended where it did, in the scene's terms
/// (`Workspace::diagnose`); `None` after a converged solve.
fn diagnosis(ws: &Workspace) -> Option<String> {
    (!ws.report().status.is_converged()).then(|| ws.diagnose().to_string())
}

/// `report["diagnosis"]` of a solution dict, when there is one.
fn with_diagnosis<'py>(d: Bound<'py, PyDict>, why: Option<String>) -> PyResult<Bound<'py, PyDict>> {
    if let Some(why) = why {
        if let Some(rep) = d.get_item("report")? {
            rep.set_item("diagnosis", why)?;
        }
    }
    Ok(d)
}

/// A solver that keeps its workspace: repeated solves start warm.
#[pyclass(module = "cablesense")]
struct Solver {
    ws: Workspace,
    solved: bool,
}

#[pymethods]
impl Solver {
    #[new]
    fn new(py: Python<'_>, scene: &Scene) -> PyResult<Self> {
        Ok(Self {
            ws: workspace(py, &scene.inner)?,
            solved: false,
        })
    }
    /// Solve (warm from the previous solution after the first call, unless
    /// `warm=False`) and return the solution dict.
    #[pyo3(signature = (warm = true))]
    fn solve<'py>(&mut self, py: Python<'py>, warm: bool) -> PyResult<Bound<'py, PyDict>> {
        let start = if warm && self.solved {
            Start::Warm
        } else {
            Start::Cold
        };
        let ws = &mut self.ws;
        let (sol, why) = py.detach(|| {
            ws.solve(start);
            (ws.solution(), diagnosis(ws))
        });
        self.solved = sol.report.status.is_converged();
        with_diagnosis(solution_dict(py, &sol)?, why)
    }
    /// Replace the loads of the next solves, keeping the warm start (no new scene,
    /// no cold solve): `loads` has the layout of the scene's `[loads]` table
    /// (`gravity_m_s2`, `point`, `tensions_n`); keys not given keep their values.
    /// With the same structure (point-load sites and frames, set of tensioned
    /// cables) nothing is rebuilt. A bad value raises `SceneError` naming the field
    /// and changes nothing.
    fn set_loads(&mut self, py: Python<'_>, loads: &Bound<'_, PyDict>) -> PyResult<()> {
        let merged = merged_loads(py, self.ws.loads(), loads)?;
        self.ws
            .set_loads(&merged)
            .map_err(|e| from_model_error(py, e))
    }
    /// The loads in effect, as a dict with the layout of the `[loads]` table.
    #[getter]
    fn loads<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        loads_dict(py, self.ws.loads())
    }
}

/// Loads as a dict with the layout of the `[loads]` table.
pub(crate) fn loads_dict<'py>(py: Python<'py>, loads: &Loads) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(loads)
        .map_err(|e| scene_err(py, format!("loads: {e}"), Some("loads".into())))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// The scene's `[estimate]` problem.
#[pyclass(module = "cablesense", name = "Estimator")]
struct PyEstimator {
    est: Estimator,
    /// The sample of one tick (reused: no allocation per tick for the input).
    changes: Vec<f64>,
    sigma: Vec<f64>,
}

fn estimate_dict<'py>(py: Python<'py>, e: &Estimate) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let p = e.values.len();
    d.set_item("names", e.names.clone())?;
    d.set_item("values", e.values.clone().into_pyarray(py))?;
    d.set_item("std_dev", e.std_dev.clone().into_pyarray(py))?;
    let cov: Bound<'py, PyArray2<f64>> =
        PyArray1::from_vec(py, e.covariance.clone()).reshape([p, p])?;
    d.set_item("covariance", cov)?;
    d.set_item("status", to_snake(&format!("{:?}", e.status)))?;
    d.set_item("fit", to_snake(&format!("{:?}", e.fit)))?;
    d.set_item("rms_sigma", e.rms_sigma)?;
    d.set_item("redundancy", e.redundancy)?;
    d.set_item("rank", e.rank)?;
    d.set_item(
        "tip",
        e.tip
            .position
            .iter()
            .copied()
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    let predicted = e.predicted_m.clone();
    d.set_item("predicted", predicted.into_pyarray(py))?;
    d.set_item("iterations", e.iterations)?;
    d.set_item("elapsed_s", e.elapsed_s)?;
    Ok(d)
}

#[pymethods]
impl PyEstimator {
    #[new]
    fn new(py: Python<'_>, scene: &Scene) -> PyResult<Self> {
        let s = &scene.inner;
        let spec = s.estimate.clone().ok_or_else(|| {
            scene_err(
                py,
                "the scene has no [estimate] table".into(),
                Some("estimate".into()),
            )
        })?;
        let robot = s.build_robot().map_err(|e| from_model_error(py, e))?;
        let est = Estimator::new(robot, s.loads.clone(), s.numerics.clone(), spec).map_err(
            |e| match e {
                cablesense::estimate::EstimateError::Model(m) => from_model_error(py, m),
                other => scene_err(py, other.to_string(), None),
            },
        )?;
        let c = est.reference_lengths().len();
        Ok(Self {
            est,
            changes: Vec::with_capacity(c),
            sigma: Vec::with_capacity(c),
        })
    }
    /// Unknown names.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.est.names().to_vec()
    }
    /// One sample: cable length changes (m; NaN = missing) and optional per-cable
    /// noise (m). Returns the estimate dict (the snapshot `Estimator::estimate`:
    /// exact statistics, fit test, the shape recomputed for the tip). With
    /// `snapshot=False` only the tick runs and the dict is {status, values,
    /// covariance (from the sensitivities the tick ended with), statistics_exact,
    /// tip}: the control-loop path, as the C ABI's tick (the snapshot costs about
    /// 16 us on the track demo, `python/bench/tick_overhead.py`).
    #[pyo3(signature = (changes, sigma = None, snapshot = true))]
    fn tick<'py>(
        &mut self,
        py: Python<'py>,
        changes: &Bound<'py, PyAny>,
        sigma: Option<&Bound<'py, PyAny>>,
        snapshot: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let c = self.est.reference_lengths().len();
        read_f64s(changes, &mut self.changes, "changes", || {
            format!("{c} cable length changes (m)")
        })?;
        if let Some(s) = sigma {
            read_f64s(s, &mut self.sigma, "sigma", || {
                format!("{c} noise levels (m)")
            })?;
        }
        if self.changes.len() != c || sigma.is_some() && self.sigma.len() != c {
            return Err(PyValueError::new_err(format!(
                "{} changes{} for {c} cables",
                self.changes.len(),
                if sigma.is_some() {
                    format!(" and {} sigmas", self.sigma.len())
                } else {
                    String::new()
                }
            )));
        }
        // the strict boundary: an infinite change or a sigma that is not finite and
        // positive is an error, not a missing measurement
        self.est
            .check_sample(&self.changes, sigma.is_some().then_some(&self.sigma[..]))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let (est, changes) = (&mut self.est, &self.changes);
        let sigma = sigma.is_some().then_some(&self.sigma[..]);
        if !snapshot {
            let status = py.detach(|| est.tick(changes, sigma));
            let p = est.theta().len();
            let d = PyDict::new(py);
            d.set_item("status", to_snake(&format!("{status:?}")))?;
            d.set_item("values", PyArray1::from_slice(py, est.theta()))?;
            let cov: Bound<'py, PyArray2<f64>> =
                PyArray1::from_slice(py, est.covariance()).reshape([p, p])?;
            d.set_item("covariance", cov)?;
            d.set_item("statistics_exact", est.statistics_are_exact())?;
            d.set_item(
                "tip",
                PyArray1::from_slice(py, est.tip_position().as_slice()),
            )?;
            return Ok(d);
        }
        let e = py.detach(|| {
            est.tick(changes, sigma);
            est.estimate()
        });
        estimate_dict(py, &e)
    }

    /// Time `count` ticks in Rust alone (no Python in the loop), cycling over the
    /// rows of `samples` (n, c), each timed on its own (`Instant`); returns the
    /// seconds per tick. With `snapshot=True` each timed tick also takes the
    /// estimate snapshot that `tick` returns (`Estimator::estimate`: exact
    /// statistics, the shape recomputed for the tip). For measuring the binding's
    /// overhead against the same estimator in the same process
    /// (`python/bench/tick_overhead.py`).
    #[pyo3(signature = (samples, count, snapshot = false))]
    fn time_ticks<'py>(
        &mut self,
        py: Python<'py>,
        samples: numpy::PyReadonlyArray2<'py, f64>,
        count: usize,
        snapshot: bool,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let c = self.est.reference_lengths().len();
        let (rows_n, cols) = samples.as_array().dim();
        let shape = [rows_n, cols];
        if shape[1] != c || shape[0] == 0 {
            return Err(PyValueError::new_err(format!(
                "samples of shape ({}, {}) for {c} cables",
                shape[0], shape[1]
            )));
        }
        let rows: Vec<f64> = samples.as_array().iter().copied().collect();
        let est = &mut self.est;
        let times = py.detach(|| {
            let mut t = Vec::with_capacity(count);
            for k in 0..count {
                let i = k % shape[0];
                let row = &rows[i * c..(i + 1) * c];
                let t0 = std::time::Instant::now();
                std::hint::black_box(est.tick(std::hint::black_box(row), None));
                if snapshot {
                    std::hint::black_box(est.estimate());
                }
                t.push(t0.elapsed().as_secs_f64());
            }
            t
        });
        Ok(times.into_pyarray(py))
    }
}

/// The embedded demo files: (name, what it is for) in `demo list` order; a name is
/// used as `demo:NAME` wherever a scene path is expected.
#[pyfunction]
fn demo_files() -> Vec<(&'static str, &'static str)> {
    cablesense::files::demo::FILES
        .iter()
        .map(|f| (f.path, f.about))
        .collect()
}

/// The text of the embedded demo file `name` (with or without the `demo:` prefix).
#[pyfunction]
fn demo_text(name: &str) -> PyResult<&'static str> {
    let name = name
        .strip_prefix(cablesense::files::demo::PREFIX)
        .unwrap_or(name);
    cablesense::files::demo::get(name)
        .map(|f| f.text)
        .ok_or_else(|| {
            pyo3::exceptions::PyKeyError::new_err(format!(
                "no embedded demo file `{name}` (cablesense.demo.names() lists them)"
            ))
        })
}

/// The module.
#[pymodule]
fn _cablesense(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<Scene>()?;
    m.add_class::<Solver>()?;
    m.add_class::<PyEstimator>()?;
    m.add_class::<tendons::TendonSolver>()?;
    m.add_class::<command::IkSolver>()?;
    m.add_function(wrap_pyfunction!(command::workspace, m)?)?;
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(demo_files, m)?)?;
    m.add_function(wrap_pyfunction!(demo_text, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate::calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(validation::validate_thesis, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate::predict_recording, m)?)?;
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add("ReadingsError", m.py().get_type::<ReadingsError>())?;
    m.add("TargetError", m.py().get_type::<TargetError>())?;
    m.add(
        "CalibrationError",
        m.py().get_type::<calibrate::CalibrationError>(),
    )?;
    Ok(())
}
