//! Estimate layer: cable-length changes -> loads and shape.
//!
//! Design choice, nested versus joint, decided by measurement (`benches/joint.rs`,
//! log in `benches/README.md`, 2026-11-22, shared 2-core machine, methods compared
//! within one run):
//!
//! * **Nested** ([`Estimator`], the default): the forward shooting problem is solved
//!   to equilibrium for every trial `theta` (warm-started chord-Newton, a few f64
//!   passes), and the length sensitivities come from implicit differentiation of
//!   that equilibrium ([`Workspace::length_sensitivities`], one dual sweep over
//!   `[x; theta]`), reused across iterations and samples with Broyden updates.
//! * **Joint** ([`JointEstimator`], module `joint`): `x` and `theta` iterated
//!   together as an equality-constrained least-squares problem (null-space
//!   elimination of `dx`, LM on `theta`, l1 merit, second-order corrections), with
//!   one exact dual sweep over `[x; theta]` at the current, not necessarily
//!   equilibrium, point per iteration.
//!
//! Measured (medians; counts per tick are load-independent):
//!
//! | case | nested LM | nested LM, fresh sweeps | joint |
//! |---|---|---|---|
//! | warm tick, track demo (1 section, 3 cables, tip force) | **80 us**: 0 dual + 8 f64 passes | 459 us: 3 + 7 | 600 us: 3 + 5 |
//! | cold, same scene | **463 us**: 2 + 21 | 1.00 ms: 5 + 17 | 792 us: 4 + 17 |
//! | warm tick, two sections, two tensioned cables (36 shooting unknowns) | **0.82 ms**: 0 + 10 | 10.9 ms: 21 + 9 | 12.8 ms: 21 + 8 |
//! | cold, same scene | **10.2 ms**: 13 + 18 | 21.6 ms: 34 + 15 | 12.0 ms: 28 + 16 |
//! | unknown tensions from zero, 32 cases, 20 iterations | **32/32 converged** (mean 8 iterations) | | 16/32 (mean 13.7) |
//!
//! So the nested method is faster warm (7-16x: a warm tick needs no dual pass at
//! all, while every joint iteration needs one, ~15x the cost of an f64 pass) and
//! cold (1.2-1.7x), and more robust: its trial points are equilibria, so a large
//! cold step is judged by the true cost, while the joint trial points (first-order
//! predictor plus chord corrections) leave the equilibrium manifold and the l1
//! merit then forces short steps. With the same sensitivity policy (an exact sweep
//! every iteration) the joint method is the cheaper one (no inner forward solves:
//! 20-45 % faster cold), but giving it reused linearisations would turn its chord
//! corrections into the nested method's warm forward solve: the gap can close, not
//! reverse. The nested method also keeps every returned estimate a physically valid
//! shape when a time budget stops it early (the joint one re-solves the forward
//! problem at its best `theta` for that). Hence the default is nested LM, and the
//! joint method is a library type for comparisons, not a [`Method`].

// Index loops below mirror the matrix formulas (G^T W G, ...) on flat buffers.
#![allow(clippy::needless_range_loop)]

mod argmin_gn;
mod joint;
mod linalg;
mod model;
mod qp;
mod spec;

pub use joint::JointEstimator;
pub use model::{DynModel, EstimationModel, RungModel};
pub use spec::{Axis, EstimateSpec, Method, UnknownKind, UnknownSpec};

use crate::error::ModelError;
use crate::ladder::Rung;
use crate::loads::Loads;
use crate::robot::Robot;
use crate::settings::SolverSettings;
use crate::statics::{Pose, SolveStatus, Start, Workspace};
use linalg::sym_eigen;
use serde::{Deserialize, Serialize};
use std::time::Instant;
use thiserror::Error;

/// LM damping above which a tiny step is `Stalled`, not `Converged`.
const LM_MAX_CONVERGED_DAMPING: f64 = 1e2;
/// Trial steps per iteration before giving up.
const MAX_TRIALS: usize = 60;

/// How an estimate ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EstimateStatus {
    /// Step below tolerance with every direction observable. Usable.
    Converged,
    /// Converged, but some directions are unobservable (listed in the estimate):
    /// those components come from their prior or initial value, not from the data.
    /// Usable along the observable directions only.
    Unobservable,
    /// Iteration limit hit: best estimate so far (cost is reported). Use with care.
    MaxIterations,
    /// Time budget hit: best estimate so far. Use with care.
    TimeBudget,
    /// The cost could not be decreased (bad data or a local minimum). Not trusted.
    Stalled,
    /// The forward model did not converge at the trial loads (a load the robot
    /// cannot reach). The previous estimate is kept. Not trusted.
    ForwardFailed,
    /// No finite measurement and no prior: nothing to estimate from. Previous kept.
    NoData,
}

/// How well an estimate explains its data, judged from the RMS of the weighted cable
/// residuals `r_j / sigma_j` ([`Estimate::rms_sigma`]) against
/// [`EstimateSpec::poor_fit_rms_sigma`]. Independent of the [`EstimateStatus`]: a
/// `converged` estimate can be a poor fit (a model that cannot produce the data).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Fit {
    /// The residuals are within the threshold: consistent with the stated noise.
    Good,
    /// The residuals are beyond the threshold: the model, its parameters or the
    /// stated noise do not explain the data. Do not trust the values or covariance.
    Poor,
    /// As many independent measurements as observable unknowns (no redundancy): any
    /// data are fitted exactly, so the fit cannot be judged from the residuals.
    Untestable,
}

/// Why an estimator could not be built.
#[derive(Debug, Error)]
pub enum EstimateError {
    /// Invalid robot, loads, settings or estimation spec.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The forward model failed at the reference loads, so no reference lengths.
    #[error("forward solve at the reference loads failed: {0:?}")]
    Reference(SolveStatus),
}

/// One unobservable direction: unit vector over the unknowns (scaled by each
/// unknown's information), with the names it mostly involves.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Direction {
    /// `(name, component)` for components above 0.1 in magnitude.
    pub components: Vec<(String, f64)>,
}

/// A serializable estimate (allocating snapshot of the estimator's state).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// Outcome.
    pub status: EstimateStatus,
    /// Iterations of the last sample.
    pub iterations: usize,
    /// Sensitivity (Jacobian) evaluations in the last sample.
    pub jacobian_evals: u64,
    /// Unknown names.
    pub names: Vec<String>,
    /// Estimated values (SI: N, N m, kg).
    pub values: Vec<f64>,
    /// Standard deviations from the covariance (same units).
    pub std_dev: Vec<f64>,
    /// Covariance `(G^T W G + P)^+`, row-major `p x p`.
    pub covariance: Vec<f64>,
    /// Numerical rank of the scaled Fisher information `G^T W G`.
    pub rank: usize,
    /// Its condition number (largest / smallest eigenvalue; infinite when singular).
    pub condition: f64,
    /// Directions the cables cannot see.
    pub unobservable: Vec<Direction>,
    /// Measured cable length changes (m); `null` when missing.
    pub measured_m: Vec<Option<f64>>,
    /// Predicted cable length changes (m).
    pub predicted_m: Vec<f64>,
    /// Predicted minus measured (m); `null` when missing.
    pub residual_m: Vec<Option<f64>>,
    /// Weighted least-squares cost `0.5 (sum w r^2 + prior terms)`.
    pub cost: f64,
    /// RMS over the measured cables of `r_j / sigma_j` (noise sigmas, -); 0 with no
    /// measurement.
    pub rms_sigma: f64,
    /// Measured cables minus the rank: the residual's degrees of freedom.
    pub redundancy: usize,
    /// Whether the residual is consistent with the noise ([`Fit`]).
    pub fit: Fit,
    /// Tip pose of the estimated shape.
    pub tip: Pose,
    /// Section end poses of the estimated shape.
    pub section_tips: Vec<Pose>,
    /// Wall time of the last sample (s).
    pub elapsed_s: f64,
}

/// Estimator: allocate once, then [`Estimator::tick`] per sample without allocating
/// (methods other than `argmin_gauss_newton` and `constrained`).
///
/// Generic over its forward model ([`EstimationModel`]): the shooting [`Workspace`]
/// by default ([`Estimator::new`]), or any rung of the model ladder
/// ([`Estimator::on_rung`], [`Estimator::with_model`]). The methods, bounds, priors,
/// covariance and statuses are the same on every model.
#[derive(Clone)]
pub struct Estimator<M = Workspace> {
    ws: M,
    spec: EstimateSpec,
    names: Vec<String>,
    p: usize,
    c: usize,
    lb: Vec<f64>,
    ub: Vec<f64>,
    prior_mean: Vec<f64>,
    prior_w: Vec<f64>,
    theta: Vec<f64>,
    theta_trial: Vec<f64>,
    ref_len: Vec<f64>,
    len: Vec<f64>,
    meas: Vec<f64>,
    wts: Vec<f64>,
    g: Vec<f64>,
    len_prev: Vec<f64>,
    h: Vec<f64>,
    scratch: Vec<f64>,
    grad: Vec<f64>,
    step: Vec<f64>,
    eig_w: Vec<f64>,
    eig_v: Vec<f64>,
    dscale: Vec<f64>,
    cov: Vec<f64>,
    g_valid: bool,
    /// `g` is an exact sweep at the current `theta` (not reused, not Broyden-updated).
    g_exact: bool,
    /// Unknowns held at an active bound in the current step (projected methods).
    active: Vec<bool>,
    /// Unknowns with unbounded variance (unobservable, no prior).
    infinite_var: Vec<bool>,
    mu: f64,
    status: EstimateStatus,
    iterations: usize,
    jac_evals: u64,
    cost: f64,
    rank: usize,
    condition: f64,
    n_unobservable: usize,
    unobs_dirs: Vec<f64>,
    elapsed: f64,
}

impl Estimator {
    /// Build an estimator for `robot` under the known `loads`; unknowns add to them.
    pub fn new(
        robot: Robot,
        loads: Loads,
        settings: SolverSettings,
        spec: EstimateSpec,
    ) -> Result<Self, EstimateError> {
        spec.validate(&robot)?;
        loads.validate(&robot)?;
        let (loads, params) = model::sites(&spec, loads);
        let ws = Workspace::with_params(robot, loads, settings, &params)?;
        Self::with_model(ws, spec)
    }

    /// The forward workspace (current shape).
    pub fn workspace(&mut self) -> &mut Workspace {
        &mut self.ws
    }
}

impl Estimator<DynModel> {
    /// Build an estimator on any rung of the model ladder (constant curvature,
    /// piecewise constant curvature, Kirchhoff or Cosserat rod) under the known
    /// `loads`; unknowns add to them.
    pub fn on_rung(
        robot: Robot,
        loads: Loads,
        rung: &Rung,
        spec: EstimateSpec,
    ) -> Result<Self, EstimateError> {
        let model = model::build(robot, loads, rung, &spec)?;
        Self::with_model(model, spec)
    }
}

impl<M: EstimationModel> Estimator<M> {
    /// Build an estimator on `model`, whose parameters are the spec's unknowns in
    /// order; computes the reference lengths and solves at the initial values.
    pub fn with_model(ws: M, spec: EstimateSpec) -> Result<Self, EstimateError> {
        spec.validate(ws.robot())?;
        let p = spec.unknowns.len();
        if ws.params().len() != p {
            return Err(ModelError::Invalid {
                field: "estimate.unknowns".into(),
                why: format!(
                    "{p} unknowns for a model with {} load parameters",
                    ws.params().len()
                ),
            }
            .into());
        }
        let c = ws.robot().cables().len();
        let names = spec
            .unknowns
            .iter()
            .map(UnknownSpec::display_name)
            .collect();
        let mut est = Self {
            ws,
            names,
            p,
            c,
            lb: spec.unknowns.iter().map(UnknownSpec::lower).collect(),
            ub: spec.unknowns.iter().map(UnknownSpec::upper).collect(),
            prior_mean: spec
                .unknowns
                .iter()
                .map(|u| u.prior_mean.unwrap_or(0.0))
                .collect(),
            prior_w: spec
                .unknowns
                .iter()
                .map(|u| u.prior_sigma.map_or(0.0, |s| 1.0 / (s * s)))
                .collect(),
            theta: spec.unknowns.iter().map(|u| u.reference).collect(),
            theta_trial: vec![0.0; p],
            ref_len: vec![0.0; c],
            len: vec![0.0; c],
            meas: vec![f64::NAN; c],
            wts: vec![0.0; c],
            g: vec![0.0; c * p],
            len_prev: vec![0.0; c],
            h: vec![0.0; p * p],
            scratch: vec![0.0; p * p],
            grad: vec![0.0; p],
            step: vec![0.0; p],
            eig_w: vec![0.0; p],
            eig_v: vec![0.0; p * p],
            dscale: vec![0.0; p],
            cov: vec![0.0; p * p],
            g_valid: false,
            g_exact: false,
            active: vec![false; p],
            infinite_var: vec![false; p],
            mu: 1e-3,
            status: EstimateStatus::NoData,
            iterations: 0,
            jac_evals: 0,
            cost: 0.0,
            rank: 0,
            condition: f64::INFINITY,
            n_unobservable: 0,
            unobs_dirs: vec![0.0; p * p],
            elapsed: 0.0,
            spec,
        };
        // reference lengths: measured, or the model at the reference loads
        if let Some(r) = &est.spec.reference_lengths_m {
            est.ref_len.copy_from_slice(r);
        } else {
            let theta = est.theta.clone();
            est.ws.set_theta(&theta);
            let rep = est.ws.solve(Start::Cold);
            if !rep.status.is_converged() {
                return Err(EstimateError::Reference(rep.status));
            }
            est.ws.cable_lengths_into(&mut est.ref_len);
        }
        for (k, u) in est.spec.unknowns.iter().enumerate() {
            est.theta[k] = u.initial.clamp(est.lb[k], est.ub[k]);
        }
        let theta = est.theta.clone();
        est.ws.set_theta(&theta);
        est.ws.solve(Start::Cold);
        est.ws.cable_lengths_into(&mut est.len);
        Ok(est)
    }

    /// Unknown names.
    pub fn names(&self) -> &[String] {
        &self.names
    }
    /// Current estimate (SI).
    pub fn theta(&self) -> &[f64] {
        &self.theta
    }
    /// Status of the last sample.
    pub fn status(&self) -> EstimateStatus {
        self.status
    }
    /// Covariance of the last sample, row-major `p x p`, from the sensitivities the
    /// sample ended with: exact when [`Estimator::statistics_are_exact`], else from
    /// reused ones (call [`Estimator::refresh_statistics`]). Unobservable directions
    /// without a prior carry no information: see the `std_dev` of [`Estimate`].
    pub fn covariance(&self) -> &[f64] {
        &self.cov
    }
    /// Whether covariance, rank and condition were computed from an exact sweep at
    /// the current estimate.
    pub fn statistics_are_exact(&self) -> bool {
        self.g_exact
    }
    /// Reference cable lengths the changes are measured from (m).
    pub fn reference_lengths(&self) -> &[f64] {
        &self.ref_len
    }
    /// The spec.
    pub fn spec(&self) -> &EstimateSpec {
        &self.spec
    }
    /// The forward model (current shape).
    pub fn model(&mut self) -> &mut M {
        &mut self.ws
    }
    /// Tip position of the current estimate (m).
    pub fn tip_position(&self) -> crate::nalgebra::Vector3<f64> {
        self.ws.tip_position()
    }

    /// Start the next sample from `theta` (clamped to the bounds) instead of the
    /// previous estimate.
    pub fn set_theta(&mut self, theta: &[f64]) {
        for k in 0..self.p {
            self.theta[k] = theta[k].clamp(self.lb[k], self.ub[k]);
        }
        self.g_valid = false;
        self.g_exact = false;
    }

    /// Process one sample: cable length changes (m, `NaN` = missing) and optional
    /// per-cable noise (m). Warm-started from the previous estimate; no allocation
    /// for the workspace methods.
    pub fn tick(&mut self, changes: &[f64], sigma: Option<&[f64]>) -> EstimateStatus {
        let t0 = Instant::now();
        let any = self.intake(changes, sigma);
        self.iterations = 0;
        self.jac_evals = 0;
        self.status = if !any {
            EstimateStatus::NoData
        } else if self.spec.method == Method::ArgminGaussNewton {
            argmin_gn::run(self)
        } else {
            self.run_workspace(t0)
        };
        if self.status == EstimateStatus::Converged && !self.explains_data() {
            self.status = EstimateStatus::Stalled;
        }
        self.finish();
        self.elapsed = t0.elapsed().as_secs_f64();
        self.status
    }

    /// Whether the residual is consistent with the noise: RMS of `r_j / sigma_j` over
    /// the measured cables at most `spec.max_rms_sigma`. A stationary point that
    /// leaves hundreds of sigma unexplained is a local minimum of the cost (seen past
    /// `PL^2/EI` ~ 20, where the cable lengths stop singling out the force) or data
    /// the model cannot produce: `stalled`, not `converged`.
    pub(crate) fn explains_data(&self) -> bool {
        let (mut sum, mut count) = (0.0, 0usize);
        for j in 0..self.c {
            if self.wts[j] > 0.0 {
                let r = self.len[j] - self.ref_len[j] - self.meas[j];
                sum += self.wts[j] * r * r;
                count += 1;
            }
        }
        count == 0 || (sum / count as f64).sqrt() <= self.spec.max_rms_sigma
    }

    /// Store a sample: finite changes with a finite positive sigma get weight
    /// `1/sigma^2`, missing or NaN ones weight 0. `false` when there is nothing to
    /// estimate from (no finite measurement and no prior).
    fn intake(&mut self, changes: &[f64], sigma: Option<&[f64]>) -> bool {
        let mut any = self.prior_w.iter().any(|w| *w > 0.0);
        for j in 0..self.c {
            let m = changes.get(j).copied().unwrap_or(f64::NAN);
            let s = sigma
                .and_then(|s| s.get(j).copied())
                .unwrap_or(self.spec.noise_m);
            if m.is_finite() && s.is_finite() && s > 0.0 {
                self.meas[j] = m;
                self.wts[j] = 1.0 / (s * s);
                any = true;
            } else {
                self.meas[j] = f64::NAN;
                self.wts[j] = 0.0;
            }
        }
        any
    }

    /// Forward solve at `theta`; lengths into `len`; `false` if it did not converge.
    fn forward(&mut self, trial: bool) -> bool {
        let th = if trial {
            &self.theta_trial
        } else {
            &self.theta
        };
        self.ws.set_theta(th);
        let rep = self.ws.solve(Start::Warm);
        self.ws.cable_lengths_into(&mut self.len);
        rep.status.is_converged()
    }

    /// `0.5 (sum_j w_j r_j^2 + sum_k prior_k (theta_k - mean_k)^2)` at `len` and `th`.
    fn cost_at(&self, trial: bool) -> f64 {
        let th = if trial {
            &self.theta_trial
        } else {
            &self.theta
        };
        let mut cost = 0.0;
        for j in 0..self.c {
            if self.wts[j] > 0.0 {
                let r = self.len[j] - self.ref_len[j] - self.meas[j];
                cost += self.wts[j] * r * r;
            }
        }
        for k in 0..self.p {
            let d = th[k] - self.prior_mean[k];
            cost += self.prior_w[k] * d * d;
        }
        0.5 * cost
    }

    /// Gradient and Gauss-Newton Hessian at the current point into `grad`, `h`.
    fn normal_equations(&mut self) {
        let (p, c) = (self.p, self.c);
        self.h.iter_mut().for_each(|x| *x = 0.0);
        for k in 0..p {
            let d = self.theta[k] - self.prior_mean[k];
            self.grad[k] = self.prior_w[k] * d;
            self.h[k * p + k] = self.prior_w[k];
        }
        for j in 0..c {
            let w = self.wts[j];
            if w == 0.0 {
                continue;
            }
            let r = self.len[j] - self.ref_len[j] - self.meas[j];
            for a in 0..p {
                let ga = self.g[j * p + a];
                self.grad[a] += w * ga * r;
                for b in 0..p {
                    self.h[a * p + b] += w * ga * self.g[j * p + b];
                }
            }
        }
    }

    /// `step = -(H + damping)^+ grad` by a Jacobi-scaled eigen pseudo-inverse:
    /// directions with relative eigenvalue below 1e-12 get no step (not invented).
    fn solve_step(&mut self, damping: f64) {
        let p = self.p;
        for k in 0..p {
            let d = self.h[k * p + k];
            self.dscale[k] = if d > 0.0 { 1.0 / d.sqrt() } else { 1.0 };
        }
        for a in 0..p {
            for b in 0..p {
                let mut v = self.h[a * p + b] * self.dscale[a] * self.dscale[b];
                if a == b {
                    v += damping * if self.h[a * p + a] > 0.0 { 1.0 } else { 0.0 };
                }
                // unknowns held at a bound are decoupled and get no step
                if self.active[a] || self.active[b] {
                    v = if a == b { 1.0 } else { 0.0 };
                }
                self.scratch[a * p + b] = v;
            }
        }
        sym_eigen(&mut self.scratch, p, &mut self.eig_w, &mut self.eig_v);
        let wmax = self.eig_w.iter().fold(0.0f64, |a, w| a.max(*w));
        self.step.iter_mut().for_each(|s| *s = 0.0);
        for i in 0..p {
            let lam = self.eig_w[i];
            if lam.is_nan() || lam <= 1e-12 * wmax {
                continue;
            }
            let mut proj = 0.0;
            for k in 0..p {
                if !self.active[k] {
                    proj += self.eig_v[k * p + i] * self.dscale[k] * self.grad[k];
                }
            }
            for k in 0..p {
                self.step[k] -= self.eig_v[k * p + i] * proj / lam * self.dscale[k];
            }
        }
    }

    fn run_workspace(&mut self, t0: Instant) -> EstimateStatus {
        let p = self.p;
        if !self.forward(false) {
            return EstimateStatus::ForwardFailed;
        }
        let mut cost = self.cost_at(false);
        let method = self.spec.method;
        // damping never carries over from an earlier (possibly impossible) sample
        self.mu = if method == Method::LevenbergMarquardt {
            1e-3
        } else {
            0.0
        };
        // scaled size of the last accepted step (contraction estimate below)
        let mut prev_step = f64::INFINITY;
        for it in 0..self.spec.max_iterations {
            self.iterations = it + 1;
            if let Some(b) = self.spec.time_budget_s {
                if t0.elapsed().as_secs_f64() > b {
                    self.cost = cost;
                    return EstimateStatus::TimeBudget;
                }
            }
            let fresh = !self.g_valid || !self.spec.reuse_jacobian;
            if fresh {
                self.jac_evals += 1;
                if !self.ws.length_sensitivities(&mut self.g, &mut self.len) {
                    self.cost = cost;
                    return EstimateStatus::ForwardFailed;
                }
                self.g_valid = true;
                self.g_exact = true;
            }
            self.normal_equations();
            // projected Newton (Bertsekas): an unknown at a bound whose gradient
            // pushes it outwards is held there; the others take the reduced step
            for k in 0..p {
                self.active[k] = method != Method::Constrained
                    && ((self.theta[k] <= self.lb[k] && self.grad[k] > 0.0)
                        || (self.theta[k] >= self.ub[k] && self.grad[k] < 0.0));
            }
            let mut scale = 1.0;
            let mut trials = 0;
            let accepted = loop {
                trials += 1;
                if trials > MAX_TRIALS {
                    self.cost = cost;
                    return EstimateStatus::Stalled;
                }
                if method == Method::Constrained {
                    if !qp::box_step(self) {
                        self.solve_step(0.0);
                    }
                } else {
                    self.solve_step(self.mu);
                }
                let mut small = true;
                let mut size = 0.0f64;
                for k in 0..p {
                    let s = self.step[k] * scale;
                    self.theta_trial[k] = (self.theta[k] + s).clamp(self.lb[k], self.ub[k]);
                    let taken = self.theta_trial[k] - self.theta[k];
                    self.step[k] = taken;
                    small &= taken.abs() <= self.spec.tolerance * (1.0 + self.theta[k].abs());
                    size = size.max(taken.abs() / (1.0 + self.theta[k].abs()));
                }
                if small && !self.g_exact && size > 0.5 * prev_step {
                    // Reused (Broyden-updated) sensitivities converge only linearly: a
                    // step that shrank by less than half since the last one leaves an
                    // error of up to step * rho / (1 - rho) > step. Certify with a
                    // fresh sweep instead (seen: error 100x the step tolerance).
                    self.g_valid = false;
                    break false;
                }
                if small {
                    // a step made tiny by heavy damping certifies nothing by itself:
                    // converged only if the undamped Gauss-Newton model predicts a
                    // negligible decrease (stationary point), else the cost could not
                    // be decreased from a non-stationary point: stalled
                    if method == Method::LevenbergMarquardt && self.mu > LM_MAX_CONVERGED_DAMPING {
                        self.solve_step(0.0);
                        let mut pred = 0.0;
                        for a in 0..p {
                            pred -= self.grad[a] * self.step[a];
                            for b in 0..p {
                                pred -= 0.5 * self.step[a] * self.h[a * p + b] * self.step[b];
                            }
                        }
                        if pred > 1e-9 * (1.0 + cost) {
                            self.cost = cost;
                            return EstimateStatus::Stalled;
                        }
                    }
                    self.cost = cost;
                    return EstimateStatus::Converged;
                }
                // predicted decrease of the quadratic model
                let mut pred = 0.0;
                for a in 0..p {
                    pred -= self.grad[a] * self.step[a];
                    for b in 0..p {
                        pred -= 0.5 * self.step[a] * self.h[a * p + b] * self.step[b];
                    }
                }
                self.len_prev.copy_from_slice(&self.len);
                let ok = self.forward(true);
                let new_cost = if ok {
                    self.cost_at(true)
                } else {
                    f64::INFINITY
                };
                if new_cost < cost || (new_cost <= cost && pred <= 0.0) {
                    let rho = if pred > 0.0 {
                        (cost - new_cost) / pred
                    } else {
                        1.0
                    };
                    if method == Method::LevenbergMarquardt {
                        if rho > 0.75 {
                            self.mu = (self.mu / 3.0).max(1e-12);
                        } else if rho < 0.25 {
                            self.mu *= 2.0;
                        }
                    }
                    if rho < 0.5 && !fresh {
                        self.g_valid = false;
                    } else if self.spec.reuse_jacobian {
                        self.broyden_update();
                    }
                    self.g_exact = false;
                    std::mem::swap(&mut self.theta, &mut self.theta_trial);
                    cost = new_cost;
                    prev_step = size;
                    break true;
                }
                // rejected: back to the accepted point
                self.forward(false);
                // The budget also bounds the trials of one iteration (up to MAX_TRIALS,
                // two forward solves each), not only the iteration count: without this a
                // 1 ms budget let one LM iteration of rejected trials run for a second
                // (fuzz/regressions/estimator_tick/time_budget_ignored_in_trials.bin).
                if self
                    .spec
                    .time_budget_s
                    .is_some_and(|b| t0.elapsed().as_secs_f64() > b)
                {
                    self.cost = cost;
                    return EstimateStatus::TimeBudget;
                }
                if !fresh {
                    self.g_valid = false;
                    break false;
                }
                if method == Method::LevenbergMarquardt {
                    self.mu = (self.mu * 4.0).max(1e-6);
                    if self.mu > 1e12 {
                        self.cost = cost;
                        return EstimateStatus::Stalled;
                    }
                } else {
                    scale *= 0.5;
                    if scale < 1e-6 {
                        self.cost = cost;
                        return EstimateStatus::Stalled;
                    }
                }
            };
            let _ = accepted;
        }
        self.cost = cost;
        EstimateStatus::MaxIterations
    }

    /// Broyden's rank-one update of the reused sensitivities with the observed change
    /// of the lengths over the accepted step `s`: `G += (dl - G s) s^T / (s^T s)`.
    /// Keeps the secant condition `G s = dl`, so reused sensitivities converge
    /// superlinearly instead of linearly; a fresh sweep replaces them when the cost
    /// stops dropping as predicted.
    fn broyden_update(&mut self) {
        let (p, c) = (self.p, self.c);
        let ss: f64 = self.step.iter().map(|v| v * v).sum();
        if ss.is_nan() || ss <= 0.0 {
            return;
        }
        for j in 0..c {
            let mut gs = 0.0;
            for k in 0..p {
                gs += self.g[j * p + k] * self.step[k];
            }
            let r = (self.len[j] - self.len_prev[j] - gs) / ss;
            for k in 0..p {
                self.g[j * p + k] += r * self.step[k];
            }
        }
    }

    /// Covariance, rank, condition and unobservable directions at the final point.
    fn finish(&mut self) {
        let p = self.p;
        if matches!(
            self.status,
            EstimateStatus::NoData | EstimateStatus::ForwardFailed
        ) {
            return;
        }
        if !self.g_valid {
            self.jac_evals += 1;
            self.g_valid = self.ws.length_sensitivities(&mut self.g, &mut self.len);
            self.g_exact = self.g_valid;
            if !self.g_valid {
                return;
            }
        }
        self.normal_equations();
        // covariance: pseudo-inverse of H (information incl. prior)
        self.solve_cov();
        // observability: scaled Fisher information without the prior
        for k in 0..p {
            let f = self.h[k * p + k] - self.prior_w[k];
            self.dscale[k] = if f > 0.0 { 1.0 / f.sqrt() } else { 0.0 };
        }
        for a in 0..p {
            for b in 0..p {
                let mut f = self.h[a * p + b];
                if a == b {
                    f -= self.prior_w[a];
                }
                self.scratch[a * p + b] = f * self.dscale[a] * self.dscale[b];
            }
        }
        sym_eigen(&mut self.scratch, p, &mut self.eig_w, &mut self.eig_v);
        let wmax = self.eig_w.iter().fold(0.0f64, |a, w| a.max(*w));
        let wmin = self.eig_w.iter().fold(f64::INFINITY, |a, w| a.min(*w));
        self.rank = 0;
        self.n_unobservable = 0;
        for i in 0..p {
            if self.eig_w[i] > self.spec.rank_tolerance * wmax && wmax > 0.0 {
                self.rank += 1;
            } else {
                let d = self.n_unobservable;
                for k in 0..p {
                    self.unobs_dirs[k * p + d] = self.eig_v[k * p + i];
                }
                self.n_unobservable += 1;
            }
        }
        // unknowns the cables do not touch at all are unobservable too
        for k in 0..p {
            if self.dscale[k] == 0.0 && self.n_unobservable < p {
                let d = self.n_unobservable;
                for q in 0..p {
                    self.unobs_dirs[q * p + d] = if q == k { 1.0 } else { 0.0 };
                }
                self.n_unobservable += 1;
            }
        }
        self.rank = self.rank.min(p - self.n_unobservable.min(p));
        self.condition = if wmin > 0.0 && self.n_unobservable == 0 {
            wmax / wmin
        } else {
            f64::INFINITY
        };
        if self.n_unobservable > 0 && self.status == EstimateStatus::Converged {
            self.status = EstimateStatus::Unobservable;
        }
    }

    fn solve_cov(&mut self) {
        let p = self.p;
        self.scratch.copy_from_slice(&self.h);
        sym_eigen(&mut self.scratch, p, &mut self.eig_w, &mut self.eig_v);
        let wmax = self.eig_w.iter().fold(0.0f64, |a, w| a.max(*w));
        self.cov.iter_mut().for_each(|x| *x = 0.0);
        self.infinite_var.iter_mut().for_each(|x| *x = false);
        for i in 0..p {
            let lam = self.eig_w[i];
            if lam.is_nan() || lam <= 1e-14 * wmax {
                // no information along this direction: unbounded variance, not zero
                for k in 0..p {
                    if self.eig_v[k * p + i].abs() > 1e-6 {
                        self.infinite_var[k] = true;
                    }
                }
                continue;
            }
            for a in 0..p {
                for b in 0..p {
                    self.cov[a * p + b] += self.eig_v[a * p + i] * self.eig_v[b * p + i] / lam;
                }
            }
        }
    }

    /// Make the covariance, rank and condition exact at the current estimate: when
    /// the last sample ended on reused (Broyden-updated) sensitivities, sweep once
    /// more at the estimate (one dual pass) and recompute them. The estimate itself
    /// does not change. [`Estimator::estimate`] calls this.
    pub fn refresh_statistics(&mut self) {
        if self.g_exact
            || matches!(
                self.status,
                EstimateStatus::NoData | EstimateStatus::ForwardFailed
            )
        {
            return;
        }
        self.g_valid = false;
        self.finish();
    }

    /// Snapshot of the last sample (allocates; recomputes the shape for output and
    /// makes the statistics exact at the estimate, see [`Estimator::refresh_statistics`]).
    pub fn estimate(&mut self) -> Estimate {
        self.refresh_statistics();
        let p = self.p;
        let section_tips = self.ws.section_tips();
        let unobservable = (0..self.n_unobservable)
            .map(|d| Direction {
                components: (0..p)
                    .filter(|k| self.unobs_dirs[k * p + d].abs() > 0.1)
                    .map(|k| (self.names[k].clone(), self.unobs_dirs[k * p + d]))
                    .collect(),
            })
            .collect();
        let predicted: Vec<f64> = (0..self.c).map(|j| self.len[j] - self.ref_len[j]).collect();
        let (mut chi2, mut measured_count) = (0.0, 0usize);
        for (j, pr) in predicted.iter().enumerate() {
            if self.wts[j] > 0.0 {
                chi2 += self.wts[j] * (pr - self.meas[j]).powi(2);
                measured_count += 1;
            }
        }
        let rms_sigma = if measured_count > 0 {
            (chi2 / measured_count as f64).sqrt()
        } else {
            0.0
        };
        let redundancy = measured_count.saturating_sub(self.rank);
        let fit = if !rms_sigma.is_finite() || rms_sigma > self.spec.poor_fit_rms_sigma {
            Fit::Poor
        } else if redundancy == 0 {
            Fit::Untestable
        } else {
            Fit::Good
        };
        let measured: Vec<Option<f64>> = self
            .meas
            .iter()
            .map(|m| m.is_finite().then_some(*m))
            .collect();
        Estimate {
            status: self.status,
            iterations: self.iterations,
            jacobian_evals: self.jac_evals,
            names: self.names.clone(),
            values: self.theta.clone(),
            std_dev: (0..p)
                .map(|k| {
                    if self.infinite_var[k] {
                        f64::INFINITY
                    } else {
                        self.cov[k * p + k].max(0.0).sqrt()
                    }
                })
                .collect(),
            covariance: self.cov.clone(),
            rank: self.rank,
            condition: self.condition,
            unobservable,
            residual_m: measured
                .iter()
                .zip(&predicted)
                .map(|(m, pr)| m.map(|m| pr - m))
                .collect(),
            measured_m: measured,
            predicted_m: predicted,
            cost: self.cost,
            rms_sigma,
            redundancy,
            fit,
            tip: section_tips.last().copied().unwrap_or(Pose {
                position: self.ws.tip_position(),
                rotation: crate::nalgebra::Matrix3::identity(),
            }),
            section_tips,
            elapsed_s: self.elapsed,
        }
    }
}
