//! Sensitivity bookkeeping: Broyden updates of reused sensitivities, and the fresh
//! sweep that makes the statistics exact.

use super::model::EstimationModel;
use super::{EstimateStatus, Estimator};
use crate::math::broyden::secant_row_update;

impl<M: EstimationModel> Estimator<M> {
    /// Broyden's rank-one update of the reused sensitivities with the observed change
    /// of the lengths over the accepted step `s`: `G += (dl - G s) s^T / (s^T s)`
    /// ([`secant_row_update`] row by row).
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
            let y = self.len[j] - self.len_prev[j];
            secant_row_update(&mut self.g[j * p..(j + 1) * p], &self.step[..p], ss, y);
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
