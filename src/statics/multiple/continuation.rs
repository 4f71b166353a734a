//! Solves with multiple shooting: the load continuation from rest (cold), warm
//! Newton from the last solution, and the branch checks.
//!
//! Branch checks, on the discretised problem:
//! - along the continuation, the sign of `det J` (the banded Jacobian) must stay the
//!   one it has at the unloaded rod; with the node blocks fixed, `det J` equals the
//!   determinant of the condensed base-to-tip map up to a fixed sign, which vanishes
//!   exactly where the equilibrium path folds or a single eigenvalue of the energy
//!   Hessian crosses zero. A step across such a point is rejected and halved;
//! - a step is also rejected when its corrector moved the unknowns by more than half
//!   the predictor's move (a jump to another branch), as in single shooting;
//! - after the last step under world-fixed loads, Jacobi's test
//!   ([`Multi::conjugate_point`]): `det dm(s)/dm(0)` must keep its sign on `(0, L]`.
//!   Single shooting sweeps it base to tip, which at `P L^2/EI = 1000` loses every
//!   digit to the growing mode; here the three directions are re-orthonormalised
//!   (Gram-Schmidt) at every node, which multiplies the determinant by a positive
//!   factor, so its sign survives.
//!
//! Not covered (as in single shooting): two eigenvalues crossing zero together (the
//! isotropic rod's axial buckling), where `det J` keeps its sign.

use super::cables::nbr_f64;
use super::intervals::{design_intensity, integrate, new_rec, LoadCtx};
use super::{max_abs, Multi, NODE};
use crate::integrate::State;
use crate::math::newton::MIN_RCOND;
use crate::math::step::StepRule;
use crate::math::{Dual, Real};
use crate::statics::plan::Plan;
use crate::statics::{SolveReport, SolveStatus};
use nalgebra::{Matrix3, Vector3};

/// Newton Jacobians per continuation step.
const STEP_BUDGET: usize = 8;
/// First continuation step in load intensity (then grown from the corrector ratio).
const FIRST_STEP: f64 = 2.0;
/// The step rule (`crate::math::step`): a step is rejected when the corrector moved
/// more than half the predictor's move; steps grow at most threefold.
const STEP_RULE: StepRule = StepRule { max_growth: 3.0 };
/// Smallest continuation step (load scale) before the solve gives up (a fold).
const MIN_STEP: f64 = 1e-5;
/// Largest weight `h / (2 dl)` of the tangent difference in the second-order
/// predictor (the extrapolation never leans on more than half the last change of the
/// tangent). Used under follower loads only: under world-fixed loads the tangent
/// decays along the path (the boundary layer thins like `lam^-1/2`) and the steps grow
/// threefold, where the extrapolation overshoots; measured at `P L^2/EI = 1000`
/// (lateral force, Kirchhoff): 10 Jacobians with the tangent predictor, 23 with this
/// one (32 uncapped). Follower force at 1000 (Kirchhoff): 130 steps and 284
/// Jacobians with the tangent predictor, 80 and 240 with this one.
const MAX_CURVATURE_WEIGHT: f64 = 0.5;
/// `max_continuation_steps` bounds the rejected steps (failures of the step control);
/// accepted steps, each of which advances the load, are bounded by this many times it
/// (a time guard: 512 with the default 32). A rod curled by a follower force needs
/// many small steps (measured: 78 at `P L^2/EI = 1000`, `tests/reach_follower.rs`).
const ACCEPTED_PER_REJECTED: usize = 16;

/// What a multiple-shooting solve needs from the workspace.
pub(crate) struct MultiArgs<'a> {
    pub plan: &'a Plan,
    pub theta: &'a [f64],
    pub intensity: f64,
    /// Tolerance on the scaled residual (the workspace's, floor included).
    pub tol: f64,
    pub max_iterations: usize,
    pub max_continuation_steps: usize,
    /// Jacobi's test after the solve (branch guard under world-fixed loads).
    pub jacobi: bool,
}

impl Multi {
    /// Solve at full load: warm Newton from the last solution when `warm` (re-meshed
    /// when the design intensity changed), else, or when that fails or changes the
    /// sign of `det J`, the continuation from rest.
    pub fn solve(&mut self, a: &MultiArgs, warm: bool) -> SolveReport {
        let rhs0 = self.rhs_evals;
        self.jac_evals = 0;
        let design = design_intensity(a.intensity);
        let full = LoadCtx {
            lam: 1.0,
            theta: a.theta,
        };
        let (mut status, mut iterations, mut steps) = (SolveStatus::NonFinite, 0, 0);
        let mut sign_ok = self.sign;
        if warm && self.has_solution {
            if self.layout.as_ref().is_some_and(|l| l.design != design) {
                self.remesh(a.plan, a.theta, design);
                sign_ok = f64::NAN;
            }
            let (st, it) = self.newton(a.plan, full, a.tol, a.max_iterations);
            (status, iterations) = (st, it);
            // the sign of det J at a fresh factorisation of this solve
            let fresh = self.fresh > 0 && self.lu_valid;
            if fresh && sign_ok.is_finite() && self.lu.det_sign() != sign_ok {
                status = SolveStatus::Stalled;
            }
            if status.is_converged() && fresh {
                self.sign = self.lu.det_sign();
            }
        }
        if !status.is_converged() {
            let (st, it, s) = self.continuation(a, design);
            status = st;
            iterations += it;
            steps = s;
        }
        if status.is_converged() && a.jacobi && self.conjugate_point(a.plan, a.theta).is_some() {
            status = SolveStatus::Unstable;
        }
        self.has_solution = status.is_converged();
        self.keep_record(a.plan, a.theta);
        self.report = SolveReport {
            status,
            iterations,
            residual: max_abs(&self.res),
            tolerance: a.tol,
            rhs_evals: self.rhs_evals - rhs0,
            jacobian_evals: self.jac_evals,
            continuation_steps: steps,
            unknowns: self.n_unknowns(),
        };
        self.report
    }

    /// Natural-parameter continuation in the load scale from the unloaded rod with a
    /// tangent predictor (second order under follower loads), the step from the
    /// corrector-to-predictor ratio, and the branch checks of the module docs. A
    /// rejected step goes back to the last accepted point with its tangent and half
    /// the step or less; the solve fails `stalled` (or the corrector's status) once the
    /// step is below [`MIN_STEP`], `max_iterations` once `max_continuation_steps` steps
    /// were rejected or [`ACCEPTED_PER_REJECTED`] times that accepted.
    fn continuation(&mut self, a: &MultiArgs, design: f64) -> (SolveStatus, usize, usize) {
        self.build(a.plan, design);
        self.straight(a.plan);
        let at = |lam: f64| LoadCtx {
            lam,
            theta: a.theta,
        };
        let (st, mut iterations) = self.newton(a.plan, at(0.0), a.tol, a.max_iterations);
        if !st.is_converged() {
            return (st, iterations, 0);
        }
        let sign0 = match self.tangent(a.plan, at(0.0), true) {
            Ok(s) => s,
            Err(st) => return (st, iterations, 0),
        };
        let mut lam = 0.0f64;
        let mut h = (FIRST_STEP / a.intensity.max(FIRST_STEP)).min(1.0);
        let (mut steps, mut rejected) = (0, 0);
        // the load step from the accepted point before `ok` (0: none yet)
        let mut prev_dl = 0.0f64;
        let second_order = a.plan.points.iter().any(|p| p.body);
        let accepted_cap = a
            .max_continuation_steps
            .saturating_mul(ACCEPTED_PER_REJECTED);
        let mut last = SolveStatus::MaxIterations;
        self.ok.clone_from(&self.nodes);
        while rejected < a.max_continuation_steps && steps - rejected < accepted_cap {
            let target = (lam + h).min(1.0);
            let step = target - lam;
            // second-order predictor (follower loads): x(lam + h) ~ x + h t + h^2/2 t',
            // with t' ~ (t - t_prev)/dl (rotation parts are body-frame rates, so the
            // two tangents are comparable and `R exp(h w + h^2/2 w')` is right to
            // second order)
            self.tan_ok.copy_from_slice(&self.tan);
            if prev_dl > 0.0 {
                let c = (0.5 * step / prev_dl).min(MAX_CURVATURE_WEIGHT);
                for ((t, o), p) in self.tan.iter_mut().zip(&self.tan_ok).zip(&self.tan_prev) {
                    *t = o + c * (o - p);
                }
            }
            let pred = step * max_abs(&self.tan);
            self.step_into(a.plan, step, false);
            self.moved.fill(0.0);
            let (st, it) = self.newton(a.plan, at(target), a.tol, STEP_BUDGET);
            iterations += it;
            steps += 1;
            let mut ratio = f64::INFINITY;
            let mut sign = f64::NAN;
            if st.is_converged() {
                ratio = max_abs(&self.moved) / (pred + 1e-9);
                // the tangent at the new point from the last factorisation if Newton
                // made one at this step (else a fresh one: the sign of det J must be
                // this point's)
                match self.tangent(a.plan, at(target), self.fresh == 0 || !self.lu_valid) {
                    Ok(s) => sign = s,
                    Err(_) => ratio = f64::INFINITY,
                }
            }
            let accept = STEP_RULE.accepts(ratio) && sign == sign0;
            // the ratio grows like h (tangent predictor) or h^2 (second order)
            let order = if prev_dl > 0.0 { 0.5 } else { 1.0 };
            let grow = STEP_RULE.growth(ratio, order);
            if accept {
                lam = target;
                self.ok.clone_from(&self.nodes);
                if lam >= 1.0 {
                    self.sign = sign;
                    return (SolveStatus::Converged, iterations, steps);
                }
                if second_order {
                    self.tan_prev.copy_from_slice(&self.tan_ok);
                    prev_dl = step;
                }
                h = step * grow;
                continue;
            }
            rejected += 1;
            last = if st.is_converged() {
                SolveStatus::Stalled
            } else {
                st
            };
            // back to the last accepted point and its tangent (the factorisation is
            // this step's: not reused)
            self.nodes.clone_from(&self.ok);
            self.tan.copy_from_slice(&self.tan_ok);
            self.lu_valid = false;
            h = step * StepRule::after_rejection(grow);
            if h < MIN_STEP {
                break;
            }
        }
        self.nodes.clone_from(&self.ok);
        self.eval(a.plan, at(1.0), false);
        let st = if h < MIN_STEP {
            last
        } else {
            SolveStatus::MaxIterations
        };
        (st, iterations, steps)
    }

    /// Tangent `dx/dlam = -J^-1 dr/dlam` at the converged node states into `tan`
    /// (`dr/dlam` by a forward difference in the load scale), with a fresh exact
    /// Jacobian when `fresh` (else the last factorisation); returns the sign of
    /// `det J`. Leaves the residual and end states at `ld`.
    fn tangent(&mut self, plan: &Plan, ld: LoadCtx, fresh: bool) -> Result<f64, SolveStatus> {
        if !self.eval(plan, ld, false) {
            return Err(SolveStatus::NonFinite);
        }
        if fresh {
            if !self.jacobian(plan, ld) {
                return Err(SolveStatus::NonFinite);
            }
            self.lu_valid = false;
            match self.lu.factor() {
                Some(rc) if rc > MIN_RCOND => self.lu_valid = true,
                _ => return Err(SolveStatus::IllConditioned),
            }
        }
        let eps = 1e-7;
        self.tan.copy_from_slice(&self.res);
        let shifted = LoadCtx {
            lam: ld.lam + eps,
            ..ld
        };
        if !self.eval(plan, shifted, false) {
            return Err(SolveStatus::NonFinite);
        }
        for (t, r) in self.tan.iter_mut().zip(&self.res) {
            *t = -(r - *t) / eps;
        }
        self.lu.solve_in_place(&mut self.tan);
        self.eval(plan, ld, false);
        Ok(self.lu.det_sign())
    }

    /// Rebuild the layout for `design` and start its nodes from the current solution
    /// (the recorded sample at or before each node's arc length).
    fn remesh(&mut self, plan: &Plan, theta: &[f64], design: f64) {
        let samples = self.record(plan, theta).rec.samples;
        let base = self.nodes[0];
        self.build(plan, design);
        let Some(layout) = self.layout.as_ref() else {
            return;
        };
        for k in 0..layout.len() {
            let s = layout.node_s(k);
            let i = samples.partition_point(|x| x.s <= s).saturating_sub(1);
            if let (true, Some(x)) = (k > 0, samples.get(i)) {
                self.nodes[k] = State {
                    r: x.r,
                    rot: x.rotation,
                    n: x.n,
                    m: x.m,
                };
            } else {
                self.nodes[k] = base;
            }
        }
        self.sign = f64::NAN;
    }

    /// Jacobi's condition on the current solution under world-fixed loads: the first
    /// arc length (m) where `det dm(s)/dm(0)` changes sign (a conjugate point), or
    /// `None`. Three `Dual<3>` directions `dm(0) = e_i` (`dn = 0`: under dead loads
    /// `n(s)` does not depend on the shape), carried interval by interval from the
    /// node states and re-orthonormalised at each node (module docs).
    /// With tensioned cables the test is not defined (as in single shooting): `None`.
    pub fn conjugate_point(&mut self, plan: &Plan, theta: &[f64]) -> Option<f64> {
        let layout = self.layout.as_ref()?;
        if layout.width != NODE {
            return None;
        }
        let (fs, ms) = (plan.force_scale, plan.moment_scale);
        let ld = LoadCtx { lam: 1.0, theta };
        // columns (theta, n/F, m/M) of the three directions
        let mut cols = [[0.0f64; NODE]; 3];
        for (c, col) in cols.iter_mut().enumerate() {
            col[6 + c] = 1.0;
        }
        let mut found: Option<f64> = None;
        for k in 0..layout.len() {
            let y = &self.nodes[k];
            let mut y0 = State {
                r: y.r.map(Dual::<3>::constant),
                rot: y.rot.map(Dual::<3>::constant),
                n: y.n.map(Dual::<3>::constant),
                m: y.m.map(Dual::<3>::constant),
            };
            for (c, col) in cols.iter().enumerate() {
                let dr = y.rot * crate::math::skew(&Vector3::new(col[0], col[1], col[2]));
                for (x, d) in y0.rot.iter_mut().zip(dr.iter()) {
                    x.d[c] = *d;
                }
                for a in 0..3 {
                    y0.n[a].d[c] = col[3 + a] * fs;
                    y0.m[a].d[c] = col[6 + a] * ms;
                }
            }
            let mut watch = |s: f64, y: &State<Dual<3>>| {
                if found.is_none() {
                    let d = Matrix3::from_fn(|r, c| y.m[r].d[c]);
                    if d.determinant() <= 0.0 {
                        found = Some(s);
                    }
                }
            };
            let out = integrate(
                plan,
                layout,
                k,
                y0,
                ld,
                None,
                &mut self.rhs_evals,
                None,
                &mut watch,
            );
            let Ok(end) = out else {
                return None;
            };
            if found.is_some() {
                return found;
            }
            let rt = end.rot.map(|x| x.re()).transpose();
            for (c, col) in cols.iter_mut().enumerate() {
                let w = rt * Matrix3::from_fn(|r, j| end.rot[(r, j)].d[c]);
                col[0] = 0.5 * (w[(2, 1)] - w[(1, 2)]);
                col[1] = 0.5 * (w[(0, 2)] - w[(2, 0)]);
                col[2] = 0.5 * (w[(1, 0)] - w[(0, 1)]);
                for a in 0..3 {
                    col[3 + a] = end.n[a].d[c] / fs;
                    col[6 + a] = end.m[a].d[c] / ms;
                }
            }
            gram_schmidt(&mut cols);
        }
        found
    }

    /// Record the solution of the current node states (samples, poses, holes).
    pub(super) fn record(&mut self, plan: &Plan, theta: &[f64]) -> super::intervals::Rec {
        let mut rec = new_rec(plan);
        let Some(layout) = self.layout.as_ref() else {
            return rec;
        };
        let ld = LoadCtx { lam: 1.0, theta };
        for k in 0..layout.len() {
            let y0 = self.nodes[k];
            let nb = nbr_f64(layout, &self.nodes, k);
            let out = integrate(
                plan,
                layout,
                k,
                y0,
                ld,
                nb.as_ref(),
                &mut self.rhs_evals,
                Some(&mut rec),
                &mut |_, _| {},
            );
            if out.is_err() {
                break;
            }
        }
        rec
    }
}

/// Modified Gram-Schmidt on three columns (positive diagonal of `R`, so the change of
/// basis has a positive determinant).
fn gram_schmidt(cols: &mut [[f64; NODE]; 3]) {
    for i in 0..3 {
        for j in 0..i {
            let d: f64 = (0..NODE).map(|t| cols[i][t] * cols[j][t]).sum();
            let cj = cols[j];
            for (x, y) in cols[i].iter_mut().zip(cj) {
                *x -= d * y;
            }
        }
        let nrm = cols[i].iter().map(|x| x * x).sum::<f64>().sqrt();
        if nrm > 0.0 {
            cols[i].iter_mut().for_each(|x| *x /= nrm);
        }
    }
}
