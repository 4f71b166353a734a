//! Solve every row of a table and line up observed, thesis-predicted and our
//! tip points and cable lengths.
//!
//! Error metric of the thesis (4.6.4): Euclidean distance between two tip points
//! divided by a reference length, in percent ([`TableSpec::ref_length_m`]).
//! Cable lengths (4.7.4): `delta` = length minus the length in the unloaded first
//! row; `del dif` = observed delta - predicted delta, averaged over the loaded rows.
//!
//! [`TableSpec::ref_length_m`]: super::TableSpec::ref_length_m

use super::tables::TableData;
use super::{ThesisTable, ValidationError};
use crate::files::Scene;
use crate::statics::{Solution, SolveStatus, Start, Workspace};

/// Solve every row of `data` with `scene` (robot, numerics and loads template).
///
/// Rows are solved in order in one [`Workspace`], each warm-started from the
/// previous row and retried cold if that fails. Non-convergence is not an error:
/// each solution carries its [`SolveStatus`].
pub fn simulate(data: &TableData, scene: &Scene) -> Result<Vec<Solution>, ValidationError> {
    let model = |cause| ValidationError::Model {
        context: format!(
            "table {} with scene {}",
            data.table,
            data.scene_path.display()
        ),
        cause,
    };
    let robot = scene.build_robot().map_err(model)?;
    let first = data.row_loads(scene, 0)?;
    let mut ws = Workspace::new(robot, first, scene.numerics.clone()).map_err(model)?;
    let mut out = Vec::with_capacity(data.rows);
    for row in 0..data.rows {
        let loads = data.row_loads(scene, row)?;
        ws.set_loads(&loads).map_err(model)?;
        if !ws.solve(Start::Warm).status.is_converged() {
            ws.solve(Start::Cold);
        }
        out.push(ws.solution());
    }
    Ok(out)
}

/// One tracked point in one row (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointRow {
    /// Observed `[x, y]`.
    pub observed: [f64; 2],
    /// Thesis-predicted `[x, y]`.
    pub thesis: [f64; 2],
    /// Our `[x, y]`.
    pub ours: [f64; 2],
    /// Error the thesis printed for this row (%).
    pub thesis_err_pct_printed: f64,
    /// |thesis - observed|, recomputed from the printed coordinates.
    pub err_thesis_obs_m: f64,
    /// |ours - observed|.
    pub err_ours_obs_m: f64,
    /// |ours - thesis|.
    pub err_ours_thesis_m: f64,
}

/// One cable in one row (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LengthRow {
    /// Observed change from row 0.
    pub observed_delta: f64,
    /// Thesis model length.
    pub thesis_length: f64,
    /// Thesis model change (as printed).
    pub thesis_delta: f64,
    /// Our length (base plate to the termination disk).
    pub ours_length: f64,
    /// Our change from row 0.
    pub ours_delta: f64,
}

/// One row of a comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct RowComparison {
    /// The row's load values (kg), in [`TableSpec::loads`](super::TableSpec::loads) order.
    pub loads: Vec<f64>,
    /// Solve status of the row.
    pub status: SolveStatus,
    /// Scaled boundary residual of the row's solve.
    pub residual: f64,
    /// Tracked points.
    pub points: Vec<PointRow>,
    /// Tracked cables.
    pub lengths: Vec<LengthRow>,
}

/// Summary of one tracked point over all rows.
#[derive(Clone, Debug, PartialEq)]
pub struct PointSummary {
    /// Label (`s1`, `s2`, `tip`).
    pub label: &'static str,
    /// Mean of |ours - observed| / L_ref (%).
    pub mean_pct_ours_obs: f64,
    /// Mean of |thesis - observed| / L_ref (%), recomputed from the coordinates.
    pub mean_pct_thesis_obs: f64,
    /// Mean of the printed error column (%).
    pub mean_pct_printed: f64,
    /// The thesis's printed average (%).
    pub thesis_avg_pct: f64,
    /// Largest |ours - thesis| (m).
    pub max_ours_thesis_m: f64,
    /// Root mean square of |ours - thesis| (m).
    pub rms_ours_thesis_m: f64,
    /// Largest |ours - observed| (m).
    pub max_ours_obs_m: f64,
}

/// Summary of one tracked cable over all rows.
#[derive(Clone, Debug, PartialEq)]
pub struct LengthSummary {
    /// Label.
    pub label: &'static str,
    /// Largest |our length - thesis length| (m).
    pub max_ours_thesis_m: f64,
    /// Mean of observed delta - our delta over the loaded rows (m).
    pub mean_del_dif_ours_m: f64,
    /// Mean of observed delta - thesis delta over the loaded rows (m), recomputed.
    pub mean_del_dif_thesis_m: f64,
    /// The thesis's printed mean `del dif` (m).
    pub thesis_avg_del_dif_m: f64,
    /// Our length in row 0 (the thesis's `refLenPre`) (m).
    pub ours_ref_length_m: f64,
    /// Thesis length in row 0 (m).
    pub thesis_ref_length_m: f64,
}

/// Observed, thesis-predicted and our values for every row of one table.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// Which table.
    pub table: ThesisTable,
    /// Reference length of the % error (m).
    pub ref_length_m: f64,
    /// Rows.
    pub rows: Vec<RowComparison>,
    /// Per tracked point.
    pub points: Vec<PointSummary>,
    /// Per tracked cable.
    pub lengths: Vec<LengthSummary>,
    /// Our full solution of each row (backbone samples for plots).
    pub solutions: Vec<Solution>,
}

impl Comparison {
    /// True when every row's solve converged.
    pub fn all_converged(&self) -> bool {
        self.rows.iter().all(|r| r.status.is_converged())
    }
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}

/// Solve every row of `data` with `scene` and compare.
pub fn compare(data: &TableData, scene: &Scene) -> Result<Comparison, ValidationError> {
    let solutions = simulate(data, scene)?;
    let spec = data.spec;
    let cable_len = |sol: &Solution, cable: usize| -> Result<f64, ValidationError> {
        sol.cables
            .get(cable)
            .map(|c| c.total_m)
            .ok_or_else(|| ValidationError::Model {
                context: format!("table {}", data.table),
                cause: crate::ModelError::BadIndex {
                    field: "lengths.cable".into(),
                    index: cable,
                    count: sol.cables.len(),
                },
            })
    };
    let mut ref_len = Vec::with_capacity(spec.lengths.len());
    for l in spec.lengths {
        ref_len.push(cable_len(&solutions[0], l.cable)?);
    }
    let mut rows = Vec::with_capacity(data.rows);
    for (r, sol) in solutions.iter().enumerate() {
        let points = spec
            .points
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let tip = sol.section_tips[p.section].position;
                let ours = [tip.x, tip.y];
                let (observed, thesis) = (data.observed[k][r], data.predicted[k][r]);
                PointRow {
                    observed,
                    thesis,
                    ours,
                    thesis_err_pct_printed: data.thesis_err_pct[k][r],
                    err_thesis_obs_m: dist(thesis, observed),
                    err_ours_obs_m: dist(ours, observed),
                    err_ours_thesis_m: dist(ours, thesis),
                }
            })
            .collect();
        let lengths = spec
            .lengths
            .iter()
            .enumerate()
            .map(|(k, l)| {
                let ours_length = cable_len(sol, l.cable)?;
                Ok(LengthRow {
                    observed_delta: data.observed_delta[k][r],
                    thesis_length: data.predicted_length[k][r],
                    thesis_delta: data.predicted_delta[k][r],
                    ours_length,
                    ours_delta: ours_length - ref_len[k],
                })
            })
            .collect::<Result<_, ValidationError>>()?;
        rows.push(RowComparison {
            loads: data.load_values.iter().map(|v| v[r]).collect(),
            status: sol.report.status,
            residual: sol.report.residual,
            points,
            lengths,
        });
    }
    let pct = 100.0 / spec.ref_length_m;
    let points = spec
        .points
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let it = || rows.iter().map(move |r| r.points[k]);
            PointSummary {
                label: p.label,
                mean_pct_ours_obs: mean(it().map(|q| q.err_ours_obs_m * pct)),
                mean_pct_thesis_obs: mean(it().map(|q| q.err_thesis_obs_m * pct)),
                mean_pct_printed: mean(it().map(|q| q.thesis_err_pct_printed)),
                thesis_avg_pct: p.thesis_avg_pct,
                max_ours_thesis_m: it().map(|q| q.err_ours_thesis_m).fold(0.0, f64::max),
                rms_ours_thesis_m: mean(it().map(|q| q.err_ours_thesis_m.powi(2))).sqrt(),
                max_ours_obs_m: it().map(|q| q.err_ours_obs_m).fold(0.0, f64::max),
            }
        })
        .collect();
    let lengths = spec
        .lengths
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let it = || rows.iter().map(move |r| r.lengths[k]);
            LengthSummary {
                label: l.label,
                max_ours_thesis_m: it()
                    .map(|q| (q.ours_length - q.thesis_length).abs())
                    .fold(0.0, f64::max),
                mean_del_dif_ours_m: mean(it().skip(1).map(|q| q.observed_delta - q.ours_delta)),
                mean_del_dif_thesis_m: mean(
                    it().skip(1).map(|q| q.observed_delta - q.thesis_delta),
                ),
                thesis_avg_del_dif_m: l.thesis_avg_del_dif_m,
                ours_ref_length_m: ref_len[k],
                thesis_ref_length_m: data.predicted_length[k][0],
            }
        })
        .collect();
    Ok(Comparison {
        table: data.table,
        ref_length_m: spec.ref_length_m,
        rows,
        points,
        lengths,
        solutions,
    })
}
