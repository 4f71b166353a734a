//! Newton with the exact dual-number Jacobian (or a chord Jacobian), the backtracking
//! line search and the f64 evaluations it needs.

use super::*;
use crate::math::newton::{chord_newton, ChordNewton, Test};

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

    /// Newton at load scale `lam` from the current `x` ([`chord_newton`]).
    ///
    /// The Jacobian is exact (dual numbers) where it is evaluated, and is reused for
    /// further full steps while they contract the residual by at least
    /// [`crate::math::newton::CHORD_CONTRACTION`] (the chord method, with Broyden's
    /// update when `use_broyden`; warm starts reuse the previous solve's
    /// factorisation). A fresh Jacobian's step gets a backtracking line search.
    pub(super) fn newton(&mut self, lam: f64, max_iterations: usize) -> (SolveStatus, usize) {
        self.first_taken = false;
        if !self.eval_at(false, lam) {
            self.res.iter_mut().for_each(|r| *r = f64::INFINITY);
            return (SolveStatus::NonFinite, 0);
        }
        self.tip_start = self.tip;
        let out = chord_newton(&mut AtScale { ws: self, lam }, max_iterations);
        (self.status_here(out.end.into()), out.iterations)
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

/// The shooting problem at load scale `lam`, as [`chord_newton`] drives it.
struct AtScale<'a> {
    ws: &'a mut Workspace,
    lam: f64,
}

impl ChordNewton for AtScale<'_> {
    /// Converged by [`Workspace::status_here`]; with loosely settled segments
    /// (condensed coupling) confirmed at fully settled ones first. Also keeps the
    /// best point at full load.
    fn test(&mut self) -> Test {
        let (ws, lam) = (&mut *self.ws, self.lam);
        if lam == 1.0 && max_abs(&ws.res) < ws.best_res {
            ws.best_res = max_abs(&ws.res);
            ws.x_best.copy_from_slice(&ws.x);
        }
        if !ws.status_here(SolveStatus::Converged).is_converged() {
            Test::Step
        } else if ws.b64.local_tol <= LOCAL_TOL {
            Test::Converged
        } else {
            ws.b64.local_tol = LOCAL_TOL;
            if ws.eval_at(false, lam) {
                Test::Recheck
            } else {
                Test::Failed
            }
        }
    }

    fn jacobian_ok(&mut self) -> &mut bool {
        &mut self.ws.lu_valid
    }

    /// Inexact inner solves while far away: 1e-10 of the outer residual, between
    /// `LOCAL_TOL` and 1e-9 (full accuracy once `res < 1e-3`).
    fn prepare(&mut self) {
        let ws = &mut *self.ws;
        ws.b64.local_tol = ws.settle_tolerance(1e-10 * max_abs(&ws.res));
    }

    fn jacobian(&mut self) -> bool {
        self.ws.jacobian(self.lam)
    }

    fn factor(&mut self) -> Option<f64> {
        self.ws.lu.factor()
    }

    /// A chord step with `use_broyden` uses the reused Jacobian's inverse with the
    /// Broyden updates so far.
    fn step(&mut self, fresh: bool) {
        let ws = &mut *self.ws;
        if fresh || !ws.use_broyden {
            for i in 0..ws.plan.n_unknowns {
                ws.dx[i] = -ws.res[i];
            }
            ws.lu.solve_in_place(&mut ws.dx);
        } else {
            ws.broyden.sync(&ws.lu);
            ws.broyden.step(&ws.res, &mut ws.dx);
        }
    }

    fn norm(&self) -> f64 {
        norm2(&self.ws.res)
    }

    fn trial(&mut self, alpha: f64) -> Option<f64> {
        let ws = &mut *self.ws;
        for i in 0..ws.plan.n_unknowns {
            ws.x_trial[i] = ws.x[i] + alpha * ws.dx[i];
        }
        ws.eval_trial(self.lam).then(|| norm2(&ws.b64.res))
    }

    fn accept(&mut self, _alpha: f64, fresh: bool) {
        let ws = &mut *self.ws;
        if !fresh && ws.use_broyden {
            ws.broyden.update(&ws.dx, &ws.res, &ws.b64.res);
        }
        std::mem::swap(&mut ws.x, &mut ws.x_trial);
        ws.res.copy_from_slice(&ws.b64.res);
        ws.noise.record(&ws.x, self.lam, ws.b64.local_tol);
        ws.note_first_step();
    }

    fn restore(&mut self) {
        self.ws.eval_at(false, self.lam);
    }
}
