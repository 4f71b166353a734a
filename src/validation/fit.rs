//! Least-squares calibration of named scene parameters against table columns.
//!
//! Residuals (m), per table, row and tracked item:
//! - [`Target::Predicted`]: our tip `x, y` minus the thesis's predicted `x, y`, and our
//!   cable length minus the thesis's predicted length (absolute lengths: the thesis
//!   printed them).
//! - [`Target::Observed`]: our tip minus the observed tip, and our length change
//!   minus the observed change for the loaded rows (only changes were observed).
//!
//! Unknowns are scaled, `z_i = p_i / |p_i(0)|`, so moduli (1e10 Pa) and radii
//! (1e-2 m) are both of order one; the Jacobian is by central differences of
//! relative step [`FitSettings::fd_step`] (each column costs two sweeps over the rows).
//!
//! Two methods: the damped Levenberg-Marquardt of the calibration layer (default;
//! [`crate::calibrate::levenberg_marquardt`], the same code that calibrates a robot
//! from a recording), and argmin's
//! Gauss-Newton. argmin 0.11 has no Levenberg-Marquardt, its Gauss-Newton takes
//! full steps (no safeguard when a trial point is invalid, e.g. a negative
//! modulus, or when a row stops converging) and inverts `J^T J`, failing when a
//! parameter does not affect the selected columns. LM's damping handles all three.
//! Both reach the same optimum on the well-posed thesis fits; argmin's oscillates on a
//! weakly identified parameter (4.2's pen-scale tilt) and stops on a rank-deficient
//! one (data/thesis/README.md, "Fitting method").

use super::compare::compare;
use super::tables::TableData;
use super::ValidationError;
use crate::calibrate::{Bounds, LeastSquares, LmSettings, LmStatus};
use crate::files::Scene;
use crate::scene::param::{set_values, ParamPath};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::cell::Cell;
use std::fmt;
use std::str::FromStr;

/// Which columns the parameters are fitted to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Target {
    /// The thesis model's predicted columns: reproduce the thesis's model.
    Predicted,
    /// The measured columns: calibrate the model to the experiment.
    Observed,
}

impl FromStr for Target {
    type Err = ValidationError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "predicted" | "pred" => Ok(Self::Predicted),
            "observed" | "obs" => Ok(Self::Observed),
            other => Err(ValidationError::BadFit(format!(
                "unknown target `{other}` (predicted | observed)"
            ))),
        }
    }
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Predicted => "predicted",
            Self::Observed => "observed",
        })
    }
}

/// Fitting algorithm.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FitMethod {
    /// Levenberg-Marquardt with Marquardt's diagonal scaling and Nielsen's damping update.
    #[default]
    LevenbergMarquardt,
    /// argmin's `GaussNewton` (full steps) on `DVector`/`DMatrix`.
    GaussNewton,
}

impl FromStr for FitMethod {
    type Err = ValidationError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "lm" | "levenberg-marquardt" => Ok(Self::LevenbergMarquardt),
            "gn" | "gauss-newton" | "argmin-gn" => Ok(Self::GaussNewton),
            other => Err(ValidationError::BadFit(format!(
                "unknown method `{other}` (lm | gn)"
            ))),
        }
    }
}

/// Settings of [`fit`].
#[derive(Clone, Debug, PartialEq)]
pub struct FitSettings {
    /// Algorithm (default Levenberg-Marquardt).
    pub method: FitMethod,
    /// Iteration limit (default 50).
    pub max_iterations: usize,
    /// Relative central-difference step on the scaled unknowns (default 1e-5).
    pub fd_step: f64,
    /// Stop when the cost decreases by less than this fraction in an accepted
    /// step, or the scaled step is shorter than this (default 1e-10).
    pub tolerance: f64,
}

impl Default for FitSettings {
    fn default() -> Self {
        Self {
            method: FitMethod::LevenbergMarquardt,
            max_iterations: 50,
            fd_step: 1e-5,
            tolerance: 1e-10,
        }
    }
}

/// How a fit ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FitStatus {
    /// Cost change or step below the tolerance: a (local) minimum. Usable.
    Converged,
    /// Iteration limit: the best point so far. Check the residuals.
    MaxIterations,
    /// No damping produced a decrease (flat or invalid neighbourhood). The best point
    /// so far; usable if its residuals are acceptable.
    Stalled,
}

/// Residual assembly: scene + tables + named parameters + target.
pub struct FitProblem {
    scene: Scene,
    tables: Vec<TableData>,
    params: Vec<ParamPath>,
    target: Target,
    scale: Vec<f64>,
    labels: Vec<String>,
    evaluations: Cell<usize>,
}

impl FitProblem {
    /// A problem fitting `params` of `scene` to `target` columns of `tables`
    /// (all modelled by `scene`).
    pub fn new(
        scene: Scene,
        tables: Vec<TableData>,
        params: Vec<ParamPath>,
        target: Target,
    ) -> Result<Self, ValidationError> {
        if params.is_empty() {
            return Err(ValidationError::BadFit("no parameter to fit".into()));
        }
        if tables.is_empty() {
            return Err(ValidationError::BadFit("no table to fit to".into()));
        }
        for t in &tables {
            if target == Target::Predicted && t.spec.predicted_is_copy {
                return Err(ValidationError::BadFit(format!(
                    "table {}'s predicted columns are a copy of table 4.3's (README \"Table 4.4 caveat\"); \
                     fit the accurate model to `--target observed` or to table 4.5acc instead",
                    t.table
                )));
            }
        }
        let mut scale = Vec::with_capacity(params.len());
        for p in &params {
            let v = p.value(&scene)?;
            scale.push(if v != 0.0 { v.abs() } else { 1.0 });
        }
        let mut labels = Vec::new();
        for t in &tables {
            for r in 0..t.rows {
                for p in t.spec.points {
                    for c in ["x", "y"] {
                        labels.push(format!("{} row {} {} {c}", t.table, r, p.label));
                    }
                }
                for l in t.spec.lengths {
                    if target == Target::Predicted {
                        labels.push(format!("{} row {} {} length", t.table, r, l.label));
                    } else if r > 0 {
                        labels.push(format!("{} row {} {} delta", t.table, r, l.label));
                    }
                }
            }
        }
        if labels.is_empty() {
            return Err(ValidationError::BadFit(
                "the tables have no column to fit".into(),
            ));
        }
        Ok(Self {
            scene,
            tables,
            params,
            target,
            scale,
            labels,
            evaluations: Cell::new(0),
        })
    }

    /// The parameters.
    pub fn params(&self) -> &[ParamPath] {
        &self.params
    }
    /// The target.
    pub fn target(&self) -> Target {
        self.target
    }
    /// The tables.
    pub fn tables(&self) -> &[TableData] {
        &self.tables
    }
    /// One label per residual (`4.3 row 2 tip y`).
    pub fn labels(&self) -> &[String] {
        &self.labels
    }
    /// Parameter values in the scene (the starting point).
    pub fn initial(&self) -> Result<Vec<f64>, ValidationError> {
        self.params
            .iter()
            .map(|p| p.value(&self.scene).map_err(Into::into))
            .collect()
    }
    /// Residual vectors evaluated so far.
    pub fn evaluations(&self) -> usize {
        self.evaluations.get()
    }

    /// The scene with the parameters set to `values`.
    pub fn scene_with(&self, values: &[f64]) -> Result<Scene, ValidationError> {
        let scene = set_values(&self.scene, &self.params, values)?;
        scene.validate().map_err(|cause| ValidationError::Model {
            context: format!("scene with {}", describe(&self.params, values)),
            cause,
        })?;
        Ok(scene)
    }

    /// Residuals (m) at parameter `values`, in [`FitProblem::labels`] order. Any row
    /// that does not converge is an error.
    pub fn residuals(&self, values: &[f64]) -> Result<Vec<f64>, ValidationError> {
        self.evaluations.set(self.evaluations.get() + 1);
        let scene = self.scene_with(values)?;
        let mut out = Vec::with_capacity(self.labels.len());
        for t in &self.tables {
            let c = compare(t, &scene)?;
            for (r, row) in c.rows.iter().enumerate() {
                if !row.status.is_converged() {
                    return Err(ValidationError::NotConverged {
                        table: t.table.name().into(),
                        row: r,
                        status: row.status,
                        residual: row.residual,
                    });
                }
                for p in &row.points {
                    let want = match self.target {
                        Target::Predicted => p.thesis,
                        Target::Observed => p.observed,
                    };
                    out.push(p.ours[0] - want[0]);
                    out.push(p.ours[1] - want[1]);
                }
                for l in &row.lengths {
                    match self.target {
                        Target::Predicted => out.push(l.ours_length - l.thesis_length),
                        Target::Observed if r > 0 => out.push(l.ours_delta - l.observed_delta),
                        Target::Observed => {}
                    }
                }
            }
        }
        Ok(out)
    }

    fn unscale(&self, z: &[f64]) -> Vec<f64> {
        z.iter().zip(&self.scale).map(|(z, s)| z * s).collect()
    }

    fn residuals_scaled(&self, z: &[f64]) -> Result<DVector<f64>, ValidationError> {
        Ok(DVector::from_vec(self.residuals(&self.unscale(z))?))
    }

    /// Central-difference Jacobian in the scaled unknowns.
    fn jacobian_scaled(&self, z: &[f64], h: f64) -> Result<DMatrix<f64>, ValidationError> {
        let m = self.labels.len();
        let mut j = DMatrix::zeros(m, z.len());
        let mut zp = z.to_vec();
        for i in 0..z.len() {
            let hi = h * z[i].abs().max(1.0);
            zp[i] = z[i] + hi;
            let rp = self.residuals_scaled(&zp)?;
            zp[i] = z[i] - hi;
            let rm = self.residuals_scaled(&zp)?;
            zp[i] = z[i];
            j.set_column(i, &((rp - rm) / (2.0 * hi)));
        }
        Ok(j)
    }
}

fn describe(params: &[ParamPath], values: &[f64]) -> String {
    params
        .iter()
        .zip(values)
        .map(|(p, v)| format!("{p} = {v:e}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Result of [`fit`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitReport {
    /// Method used.
    pub method: FitMethod,
    /// How it ended.
    pub status: FitStatus,
    /// Parameter paths.
    pub params: Vec<String>,
    /// Starting values.
    pub initial: Vec<f64>,
    /// Fitted values.
    pub values: Vec<f64>,
    /// Formal standard errors `sqrt(diag(s^2 (J^T J)^-1))`, `s^2 = SSR / (m - n)`,
    /// in parameter units; NaN when not identifiable (or no degrees of freedom).
    pub std_errors: Vec<f64>,
    /// Residual labels.
    pub labels: Vec<String>,
    /// Residuals at the fitted values (m).
    pub residuals: Vec<f64>,
    /// Root mean square residual (m).
    pub rms_m: f64,
    /// Largest |residual| (m).
    pub max_abs_m: f64,
    /// Iterations.
    pub iterations: usize,
    /// Residual-vector evaluations (each a forward solve of every row).
    pub evaluations: usize,
}

/// Fit the problem's parameters by least squares.
pub fn fit(problem: &FitProblem, settings: &FitSettings) -> Result<FitReport, ValidationError> {
    let x0 = problem.initial()?;
    let z0: Vec<f64> = x0.iter().zip(&problem.scale).map(|(x, s)| x / s).collect();
    let start_evals = problem.evaluations();
    let (z, iterations, status) = match settings.method {
        FitMethod::LevenbergMarquardt => levenberg_marquardt(problem, &z0, settings)?,
        FitMethod::GaussNewton => gauss_newton_argmin(problem, &z0, settings)?,
    };
    let values = problem.unscale(&z);
    let residuals = problem.residuals(&values)?;
    let jac = problem.jacobian_scaled(&z, settings.fd_step)?;
    let (m, n) = (residuals.len(), values.len());
    let ssr: f64 = residuals.iter().map(|r| r * r).sum();
    let std_errors = match (jac.transpose() * &jac).try_inverse() {
        Some(inv) if m > n => (0..n)
            .map(|i| {
                let v = inv[(i, i)] * ssr / (m - n) as f64;
                if v.is_finite() && v >= 0.0 {
                    v.sqrt() * problem.scale[i]
                } else {
                    f64::NAN
                }
            })
            .collect(),
        _ => vec![f64::NAN; n],
    };
    Ok(FitReport {
        method: settings.method,
        status,
        params: problem.params.iter().map(|p| p.to_string()).collect(),
        initial: x0,
        values,
        std_errors,
        labels: problem.labels.clone(),
        rms_m: (ssr / m as f64).sqrt(),
        max_abs_m: residuals.iter().fold(0.0, |a, r| a.max(r.abs())),
        residuals,
        iterations,
        evaluations: problem.evaluations() - start_evals,
    })
}

/// The scaled residuals of a [`FitProblem`] as a least-squares problem of the
/// calibration layer (central-difference Jacobian of relative step `h`).
struct Scaled<'a> {
    problem: &'a FitProblem,
    h: f64,
}

impl LeastSquares for Scaled<'_> {
    type Error = ValidationError;
    fn unknowns(&self) -> usize {
        self.problem.params.len()
    }
    fn residual_count(&self) -> usize {
        self.problem.labels.len()
    }
    fn residuals(&mut self, z: &[f64], out: &mut [f64]) -> Result<(), ValidationError> {
        out.copy_from_slice(self.problem.residuals_scaled(z)?.as_slice());
        Ok(())
    }
    fn jacobian(
        &mut self,
        z: &[f64],
        _r: &[f64],
        jac: &mut DMatrix<f64>,
    ) -> Result<(), ValidationError> {
        *jac = self.problem.jacobian_scaled(z, self.h)?;
        Ok(())
    }
}

/// Damped Gauss-Newton (Levenberg-Marquardt) in the scaled unknowns: the calibration
/// layer's [`crate::calibrate::levenberg_marquardt`] (Madsen, Nielsen & Tingleff 2004,
/// algorithm 3.16, Marquardt's `diag(J^T J)` scaling), unbounded, least squares.
fn levenberg_marquardt(
    problem: &FitProblem,
    z0: &[f64],
    s: &FitSettings,
) -> Result<(Vec<f64>, usize, FitStatus), ValidationError> {
    let settings = LmSettings {
        max_iterations: s.max_iterations,
        tolerance: s.tolerance,
        ..LmSettings::default()
    };
    let mut ls = Scaled {
        problem,
        h: s.fd_step,
    };
    let res = crate::calibrate::levenberg_marquardt(
        &mut ls,
        z0,
        &Bounds::none(z0.len()),
        &settings,
        &mut |_| {},
    )?;
    let status = match res.status {
        LmStatus::Converged => FitStatus::Converged,
        LmStatus::MaxIterations => FitStatus::MaxIterations,
        // (not produced by the LM itself; only `calibrate` sets it)
        LmStatus::Stalled | LmStatus::TooManyFailedRows => FitStatus::Stalled,
    };
    Ok((res.z, res.iterations, status))
}

/// argmin's Gauss-Newton on the same residuals (in mm, so its absolute cost
/// tolerance is meaningful).
fn gauss_newton_argmin(
    problem: &FitProblem,
    z0: &[f64],
    s: &FitSettings,
) -> Result<(Vec<f64>, usize, FitStatus), ValidationError> {
    use argmin::core::{Executor, Jacobian, Operator, TerminationReason, TerminationStatus};
    use argmin::solver::gaussnewton::GaussNewton;

    struct Adapter<'a> {
        problem: &'a FitProblem,
        h: f64,
    }
    impl Operator for Adapter<'_> {
        type Param = DVector<f64>;
        type Output = DVector<f64>;
        fn apply(&self, z: &Self::Param) -> Result<Self::Output, argmin::core::Error> {
            Ok(self.problem.residuals_scaled(z.as_slice())? * 1e3)
        }
    }
    impl Jacobian for Adapter<'_> {
        type Param = DVector<f64>;
        type Jacobian = DMatrix<f64>;
        fn jacobian(&self, z: &Self::Param) -> Result<Self::Jacobian, argmin::core::Error> {
            Ok(self.problem.jacobian_scaled(z.as_slice(), self.h)? * 1e3)
        }
    }
    let solver = GaussNewton::new()
        .with_tolerance(s.tolerance.max(1e-15))
        .map_err(|e| ValidationError::BadFit(e.to_string()))?;
    let res = Executor::new(
        Adapter {
            problem,
            h: s.fd_step,
        },
        solver,
    )
    .configure(|st| {
        st.param(DVector::from_column_slice(z0))
            .max_iters(s.max_iterations as u64)
    })
    .run()
    .map_err(|e| ValidationError::BadFit(format!("argmin Gauss-Newton: {e}")))?;
    let st = &res.state;
    let z = st
        .best_param
        .clone()
        .or_else(|| st.param.clone())
        .ok_or_else(|| ValidationError::BadFit("argmin returned no parameter".into()))?;
    let status = match &st.termination_status {
        TerminationStatus::Terminated(TerminationReason::SolverConverged) => FitStatus::Converged,
        TerminationStatus::Terminated(TerminationReason::MaxItersReached) => {
            FitStatus::MaxIterations
        }
        _ => FitStatus::Stalled,
    };
    Ok((z.as_slice().to_vec(), st.iter as usize, status))
}
