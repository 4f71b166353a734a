//! The solve itself: a warm Newton from the last solution (with the secant
//! predictor and the branch guard's checks), the cold path when that is not
//! possible or fails, and the report.

use super::continuation::CERTIFY_INTENSITY;
use super::*;

/// Largest change of load intensity a warm solve under loads outside Jacobi's test
/// may take above [`CERTIFY_INTENSITY`] before it is solved as a checked cold solve.
const WARM_STEP_INTENSITY: f64 = 0.25;

/// Largest chord step (scaled unknowns) that refines a solution for the load-path
/// predictor's history (`predict.rs`): the step from a converged residual is about
/// the tolerance; a larger one means a stale or ill-conditioned Jacobian, and the
/// solution is kept as it is.
const REFINE_MAX_STEP: f64 = 1e-6;
/// Only a solution whose residual is above this fraction of the tolerance is refined:
/// below it the cubic's eightfold amplification stays under the tolerance anyway, and
/// the chord step from such a residual is mostly round-off. Why not always: with the
/// condensed coupling a pass's residual depends on where its next holes start by up to
/// ~2e-10 near the end of the documented region (`tests/stability.rs`, tension
/// intensity 6.08: the same unknowns evaluated 4.7e-11 and 2.5e-10), and refining every
/// solution there moved a warm step's start into that noise, where Newton's line
/// search stalled (`Stalled` at 2.5e-10); at 0.1 the step converges and Till's 100-disk
/// ramp keeps its gain (0.14 Newton iterations a solve, 0.12 refining every solution).
const REFINE_FROM: f64 = 0.1;

impl Workspace {
    /// Solve in place. Never panics; the status says whether the result is usable.
    ///
    /// With `branch_guard` (default) a `converged` status also means "on the branch
    /// reached by loading the unloaded rod quasi-statically" (cold) or "on the branch
    /// of the previous solution" (warm), as far as the guard can tell: Jacobi's
    /// condition for world-fixed loads, a branch-checked load continuation for other
    /// loads above a load intensity of 3 (`CERTIFY_INTENSITY`), and for warm solves a
    /// check that Newton went where its first (tangent) step pointed, else a checked
    /// cold solve.
    pub fn solve(&mut self, start: Start) -> SolveReport {
        let rhs0 = self.bufs.rhs_count();
        self.jac.evals = 0;
        self.it.best_res = f64::INFINITY;
        let mut warm = start == Start::Warm && self.out.has_solution;
        // branch guard, warm: under loads outside Jacobi's test above the certify
        // intensity, a step of more than WARM_STEP_INTENSITY can land on another
        // equilibrium already in its first pass (the chords settle elsewhere), which no
        // check on the Newton path sees: such a step is solved as a checked cold solve
        let intensity = self.load_intensity();
        self.it.tol = self.prob.settings.tolerance.max(self.residual_floor());
        self.it.noise.forget();
        self.it.verdict = false;
        if let Some(rep) = self.multi_first(start, intensity) {
            return rep;
        }
        if warm
            && self.prob.settings.branch_guard
            && !self.guarded()
            && intensity > CERTIFY_INTENSITY
            && (intensity - self.path.last_intensity).abs() > WARM_STEP_INTENSITY
        {
            warm = false;
        }
        let (mut status, mut iterations, mut continuation_steps) = (SolveStatus::NonFinite, 0, 0);
        let mut cold = !warm;
        // the secant predictor moves a warm start along the load path, except where
        // the branch guard's step check of large moves is in force
        // Not with load parameters: the estimators' inner solves keep their old paths
        // (with both on, tests/estimate_joint.rs's nested LM moved by 2.5e-7 relative
        // and an unobservable case changed status).
        let plain = self.prob.plan.params.is_empty();
        let predict = plain && !(self.guarded() && intensity > CERTIFY_INTENSITY);
        let predicted = self.path.secant.start(
            &mut self.it.x,
            &mut self.path.holes_aux,
            &self.prob.loads,
            &self.bufs.b64.theta,
            warm && predict,
        );
        if predicted {
            crate::statics::pass::set_local_next(
                &self.prob.plan,
                &mut self.bufs.b64,
                &self.path.holes_aux,
                &self.it.x,
            );
        }
        if warm {
            self.path.x_start.copy_from_slice(&self.it.x);
            self.bufs.b64.local_tol = LOCAL_TOL;
            self.jac.use_broyden = plain;
            (status, iterations) = self.newton(1.0, self.prob.settings.max_iterations);
            self.jac.use_broyden = false;
            // branch guard, warm: a solve its tangent step did not describe may have
            // jumped to another equilibrium; answer as a cold (checked) solve would
            if status.is_converged()
                && self.prob.settings.branch_guard
                && self.left_branch_checked(intensity)
            {
                cold = true;
                self.it.best_res = f64::INFINITY;
            }
            // a failed warm start falls back like a failed cold one
            cold |= !status.is_converged() && self.prob.settings.continuation;
        }
        if cold {
            let (st, it, steps) = self.solve_cold();
            status = st;
            iterations += it;
            continuation_steps = steps;
        }
        if !status.is_converged() && self.it.best_res < max_abs(&self.it.res) {
            // hand back the best full-load iterate, not a partial-load point
            self.it.x.copy_from_slice(&self.it.x_best);
            self.eval_at(false, 1.0);
        }
        if self.bufs.b64.local_tol > LOCAL_TOL {
            // a failed solve's last point was evaluated with a loose inner tolerance
            self.bufs.b64.local_tol = LOCAL_TOL;
            self.eval_at(false, 1.0);
        }
        if matches!(self.bufs.last_pass, Some(lam) if lam != 1.0) {
            // a path that stopped at a partial load (a continuation whose first
            // tangent failed) left that load's residual: a status is only ever read
            // from the full load's (the fuzzed RK4 rod of
            // `fuzz/regressions/forward_solve/arc_converged_with_infinite_cable_length.bin`
            // was reported `Converged` at load 0, its residual exactly 0)
            self.eval_at(false, 1.0);
        }
        // the status of the state handed back, decided like every other one (a branch
        // verdict on this solve keeps its own)
        let status = self.it.status(status);
        if let Some(rep) = self.multi_fallback(status, intensity) {
            return rep;
        }
        self.out.has_solution = status.is_converged();
        if self.out.has_solution {
            crate::statics::pass::local_next(
                &self.prob.plan,
                &self.bufs.b64,
                &mut self.path.holes_aux,
            );
        }
        // the point the predictor extrapolates from: the solution with one more
        // chord step, no pass (`predict.rs`, "refined solutions")
        self.it.x_trial.copy_from_slice(&self.it.x);
        if self.out.has_solution
            && predict
            && self.jac.lu_valid
            && max_abs(&self.it.res) > REFINE_FROM * self.it.tol
        {
            self.jac.inverse_step(&self.it.res, &mut self.it.dx);
            if self.it.dx.iter().all(|d| d.abs() <= REFINE_MAX_STEP) {
                for (x, d) in self.it.x_trial.iter_mut().zip(&self.it.dx) {
                    *x += d;
                }
                let (plan, b64) = (&self.prob.plan, &self.bufs.b64);
                crate::statics::pass::refine_local_next(
                    plan,
                    b64,
                    &self.it.dx,
                    &mut self.path.holes_aux,
                );
            }
        }
        self.path.secant.finish(
            self.out.has_solution,
            &self.it.x,
            &self.it.x_trial,
            &self.path.holes_aux,
            &self.prob.loads,
            &self.bufs.b64.theta,
        );
        self.path.last_intensity = intensity;
        self.out.report = SolveReport {
            status,
            iterations,
            residual: max_abs(&self.it.res),
            tolerance: self.it.tol,
            rhs_evals: self.bufs.rhs_count() - rhs0,
            jacobian_evals: self.jac.evals,
            continuation_steps,
            unknowns: self.prob.plan.n_unknowns,
        };
        self.out.report
    }

    /// Non-dimensional intensity of the current loads and load parameters (the sum of
    /// the bending angles each would cause alone: `P s^2/EI`, `M s/EI`, `T r s/EI`,
    /// weights like forces; see the `intensity` module).
    pub fn load_intensity(&self) -> f64 {
        load_intensity(
            &self.prob.robot,
            &self.prob.loads,
            &self.prob.plan.params,
            &self.bufs.b64.theta,
        )
    }

    /// Round-off floor of the scaled residual for the current loads and load
    /// parameters (see the `floor` module): the smallest tolerance a solve uses.
    pub fn residual_floor(&self) -> f64 {
        let intensity = self.load_intensity();
        residual_floor(
            &self.prob.robot,
            &self.prob.loads,
            &self.prob.settings,
            &self.prob.plan.cables,
            &self.prob.plan.params,
            &self.bufs.b64.theta,
            intensity,
        )
    }
}
