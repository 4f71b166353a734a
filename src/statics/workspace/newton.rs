//! Newton with the exact dual-number Jacobian (or a chord Jacobian), the backtracking
//! line search and the f64 evaluations it needs.

use super::*;
use crate::math::newton::{backtrack, CHORD_CONTRACTION, MAX_CHORD_STEPS};

impl Workspace {
    /// Condensed coupling: sweeps over `[x (; theta)]` in chunks of six outer
    /// directions with the plan's local directions, after making sure the assumed
    /// next holes belong to `x` at load scale `lam` (an `f64` pass if not).
    pub(super) fn condensed_sweeps(&mut self, w: usize, with_theta: bool, lam: f64) -> bool {
        if self.last_pass != Some(lam) || self.b64.x != self.x {
            self.eval_at(false, lam);
            if self.last_pass != Some(lam) {
                return false;
            }
        }
        let (plan, x, b64) = (&self.plan, &self.x, &mut self.b64);
        let (jac_s, jac_m) = if with_theta {
            (&mut self.sens_s[..], &mut self.sens_m[..])
        } else {
            (self.lu.matrix_mut(), &mut [][..])
        };
        self.wide
            .as_mut()
            .is_some_and(|b| b.sweeps(plan, x, w, with_theta, b64, jac_s, jac_m, lam))
    }

    /// Straight-rod reactions as the starting point, loads scaled by `lam`.
    pub(super) fn cold_guess(&mut self, lam: f64) {
        let p = &self.plan;
        let (f, m) = p.straight_wrench(lam);
        let off = if p.closed_form {
            0
        } else {
            for i in 0..3 {
                self.x[i] = f[i] / p.force_scale;
            }
            3
        };
        for i in 0..3 {
            self.x[off + i] = m[i] / p.moment_scale;
        }
        let axis = p.base_rot * Vector3::z();
        if p.condensed {
            // straight-rod next holes; a cold start does not reuse an old segment map
            self.b64.mlin_valid = false;
            self.b64.seg_map_valid = false;
            self.b64.dnext_valid = false;
            for (j, c) in p.cables.iter().enumerate() {
                let route = &self.robot.cables()[j].route;
                for k in 0..c.len.saturating_sub(1) {
                    let s = self.robot.guides()[route[k + 1]].s;
                    self.b64.next[j][k] = p.base_r + axis * s + p.base_rot * c.hole_local[k + 1];
                }
            }
            for (g, a) in self.b64.anchor.iter_mut().enumerate() {
                *a = (p.base_r + axis * self.robot.guides()[g].s, p.base_rot);
            }
        }
        for (j, c) in p.cables.iter().enumerate() {
            if let Some(u) = c.unknowns {
                let route = &self.robot.cables()[j].route;
                for (k, &g) in route.iter().enumerate().skip(1) {
                    let s = self.robot.guides()[g].s;
                    let q = p.base_r + axis * s + p.base_rot * c.hole_local[k];
                    for a in 0..3 {
                        self.x[u + 3 * (k - 1) + a] = q[a] / p.length;
                    }
                }
            }
        }
    }

    /// Residual at `x` (f64 pass) into `res`; `false` when the pass failed.
    pub(super) fn eval_at(&mut self, trial: bool, lam: f64) -> bool {
        let src = if trial { &self.x_trial } else { &self.x };
        self.b64.x.copy_from_slice(src);
        let out = pass(&self.plan, &mut self.b64, lam, None);
        self.last_pass = out.is_ok().then_some(lam);
        match out {
            Ok(y) => {
                self.tip = y.r;
                self.tip_axis = y.rot.column(2).into_owned();
                let local = self.b64.local_tol;
                if !trial {
                    // a second settled evaluation of the same point: its settle noise
                    let (x, old, new) = (&self.x, &self.res, &self.b64.res);
                    self.tol = self.noise.raised(self.tol, x, lam, local, old, new);
                }
                self.res.copy_from_slice(&self.b64.res);
                self.noise
                    .record(src_of(trial, &self.x, &self.x_trial), lam, local);
                true
            }
            Err(_) => {
                // no residual at `x`: never leave an older one to decide a status
                self.res.fill(f64::INFINITY);
                self.noise.forget();
                false
            }
        }
    }

    /// Jacobian at `x` into the LU buffer.
    pub(super) fn jacobian(&mut self, lam: f64) -> bool {
        let n = self.plan.n_unknowns;
        self.jac_evals += 1;
        if self.plan.condensed {
            return self.condensed_sweeps(n, false, lam);
        }
        let jac = self.lu.matrix_mut();
        if n <= 3 {
            sweep::<3>(
                &self.plan,
                &self.x,
                0,
                false,
                &mut self.b3,
                jac,
                &mut [],
                lam,
            )
        } else {
            (0..n).step_by(6).all(|c0| {
                sweep::<6>(
                    &self.plan,
                    &self.x,
                    c0,
                    false,
                    &mut self.b6,
                    jac,
                    &mut [],
                    lam,
                )
            })
        }
    }

    /// Newton at load scale `lam` from the current `x`.
    ///
    /// The Jacobian is exact (dual numbers) where it is evaluated, and is reused for
    /// further full steps while they contract the residual by at least
    /// [`CHORD_CONTRACTION`] (the chord method; warm starts reuse the previous solve's
    /// factorisation). A fresh Jacobian's step gets a backtracking line search on
    /// `||r||_2`; a stale one that does not contract is discarded and refreshed.
    pub(super) fn newton(&mut self, lam: f64, max_iterations: usize) -> (SolveStatus, usize) {
        let n = self.plan.n_unknowns;
        self.first_taken = false;
        if !self.eval_at(false, lam) {
            self.res.iter_mut().for_each(|r| *r = f64::INFINITY);
            return (SolveStatus::NonFinite, 0);
        }
        self.tip_start = self.tip;
        let mut it = 0;
        let mut jacobians = 0;
        let mut chord_steps = 0;
        loop {
            if lam == 1.0 && max_abs(&self.res) < self.best_res {
                self.best_res = max_abs(&self.res);
                self.x_best.copy_from_slice(&self.x);
            }
            if self.status_here(SolveStatus::Converged).is_converged() {
                if self.b64.local_tol <= LOCAL_TOL {
                    return (self.status_here(SolveStatus::Converged), it);
                }
                // confirm with fully settled segments (condensed coupling)
                self.b64.local_tol = LOCAL_TOL;
                if !self.eval_at(false, lam) {
                    return (self.status_here(SolveStatus::NonFinite), it);
                }
                continue;
            }
            if chord_steps >= MAX_CHORD_STEPS {
                self.lu_valid = false;
            }
            // inexact inner solves while far away: 1e-10 of the outer residual,
            // between LOCAL_TOL and 1e-9 (full accuracy once res < 1e-3)
            self.b64.local_tol = self.settle_tolerance(1e-10 * max_abs(&self.res));
            let fresh = !self.lu_valid;
            if fresh && jacobians >= max_iterations {
                return (self.status_here(SolveStatus::MaxIterations), it);
            }
            it += 1;
            if fresh {
                jacobians += 1;
                chord_steps = 0;
                if !self.jacobian(lam) {
                    return (self.status_here(SolveStatus::NonFinite), it);
                }
                match self.lu.factor() {
                    Some(rc) if rc > 1e-14 => self.lu_valid = true,
                    _ => return (self.status_here(SolveStatus::IllConditioned), it),
                }
            }
            if fresh || !self.use_broyden {
                for i in 0..n {
                    self.dx[i] = -self.res[i];
                }
                self.lu.solve_in_place(&mut self.dx);
            } else {
                // the reused Jacobian's inverse with the Broyden updates so far
                self.broyden.sync(&self.lu);
                self.broyden.step(&self.res, &mut self.dx);
            }
            let f0 = norm2(&self.res);
            if !fresh {
                for i in 0..n {
                    self.x_trial[i] = self.x[i] + self.dx[i];
                }
                chord_steps += 1;
                if self.eval_trial(lam) && norm2(&self.b64.res) < CHORD_CONTRACTION * f0 {
                    if self.use_broyden {
                        self.broyden.update(&self.dx, &self.res, &self.b64.res);
                    }
                    std::mem::swap(&mut self.x, &mut self.x_trial);
                    self.res.copy_from_slice(&self.b64.res);
                    self.noise.record(&self.x, lam, self.b64.local_tol);
                    self.note_first_step();
                } else {
                    self.lu_valid = false;
                }
                continue;
            }
            let found = backtrack(f0, |alpha| {
                for i in 0..n {
                    self.x_trial[i] = self.x[i] + alpha * self.dx[i];
                }
                self.eval_trial(lam).then(|| norm2(&self.b64.res))
            });
            let Some(alpha) = found else {
                self.eval_at(false, lam);
                self.lu_valid = false;
                return (self.status_here(SolveStatus::Stalled), it);
            };
            std::mem::swap(&mut self.x, &mut self.x_trial);
            self.res.copy_from_slice(&self.b64.res);
            self.noise.record(&self.x, lam, self.b64.local_tol);
            self.note_first_step();
            if alpha < 1.0 {
                // far from the solution: the Jacobian changes quickly, do not reuse it
                self.lu_valid = false;
            }
        }
    }

    /// Residual at `x_trial` into `b64.res`; `false` when the pass failed.
    pub(super) fn eval_trial(&mut self, lam: f64) -> bool {
        self.b64.x.copy_from_slice(&self.x_trial);
        let out = pass(&self.plan, &mut self.b64, lam, None);
        self.last_pass = out.is_ok().then_some(lam);
        match out {
            Ok(y) => {
                self.tip = y.r;
                self.tip_axis = y.rot.column(2).into_owned();
                true
            }
            Err(_) => false,
        }
    }

    /// Remember the point after the first accepted Newton step (warm branch check).
    pub(super) fn note_first_step(&mut self) {
        if !self.first_taken {
            self.first_taken = true;
            self.x_first.copy_from_slice(&self.x);
            self.tip_first = self.tip;
        }
    }
}

/// The unknowns an evaluation read: the trial point or the current one.
fn src_of<'a>(trial: bool, x: &'a [f64], x_trial: &'a [f64]) -> &'a [f64] {
    if trial {
        x_trial
    } else {
        x
    }
}
