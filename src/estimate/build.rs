//! Building an [`Estimator`] and reading its state.

use super::model::{self, DynModel, EstimationModel};
use super::{EstimateError, EstimateStatus, Estimator};
use crate::error::ModelError;
use crate::ladder::Rung;
use crate::loads::Loads;
use crate::math::damping::{Damping, DampingRule};
use crate::robot::Robot;
use crate::scene::estimate::{EstimateSpec, UnknownSpec};
use crate::settings::SolverSettings;
use crate::statics::{Start, Workspace};

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
        let c = ws.channels();
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
            wts_in: vec![0.0; c],
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
            damping: Damping::new(DampingRule::Ratio, 1e-3),
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
            est.ref_len[..r.len()].copy_from_slice(r);
        } else {
            let theta = est.theta.clone();
            est.ws.set_theta(&theta);
            let rep = est.ws.solve(Start::Cold);
            if !rep.status.is_converged() {
                return Err(EstimateError::Reference(rep.status));
            }
            est.ws.cable_lengths_into(&mut est.ref_len);
        }
        // load cells measure absolute tensions
        for j in 0..c {
            if est.ws.is_tension_channel(j) {
                est.ref_len[j] = 0.0;
            }
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
}
