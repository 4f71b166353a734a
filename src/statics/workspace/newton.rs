//! Newton with the exact dual-number Jacobian (or a chord Jacobian), the backtracking
//! line search and the f64 evaluations it needs.

use super::*;
use crate::math::newton::{chord_newton, ChordNewton, Test};

impl Workspace {
    /// Condensed coupling: sweeps over `[x (; theta)]` in chunks of six outer
    /// directions with the plan's local directions, after making sure the assumed
    /// next holes belong to `x` at load scale `lam` (an `f64` pass if not).
    pub(super) fn condensed_sweeps(&mut self, w: usize, with_theta: bool, lam: f64) -> bool {
        if self.bufs.last_pass != Some(lam) || self.bufs.b64.x != self.it.x {
            self.eval_at(false, lam);
            if self.bufs.last_pass != Some(lam) {
                return false;
            }
        }
        let (plan, x, b64) = (&self.prob.plan, &self.it.x, &mut self.bufs.b64);
        let (jac_s, jac_m) = if with_theta {
            (&mut self.sens.dres[..], &mut self.sens.dlen[..])
        } else {
            (self.jac.lu.matrix_mut(), &mut [][..])
        };
        self.bufs
            .wide
            .as_mut()
            .is_some_and(|b| b.sweeps(plan, x, w, with_theta, b64, jac_s, jac_m, lam))
    }

    /// Straight-rod reactions as the starting point, loads scaled by `lam`.
    pub(super) fn cold_guess(&mut self, lam: f64) {
        let p = &self.prob.plan;
        let (f, m) = p.straight_wrench(lam);
        let off = if p.closed_form {
            0
        } else {
            for i in 0..3 {
                self.it.x[i] = f[i] / p.force_scale;
            }
            3
        };
        for i in 0..3 {
            self.it.x[off + i] = m[i] / p.moment_scale;
        }
        let axis = p.base_rot * Vector3::z();
        if p.condensed {
            // straight-rod next holes; a cold start does not reuse an old segment map
            self.bufs.b64.mlin_valid = false;
            self.bufs.b64.seg_map_valid = false;
            self.bufs.b64.dnext_valid = false;
            for (j, c) in p.cables.iter().enumerate() {
                let route = &self.prob.robot.cables()[j].route;
                for k in 0..c.len.saturating_sub(1) {
                    let s = self.prob.robot.guides()[route[k + 1]].s;
                    self.bufs.b64.next[j][k] =
                        p.base_r + axis * s + p.base_rot * c.hole_local[k + 1];
                }
            }
            for (g, a) in self.bufs.b64.anchor.iter_mut().enumerate() {
                *a = (p.base_r + axis * self.prob.robot.guides()[g].s, p.base_rot);
            }
        }
        for (j, c) in p.cables.iter().enumerate() {
            if let Some(u) = c.unknowns {
                let route = &self.prob.robot.cables()[j].route;
                for (k, &g) in route.iter().enumerate().skip(1) {
                    let s = self.prob.robot.guides()[g].s;
                    let q = p.base_r + axis * s + p.base_rot * c.hole_local[k];
                    for a in 0..3 {
                        self.it.x[u + 3 * (k - 1) + a] = q[a] / p.length;
                    }
                }
            }
        }
    }

    /// Residual at `x` (f64 pass) into `res`; `false` when the pass failed.
    pub(super) fn eval_at(&mut self, trial: bool, lam: f64) -> bool {
        let src = if trial { &self.it.x_trial } else { &self.it.x };
        self.bufs.b64.x.copy_from_slice(src);
        let out = pass(&self.prob.plan, &mut self.bufs.b64, lam, None);
        self.bufs.last_pass = out.is_ok().then_some(lam);
        match out {
            Ok(y) => {
                self.out.tip = y.r;
                self.out.tip_axis = y.rot.column(2).into_owned();
                let local = self.bufs.b64.local_tol;
                if !trial {
                    // a second settled evaluation of the same point: its settle noise
                    let (x, old, new) = (&self.it.x, &self.it.res, &self.bufs.b64.res);
                    self.it.tol = self.it.noise.raised(self.it.tol, x, lam, local, old, new);
                }
                self.it.res.copy_from_slice(&self.bufs.b64.res);
                self.it
                    .noise
                    .record(src_of(trial, &self.it.x, &self.it.x_trial), lam, local);
                true
            }
            Err(_) => {
                // no residual at `x`: never leave an older one to decide a status
                self.it.res.fill(f64::INFINITY);
                self.it.noise.forget();
                false
            }
        }
    }

    /// Jacobian at `x` into the LU buffer.
    pub(super) fn jacobian(&mut self, lam: f64) -> bool {
        let n = self.prob.plan.n_unknowns;
        self.jac.evals += 1;
        if self.prob.plan.condensed {
            return self.condensed_sweeps(n, false, lam);
        }
        let jac = self.jac.lu.matrix_mut();
        if n <= 3 {
            sweep::<3>(
                &self.prob.plan,
                &self.it.x,
                0,
                false,
                &mut self.bufs.b3,
                jac,
                &mut [],
                lam,
            )
        } else {
            (0..n).step_by(6).all(|c0| {
                sweep::<6>(
                    &self.prob.plan,
                    &self.it.x,
                    c0,
                    false,
                    &mut self.bufs.b6,
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
        self.path.first_taken = false;
        if !self.eval_at(false, lam) {
            self.it.res.iter_mut().for_each(|r| *r = f64::INFINITY);
            return (SolveStatus::NonFinite, 0);
        }
        self.path.tip_start = self.out.tip;
        let out = chord_newton(&mut AtScale { ws: self, lam }, max_iterations);
        (self.it.status(out.end.into()), out.iterations)
    }

    /// Residual at `x_trial` into `b64.res`; `false` when the pass failed.
    pub(super) fn eval_trial(&mut self, lam: f64) -> bool {
        self.bufs.b64.x.copy_from_slice(&self.it.x_trial);
        let out = pass(&self.prob.plan, &mut self.bufs.b64, lam, None);
        self.bufs.last_pass = out.is_ok().then_some(lam);
        match out {
            Ok(y) => {
                self.out.tip = y.r;
                self.out.tip_axis = y.rot.column(2).into_owned();
                true
            }
            Err(_) => false,
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
    /// Converged by [`Iterate::status`](super::Iterate::status); with loosely settled segments
    /// (condensed coupling) confirmed at fully settled ones first. Also keeps the
    /// best point at full load.
    fn test(&mut self) -> Test {
        let (ws, lam) = (&mut *self.ws, self.lam);
        if lam == 1.0 && max_abs(&ws.it.res) < ws.it.best_res {
            ws.it.best_res = max_abs(&ws.it.res);
            ws.it.x_best.copy_from_slice(&ws.it.x);
        }
        if !ws.it.status(SolveStatus::Converged).is_converged() {
            Test::Step
        } else if ws.bufs.b64.local_tol <= LOCAL_TOL {
            Test::Converged
        } else {
            ws.bufs.b64.local_tol = LOCAL_TOL;
            if ws.eval_at(false, lam) {
                Test::Recheck
            } else {
                Test::Failed
            }
        }
    }

    fn jacobian_ok(&mut self) -> &mut bool {
        &mut self.ws.jac.lu_valid
    }

    /// Inexact inner solves while far away: 1e-10 of the outer residual, between
    /// `LOCAL_TOL` and 1e-9 (full accuracy once `res < 1e-3`).
    fn prepare(&mut self) {
        let ws = &mut *self.ws;
        ws.bufs.b64.local_tol = ws.settle_tolerance(1e-10 * max_abs(&ws.it.res));
    }

    fn jacobian(&mut self) -> bool {
        self.ws.jacobian(self.lam)
    }

    fn factor(&mut self) -> Option<f64> {
        self.ws.jac.lu.factor()
    }

    /// A chord step with `use_broyden` uses the reused Jacobian's inverse with the
    /// Broyden updates so far.
    fn step(&mut self, fresh: bool) {
        let it = &mut self.ws.it;
        self.ws.jac.step(fresh, &it.res, &mut it.dx);
    }

    fn norm(&self) -> f64 {
        norm2(&self.ws.it.res)
    }

    fn trial(&mut self, alpha: f64) -> Option<f64> {
        let ws = &mut *self.ws;
        for i in 0..ws.prob.plan.n_unknowns {
            ws.it.x_trial[i] = ws.it.x[i] + alpha * ws.it.dx[i];
        }
        ws.eval_trial(self.lam).then(|| norm2(&ws.bufs.b64.res))
    }

    fn accept(&mut self, _alpha: f64, fresh: bool) {
        let ws = &mut *self.ws;
        if !fresh && ws.jac.use_broyden {
            ws.jac
                .broyden
                .update(&ws.it.dx, &ws.it.res, &ws.bufs.b64.res);
        }
        std::mem::swap(&mut ws.it.x, &mut ws.it.x_trial);
        ws.it.res.copy_from_slice(&ws.bufs.b64.res);
        ws.it
            .noise
            .record(&ws.it.x, self.lam, ws.bufs.b64.local_tol);
        // (warm branch check)
        ws.path.note_first_step(&ws.it.x, ws.out.tip);
    }

    fn restore(&mut self) {
        self.ws.eval_at(false, self.lam);
    }
}
