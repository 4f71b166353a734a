//! Sensitivity bookkeeping: Broyden updates of reused sensitivities, and the fresh
//! sweep that makes the statistics exact.

// Index loops below mirror the matrix formulas on flat buffers.
#![allow(clippy::needless_range_loop)]

use super::model::EstimationModel;
use super::{EstimateStatus, Estimator};

impl<M: EstimationModel> Estimator<M> {
    /// Broyden's rank-one update of the reused sensitivities with the observed change
    /// of the lengths over the accepted step `s`: `G += (dl - G s) s^T / (s^T s)`.
    /// Keeps the secant condition `G s = dl`, so reused sensitivities converge
    /// superlinearly instead of linearly; a fresh sweep replaces them when the cost
    /// stops dropping as predicted.
    pub(super) fn broyden_update(&mut self) {
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
}
