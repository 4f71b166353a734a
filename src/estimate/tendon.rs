//! Unknown external loads on a displacement-driven (tendon) robot, from load cells.
//!
//! The robot's tendons are driven by the row's servo readings (inputs of the forward
//! solve, [`TendonWorkspace`]); the unknowns are the estimate spec's external loads
//! (force and torque components, payload masses at section ends: the extra load
//! parameters of the tendon workspace). Per row the measurements are
//!
//! * the **tension** of each driven tendon that has a load cell (`tension_<cable>`
//!   columns, N, absolute): residual `r_i = T_i(theta; q) - T_i,meas`, weight
//!   `1/sigma_T^2` with `sigma_T` = [`EstimateSpec::load_cell_sigma_n`] (default
//!   0.01 N);
//! * the **length change** of each passive (measuring) cable the row gives (m, from
//!   the reference state: every unknown at its `reference`, readings at `q = 0`;
//!   `length_<cable>` columns of a readings file): residual as in the cable-length
//!   estimator, weight `1/noise_m^2`.
//!
//! **Displacement residuals.** The readings are inputs, not measurements: the
//! forward solve matches every driven tendon's displacement exactly (its NCP residual
//! `G_i = min(a_i T_i, c_i T_i + L_f,i - l_i) = 0`, `tendons::solve`), so in this
//! nested formulation each displacement residual is an equality constraint with
//! zero tolerance, not a least-squares term. A reading missing from a row keeps the
//! tendon's last value (the readings parser); a row without a usable reading for some
//! tendon before any value is a bad row. The tension of a displacement-driven tendon
//! cannot itself be an unknown here (its value follows from its reading): such a
//! spec is refused with an error naming the unknown; measure it with a load cell.
//!
//! **Slack.** A slack tendon (`T = 0`, path shorter than its free length) says
//! nothing about the loads (`dT/dtheta = 0` there). Its load-cell residual is left
//! out (reported as none, `slack_no_residual`) when the load cell agrees that it is
//! slack: `T_meas <= 3 sigma_T` ([`SLACK_AGREES_SIGMAS`]). A load cell reading
//! clearly above zero on a tendon the model has slack keeps its residual `-T_meas`
//! (the data contradict the model; dropping it would reward the iteration for
//! predicting slack).
//!
//! **Observability** is the estimator's: the rank of the scaled Fisher information
//! over the measured channels. Without load cells or measuring cables nothing
//! constrains the loads: such a row is solved at the held estimate and reported
//! `unobservable` with every unknown listed and an infinite standard deviation
//! (never an invented value).
//!
//! **Sensitivities** are exact (no friction): implicit differentiation of the tendon
//! conditions around the shooting solve ([`TendonWorkspace::load_sensitivities`]);
//! `tests/estimate_tendon_loads.rs` checks them against central differences.

use super::model::{sites, EstimationModel};
use super::{Estimate, EstimateError, EstimateStatus, Estimator};
use crate::error::ModelError;
use crate::loads::Loads;
use crate::robot::Robot;
use crate::scene::estimate::{EstimateSpec, UnknownKind};
use crate::settings::SolverSettings;
use crate::statics::{ParamSite, Pose, SolveReport, SolveStatus, Start, Workspace};
use crate::tendons::{Actuation, TendonWorkspace};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// A slack tendon's load cell agrees with slack below this many noise sigmas.
pub const SLACK_AGREES_SIGMAS: f64 = 3.0;

/// The forward model of a tendon robot driven by readings, with load parameters:
/// channels `0..cables` are path lengths (m), `cables..cables + driven` the driven
/// tendons' tensions (N).
#[derive(Clone)]
pub struct TendonModel {
    tw: TendonWorkspace,
    params: Vec<ParamSite>,
    readings: Vec<f64>,
    nc: usize,
    dl: Vec<f64>,
    dt: Vec<f64>,
    report: SolveReport,
}

impl TendonModel {
    /// Wrap a tendon workspace whose extra parameters are at `params`; readings
    /// start at the reference (`q = 0`).
    pub fn new(tw: TendonWorkspace, params: Vec<ParamSite>) -> Self {
        let nc = tw.workspace().robot().cables().len();
        let (nt, e) = (tw.driven().len(), tw.extra_count());
        Self {
            readings: tw.zero_readings(),
            dl: vec![0.0; nc * e],
            dt: vec![0.0; nt * e],
            nc,
            tw,
            params,
            report: SolveReport {
                status: SolveStatus::NonFinite,
                iterations: 0,
                residual: f64::INFINITY,
                tolerance: f64::NAN,
                rhs_evals: 0,
                jacobian_evals: 0,
                continuation_steps: 0,
                unknowns: 0,
            },
        }
    }
    /// Set the row's readings (m, one per driven tendon) for the next solves.
    pub fn set_readings(&mut self, readings_m: &[f64]) -> Result<(), ModelError> {
        self.tw.validate_readings(readings_m)?;
        self.readings.copy_from_slice(readings_m);
        Ok(())
    }
    /// The readings of the current row (m).
    pub fn readings(&self) -> &[f64] {
        &self.readings
    }
    /// The tendon workspace (tensions, taut flags, shape).
    pub fn tendons(&self) -> &TendonWorkspace {
        &self.tw
    }
    /// The tendon workspace, to change its settings
    /// ([`TendonWorkspace::set_tendon_settings`]).
    pub fn tendons_mut(&mut self) -> &mut TendonWorkspace {
        &mut self.tw
    }
}

impl EstimationModel for TendonModel {
    fn robot(&self) -> &Robot {
        self.tw.workspace().robot()
    }
    fn params(&self) -> &[ParamSite] {
        &self.params
    }
    fn set_theta(&mut self, theta: &[f64]) {
        self.tw.set_extra(theta)
    }
    fn solve(&mut self, start: Start) -> SolveReport {
        let (status, iterations, residual) =
            match self.tw.solve_readings_from(&self.readings, start) {
                Ok(r) => (r.status, r.iterations, r.residual_m),
                // readings are checked in `set_readings`: not reached, but never a panic
                Err(_) => (SolveStatus::NonFinite, 0, f64::INFINITY),
            };
        self.report = SolveReport {
            status,
            iterations,
            residual,
            ..self.report
        };
        self.report
    }
    fn cable_lengths_into(&self, out: &mut [f64]) {
        self.tw.workspace().cable_lengths_into(&mut out[..self.nc]);
        for (o, t) in out[self.nc..].iter_mut().zip(self.tw.tensions()) {
            *o = *t;
        }
    }
    fn length_sensitivities(&mut self, out: &mut [f64], lengths: &mut [f64]) -> bool {
        self.report.jacobian_evals += 1;
        if !self.tw.load_sensitivities(&mut self.dl, &mut self.dt) {
            return false;
        }
        let e = self.params.len();
        out[..self.nc * e].copy_from_slice(&self.dl);
        out[self.nc * e..].copy_from_slice(&self.dt);
        self.cable_lengths_into(lengths);
        true
    }
    fn tip_position(&self) -> Vector3<f64> {
        self.tw.tip_position()
    }
    fn section_tips(&mut self) -> Vec<Pose> {
        self.tw.workspace_mut().solution().section_tips
    }
    fn workspace_mut(&mut self) -> Option<&mut Workspace> {
        Some(self.tw.workspace_mut())
    }
    fn channels(&self) -> usize {
        self.nc + self.tw.driven().len()
    }
    fn is_tension_channel(&self, j: usize) -> bool {
        j >= self.nc
    }
    fn drops_residual(&self, j: usize, measured: f64, sigma: f64) -> bool {
        j >= self.nc && !self.tw.taut()[j - self.nc] && measured <= SLACK_AGREES_SIGMAS * sigma
    }
}

/// One row's estimate on a tendon robot.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TendonEstimate {
    /// Loads, standard deviations, status, observability, fit and shape; its
    /// `measured_m`/`predicted_m`/`residual_m` are the cables' path-length changes
    /// (measured only for passive cables).
    pub estimate: Estimate,
    /// Names of the driven tendons.
    pub tendons: Vec<String>,
    /// The row's readings (m).
    pub readings_m: Vec<f64>,
    /// Model tensions at the estimate (N).
    pub tensions_n: Vec<f64>,
    /// Whether each driven tendon is taut at the estimate.
    pub taut: Vec<bool>,
    /// Load-cell tensions of the row (N); none where the row has no load cell.
    pub measured_tension_n: Vec<Option<f64>>,
    /// Model minus load cell (N); none without a load cell or when left out.
    pub tension_residual_n: Vec<Option<f64>>,
    /// A load cell on a slack tendon that agrees with slack: no residual (module docs).
    pub slack_no_residual: Vec<bool>,
}

/// What [`TendonLoadEstimator::predict`] returns.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Prediction {
    /// Status of the forward solve.
    pub status: SolveStatus,
    /// Tensions of the driven tendons (N).
    pub tensions_n: Vec<f64>,
    /// Taut flags of the driven tendons.
    pub taut: Vec<bool>,
    /// Path-length change of every cable from the reference (m).
    pub length_changes_m: Vec<f64>,
    /// Tip position (m).
    pub tip_m: [f64; 3],
}

/// Estimator of unknown external loads on a displacement-driven robot (module
/// docs): allocate once, then [`TendonLoadEstimator::tick`] per row.
#[derive(Clone)]
pub struct TendonLoadEstimator {
    est: Estimator<TendonModel>,
    meas: Vec<f64>,
    names: Vec<String>,
}

impl TendonLoadEstimator {
    /// Build for `robot` (with displacement-driven tendons) under the known `loads`;
    /// the spec's unknowns add to them. Refuses a tension unknown on a
    /// displacement-driven cable (module docs).
    pub fn new(
        robot: Robot,
        loads: Loads,
        settings: SolverSettings,
        spec: EstimateSpec,
    ) -> Result<Self, EstimateError> {
        spec.validate(&robot)?;
        loads.validate(&robot)?;
        for (i, u) in spec.unknowns.iter().enumerate() {
            if u.kind != UnknownKind::Tension {
                continue;
            }
            let j = u.cable.unwrap_or(0);
            if robot.cables()[j].actuation == Actuation::Displacement {
                return Err(ModelError::Invalid {
                    field: format!("estimate.unknowns[{i}].cable"),
                    why: format!(
                        "cable `{}` is displacement-driven: its tension follows from its reading (measure it with a load cell, `tension_{}`)",
                        robot.cables()[j].name, robot.cables()[j].name
                    ),
                }
                .into());
            }
        }
        let (loads, params) = sites(&spec, loads);
        let tw = TendonWorkspace::with_params(robot, loads, settings, &params)?.without_rollback();
        let names = tw
            .driven()
            .iter()
            .map(|&j| tw.workspace().robot().cables()[j].name.clone())
            .collect();
        let model = TendonModel::new(tw, params);
        let est = Estimator::with_model(model, spec)?;
        let c = est.c;
        Ok(Self {
            est,
            meas: vec![f64::NAN; c],
            names,
        })
    }

    /// Process one row: `readings_m` per driven tendon (m), `tensions_n` per driven
    /// tendon (N, `NaN` = no load cell), and optionally the path-length changes of
    /// the cables (m, per cable; read for passive cables only, `NaN` = missing).
    /// Warm-started from the previous row. A bad row is an error naming the value
    /// and leaves the estimator as it was.
    pub fn tick(
        &mut self,
        readings_m: &[f64],
        tensions_n: &[f64],
        length_changes_m: Option<&[f64]>,
    ) -> Result<EstimateStatus, ModelError> {
        let nt = self.names.len();
        let nc = self.est.c - nt;
        if tensions_n.len() != nt {
            return Err(ModelError::Invalid {
                field: "tensions".into(),
                why: format!("{} tensions for {nt} driven tendons", tensions_n.len()),
            });
        }
        for (i, t) in tensions_n.iter().enumerate() {
            // (the field name is built only on failure: no allocation per row)
            let fine = t.is_nan() || (t.is_finite() && *t >= 0.0);
            if !fine {
                ModelError::non_negative(format!("tension_{}", self.names[i]), *t)?;
            }
        }
        if let Some(l) = length_changes_m {
            if l.len() != nc {
                return Err(ModelError::Invalid {
                    field: "length changes".into(),
                    why: format!("{} values for {nc} cables", l.len()),
                });
            }
        }
        if self.est.ws.readings() != readings_m {
            // new readings move the state at the same loads: the sensitivities of
            // the last row are not this row's (the cable-length estimator can reuse
            // them because its state moves only with theta). One fresh sweep per row.
            self.est.g_valid = false;
            self.est.g_exact = false;
        }
        self.est.ws.set_readings(readings_m)?;
        let robot = self.est.ws.robot();
        for j in 0..nc {
            let passive = robot.cables()[j].actuation == Actuation::Passive;
            self.meas[j] = match length_changes_m {
                Some(l) if passive && l[j].is_finite() => l[j],
                _ => f64::NAN,
            };
        }
        self.meas[nc..].copy_from_slice(tensions_n);
        let status = self.est.tick(&self.meas, None);
        Ok(if status == EstimateStatus::NoData {
            self.est.tick_held()
        } else {
            status
        })
    }

    /// Snapshot of the last row (allocates).
    pub fn estimate(&mut self) -> TendonEstimate {
        let mut estimate = self.est.estimate();
        let nt = self.names.len();
        let nc = self.est.c - nt;
        let measured_tension_n = estimate.measured_m.split_off(nc);
        let tension_residual_n = estimate.residual_m.split_off(nc);
        estimate.predicted_m.truncate(nc);
        let tw = self.est.ws.tendons();
        TendonEstimate {
            slack_no_residual: measured_tension_n
                .iter()
                .zip(&tension_residual_n)
                .map(|(m, r)| m.is_some() && r.is_none())
                .collect(),
            tendons: self.names.clone(),
            readings_m: self.est.ws.readings().to_vec(),
            tensions_n: tw.tensions().to_vec(),
            taut: tw.taut().to_vec(),
            measured_tension_n,
            tension_residual_n,
            estimate,
        }
    }

    /// The forward model at loads `theta` (the spec's unknowns, in order) and
    /// `readings_m`: what the sensors of a robot under those loads would read
    /// (synthetic data for tests and demos, `files::load_cells`). Solves the model
    /// of this estimator (its next row starts warm from here); the estimate is
    /// unchanged.
    pub fn predict(&mut self, theta: &[f64], readings_m: &[f64]) -> Result<Prediction, ModelError> {
        if theta.len() != self.est.p || theta.iter().any(|t| !t.is_finite()) {
            return Err(ModelError::Invalid {
                field: "theta".into(),
                why: format!("{} finite values for {} unknowns", theta.len(), self.est.p),
            });
        }
        self.est.ws.set_readings(readings_m)?;
        self.est.ws.set_theta(theta);
        // the model moved away from the estimate's state
        self.est.g_valid = false;
        self.est.g_exact = false;
        let status = self.est.ws.solve(Start::Warm).status;
        let nc = self.est.c - self.names.len();
        let mut out = vec![0.0; self.est.c];
        self.est.ws.cable_lengths_into(&mut out);
        let tw = self.est.ws.tendons();
        Ok(Prediction {
            status,
            tensions_n: tw.tensions().to_vec(),
            taut: tw.taut().to_vec(),
            length_changes_m: (0..nc).map(|j| out[j] - self.est.ref_len[j]).collect(),
            tip_m: tw.tip_position().into(),
        })
    }

    /// The estimator (status, covariance, spec, `set_theta` for a fallback).
    pub fn estimator(&mut self) -> &mut Estimator<TendonModel> {
        &mut self.est
    }

    /// Settings of the tendon iteration inside every forward solve (budget,
    /// tolerance; default [`crate::tendons::TendonSettings::default`]). An error
    /// names the field that is out of range; the settings then stay as they were.
    pub fn set_tendon_settings(
        &mut self,
        settings: crate::tendons::TendonSettings,
    ) -> Result<(), crate::error::ModelError> {
        self.est.ws.tendons_mut().set_tendon_settings(settings)
    }

    /// Names of the driven tendons, in reading order.
    pub fn tendons(&self) -> &[String] {
        &self.names
    }
}
