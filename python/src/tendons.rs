//! `TendonSolver`: servo readings of displacement-driven tendons in, shape, tensions
//! and taut flags out (`cablesense::tendons::TendonWorkspace` through
//! `Scene::tendon_workspace()`), one row at a time warm-started, a 2-D array of rows,
//! or the lines of a readings file streamed through the scene's `[readings]` parser.

use crate::{
    from_model_error, loads_dict, merged_loads, read_f64s, read_rows, readings_err, report_status,
    solution_dict, Scene,
};
use cablesense::files::readings::{ReadingRow, ReadingsParser};
use cablesense::tendons::{TendonReport, TendonWorkspace};
use cablesense::{ModelError, Start};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// One solved row, copied out of the workspace inside the GIL-free section.
struct Row {
    tip: [f64; 3],
    section_tips: Vec<f64>,
    tensions: Vec<f64>,
    taut: Vec<bool>,
    lengths: Vec<f64>,
    report: TendonReport,
    /// Why the row did not converge (`TendonWorkspace::diagnose`); `None` if it did.
    diagnosis: Option<String>,
    /// Arc length (m) and backbone positions (m, `3 * stations`) of the row's
    /// solution, when asked for (`solve_many(shapes=True)`).
    shape: Option<(Vec<f64>, Vec<f64>)>,
}

impl Row {
    fn take(ws: &mut TendonWorkspace, report: TendonReport, shape: bool) -> Self {
        let sol = ws.workspace_mut().solution();
        let mut section_tips = Vec::with_capacity(3 * sol.section_tips.len());
        for t in &sol.section_tips {
            section_tips.extend(t.position.iter());
        }
        let shape = shape.then(|| {
            let s = sol.samples.iter().map(|x| x.s).collect();
            let r = sol
                .samples
                .iter()
                .flat_map(|x| x.r.iter().copied())
                .collect();
            (s, r)
        });
        let tip = ws.tip_position();
        Self {
            tip: [tip.x, tip.y, tip.z],
            section_tips,
            tensions: ws.tensions().to_vec(),
            taut: ws.taut().to_vec(),
            lengths: ws.lengths().to_vec(),
            report,
            diagnosis: (!report.status.is_converged()).then(|| ws.diagnose().to_string()),
            shape,
        }
    }
}

fn report_dict<'py>(py: Python<'py>, r: &TendonReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("status", report_status(r.status))?;
    d.set_item("converged", r.status.is_converged())?;
    d.set_item("iterations", r.iterations)?;
    d.set_item("residual_m", r.residual_m)?;
    d.set_item("forward_solves", r.forward_solves)?;
    d.set_item("slack", r.slack)?;
    Ok(d)
}

fn row_dict<'py>(py: Python<'py>, row: &Row) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let k = row.section_tips.len() / 3;
    d.set_item("tip", PyArray1::from_slice(py, &row.tip))?;
    d.set_item(
        "section_tips",
        PyArray1::from_slice(py, &row.section_tips).reshape([k, 3])?,
    )?;
    d.set_item("tensions", PyArray1::from_slice(py, &row.tensions))?;
    d.set_item("taut", PyArray1::from_slice(py, &row.taut))?;
    d.set_item("lengths", PyArray1::from_slice(py, &row.lengths))?;
    let report = report_dict(py, &row.report)?;
    if let Some(why) = &row.diagnosis {
        report.set_item("diagnosis", why)?;
    }
    d.set_item("report", report)?;
    Ok(d)
}

/// Solves of a scene's displacement-driven tendons from servo readings.
///
/// Built once per scene (validates it and solves the reference at the pretensions);
/// every solve after the first starts warm from the previous one, so rows of a
/// recording should come in time order. The GIL is released inside every solve.
#[pyclass(module = "cablesense")]
pub struct TendonSolver {
    ws: TendonWorkspace,
    /// The readings of one row (reused: no allocation per call for the input).
    q: Vec<f64>,
    /// The readings `solve()` without readings solves (`set_readings`, or the last
    /// row solved).
    current: Vec<f64>,
    parser: ReadingsParser,
    scale_m: f64,
}

/// Prefix a readings error's field with the row index of a batch.
fn in_row(e: ModelError, i: usize) -> ModelError {
    match e {
        ModelError::NonFinite { field, value } => ModelError::NonFinite {
            field: format!("rows[{i}].{field}"),
            value,
        },
        ModelError::OutOfRange { field, value, why } => ModelError::OutOfRange {
            field: format!("rows[{i}].{field}"),
            value,
            why,
        },
        ModelError::Invalid { field, why } => ModelError::Invalid {
            field: format!("rows[{i}].{field}"),
            why,
        },
        other => other,
    }
}

#[pymethods]
impl TendonSolver {
    /// Build the tendon model of `scene` (it needs displacement-driven tendons).
    #[new]
    fn new(py: Python<'_>, scene: &Scene) -> PyResult<Self> {
        let s = &scene.inner;
        let ws = py
            .detach(|| s.tendon_workspace())
            .map_err(|e| from_model_error(py, e))?;
        if ws.driven().is_empty() {
            return Err(crate::scene_err(
                py,
                "the scene has no displacement-driven tendon (actuation = \"displacement\")".into(),
                Some("robot.cables".into()),
            ));
        }
        let parser = s.readings_parser(&ws);
        Ok(Self {
            q: vec![0.0; ws.driven().len()],
            current: ws.zero_readings(),
            scale_m: s.readings.as_ref().map_or(1.0, |r| r.scale_m),
            parser,
            ws,
        })
    }

    /// Readings column of each driven tendon (the order `solve` takes them in).
    #[getter]
    fn columns(&self) -> Vec<String> {
        self.ws.columns().to_vec()
    }

    /// Cable name of each driven tendon.
    #[getter]
    fn cable_names(&self) -> Vec<String> {
        let robot = self.ws.workspace().robot();
        self.ws
            .driven()
            .iter()
            .map(|&j| robot.cables()[j].name.clone())
            .collect()
    }

    /// Metres per unit of a readings file's tendon columns (`[readings] scale_m`,
    /// default 1). `solve` takes metres; `solve_line` applies this scale itself.
    #[getter]
    fn scale_m(&self) -> f64 {
        self.scale_m
    }

    /// Free length `L0` of each driven tendon at reading 0 (m).
    #[getter]
    fn rest_free_lengths<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.ws.rest_free_lengths())
    }

    /// Budget of every later solve (the scene's `numerics.tendons.max_passes` and
    /// `time_budget_s`): at most `max_passes` rod evaluations and `time_budget_s`
    /// seconds of wall time per row (None: no limit, the default). A row that runs
    /// out ends with report status `"budget_exhausted"` at about the budget
    /// (overshoot: one evaluation, or one Jacobian sweep and the evaluation after
    /// it) and is rolled back like any row that does not converge; a budgeted row
    /// does not run the nested fallback (docs/control-loop-budget.md). A bad value
    /// (0 passes, more than 100 000, a time that is not positive) raises
    /// `SceneError` naming the field and changes nothing.
    #[pyo3(signature = (max_passes = None, time_budget_s = None))]
    fn set_budget(
        &mut self,
        py: Python<'_>,
        max_passes: Option<usize>,
        time_budget_s: Option<f64>,
    ) -> PyResult<()> {
        let settings = cablesense::tendons::TendonSettings {
            max_passes,
            time_budget_s,
            ..*self.ws.tendon_settings()
        };
        self.ws
            .set_tendon_settings(settings)
            .map_err(|e| from_model_error(py, e))
    }

    /// Solve one row: `readings` (m, one per driven tendon, in `columns` order; a
    /// sequence or a 1-D float array; None: the readings of `set_readings`, else of
    /// the last row). Warm from the previous solve unless `warm=False`. Returns
    /// {tip (3,), section_tips (k, 3), tensions (p,) N, taut (p,) bool, lengths (c,)
    /// m of every cable, report}. A bad reading (wrong count, NaN, pulling in more
    /// than the whole tendon) raises `ReadingsError` whose `field` names it, e.g.
    /// `readings[1] (s1b)`; a value that is not a sequence of numbers `TypeError`.
    #[pyo3(signature = (readings = None, warm = true))]
    fn solve<'py>(
        &mut self,
        py: Python<'py>,
        readings: Option<&Bound<'py, PyAny>>,
        warm: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let p = self.current.len();
        match readings {
            Some(r) => read_f64s(r, &mut self.q, "readings", || format!("{p} readings (m)"))?,
            None => self.q.clone_from(&self.current),
        }
        let start = if warm { Start::Warm } else { Start::Cold };
        let (ws, q) = (&mut self.ws, &self.q);
        let row = py
            .detach(|| {
                let report = ws.solve_readings_from(q, start)?;
                Ok::<_, ModelError>(Row::take(ws, report, false))
            })
            .map_err(|e| readings_err(py, e, None))?;
        self.current.clone_from(&self.q);
        row_dict(py, &row)
    }

    /// Set the readings (m, in `columns` order) that the next `solve()` without
    /// readings solves, warm from the current state; checked now (`ReadingsError`
    /// as `solve`), nothing is solved yet.
    fn set_readings(&mut self, py: Python<'_>, readings: &Bound<'_, PyAny>) -> PyResult<()> {
        let p = self.current.len();
        read_f64s(readings, &mut self.q, "readings", || {
            format!("{p} readings (m)")
        })?;
        self.ws
            .validate_readings(&self.q)
            .map_err(|e| readings_err(py, e, None))?;
        self.current.clone_from(&self.q);
        Ok(())
    }

    /// The readings `solve()` without readings solves (m, `columns` order).
    #[getter]
    fn readings<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.current)
    }

    /// Replace the external loads of the next solves on the live solver, keeping its
    /// warm start (no new scene, no cold reference solve): `loads` has the layout of
    /// the scene's `[loads]` table (`gravity_m_s2`, `point`, `tensions_n`); keys not
    /// given keep their values. Driven and passive tendons keep tension 0 (theirs
    /// follow from the readings). Each tendon's free length at reading 0 stays the
    /// one fixed at construction (a payload does not change a tendon's length), so
    /// this is the same robot carrying other loads, not `TendonSolver` of a scene
    /// with these loads (whose reference solve would fix other free lengths). A bad
    /// value raises `SceneError` naming the field and changes nothing.
    fn set_loads(&mut self, py: Python<'_>, loads: &Bound<'_, PyDict>) -> PyResult<()> {
        let merged = merged_loads(py, self.ws.workspace().loads(), loads)?;
        self.ws
            .set_loads(&merged)
            .map_err(|e| from_model_error(py, e))
    }

    /// The external loads in effect, as a dict with the layout of the `[loads]` table.
    #[getter]
    fn loads<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        loads_dict(py, self.ws.workspace().loads())
    }

    /// Solve every row of a 2-D float array `rows` (n, p) in order, warm-started
    /// from row to row (and from the previous call), with the GIL released for the
    /// whole batch. Returns {tip (n, 3), section_tips (n, k, 3), tensions (n, p),
    /// taut (n, p) bool, converged (n,) bool, status [n], iterations (n,),
    /// diagnosis [n] (why a row did not converge, None for a converged one)}; with
    /// `shapes=True` also `s` (m,) arc length of the stations (m) and `shapes`
    /// (n, m, 3), the backbone of every row (m; a row that did not converge has its
    /// failed attempt's). A bad reading raises `ReadingsError` with `field`
    /// `rows[i].readings[j] (column)`; the rows before it are solved and the solver
    /// keeps their state. `rows` that numpy cannot make a 2-D float array of `p`
    /// columns raise `TypeError` (`ValueError` for a wrong column count) saying the
    /// shape expected and the one given.
    #[pyo3(signature = (rows, shapes = false))]
    fn solve_many<'py>(
        &mut self,
        py: Python<'py>,
        rows: &Bound<'py, PyAny>,
        shapes: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let p = self.current.len();
        let rows_in = read_rows(py, rows, p, "rows", &format!("{p} readings (m)"))?;
        if rows_in.cols != p {
            return Err(readings_err(
                py,
                ModelError::Invalid {
                    field: "rows".into(),
                    why: format!(
                        "{} columns for {p} displacement-driven tendons ({})",
                        rows_in.cols, rows_in.shape_msg
                    ),
                },
                None,
            ));
        }
        let (n, data) = (rows_in.n, rows_in.data);
        let ws = &mut self.ws;
        let solved = py.detach(|| {
            let mut out: Vec<Row> = Vec::with_capacity(n);
            for (i, q) in data.chunks_exact(p.max(1)).take(n).enumerate() {
                let report = ws.solve_readings(q).map_err(|e| in_row(e, i))?;
                out.push(Row::take(ws, report, shapes));
            }
            Ok::<_, ModelError>(out)
        });
        let solved = solved.map_err(|e| readings_err(py, e, None))?;
        if n > 0 {
            self.current.copy_from_slice(&data[(n - 1) * p..n * p]);
        }
        let k = self.ws.workspace().robot().sections().len();
        let d = PyDict::new(py);
        let flat =
            |f: &dyn Fn(&Row) -> Vec<f64>| -> Vec<f64> { solved.iter().flat_map(f).collect() };
        d.set_item(
            "tip",
            PyArray1::from_vec(py, flat(&|r| r.tip.to_vec())).reshape([n, 3])?,
        )?;
        d.set_item(
            "section_tips",
            PyArray1::from_vec(py, flat(&|r| r.section_tips.clone())).reshape([n, k, 3])?,
        )?;
        d.set_item(
            "tensions",
            PyArray1::from_vec(py, flat(&|r| r.tensions.clone())).reshape([n, p])?,
        )?;
        let taut: Vec<bool> = solved.iter().flat_map(|r| r.taut.clone()).collect();
        let taut: Bound<'py, PyArray2<bool>> = PyArray1::from_vec(py, taut).reshape([n, p])?;
        d.set_item("taut", taut)?;
        let converged: Vec<bool> = solved
            .iter()
            .map(|r| r.report.status.is_converged())
            .collect();
        d.set_item("converged", PyArray1::from_vec(py, converged))?;
        let status: Vec<String> = solved
            .iter()
            .map(|r| report_status(r.report.status))
            .collect();
        d.set_item("status", status)?;
        let iterations: Vec<u64> = solved.iter().map(|r| r.report.iterations as u64).collect();
        d.set_item("iterations", PyArray1::from_vec(py, iterations))?;
        let diagnosis: Vec<Option<String>> = solved.iter().map(|r| r.diagnosis.clone()).collect();
        d.set_item("diagnosis", diagnosis)?;
        if shapes {
            // every row samples the same stations (the integration grid of the
            // robot); a row that did not would make the stack ragged
            let s: Vec<f64> = solved
                .first()
                .and_then(|r| r.shape.as_ref())
                .map(|(s, _)| s.clone())
                .unwrap_or_default();
            let m = s.len();
            let mut all = Vec::with_capacity(n * m * 3);
            for (i, r) in solved.iter().enumerate() {
                let (si, ri) = r.shape.as_ref().map(|(a, b)| (a, b)).unwrap_or((&s, &s));
                if si.len() != m {
                    return Err(pyo3::exceptions::PyValueError::new_err(format!(
                        "rows[{i}]: {} stations where row 0 has {m}: the shapes do not stack",
                        si.len()
                    )));
                }
                all.extend_from_slice(ri);
            }
            d.set_item("s", PyArray1::from_vec(py, s))?;
            d.set_item("shapes", PyArray1::from_vec(py, all).reshape([n, m, 3])?)?;
        }
        Ok(d)
    }

    /// Feed one line of a readings file (CSV with a header, or JSON lines; the
    /// scene's `[readings]` table maps columns and scale) and solve it warm.
    /// Returns None for a header, comment or blank line, else the `solve` dict plus
    /// `line`, `t_s` (or None), `readings` (m) and `measured_tip` (m, or None). A
    /// missing cell keeps that tendon's last reading. A bad line raises
    /// `ReadingsError` with `line` and `field` (the column) and leaves the solver as
    /// it was, so the stream can go on.
    fn solve_line<'py>(
        &mut self,
        py: Python<'py>,
        line_no: usize,
        text: &str,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        let row: ReadingRow = match self.parser.line(line_no, text) {
            Ok(None) => return Ok(None),
            Ok(Some(r)) => r,
            Err(e) => {
                return Err(readings_err(
                    py,
                    ModelError::Invalid {
                        field: e.field.clone(),
                        why: e.why.clone(),
                    },
                    Some(e.line),
                ))
            }
        };
        let ws = &mut self.ws;
        let solved = py
            .detach(|| {
                let report = ws.solve_readings(&row.readings_m)?;
                Ok::<_, ModelError>(Row::take(ws, report, false))
            })
            .map_err(|e| readings_err(py, e, Some(row.line)))?;
        self.current.clone_from(&row.readings_m);
        let d = row_dict(py, &solved)?;
        d.set_item("line", row.line)?;
        d.set_item("t_s", row.t_s)?;
        d.set_item("readings", PyArray1::from_vec(py, row.readings_m))?;
        d.set_item(
            "measured_tip",
            row.measured_tip_m.map(|t| PyArray1::from_slice(py, &t)),
        )?;
        Ok(Some(d))
    }

    /// The full solution of the last solve: the dict of `cablesense.solve` (samples
    /// `s`, `r`, `R`, tip, section tips, cable lengths) whose `report` is the row's
    /// report as `solve` returns it (status, converged, iterations, residual_m,
    /// forward_solves, slack, and diagnosis when it did not converge): a row solves
    /// shape and tensions together, so the inner shooting workspace has no report of
    /// its own for it. After a row that did not converge, the failed attempt's shape.
    fn solution<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let ws = &mut self.ws;
        let (sol, report, why) = py.detach(|| {
            let report = *ws.report();
            let why = (!report.status.is_converged()).then(|| ws.diagnose().to_string());
            (ws.workspace_mut().solution(), report, why)
        });
        let d = solution_dict(py, &sol)?;
        let rep = report_dict(py, &report)?;
        if let Some(why) = why {
            rep.set_item("diagnosis", why)?;
        }
        d.set_item("report", rep)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!("TendonSolver(tendons {:?})", self.ws.columns())
    }
}
