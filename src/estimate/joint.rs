//! Joint (all-at-once, "simultaneous") estimator: the shooting unknowns `x` and the
//! load unknowns `theta` are iterated together, instead of solving the forward
//! problem to equilibrium for every trial `theta` as [`Estimator`] does.
//!
//! Problem (equality-constrained least squares; Nocedal & Wright, *Numerical
//! Optimization*, 2nd ed., ch. 18):
//!
//! ```text
//! min_{x, theta}  f = 1/2 sum_j w_j (l_j(x, theta) - l_ref_j - m_j)^2
//!                   + 1/2 sum_k pi_k (theta_k - mu_k)^2
//! s.t.            r(x, theta) = 0          (scaled shooting residual, statics docs)
//! ```
//!
//! with `l` the cable lengths, `m` the measured changes, `w = 1/sigma^2` (0 for a
//! missing/NaN sample), `pi = 1/sigma_prior^2`. Each iteration linearises `r` and
//! `l` at the current `z = [x; theta]` with one dual-number sweep over `[x; theta]`
//! ([`Workspace::joint_jacobians`](crate::statics::Workspace::joint_jacobians):
//! `R_x, R_t, C_x, C_t`), and solves the linearised problem by eliminating `dx`
//! through the linearised constraint `r + R_x dx + R_t dtheta = 0`:
//!
//! ```text
//! a = -R_x^-1 r,  B = -R_x^-1 R_t,  dx = a + B dtheta       (null-space elimination, N&W 18.1)
//! G = C_t + C_x B                    (= the implicit sensitivities dl/dtheta of the nested method)
//! l~ = l + C_x a                     (lengths after the Newton correction of x)
//! (G^T W G + P + mu D) dtheta = -(G^T W (l~ - l_ref - m) + P (theta - mu_prior))
//! ```
//!
//! i.e. the nested method's Levenberg-Marquardt step with `l~` in place of the
//! equilibrium lengths (the same Jacobi-scaled eigen pseudo-inverse, damping and
//! projected active set as [`Estimator`]). At an equilibrium (`r = 0`) both methods
//! take the same `dtheta`; the joint one moves `x` by the first-order predictor
//! `B dtheta` instead of re-solving the forward problem.
//!
//! Globalisation: the `l1` merit `phi = f + nu ||r||_1` (N&W eq. 18.27), with the
//! penalty at least twice the max-norm of the least-squares multiplier estimate
//! (exactness, N&W theorem 17.3) and raised further when needed for the step to be
//! a descent direction (N&W eq. 18.36 with `rho = 1/2`), never lowered within a
//! sample; a trial is accepted when `phi` drops by at least `1e-4` of the
//! predicted drop of the (undamped) model. A trial that is rejected or raised the
//! constraint violation first gets second-order corrections `x -= R_x^-1 r(trial)`
//! (N&W section 18.3, eq. 18.24: against the Maratos effect), repeated as chord
//! steps with the factorisation at hand (one `f64` pass each) while they contract;
//! if it is still rejected, the LM damping on `theta` is raised, and the `x` part
//! is halved when it dominates the step. Residuals below half the forward
//! tolerance count as satisfied in the merit (dead zone, see `l1`). Bounds by
//! projection, as in [`Estimator`].
//!
//! Convergence: the `theta` step is below `tolerance (1 + |theta|)` (the spec's rule)
//! and the scaled shooting residual is below the forward solver's `tolerance`,
//! reached by chord steps with the last factorisation once `theta` is stationary.
//! So a `Converged` estimate's shape is an equilibrium to the forward solver's own
//! tolerance. Any other exit (`MaxIterations`, `TimeBudget`, `Stalled`) hands back
//! the best `theta` (the merit decreases monotonically) with the shape re-solved to
//! equilibrium at that `theta` (one warm forward solve, after the budget check), as
//! the nested method does; `ForwardFailed` when that solve does not converge.
//!
//! The measured comparison with the nested method, and why the nested one stays the
//! default, is in the module docs of [`crate::estimate`] and `benches/README.md`.

use super::{
    Estimate, EstimateError, EstimateSpec, EstimateStatus, Estimator, LM_MAX_CONVERGED_DAMPING,
    MAX_TRIALS,
};
use crate::loads::Loads;
use crate::math::DenseLu;
use crate::robot::Robot;
use crate::settings::SolverSettings;
use crate::statics::{Start, Workspace};
use std::time::Instant;

// The merit, the pass and the linearised subproblem of one iteration.
mod model;
use model::{data_cost, eval, l1, linearise, max_abs, model_cost};
// Chord steps on `r` with the factorisation at hand (polish, second-order correction).
mod chord;
use chord::{polish, restore};

/// Armijo fraction of the predicted merit decrease (N&W eq. 18.28 with `eta`).
const ETA: f64 = 1e-4;

/// Buffers of the joint iteration, sized once (`n` shooting unknowns, `p` loads,
/// `c` cables, `w = n + p`).
struct JointState {
    n: usize,
    x: Vec<f64>,
    x_trial: Vec<f64>,
    x_keep: Vec<f64>,
    r_keep: Vec<f64>,
    l_keep: Vec<f64>,
    r: Vec<f64>,
    r_trial: Vec<f64>,
    l_trial: Vec<f64>,
    /// `[R_x R_t]`, `n x w` row-major.
    jr: Vec<f64>,
    /// `[C_x C_t]`, `c x w` row-major.
    jc: Vec<f64>,
    lu: DenseLu,
    /// `R_x^T`, factorised for the multiplier estimate.
    lut: DenseLu,
    /// `-R_x^-1 r`.
    a: Vec<f64>,
    /// `-R_x^-1 R_t`, `n x p` row-major.
    b: Vec<f64>,
    /// `l + C_x a`.
    lt: Vec<f64>,
    col: Vec<f64>,
    /// `l1` penalty parameter of the merit.
    nu: f64,
}

impl JointState {
    fn new(n: usize, p: usize, c: usize) -> Self {
        let w = n + p;
        Self {
            n,
            x: vec![0.0; n],
            x_trial: vec![0.0; n],
            x_keep: vec![0.0; n],
            r_keep: vec![0.0; n],
            l_keep: vec![0.0; c],
            r: vec![0.0; n],
            r_trial: vec![0.0; n],
            l_trial: vec![0.0; c],
            jr: vec![0.0; n * w],
            jc: vec![0.0; c * w],
            lu: DenseLu::new(n),
            lut: DenseLu::new(n),
            a: vec![0.0; n],
            b: vec![0.0; n * p],
            lt: vec![0.0; c],
            col: vec![0.0; n],
            nu: 0.0,
        }
    }
}

/// The joint estimator: same problem, spec, statistics and [`Estimate`] as
/// [`Estimator`] (which it wraps; `spec.method` is ignored), different iteration.
/// Allocates once; [`JointEstimator::tick`] allocates nothing afterwards.
pub struct JointEstimator {
    est: Estimator,
    st: JointState,
}

impl JointEstimator {
    /// Build for `robot` under the known `loads`; unknowns add to them (as
    /// [`Estimator::new`], including the reference lengths and the initial
    /// equilibrium at the unknowns' `initial` values).
    pub fn new(
        robot: Robot,
        loads: Loads,
        settings: SolverSettings,
        spec: EstimateSpec,
    ) -> Result<Self, EstimateError> {
        let mut est = Estimator::new(robot, loads, settings, spec)?;
        let n = est.workspace().unknowns();
        let st = JointState::new(n, est.p, est.c);
        Ok(Self { est, st })
    }

    /// Process one sample: cable length changes (m, `NaN` = missing) and optional
    /// per-cable noise (m), warm-started from the previous estimate and shape
    /// (which need not be an equilibrium). No allocation.
    pub fn tick(&mut self, changes: &[f64], sigma: Option<&[f64]>) -> EstimateStatus {
        let t0 = Instant::now();
        let any = self.est.intake(changes, sigma);
        let est = &mut self.est;
        est.iterations = 0;
        est.jac_evals = 0;
        est.status = if any {
            run(est, &mut self.st, t0)
        } else {
            EstimateStatus::NoData
        };
        if est.status == EstimateStatus::Converged && !est.explains_data() {
            est.status = EstimateStatus::Stalled;
        }
        est.finish();
        est.elapsed = t0.elapsed().as_secs_f64();
        est.status
    }

    /// Current estimate (SI).
    pub fn theta(&self) -> &[f64] {
        self.est.theta()
    }
    /// Unknown names.
    pub fn names(&self) -> &[String] {
        self.est.names()
    }
    /// Status of the last sample.
    pub fn status(&self) -> EstimateStatus {
        self.est.status()
    }
    /// Iterations (linearisations) of the last sample.
    pub fn iterations(&self) -> usize {
        self.est.iterations
    }
    /// Dual-number sweeps over `[x; theta]` in the last sample.
    pub fn jacobian_evals(&self) -> u64 {
        self.est.jac_evals
    }
    /// Covariance of the last sample (see [`Estimator::covariance`]).
    pub fn covariance(&self) -> &[f64] {
        self.est.covariance()
    }
    /// Reference cable lengths (m).
    pub fn reference_lengths(&self) -> &[f64] {
        self.est.reference_lengths()
    }
    /// The spec.
    pub fn spec(&self) -> &EstimateSpec {
        self.est.spec()
    }
    /// The forward workspace (current shape).
    pub fn workspace(&mut self) -> &mut Workspace {
        self.est.workspace()
    }
    /// Tip position of the current estimate (m).
    pub fn tip_position(&self) -> crate::nalgebra::Vector3<f64> {
        self.est.tip_position()
    }
    /// Start the next sample from `theta` (clamped to the bounds).
    pub fn set_theta(&mut self, theta: &[f64]) {
        self.est.set_theta(theta);
    }
    /// Snapshot of the last sample (allocates; see [`Estimator::estimate`]).
    pub fn estimate(&mut self) -> Estimate {
        self.est.estimate()
    }
}

/// The joint iteration for one sample; leaves the workspace at the returned shape.
fn run(est: &mut Estimator, st: &mut JointState, t0: Instant) -> EstimateStatus {
    let (n, p) = (st.n, est.p);
    // the forward solver's tolerance, at least the residual's round-off floor
    let tol_r = est.ws.settings().tolerance.max(est.ws.residual_floor());
    let tau = 0.5 * tol_r;
    st.x.copy_from_slice(est.ws.unknowns_vector());
    if !eval(est, st, false) {
        // the stored shape is unusable (e.g. after a failed sample): start from the
        // forward model's equilibrium at theta instead
        est.ws.set_theta(&est.theta);
        if !est.ws.solve(Start::Cold).status.is_converged() {
            return EstimateStatus::ForwardFailed;
        }
        st.x.copy_from_slice(est.ws.unknowns_vector());
        if !eval(est, st, false) {
            return EstimateStatus::ForwardFailed;
        }
    }
    // `true` while the workspace's last f64 pass was at the current point
    let mut f = data_cost(est, &est.theta, &est.len);
    let mut h1 = l1(&st.r, tau);
    st.nu = 0.0;
    est.damping.reset(1e-3);
    for it in 0..est.spec.max_iterations {
        est.iterations = it + 1;
        if let Some(b) = est.spec.time_budget_s {
            if t0.elapsed().as_secs_f64() > b {
                return conclude(est, st, EstimateStatus::TimeBudget);
            }
        }
        if let Err(status) = linearise(est, st) {
            return conclude(est, st, status);
        }
        // projected Newton (Bertsekas), as the nested method
        for k in 0..p {
            est.active[k] = (est.theta[k] <= est.lb[k] && est.grad[k] > 0.0)
                || (est.theta[k] >= est.ub[k] && est.grad[k] < 0.0);
        }
        let mut alpha = 1.0;
        let mut trials = 0;
        loop {
            trials += 1;
            if trials > MAX_TRIALS {
                return conclude(est, st, EstimateStatus::Stalled);
            }
            est.solve_step(est.damping.mu());
            let mut small = true;
            for k in 0..p {
                let t = (est.theta[k] + est.step[k] * alpha).clamp(est.lb[k], est.ub[k]);
                est.theta_trial[k] = t;
                est.step[k] = t - est.theta[k];
                small &= est.step[k].abs() <= est.spec.tolerance * (1.0 + est.theta[k].abs());
            }
            if small {
                if est.damping.mu() > LM_MAX_CONVERGED_DAMPING
                    && est.gn_predicted_decrease() > 1e-9 * (1.0 + f)
                {
                    return conclude(est, st, EstimateStatus::Stalled);
                }
                let (done, moved) = polish(est, st, tol_r);
                if moved {
                    est.g_exact = false;
                    f = data_cost(est, &est.theta, &est.len);
                    h1 = l1(&st.r, tau);
                }
                if done {
                    return conclude(est, st, EstimateStatus::Converged);
                }
                if moved {
                    break; // relinearise at the better point
                }
                // no chord progress: take the full step below (Newton on x with
                // backtracking on the merit)
                est.solve_step(est.damping.mu());
                for k in 0..p {
                    let t = (est.theta[k] + est.step[k] * alpha).clamp(est.lb[k], est.ub[k]);
                    est.theta_trial[k] = t;
                    est.step[k] = t - est.theta[k];
                }
            }
            let (mut xa, mut xb) = (0.0, 0.0);
            for i in 0..n {
                let da = alpha * st.a[i];
                let mut db = 0.0;
                for k in 0..p {
                    db += st.b[i * p + k] * est.step[k];
                }
                xa += da * da;
                xb += db * db;
                st.x_trial[i] = st.x[i] + da + db;
            }
            // predicted decrease of the merit (linearised constraint: alpha ||r||_1)
            let pred_f = f - model_cost(est, st, alpha);
            let pred_c = alpha * h1;
            if pred_c > 0.0 && pred_f < 0.0 {
                // N&W eq. 18.36 (rho = 1/2): pred >= nu pred_c / 2 > 0
                st.nu = st.nu.max(-2.0 * pred_f / pred_c);
            }
            let pred = pred_f + st.nu * pred_c;
            let phi = f + st.nu * h1;
            let accept = |ft: f64, h1t: f64, nu: f64| {
                let phit = ft + nu * h1t;
                phit.is_finite()
                    && if pred > 0.0 {
                        phi - phit >= ETA * pred
                    } else {
                        phit <= phi
                    }
            };
            let ok = eval(est, st, true);
            let mut ft = data_cost(est, &est.theta_trial, &st.l_trial);
            let mut h1t = l1(&st.r_trial, tau);
            let mut accepted = ok && accept(ft, h1t, st.nu);
            if ok && (!accepted || h1t > h1) {
                // second-order corrections (N&W section 18.3, eq. 18.24), repeated as
                // chord steps x -= R_x^-1 r(trial) with the factorisation at hand,
                // when the trial is rejected or worsened the constraint violation:
                // the linearised constraint hides an O(|step|^2) violation that the
                // l1 penalty charges (Maratos effect), shrinking the steps for
                // nothing. Target: the linearised constraint's (1 - alpha) r, so the
                // actual merit change can match the predicted one (dead zone floor).
                restore(est, st, ((1.0 - alpha) * max_abs(&st.r)).max(tau));
                ft = data_cost(est, &est.theta_trial, &st.l_trial);
                h1t = l1(&st.r_trial, tau);
                accepted = accept(ft, h1t, st.nu);
            }
            if accepted {
                let rho = if pred > 0.0 {
                    (phi - (ft + st.nu * h1t)) / pred
                } else {
                    1.0
                };
                est.damping.accepted(rho);
                std::mem::swap(&mut st.x, &mut st.x_trial);
                std::mem::swap(&mut st.r, &mut st.r_trial);
                std::mem::swap(&mut est.len, &mut st.l_trial);
                std::mem::swap(&mut est.theta, &mut est.theta_trial);
                est.ws.set_theta(&est.theta);
                est.g_exact = false;
                f = ft;
                h1 = h1t;
                break;
            }
            if !est.damping.rejected() {
                return conclude(est, st, EstimateStatus::Stalled);
            }
            if xa > xb {
                // the Newton correction of x dominates: backtrack along it
                alpha *= 0.5;
                if alpha < 1e-6 {
                    return conclude(est, st, EstimateStatus::Stalled);
                }
            }
        }
    }
    conclude(est, st, EstimateStatus::MaxIterations)
}

/// Leave the workspace at the returned shape and set `est.len`, `est.cost`.
/// Converged: the joint iterate (an equilibrium to tolerance). Otherwise: the
/// equilibrium at the best `theta` by one warm forward solve from the iterate.
fn conclude(est: &mut Estimator, st: &mut JointState, status: EstimateStatus) -> EstimateStatus {
    est.ws.set_theta(&est.theta);
    // always a fresh pass: the cable lengths (hence `len`, `cost`, the residuals and
    // the data check) come from the pass's recording, which the joint sweeps do not
    // refresh (it held the reference shape's lengths: found by the data check)
    est.ws.adopt_unknowns(&st.x, true);
    let status = if status == EstimateStatus::Converged {
        status
    } else if est.ws.solve(Start::Warm).status.is_converged() {
        // the sensitivities were taken off the manifold: not exact at this shape
        est.g_exact = false;
        status
    } else {
        EstimateStatus::ForwardFailed
    };
    est.ws.cable_lengths_into(&mut est.len);
    est.cost = est.cost_at(false);
    status
}
