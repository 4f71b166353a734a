//! Python module `cablesense` (extension `cablesense._cablesense`): scenes, forward
//! solves with numpy arrays, a warm-started solver, the estimator. Only translates
//! types and errors; the GIL is released inside every solve and tick.

use cablesense::estimate::{Estimate, Estimator};
use cablesense::{ModelError, Scene as CoreScene, Solution, Start, Workspace};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods};
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

/// The field path of a model error.
fn field_of(e: &ModelError) -> Option<String> {
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
fn scene_err(py: Python<'_>, msg: String, field: Option<String>) -> PyErr {
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

fn from_model_error(py: Python<'_>, e: ModelError) -> PyErr {
    let field = field_of(&e);
    scene_err(py, e.to_string(), field)
}

/// A validated scene: robot, loads, numerics and optional `[estimate]`.
#[pyclass(module = "cablesense", frozen)]
#[derive(Clone)]
struct Scene {
    inner: CoreScene,
}

#[pymethods]
impl Scene {
    /// Read a `.toml` or `.json` scene file.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Self> {
        CoreScene::load(&path)
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

fn workspace(py: Python<'_>, scene: &CoreScene) -> PyResult<Workspace> {
    let robot = scene.build_robot().map_err(|e| from_model_error(py, e))?;
    Workspace::new(robot, scene.loads.clone(), scene.numerics.clone())
        .map_err(|e| from_model_error(py, e))
}

/// A solution as a dict of numpy arrays.
fn solution_dict<'py>(py: Python<'py>, sol: &Solution) -> PyResult<Bound<'py, PyDict>> {
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
    let sol = py.detach(move || {
        ws.solve(Start::Cold);
        ws.solution()
    });
    solution_dict(py, &sol)
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
        let sol = py.detach(|| {
            ws.solve(start);
            ws.solution()
        });
        self.solved = sol.report.status.is_converged();
        solution_dict(py, &sol)
    }
}

/// The scene's `[estimate]` problem.
#[pyclass(module = "cablesense", name = "Estimator")]
struct PyEstimator {
    est: Estimator,
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
        Ok(Self { est })
    }
    /// Unknown names.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.est.names().to_vec()
    }
    /// One sample: cable length changes (m; NaN = missing) and optional per-cable
    /// noise (m). Returns the estimate dict.
    #[pyo3(signature = (changes, sigma = None))]
    fn tick<'py>(
        &mut self,
        py: Python<'py>,
        changes: Vec<f64>,
        sigma: Option<Vec<f64>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let c = self.est.reference_lengths().len();
        if changes.len() != c || sigma.as_ref().is_some_and(|s| s.len() != c) {
            return Err(PyValueError::new_err(format!(
                "{} changes{} for {c} cables",
                changes.len(),
                sigma
                    .as_ref()
                    .map_or(String::new(), |s| format!(" and {} sigmas", s.len()))
            )));
        }
        let est = &mut self.est;
        let e = py.detach(|| {
            est.tick(&changes, sigma.as_deref());
            est.estimate()
        });
        estimate_dict(py, &e)
    }
}

/// The module.
#[pymodule]
fn _cablesense(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Scene>()?;
    m.add_class::<Solver>()?;
    m.add_class::<PyEstimator>()?;
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    Ok(())
}
