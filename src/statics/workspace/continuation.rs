//! Cold solves: load continuation (plain and branch-checked), the branch checks of
//! warm solves and Jacobi's test for conjugate points.

use super::*;
use crate::math::newton::MIN_RCOND;
use crate::math::step::StepRule;

/// Newton iterations a cold start gets before continuation takes over.
const COLD_BUDGET: usize = 4;
/// Newton iterations per continuation step.
const CONTINUATION_BUDGET: usize = 10;

/// Load intensity (see `intensity.rs`) above which a cold solve under loads outside
/// Jacobi's test (tensioned cables, body-frame loads) is a branch-checked load
/// continuation from the unloaded rod instead of a Newton from the straight rod. On the
/// track demo a cold Newton lands on the continued branch up to 6 and on other
/// equilibria from 7 (docs/where-methods-fail.md): half of 6, for margin.
pub const CERTIFY_INTENSITY: f64 = 3.0;
/// Largest load-intensity increment of one step of the branch-checked continuation.
const CERTIFY_STEP: f64 = 2.0;
/// The branch-checked continuation's step rule: accepted while the corrector moves
/// the unknowns by at most [`crate::math::step::CORRECTOR_RATIO`] of the predictor's own move; steps
/// grow at most twofold.
const STEP_RULE: StepRule = StepRule { max_growth: 2.0 };
/// A warm solve has left its branch when, after the first step `d1`, Newton still moved
/// the unknowns by more than `WARM_JUMP_RATIO |d1| + WARM_JUMP_FLOOR` (scaled units,
/// max norm): its tangent step no longer described where it went.
const WARM_JUMP_RATIO: f64 = 1.0;
const WARM_JUMP_FLOOR: f64 = 1e-3;
/// A warm solve under world-fixed loads that moved the unknowns (scaled) or the tip
/// (in units of L) by more than this also gets Jacobi's test.
const WARM_CHECK_STEP: f64 = 0.05;

impl Workspace {
    /// Cold solve: Newton from the straight rod (with Jacobi's test and continuation
    /// as fallback), or, for loads outside Jacobi's test above [`CERTIFY_INTENSITY`],
    /// the branch-checked continuation directly.
    pub(super) fn solve_cold(&mut self) -> (SolveStatus, usize, usize) {
        self.cold_guess(1.0);
        self.jac.lu_valid = false;
        self.bufs.b64.local_tol = self.settle_tolerance(1e-9);
        if self.prob.settings.branch_guard
            && !self.guarded()
            && self.load_intensity() > CERTIFY_INTENSITY
        {
            return self.checked_continuation();
        }
        // A cold Newton from the straight rod is cut short (heavy damping means it is
        // far from the basin); continuation with a secant predictor is then cheaper.
        let budget = if self.prob.settings.continuation {
            COLD_BUDGET.min(self.prob.settings.max_iterations)
        } else {
            self.prob.settings.max_iterations
        };
        let (mut status, mut iterations) = self.newton(1.0, budget);
        let mut steps = 0;
        // branch guard: a cold Newton can land on an unstable equilibrium (looped or
        // inverted rod, seen from PL^2/EI ~ 5 on); continuation may still reach the
        // stable one from the unloaded rod
        if status.is_converged() && self.guarded() && self.conjugate_point().is_some() {
            status = SolveStatus::Unstable;
            // never hand back the unstable equilibrium as the best full-load iterate
            self.it.best_res = f64::INFINITY;
        }
        if !status.is_converged() && self.prob.settings.continuation {
            let (st, it, s) = self.continuation();
            status = st;
            iterations += it;
            steps = s;
            if status.is_converged() && self.guarded() && self.conjugate_point().is_some() {
                status = SolveStatus::Unstable;
            }
        }
        (status, iterations, steps)
    }

    /// [`left_branch`], and for a large step under world-fixed loads of
    /// intensity above [`CERTIFY_INTENSITY`] also Jacobi's test (one `Dual<3>` sweep,
    /// only then: the control loop's small steps, and mild loads, do not pay for it).
    pub(super) fn left_branch_checked(&mut self, intensity: f64) -> bool {
        let length = self.prob.plan.length;
        if left_branch(&self.path, &self.it.x, self.out.tip, length) {
            return true;
        }
        let step = max_abs_diff(&self.it.x, &self.path.x_start);
        let moved = (self.out.tip - self.path.tip_start).norm() / self.prob.plan.length;
        self.guarded()
            && intensity > CERTIFY_INTENSITY
            && (step > WARM_CHECK_STEP || moved > WARM_CHECK_STEP)
            && self.conjugate_point().is_some()
    }

    /// Natural-parameter continuation in the load scale from the unloaded rod, with a
    /// secant predictor from the last two converged load levels.
    pub(super) fn continuation(&mut self) -> (SolveStatus, usize, usize) {
        let mut lam: f64 = 0.0;
        let mut step: f64 = 0.25;
        let mut iterations = 0;
        let mut steps = 0;
        self.cold_guess(0.0);
        self.jac.lu_valid = false;
        self.path.x_ok.copy_from_slice(&self.it.x);
        self.path.x_prev.copy_from_slice(&self.it.x);
        let mut lam_prev: f64 = 0.0;
        let per_step = self.prob.settings.max_iterations.min(CONTINUATION_BUDGET);
        while steps < self.prob.settings.max_continuation_steps {
            let target = (lam + step).min(1.0);
            if lam > lam_prev {
                let k = (target - lam) / (lam - lam_prev);
                for i in 0..self.it.x.len() {
                    self.it.x[i] =
                        self.path.x_ok[i] + k * (self.path.x_ok[i] - self.path.x_prev[i]);
                }
            }
            let (st, it) = self.newton(target, per_step);
            iterations += it;
            steps += 1;
            if st.is_converged() {
                self.path.x_prev.copy_from_slice(&self.path.x_ok);
                lam_prev = lam;
                lam = target;
                self.path.x_ok.copy_from_slice(&self.it.x);
                if lam >= 1.0 {
                    return (self.it.status(st), iterations, steps);
                }
                if it <= 4 {
                    step *= 2.0;
                }
            } else {
                self.it.x.copy_from_slice(&self.path.x_ok);
                step *= 0.5;
                if step < 1e-4 {
                    self.eval_at(false, 1.0);
                    return (st, iterations, steps);
                }
            }
        }
        self.it.x.copy_from_slice(&self.path.x_ok);
        let (st, it) = self.newton(1.0, self.prob.settings.max_iterations);
        (st, iterations + it, steps)
    }

    /// Branch-checked continuation (the branch guard for loads outside Jacobi's test):
    /// tangent predictor, steps capped at [`CERTIFY_STEP`] of load intensity, and a
    /// converged step is accepted only if
    /// - the corrector moved the unknowns by at most [`crate::math::step::CORRECTOR_RATIO`] of the
    ///   predictor's own move (else it likely converged onto another branch), and
    /// - the shooting Jacobian's determinant kept the sign it has at the unloaded rod
    ///   (a sign change means the path passed a fold or bifurcation: past a fold the
    ///   equilibrium is the unstable sibling of the branch).
    ///
    /// A rejected step is halved; below `1e-4` of the load scale (a fold of the
    /// branch) the status is `stalled`, and running out of steps is `max_iterations`:
    /// never a full-load Newton from a partial load.
    pub(super) fn checked_continuation(&mut self) -> (SolveStatus, usize, usize) {
        let max_step = (CERTIFY_STEP / self.load_intensity()).min(1.0);
        let mut step = max_step.min(0.25);
        let (mut lam, mut iterations, mut steps) = (0.0f64, 0, 0);
        let per_step = self.prob.settings.max_iterations.min(CONTINUATION_BUDGET);
        self.cold_guess(0.0);
        let sign0 = match self.tangent(0.0) {
            Ok(sign) => sign,
            // (the unloaded point left here is re-evaluated at full load before its
            // status is read: `Workspace::solve`)
            Err(st) => return (st, 0, 0),
        };
        self.path.x_ok.copy_from_slice(&self.it.x);
        self.path.x_prev.copy_from_slice(&self.path.x_tan);
        let mut last = SolveStatus::MaxIterations;
        while steps < self.prob.settings.max_continuation_steps {
            let target = (lam + step).min(1.0);
            let h = target - lam;
            for i in 0..self.it.x.len() {
                self.it.x[i] = self.path.x_ok[i] + h * self.path.x_prev[i];
            }
            let (st, it) = self.newton(target, per_step);
            iterations += it;
            steps += 1;
            // corrector move over predictor move: O(h) on a smooth branch, O(1) after a
            // jump to another one
            let ratio = if st.is_converged() {
                let length = self.prob.plan.length;
                corrector_ratio(&self.path, &self.it.x, self.out.tip, h, length)
            } else {
                f64::INFINITY
            };
            let accept = STEP_RULE.accepts(ratio) && self.tangent(target) == Ok(sign0);
            // next step from the ratio's linear growth in h, within [h/4, 2h]
            let grow = STEP_RULE.growth(ratio, 1.0);
            if accept {
                lam = target;
                self.path.x_ok.copy_from_slice(&self.it.x);
                self.path.x_prev.copy_from_slice(&self.path.x_tan);
                if lam >= 1.0 {
                    // the tangent's passes re-settled the chords from another start
                    // (residual 1.3e-12 against 1.0e-12 seen by the fuzzer): confirm
                    let (st, it) = self.newton(1.0, per_step);
                    return (st, iterations + it, steps);
                }
                step = (h * grow).min(max_step);
                continue;
            }
            last = if st.is_converged() {
                SolveStatus::Stalled
            } else {
                st
            };
            self.it.x.copy_from_slice(&self.path.x_ok);
            self.jac.lu_valid = false;
            step = h * StepRule::after_rejection(grow);
            if step < 1e-4 {
                break;
            }
        }
        self.it.x.copy_from_slice(&self.path.x_ok);
        self.eval_at(false, 1.0);
        // a branch verdict: the guard could not follow the branch to full load, so no
        // state of this solve counts as on it, whatever its residual (the partial-load
        // point evaluated at full load, or the best full-load iterate)
        self.it.best_res = f64::INFINITY;
        self.it.verdict = true;
        let st = if step < 1e-4 {
            last
        } else {
            SolveStatus::MaxIterations
        };
        (st, iterations, steps)
    }

    /// Tangent `dx/dlam = -J^-1 dr/dlam` of the equilibrium path at `x` (converged at
    /// load scale `lam`) into `x_tan`, and the sign of `det J`: a fresh exact Jacobian
    /// and a forward difference of the residual in `lam`. Leaves that Jacobian
    /// factorised for the next corrector.
    pub(super) fn tangent(&mut self, lam: f64) -> Result<f64, SolveStatus> {
        let n = self.prob.plan.n_unknowns;
        self.jac.evals += 1;
        if !self.eval_at(false, lam) || !self.jacobian(lam) {
            return Err(SolveStatus::NonFinite);
        }
        match self.jac.lu.factor() {
            Some(rc) if rc > MIN_RCOND => self.jac.lu_valid = true,
            _ => return Err(SolveStatus::IllConditioned),
        }
        self.it.dx.copy_from_slice(&self.it.res);
        let eps = 1e-6;
        if !self.eval_at(false, lam + eps) {
            return Err(SolveStatus::NonFinite);
        }
        for i in 0..n {
            self.path.x_tan[i] = -(self.it.res[i] - self.it.dx[i]) / eps;
        }
        self.jac.lu.solve_in_place(&mut self.path.x_tan);
        // the tip's tangent, by a pass from this point's settled chords
        if !self.eval_at(false, lam) {
            return Err(SolveStatus::NonFinite);
        }
        self.path.tip_ok = self.out.tip;
        for i in 0..n {
            self.it.x_trial[i] = self.it.x[i] + eps * self.path.x_tan[i];
        }
        if !self.eval_at(true, lam + eps) {
            return Err(SolveStatus::NonFinite);
        }
        self.path.tip_tan = (self.out.tip - self.path.tip_ok) / eps;
        // leave the pass state at `lam`
        self.eval_at(false, lam);
        Ok(self.jac.lu.det_sign())
    }

    /// Whether cold solves get the branch guard: world-fixed (dead) loads and no
    /// tensioned cable, where `n(0)` is in closed form and Jacobi's condition on
    /// `dm(s)/dm0` is the stability test of the clamped-free rod.
    pub(super) fn guarded(&self) -> bool {
        self.prob.settings.branch_guard && self.prob.plan.closed_form
    }

    /// Jacobi's condition at the current solution: the first arc length (m) where
    /// `det d(n, m)(s)/d(n0, m0)` (or `det dm(s)/dm0` with `n(0)` in closed form)
    /// changes sign, i.e. a conjugate point, or `None` when it keeps its sign on
    /// `(0, L]`. One dual sweep along the base wrench. With the exact cable coupling the
    /// hole unknowns are held fixed in that sweep, so the test is not defined there:
    /// `None`.
    pub fn conjugate_point(&mut self) -> Option<f64> {
        if self.multi.active {
            return self
                .multi
                .solver
                .conjugate_point(&self.prob.plan, &self.bufs.b64.theta);
        }
        let n = self.prob.plan.n_unknowns;
        let (plan, x) = (&self.prob.plan, &self.it.x);
        let mut scratch_s = [0.0; 36];
        let jac_s = &mut scratch_s[..];
        if plan.condensed {
            if self.bufs.last_pass != Some(1.0) || self.bufs.b64.x != *x {
                self.eval_at(false, 1.0);
            }
            let (plan, x, b64) = (&self.prob.plan, &self.it.x, &self.bufs.b64);
            let b = &mut self.bufs.wide.as_mut()?.narrow;
            b.next.clone_from(&b64.next);
            b.watch = true;
            b.conjugate_at = None;
            let ok = sweep(plan, x, 0, false, b, jac_s, &mut [], 1.0);
            b.watch = false;
            return if ok { b.conjugate_at } else { None };
        }
        if n == 3 {
            self.bufs.b3.watch = true;
            self.bufs.b3.conjugate_at = None;
            let ok = sweep::<3>(plan, x, 0, false, &mut self.bufs.b3, jac_s, &mut [], 1.0);
            self.bufs.b3.watch = false;
            ok.then_some(self.bufs.b3.conjugate_at).flatten()
        } else if n == 6 {
            self.bufs.b6.watch = true;
            self.bufs.b6.conjugate_at = None;
            let ok = sweep::<6>(plan, x, 0, false, &mut self.bufs.b6, jac_s, &mut [], 1.0);
            self.bufs.b6.watch = false;
            ok.then_some(self.bufs.b6.conjugate_at).flatten()
        } else {
            None
        }
    }
}

/// A warm solve left its branch: after the first accepted step `d1` (`path`), Newton
/// moved the unknowns to `x` (tip `tip`, rod length `length`) by more than
/// `WARM_JUMP_RATIO |d1| + WARM_JUMP_FLOOR` (max norm).
fn left_branch(path: &Path, x: &[f64], tip: Vector3<f64>, length: f64) -> bool {
    if !path.first_taken {
        return false;
    }
    let d1 = max_abs_diff(&path.x_first, &path.x_start);
    let rest = max_abs_diff(x, &path.x_first);
    let t1 = (path.tip_first - path.tip_start).norm() / length;
    let trest = (tip - path.tip_first).norm() / length;
    rest > WARM_JUMP_RATIO * d1 + WARM_JUMP_FLOOR || trest > WARM_JUMP_RATIO * t1 + WARM_JUMP_FLOOR
}

/// How far the corrector of a checked continuation step of size `h` (from `x_ok`
/// along the tangent in `x_prev` of `path`) moved to `x` (tip `tip`), relative to the
/// predictor's own move: the larger of the ratios for the unknowns and for the tip.
fn corrector_ratio(path: &Path, x: &[f64], tip: Vector3<f64>, h: f64, length: f64) -> f64 {
    let (mut dp, mut dc) = (0.0f64, 0.0f64);
    for ((xi, ok), tan) in x.iter().zip(&path.x_ok).zip(&path.x_prev) {
        let d = h * tan;
        dp = dp.max(d.abs());
        dc = dc.max((xi - ok - d).abs());
    }
    let tip_pred = path.tip_ok + path.tip_tan * h;
    let (tp, tc) = ((path.tip_tan * h).norm(), (tip - tip_pred).norm());
    (dc / (dp + 1e-9)).max(tc / (tp + 1e-9 * length))
}
