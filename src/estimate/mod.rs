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

//! Code map (one idea per file, all `impl Estimator` blocks on the struct below):
//! `build` (constructors, accessors), `tick` (one sample: intake, forward solve,
//! cost), `iterate` (normal equations, damped step, the LM/GN/constrained loop),
//! `sensitivity` (Broyden updates, when sensitivities are re-swept), `observe`
//! (covariance, rank, unobservable directions, the [`Estimate`] snapshot).
//! `tendon`: unknown external loads on a displacement-driven robot from load cells
//! ([`TendonLoadEstimator`] over [`TendonModel`]: the same estimator with the
//! tendon tensions as extra measurement channels).

mod argmin_gn;
mod build;
mod iterate;
mod joint;
mod linalg;
mod model;
mod observe;
mod qp;
mod sensitivity;
mod tendon;
mod tick;

pub use crate::scene::estimate::{Axis, EstimateSpec, Method, UnknownKind, UnknownSpec};
pub use joint::JointEstimator;
pub use model::{CloneModel, DynModel, EstimationModel, RungModel};
pub use tendon::{
    Prediction, TendonEstimate, TendonLoadEstimator, TendonModel, SLACK_AGREES_SIGMAS,
};

use crate::error::ModelError;
use crate::math::damping::Damping;
use crate::statics::{Pose, SolveStatus, Workspace};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// LM damping above which a tiny step is `Stalled`, not `Converged`.
const LM_MAX_CONVERGED_DAMPING: f64 = 1e2;
/// A heavily damped tiny step is `Converged` when the undamped Gauss-Newton model
/// predicts a cost decrease below this (plus `1e-9 cost`), in whitened cost units
/// (`0.5 sum (r/sigma)^2`): the undamped step is then under `sqrt(2e-6)` = 1.4e-3
/// standard deviations (Mahalanobis), below what the data resolve and at the level
/// of the forward model's own noise (a tendon solve's 1e-12 m length tolerance is
/// ~1e-7 N in a stiff tendon's tension, 1e-5 of a 0.01 N load-cell sigma, so near
/// the optimum trial costs differ by noise and LM's damping grows). Above it the
/// point is not stationary and the estimate is `Stalled`.
const STATIONARY_DECREASE: f64 = 1e-6;
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

impl Estimate {
    /// Whether this estimate must not warm-start the next sample of a stream: the
    /// solver stalled or the forward model failed (not trusted), or the fit is
    /// [`Fit::Poor`] (the data contradict the model: a corrupted reading). A stream
    /// then starts its next sample from the reference instead (`cablesense track`
    /// and the load-cell stream of `cablesense estimate` do). `MaxIterations` and
    /// `TimeBudget` estimates are the best so far and stay the warm start (a control
    /// loop with a tight budget would otherwise never move); `NoData` keeps the
    /// previous estimate.
    pub fn poisons_warm_start(&self) -> bool {
        matches!(
            self.status,
            EstimateStatus::Stalled | EstimateStatus::ForwardFailed
        ) || self.fit == Fit::Poor
    }
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
    /// Weights of the channels at the current point: `wts_in`, with the residuals
    /// the model drops there ([`EstimationModel::drops_residual`]) at 0.
    wts: Vec<f64>,
    /// Weights `1/sigma^2` of the sample's measured channels (0 = not measured).
    wts_in: Vec<f64>,
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
    /// Levenberg-Marquardt damping (trust-ratio rule, `math::damping`).
    damping: Damping,
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
