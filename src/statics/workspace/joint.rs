//! Workspace methods for the joint (all-at-once) estimator of
//! `crate::estimate::JointEstimator`: the linearisation of the shooting residual and
//! of the cable lengths with respect to `z = [x; theta]` at an arbitrary point (not
//! only at an equilibrium), adopting an externally iterated `x`, and pass counters.
//!
//! This file is a child module of `workspace` (declared there with `#[path]`) so that
//! it reads the workspace's private buffers without widening their visibility; it
//! adds methods only and changes none of the forward solver.

use super::{max_abs, sweep, SolveStatus, Workspace, ARC_SWEEP};
use crate::math::Dual;

/// Cumulative integration counts of one workspace (all solves and sweeps so far).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RhsCounts {
    /// ODE right-hand-side evaluations in `f64` passes.
    pub f64_rhs: u64,
    /// ODE right-hand-side evaluations in dual-number passes (`Dual<3>` and `Dual<6>`;
    /// with a fixed-step integrator, divide by the count of one `f64` pass to get
    /// the number of passes).
    pub dual_rhs: u64,
    /// Condensed coupling: re-integrations of a disk gap by the local iteration on
    /// the next-hole positions in `f64` passes (each costs one gap's right-hand
    /// sides, included in `f64_rhs`).
    pub local_iterations: u64,
}

impl Workspace {
    /// Exact first derivatives at the scaled unknowns `x` and the current `theta`,
    /// from forward-mode dual passes seeded along all of `[x; theta]` (6 directions
    /// per pass, or one `Dual<3>` pass when `n + p <= 3`):
    ///
    /// * `jac_s` (`n x (n + p)`, row-major): `[R_x  R_theta]` of the scaled shooting
    ///   residual `r(x, theta)` (the boundary conditions of thesis eq. 2.13-2.14
    ///   and the hole-position consistency rows of tensioned cables);
    /// * `jac_m` (`c x (n + p)`): `[C_x  C_theta]` of the cable lengths (m).
    ///
    /// Unlike [`Workspace::length_sensitivities`], `x` need not be an equilibrium and
    /// nothing is factorised or eliminated: the joint estimator does that. The
    /// workspace's own iterate, factorisation and warm start are untouched. No
    /// allocation. `false` when a pass failed (non-finite state) or a slice is short.
    pub fn joint_jacobians(&mut self, x: &[f64], jac_s: &mut [f64], jac_m: &mut [f64]) -> bool {
        let n = self.prob.plan.n_unknowns;
        let p = self.prob.plan.params.len();
        let c = self.prob.plan.cables.len();
        let w = n + p;
        if x.len() != n || jac_s.len() < n * w || jac_m.len() < c * w {
            return false;
        }
        self.jac.evals += 1;
        if self.prob.plan.condensed {
            return self.joint_condensed(x, w, jac_s, jac_m);
        }
        let ok = if w <= 3 {
            sweep::<3>(
                &self.prob.plan,
                x,
                0,
                true,
                &mut self.bufs.b3,
                jac_s,
                jac_m,
                1.0,
            )
        } else if let Some(b) = self.bufs.b_arc.as_mut().filter(|_| w > 6 && w <= ARC_SWEEP) {
            let ok = sweep(&self.prob.plan, x, 0, true, b, jac_s, jac_m, 1.0);
            for k in 0..p {
                b.theta[k] = Dual::constant(self.bufs.b64.theta[k]);
            }
            ok
        } else {
            (0..w).step_by(6).all(|c0| {
                sweep::<6>(
                    &self.prob.plan,
                    x,
                    c0,
                    true,
                    &mut self.bufs.b6,
                    jac_s,
                    jac_m,
                    1.0,
                )
            })
        };
        self.bufs.unseed_theta(p);
        ok
    }

    /// Condensed coupling: settle the segments at `x` (one `f64` pass), sweep with the
    /// local directions, then restore the workspace's own point if `x` differs.
    fn joint_condensed(
        &mut self,
        x: &[f64],
        w: usize,
        jac_s: &mut [f64],
        jac_m: &mut [f64],
    ) -> bool {
        // the next holes must be settled at `x` and the current theta: skip the pass
        // when the last one was exactly that (e.g. right after `adopt_unknowns`)
        if self.bufs.last_pass != Some(1.0) || self.bufs.b64.x != x {
            self.it.x_trial.copy_from_slice(x);
            if !self.eval_trial(1.0) {
                return false;
            }
        }
        let (plan, b64) = (&self.prob.plan, &mut self.bufs.b64);
        let ok = self
            .bufs
            .wide
            .as_mut()
            .is_some_and(|b| b.sweeps(plan, x, w, true, b64, jac_s, jac_m, 1.0));
        if x != self.it.x.as_slice() {
            self.eval_at(false, 1.0);
        }
        ok
    }

    /// Make `x` the workspace's current point: the shape returned by
    /// [`Workspace::solution`], [`Workspace::tip_position`] and
    /// [`Workspace::cable_lengths_into`], and the start of the next
    /// [`Start::Warm`](super::Start) solve. With `evaluate`, one `f64` pass at `x`
    /// refreshes the residual, tip and hole positions (skip it only when the last
    /// pass of this workspace was at exactly this `x` and `theta`). Returns the
    /// max-norm of the scaled residual at `x` (infinite when the pass failed). The
    /// first-order predictor of [`Workspace::set_theta_predicted`] is invalidated.
    /// No allocation.
    pub fn adopt_unknowns(&mut self, x: &[f64], evaluate: bool) -> f64 {
        if x.len() != self.it.x.len() {
            return f64::INFINITY;
        }
        self.it.x.copy_from_slice(x);
        self.sens.dxdtheta_valid = false;
        self.it.noise.forget();
        let res = if evaluate {
            if self.eval_at(false, 1.0) {
                max_abs(&self.it.res)
            } else {
                f64::INFINITY
            }
        } else {
            self.it.res.copy_from_slice(&self.bufs.b64.res);
            max_abs(&self.it.res)
        };
        // a finite point is a usable warm start even if it is not an equilibrium;
        // the report describes the adopted point (MaxIterations: "best iterate, see
        // `residual`", the closest status for an externally iterated point)
        self.out.has_solution = res.is_finite();
        self.it.tol = self.prob.settings.tolerance.max(self.residual_floor());
        // (a branch verdict belonged to the last solve's state, not to this one)
        self.it.verdict = false;
        self.out.report.status = self.it.status(SolveStatus::MaxIterations);
        self.out.report.residual = res;
        self.out.report.tolerance = self.it.tol;
        res
    }

    /// Cumulative integration counts of this workspace (for method comparisons).
    pub fn rhs_counts(&self) -> RhsCounts {
        RhsCounts {
            f64_rhs: self.bufs.b64.rhs_evals,
            dual_rhs: self.bufs.dual_rhs(),
            local_iterations: self.bufs.b64.retries,
        }
    }
}
