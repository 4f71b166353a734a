//! One sample: intake of the measurements, forward solve at a trial point, cost.

use super::model::EstimationModel;
use super::{argmin_gn, EstimateStatus, Estimator};
use crate::scene::estimate::Method;
use crate::statics::Start;
use std::time::Instant;

impl<M: EstimationModel> Estimator<M> {
    /// Check one sample at the boundary, as the front ends (Python, C, the CLI's
    /// readers) do before [`Estimator::tick`]: one change per channel, each finite or
    /// `NaN` (missing); an infinite change is an error (not a missing one). `sigma`,
    /// when given, one per channel, each finite and > 0 (a channel without a noise
    /// figure is left out of `sigma` altogether, not given 0 or NaN). `tick` itself
    /// still takes what this rejects as a missing measurement.
    pub fn check_sample(
        &self,
        changes: &[f64],
        sigma: Option<&[f64]>,
    ) -> Result<(), crate::error::ModelError> {
        use crate::error::ModelError;
        if changes.len() != self.c {
            return Err(ModelError::Invalid {
                field: "changes".into(),
                why: format!("{} values for {} channels", changes.len(), self.c),
            });
        }
        if let Some(j) = changes.iter().position(|v| v.is_infinite()) {
            return Err(ModelError::NonFinite {
                field: format!("changes[{j}] (NaN marks a missing one)"),
                value: changes[j],
            });
        }
        if let Some(sigma) = sigma {
            if sigma.len() != self.c {
                return Err(ModelError::Invalid {
                    field: "sigma".into(),
                    why: format!("{} values for {} channels", sigma.len(), self.c),
                });
            }
            if let Some(j) = sigma.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
                return Err(if sigma[j].is_finite() {
                    ModelError::NonPositive {
                        field: format!("sigma[{j}]"),
                        value: sigma[j],
                    }
                } else {
                    ModelError::NonFinite {
                        field: format!("sigma[{j}]"),
                        value: sigma[j],
                    }
                });
            }
        }
        Ok(())
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
    pub(super) fn intake(&mut self, changes: &[f64], sigma: Option<&[f64]>) -> bool {
        let mut any = self.prior_w.iter().any(|w| *w > 0.0);
        for j in 0..self.c {
            let m = changes.get(j).copied().unwrap_or(f64::NAN);
            let default = if self.ws.is_tension_channel(j) {
                self.spec.load_cell_sigma_n
            } else {
                self.spec.noise_m
            };
            let s = sigma.and_then(|s| s.get(j).copied()).unwrap_or(default);
            if m.is_finite() && s.is_finite() && s > 0.0 {
                self.meas[j] = m;
                self.wts_in[j] = 1.0 / (s * s);
                any = true;
            } else {
                self.meas[j] = f64::NAN;
                self.wts_in[j] = 0.0;
            }
            self.wts[j] = self.wts_in[j];
        }
        any
    }

    /// The weights at the model's current point: a channel whose residual the model
    /// drops there (a slack tendon, [`EstimationModel::drops_residual`]) weighs 0.
    pub(super) fn apply_drops(&mut self) {
        for j in 0..self.c {
            let w = self.wts_in[j];
            self.wts[j] = if w > 0.0 && self.ws.drops_residual(j, self.meas[j], 1.0 / w.sqrt()) {
                0.0
            } else {
                w
            };
        }
    }

    /// A sample without any measurement on a model driven by inputs (a tendon
    /// robot's readings): solve at the current estimate, which is held (no data
    /// moves it), and report the statistics at that point: with no information,
    /// every unknown is unobservable (rank 0, infinite standard deviation unless a
    /// prior bounds it), status `unobservable` (or `forward_failed`). Never an
    /// invented value.
    pub(crate) fn tick_held(&mut self) -> EstimateStatus {
        let t0 = Instant::now();
        self.intake(&[], None);
        self.iterations = 0;
        self.jac_evals = 0;
        self.g_valid = false;
        self.g_exact = false;
        self.status = if self.forward(false) {
            self.cost = self.cost_at(false);
            EstimateStatus::Converged
        } else {
            EstimateStatus::ForwardFailed
        };
        self.finish();
        self.elapsed = t0.elapsed().as_secs_f64();
        self.status
    }

    /// Forward solve at `theta`; lengths into `len`; `false` if it did not converge.
    pub(super) fn forward(&mut self, trial: bool) -> bool {
        let th = if trial {
            &self.theta_trial
        } else {
            &self.theta
        };
        self.ws.set_theta(th);
        let rep = self.ws.solve(Start::Warm);
        self.ws.cable_lengths_into(&mut self.len);
        self.apply_drops();
        rep.status.is_converged()
    }

    /// `0.5 (sum_j w_j r_j^2 + sum_k prior_k (theta_k - mean_k)^2)` at `len` and `th`.
    pub(super) fn cost_at(&self, trial: bool) -> f64 {
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
}
