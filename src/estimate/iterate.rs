//! The Gauss-Newton / Levenberg-Marquardt / constrained iteration on `theta`.

// Index loops below mirror the matrix formulas (G^T W G, ...) on flat buffers.
#![allow(clippy::needless_range_loop)]

use super::linalg::sym_eigen;
use super::model::EstimationModel;
use super::{qp, EstimateStatus, Estimator, LM_MAX_CONVERGED_DAMPING, MAX_TRIALS};
use crate::scene::estimate::Method;
use std::time::Instant;

/// Accepted Broyden-updated steps after which a small step that stalled the cost is
/// certified with a fresh sensitivity sweep whatever the step ratio (warm ticks of a
/// control loop converge in fewer and never pay for it; see `run_workspace`).
const MAX_UNCERTIFIED_REUSE: usize = 4;

impl<M: EstimationModel> Estimator<M> {
    /// Gradient and Gauss-Newton Hessian at the current point into `grad`, `h`.
    pub(super) fn normal_equations(&mut self) {
        // (`len` lent out for the call, no allocation: `take` leaves an empty vector)
        let len = std::mem::take(&mut self.len);
        self.normal_equations_at(&len);
        self.len = len;
    }

    /// Gradient and Gauss-Newton Hessian into `grad`, `h` with the sensitivities
    /// `g` and the cable lengths `len` (the joint estimator's are those after the
    /// Newton correction of the shape, `joint/model.rs`).
    pub(super) fn normal_equations_at(&mut self, len: &[f64]) {
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
            let r = len[j] - self.ref_len[j] - self.meas[j];
            for a in 0..p {
                let ga = self.g[j * p + a];
                self.grad[a] += w * ga * r;
                for b in 0..p {
                    self.h[a * p + b] += w * ga * self.g[j * p + b];
                }
            }
        }
    }

    /// Undamped Gauss-Newton predicted decrease of the cost from the current point
    /// (`step` is left at the undamped step): LM's stationarity certificate.
    pub(super) fn gn_predicted_decrease(&mut self) -> f64 {
        let p = self.p;
        self.solve_step(0.0);
        let mut pred = 0.0;
        for a in 0..p {
            pred -= self.grad[a] * self.step[a];
            for b in 0..p {
                pred -= 0.5 * self.step[a] * self.h[a * p + b] * self.step[b];
            }
        }
        pred
    }

    /// `step = -(H + damping)^+ grad` by a Jacobi-scaled eigen pseudo-inverse:
    /// directions with relative eigenvalue below 1e-12 get no step (not invented).
    pub(super) fn solve_step(&mut self, damping: f64) {
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

    pub(super) fn run_workspace(&mut self, t0: Instant) -> EstimateStatus {
        let p = self.p;
        if !self.forward(false) {
            return EstimateStatus::ForwardFailed;
        }
        let mut cost = self.cost_at(false);
        let method = self.spec.method;
        // damping never carries over from an earlier (possibly impossible) sample
        self.damping.reset(if method == Method::LevenbergMarquardt {
            1e-3
        } else {
            0.0
        });
        // scaled size of the last accepted step (contraction estimate below)
        let mut prev_step = f64::INFINITY;
        // accepted steps since the last fresh sensitivity sweep
        let mut reused = 0usize;
        // cost after / before the last accepted step (a stall: above 0.5)
        let mut last_cost_ratio = 0.0f64;
        // the iteration limit; a certifying fresh sweep asked for on the last
        // iteration gets one more (once), so certification never turns a converged
        // run into `MaxIterations`
        let mut limit = self.spec.max_iterations;
        let mut it = 0;
        while it < limit {
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
                reused = 0;
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
                    self.solve_step(self.damping.mu());
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
                if small
                    && !self.g_exact
                    && (size > 0.5 * prev_step
                        || (reused > MAX_UNCERTIFIED_REUSE && last_cost_ratio > 0.5))
                {
                    // Reused (Broyden-updated) sensitivities converge only linearly: a
                    // step that shrank by less than half since the last one leaves an
                    // error of up to step * rho / (1 - rho) > step. Certify with a
                    // fresh sweep instead (seen: error 100x the step tolerance). After
                    // a long run of Broyden steps the step ratio is no estimate of the
                    // contraction either when the cost stalls (the last step took off
                    // less than half of it): on a weakly observable direction the
                    // updated sensitivities can be wrong while the steps shrink and
                    // the cost stalls (seen: estimate_roundtrip (b), cold, 11 reused
                    // steps, the last ratio 0.18, loads 1e-7 N off with residuals of
                    // 4e-10 m where the truth has 1e-16 m): certify with a fresh sweep.
                    self.g_valid = false;
                    if it + 1 == limit && limit == self.spec.max_iterations {
                        limit += 1;
                    }
                    break false;
                }
                if small {
                    // a step made tiny by heavy damping certifies nothing by itself:
                    // converged only if the undamped Gauss-Newton model predicts a
                    // negligible decrease (stationary point), else the cost could not
                    // be decreased from a non-stationary point: stalled
                    if method == Method::LevenbergMarquardt
                        && self.damping.mu() > LM_MAX_CONVERGED_DAMPING
                    {
                        let pred = self.gn_predicted_decrease();
                        if pred > super::STATIONARY_DECREASE + 1e-9 * cost {
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
                        self.damping.accepted(rho);
                    }
                    if rho < 0.5 && !fresh {
                        self.g_valid = false;
                    } else if self.spec.reuse_jacobian {
                        self.broyden_update();
                    }
                    self.g_exact = false;
                    std::mem::swap(&mut self.theta, &mut self.theta_trial);
                    last_cost_ratio = if cost > 0.0 { new_cost / cost } else { 0.0 };
                    cost = new_cost;
                    prev_step = size;
                    reused += 1;
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
                    if !self.damping.rejected() {
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
            it += 1;
        }
        self.cost = cost;
        EstimateStatus::MaxIterations
    }
}
