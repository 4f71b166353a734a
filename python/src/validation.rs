//! `validate_thesis(table)`: one thesis table (the data embedded in the library)
//! compared with the model, as `cablesense validate --table T` prints it.

use cablesense::files::demo::DataSource;
use cablesense::validation::{compare, FittedFile, RowComparison, TableData, Target, ThesisTable};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

fn err(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn row_dict<'py>(py: Python<'py>, r: &RowComparison) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("loads", r.loads.clone())?;
    d.set_item("status", crate::report_status(r.status))?;
    d.set_item("residual", r.residual)?;
    let points = PyList::empty(py);
    for p in &r.points {
        let x = PyDict::new(py);
        x.set_item("observed_m", p.observed.to_vec())?;
        x.set_item("thesis_m", p.thesis.to_vec())?;
        x.set_item("ours_m", p.ours.to_vec())?;
        x.set_item("err_ours_obs_m", p.err_ours_obs_m)?;
        x.set_item("err_thesis_obs_m", p.err_thesis_obs_m)?;
        x.set_item("err_ours_thesis_m", p.err_ours_thesis_m)?;
        points.append(x)?;
    }
    d.set_item("points", points)?;
    let lengths = PyList::empty(py);
    for l in &r.lengths {
        let x = PyDict::new(py);
        x.set_item("observed_delta_m", l.observed_delta)?;
        x.set_item("thesis_length_m", l.thesis_length)?;
        x.set_item("thesis_delta_m", l.thesis_delta)?;
        x.set_item("ours_length_m", l.ours_length)?;
        x.set_item("ours_delta_m", l.ours_delta)?;
        lengths.append(x)?;
    }
    d.set_item("lengths", lengths)?;
    Ok(d)
}

/// Compare the model with one thesis table (`4.1`, `4.2`, `4.3`, `4.3m`, `4.4`,
/// `4.5`, `4.5acc`; the data embedded in the library), with the stored fit to the
/// thesis's predicted columns applied unless `fitted=False`. Returns {table, title,
/// ref_length_m, all_converged, rows [{loads, status, residual, points, lengths}],
/// points [per tracked point: label, mean_pct_ours_obs, mean_pct_thesis_obs,
/// thesis_avg_pct, max_ours_thesis_m, rms_ours_thesis_m, max_ours_obs_m], lengths
/// [per cable: label, max_ours_thesis_m, mean_del_dif_ours_m, mean_del_dif_thesis_m,
/// thesis_avg_del_dif_m]}. The GIL is released during the solves.
#[pyfunction]
#[pyo3(signature = (table, fitted = true))]
pub fn validate_thesis<'py>(
    py: Python<'py>,
    table: &str,
    fitted: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let t: ThesisTable = table.parse().map_err(err)?;
    let c = py
        .detach(|| {
            let src = DataSource::THESIS;
            let data = TableData::load_from(&src, t)?;
            let scene = match fitted {
                true => {
                    match FittedFile::load_from(&src)?.get(data.spec.scene, Target::Predicted) {
                        Some(rec) => rec.apply(&data.scene)?,
                        None => data.scene.clone(),
                    }
                }
                false => data.scene.clone(),
            };
            compare(&data, &scene)
        })
        .map_err(err)?;
    let d = PyDict::new(py);
    d.set_item("table", t.name())?;
    d.set_item("title", t.spec().title)?;
    d.set_item("ref_length_m", c.ref_length_m)?;
    d.set_item("all_converged", c.all_converged())?;
    let rows = PyList::empty(py);
    for r in &c.rows {
        rows.append(row_dict(py, r)?)?;
    }
    d.set_item("rows", rows)?;
    let points = PyList::empty(py);
    for p in &c.points {
        let x = PyDict::new(py);
        x.set_item("label", p.label)?;
        x.set_item("mean_pct_ours_obs", p.mean_pct_ours_obs)?;
        x.set_item("mean_pct_thesis_obs", p.mean_pct_thesis_obs)?;
        x.set_item("mean_pct_printed", p.mean_pct_printed)?;
        x.set_item("thesis_avg_pct", p.thesis_avg_pct)?;
        x.set_item("max_ours_thesis_m", p.max_ours_thesis_m)?;
        x.set_item("rms_ours_thesis_m", p.rms_ours_thesis_m)?;
        x.set_item("max_ours_obs_m", p.max_ours_obs_m)?;
        points.append(x)?;
    }
    d.set_item("points", points)?;
    let lengths = PyList::empty(py);
    for l in &c.lengths {
        let x = PyDict::new(py);
        x.set_item("label", l.label)?;
        x.set_item("max_ours_thesis_m", l.max_ours_thesis_m)?;
        x.set_item("mean_del_dif_ours_m", l.mean_del_dif_ours_m)?;
        x.set_item("mean_del_dif_thesis_m", l.mean_del_dif_thesis_m)?;
        x.set_item("thesis_avg_del_dif_m", l.thesis_avg_del_dif_m)?;
        x.set_item("ours_ref_length_m", l.ours_ref_length_m)?;
        x.set_item("thesis_ref_length_m", l.thesis_ref_length_m)?;
        lengths.append(x)?;
    }
    d.set_item("lengths", lengths)?;
    Ok(d)
}
