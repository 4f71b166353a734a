//! Observability and statistics at the final point: covariance, rank, condition,
//! unobservable directions, and the serializable [`Estimate`] snapshot.

// Index loops below mirror the matrix formulas on flat buffers.
#![allow(clippy::needless_range_loop)]

use super::linalg::sym_eigen;
use super::model::EstimationModel;
use super::{Direction, Estimate, EstimateStatus, Estimator, Fit};
use crate::statics::Pose;

impl<M: EstimationModel> Estimator<M> {
    /// Covariance, rank, condition and unobservable directions at the final point.
    pub(super) fn finish(&mut self) {
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

    pub(super) fn solve_cov(&mut self) {
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
            // a dropped residual (a slack tendon's load cell) is reported as none
            residual_m: measured
                .iter()
                .zip(&predicted)
                .zip(&self.wts)
                .map(|((m, pr), w)| m.filter(|_| *w > 0.0).map(|m| pr - m))
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
