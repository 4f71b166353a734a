//! `calibrate(scene, train, val=None, ...)`: the scene's `[calibration]` table
//! mapping a recording, the model the scene calls for (`calibrate::SceneModel`:
//! servo readings for displacement-driven tendons, else tension columns), fitted
//! with `cablesense::calibrate_scene`; the report comes back as a dict (the
//! layout of `cablesense calibrate`'s `report.json`) with the calibrated scene.

use crate::Scene;
use cablesense::calibrate::{
    calibrate_scene, scene_spec, CalibrationError as CoreError, CalibrationModel, ColumnMap,
    ParamSpec, Recording, RigidTransform, SceneCalibration, SceneModel, TipErrors,
};
use cablesense::nalgebra::Vector3;
use numpy::PyArrayMethods;
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

create_exception!(
    cablesense,
    CalibrationError,
    PyValueError,
    "A calibration could not run: a bad recording cell (`file`, `line`, `column`), a \
     missing column, a unit mismatch, a bad parameter path, or a model that cannot be \
     built or solved at some parameter values (`field`)."
);

/// A Python `CalibrationError` with `file`, `line`, `column` and `field` (each or None).
fn calibration_err(py: Python<'_>, e: CoreError) -> PyErr {
    let (mut file, mut line, mut column, mut field) = (None, None, None, None);
    match &e {
        CoreError::Recording {
            file: f,
            line: l,
            column: c,
            ..
        }
        | CoreError::MissingColumn {
            file: f,
            line: l,
            column: c,
            ..
        } => {
            file = Some(f.clone());
            line = Some(*l);
            column = Some(c.clone());
        }
        CoreError::UnitMismatch {
            file: f, line: l, ..
        } => {
            file = Some(f.clone());
            line = Some(*l);
        }
        CoreError::Io { path, .. } => file = Some(path.clone()),
        CoreError::Model { source, .. } => field = crate::field_of(source),
        CoreError::NotConverged { line: l, .. } => line = Some(*l),
        CoreError::Param(_) | CoreError::BadInput(_) => {}
    }
    let err = CalibrationError::new_err(e.to_string());
    let v = err.value(py);
    let _ = v.setattr("file", file);
    let _ = v.setattr("line", line);
    let _ = v.setattr("column", column);
    let _ = v.setattr("field", field);
    err
}

fn bad_input(py: Python<'_>, msg: String) -> PyErr {
    calibration_err(py, CoreError::BadInput(msg))
}

/// Calibrate `scene` on the recording `train` (CSV or JSON lines; the scene's
/// `[calibration]` table maps its columns and lists the parameters), predicting
/// `val` too when given. `params` adds parameter paths (e.g.
/// `robot/sections/*/youngs_modulus_pa`) to the scene's; `max_iterations`
/// overrides the table's. The GIL is released during the fit (seconds for the
/// demo, minutes for the hardware robot). Returns the report dict (`status`,
/// `iterations`, `params` [{name, initial, value, std_error, at_bound}],
/// `capture_to_base`, `marker_offset_m`, `statistics`, `train` and `val` tip errors
/// `{raw, mean_removed}` with `rmse_m`, ..., `rms_sigma`, `warnings`, `rows`) with
/// `scene`: the calibrated `Scene`.
#[pyfunction]
#[pyo3(signature = (scene, train, val = None, params = None, threads = 2, max_iterations = None))]
pub fn calibrate<'py>(
    py: Python<'py>,
    scene: &Scene,
    train: PathBuf,
    val: Option<PathBuf>,
    params: Option<Vec<String>>,
    threads: usize,
    max_iterations: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let scene = &scene.inner;
    let mut spec = scene_spec(scene);
    for p in params.unwrap_or_default() {
        spec.params.push(ParamSpec::new(p));
    }
    if let Some(m) = max_iterations {
        spec.max_iterations = m;
    }
    spec.validate()
        .map_err(|e| calibration_err(py, model_error("calibration", e)))?;
    if spec.params.is_empty() && !spec.fit_capture_frame && !spec.fit_marker_offset {
        return Err(bad_input(
            py,
            "nothing to fit: no params, no [[calibration.params]], frame and offset fixed".into(),
        ));
    }
    let report = py.detach(|| {
        let map = ColumnMap::from_spec(&spec);
        let train = Recording::load(&train, &map)?;
        let val = val.map(|v| Recording::load(v, &map)).transpose()?;
        let SceneCalibration {
            report,
            scene: out_scene,
        } = calibrate_scene(scene, &spec, &train, val.as_ref(), threads, &mut |_| {})?;
        let json = serde_json::to_string(&report).map_err(|e| CoreError::Io {
            path: "<report>".into(),
            why: e.to_string(),
        })?;
        Ok::<_, CoreError>((json, out_scene))
    });
    let (json, out_scene) = report.map_err(|e| calibration_err(py, e))?;
    let d: Bound<'py, PyDict> = py
        .import("json")?
        .call_method1("loads", (json,))?
        .cast_into()?;
    d.set_item("scene", Scene { inner: out_scene })?;
    Ok(d)
}

/// Predict every row of `recording` with a (calibrated) scene and compare with its
/// marker columns: the scene's `[calibration]` gives the columns, the capture frame,
/// the marker offset and body; the model is the one the scene calls for (servo
/// readings or tensions), warm-started row to row. This is the hardware validation:
/// `data/calibration/ftdcr_v4_calibrated.toml` on `data/hardware/ftdcr_v4/val.csv`
/// (443 rows, several seconds). Returns {lines (n,), predicted_m (n, 3) and
/// measured_m (n, 3) in the robot base frame, errors {raw, mean_removed} with
/// rmse_m, median_m, p95_m, max_m, count}.
#[pyfunction]
pub fn predict_recording<'py>(
    py: Python<'py>,
    scene: &Scene,
    recording: PathBuf,
) -> PyResult<Bound<'py, PyDict>> {
    let scene = &scene.inner;
    let spec = scene_spec(scene);
    let out = py.detach(|| {
        let rec = Recording::load(&recording, &ColumnMap::from_spec(&spec))?;
        let frame = RigidTransform::from_spec(&spec.capture_to_base);
        let offset = Vector3::from(spec.marker_offset_m);
        let mut model = SceneModel::new(scene, &[], &rec.input_names, spec.marker_s_m)?;
        let (mut predicted, mut measured, mut lines) = (Vec::new(), Vec::new(), Vec::new());
        for row in &rec.rows {
            let pose = model.predict(row)?;
            predicted.push(pose.position + pose.rotation * offset);
            measured.push(frame.apply(&row.marker_m));
            lines.push(row.line as u64);
        }
        let errors = TipErrors::of(&predicted, &measured);
        let json = serde_json::to_string(&errors).map_err(|e| CoreError::Io {
            path: "<errors>".into(),
            why: e.to_string(),
        })?;
        Ok::<_, CoreError>((lines, predicted, measured, json))
    });
    let (lines, predicted, measured, json) = out.map_err(|e| calibration_err(py, e))?;
    let n = lines.len();
    let flat =
        |v: &[Vector3<f64>]| -> Vec<f64> { v.iter().flat_map(|p| p.iter().copied()).collect() };
    let d = PyDict::new(py);
    d.set_item("lines", numpy::PyArray1::from_vec(py, lines))?;
    d.set_item(
        "predicted_m",
        numpy::PyArray1::from_vec(py, flat(&predicted)).reshape([n, 3])?,
    )?;
    d.set_item(
        "measured_m",
        numpy::PyArray1::from_vec(py, flat(&measured)).reshape([n, 3])?,
    )?;
    d.set_item("errors", py.import("json")?.call_method1("loads", (json,))?)?;
    Ok(d)
}

fn model_error(context: &str, source: cablesense::ModelError) -> CoreError {
    CoreError::Model {
        context: context.into(),
        source,
    }
}
