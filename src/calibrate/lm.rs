//! Levenberg-Marquardt for bounded, optionally robust, nonlinear least squares.
//!
//! Minimises `sum_g rho(|r_g(z)|)` over a box `lower <= z <= upper`, where the
//! residuals are taken in groups `r_g` (e.g. the 3 coordinates of one marker point),
//! `rho(a) = a^2 / 2` (least squares) or Huber's
//! `rho(a) = a^2/2 (a <= k), k a - k^2/2 (a > k)` on the first `rows` residuals.
//! The step solves the damped normal equations
//! `(J^T W J + mu diag(J^T W J)) h = -J^T W r` (Marquardt's scaling; Madsen, Nielsen &
//! Tingleff 2004, algorithm 3.16 with Nielsen's damping update, `math::damping`), with `W` the IRLS
//! weights `rho'(a)/a` at the current point. Bounds: variables at a bound whose
//! gradient pushes outwards are held, the others stepped, and the trial point is
//! projected onto the box (a projected LM; the gain ratio uses the projected step).
//!
//! The problem supplies residuals and, optionally, its own Jacobian; the default is
//! central differences ([`central_differences`]).

use crate::math::damping::{Damping, DampingRule};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// A residual function `r(z)` of `n` unknowns.
pub trait LeastSquares {
    /// Error of an evaluation (a trial point that fails is rejected by the LM).
    type Error;
    /// Number of unknowns.
    fn unknowns(&self) -> usize;
    /// Number of residuals.
    fn residual_count(&self) -> usize;
    /// Residuals at `z` into `out` (length [`LeastSquares::residual_count`]).
    fn residuals(&mut self, z: &[f64], out: &mut [f64]) -> Result<(), Self::Error>;
    /// Jacobian `dr/dz` at `z` (with `r = r(z)` already evaluated) into `jac`
    /// (`residual_count x unknowns`). Default: central differences of step
    /// [`LeastSquares::fd_step`] `* max(|z_k|, 1)`.
    fn jacobian(
        &mut self,
        z: &[f64],
        r: &[f64],
        jac: &mut DMatrix<f64>,
    ) -> Result<(), Self::Error> {
        let _ = r;
        let h = self.fd_step();
        central_differences(self, z, h, jac)
    }
    /// Relative finite-difference step of the default Jacobian (default 1e-6).
    fn fd_step(&self) -> f64 {
        1e-6
    }
}

/// Central-difference Jacobian of `p` at `z`, step `h max(|z_k|, 1)` per column.
pub fn central_differences<P: LeastSquares + ?Sized>(
    p: &mut P,
    z: &[f64],
    h: f64,
    jac: &mut DMatrix<f64>,
) -> Result<(), P::Error> {
    let m = p.residual_count();
    let mut zp = z.to_vec();
    let mut rp = vec![0.0; m];
    let mut rm = vec![0.0; m];
    for k in 0..z.len() {
        let hk = h * z[k].abs().max(1.0);
        zp[k] = z[k] + hk;
        p.residuals(&zp, &mut rp)?;
        zp[k] = z[k] - hk;
        p.residuals(&zp, &mut rm)?;
        zp[k] = z[k];
        for i in 0..m {
            jac[(i, k)] = (rp[i] - rm[i]) / (2.0 * hk);
        }
    }
    Ok(())
}

/// Huber loss on the first `rows` residuals, in groups of `group`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Huber {
    /// Threshold `k` on a group's norm (same unit as the residuals).
    pub threshold: f64,
    /// Residuals per group (3 for a point).
    pub group: usize,
    /// Residuals subject to the loss (the rest, e.g. priors, stay quadratic).
    pub rows: usize,
}

impl Huber {
    /// IRLS weight of a group of norm `a`: `rho'(a) / a`.
    pub fn weight(&self, a: f64) -> f64 {
        if a <= self.threshold {
            1.0
        } else {
            self.threshold / a
        }
    }
    /// `rho(a)`.
    pub fn rho(&self, a: f64) -> f64 {
        if a <= self.threshold {
            0.5 * a * a
        } else {
            self.threshold * a - 0.5 * self.threshold * self.threshold
        }
    }
}

/// Settings of [`levenberg_marquardt`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LmSettings {
    /// Jacobian evaluations (accepted steps) allowed (default 50).
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction, or the
    /// step is shorter than this times `|z|` (default 1e-10).
    pub tolerance: f64,
    /// Initial damping `mu` relative to `diag(J^T W J)` (default 1e-3).
    pub initial_damping: f64,
    /// Robust loss; `None` (default) = least squares.
    pub huber: Option<Huber>,
}

impl Default for LmSettings {
    fn default() -> Self {
        Self {
            max_iterations: 50,
            tolerance: 1e-10,
            initial_damping: 1e-3,
            huber: None,
        }
    }
}

/// How [`levenberg_marquardt`] ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LmStatus {
    /// Cost decrease, step or projected gradient below the tolerance at a
    /// stationary point (every free column's cosine with the residual at most
    /// [`STATIONARY_COSINE`]): a (local) minimum. Usable.
    Converged,
    /// Iteration limit: the best point so far. Usable if its residuals are.
    MaxIterations,
    /// No damping produced a decrease (flat or invalid neighbourhood), or the steps
    /// vanished under a growing damping away from a stationary point: the best
    /// point so far, not a minimum.
    Stalled,
    /// Not produced by [`levenberg_marquardt`]: a calibration
    /// ([`super::calibrate`]) found more rows whose forward solve fails than its
    /// `max_failed_fraction` allows and took no step. The values are the start
    /// values; not a fit.
    TooManyFailedRows,
}

/// One step of the iteration, for progress display.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmIteration {
    /// Accepted steps so far.
    pub iteration: usize,
    /// Cost `sum rho` at the current point.
    pub cost: f64,
    /// Damping `mu`.
    pub damping: f64,
    /// Whether the last trial was accepted.
    pub accepted: bool,
}

/// Result of [`levenberg_marquardt`].
#[derive(Clone, Debug, PartialEq)]
pub struct LmResult {
    /// Final unknowns.
    pub z: Vec<f64>,
    /// How it ended.
    pub status: LmStatus,
    /// Accepted steps.
    pub iterations: usize,
    /// Residual evaluations (Jacobians by differences not included).
    pub evaluations: usize,
    /// Final cost `sum rho`.
    pub cost: f64,
    /// Residuals at `z`.
    pub residuals: Vec<f64>,
    /// IRLS weights per residual at `z` (all 1 without a robust loss).
    pub weights: Vec<f64>,
    /// Jacobian at `z` (`residuals x unknowns`).
    pub jacobian: DMatrix<f64>,
    /// Why the last rejected trial was rejected (`None` if none was): with
    /// [`LmStatus::Stalled`], the reason the fit could not move.
    pub last_rejection: Option<String>,
}

/// Box bounds on the unknowns (`-inf`/`+inf` for none).
#[derive(Clone, Debug, PartialEq)]
pub struct Bounds {
    /// Lower bounds.
    pub lower: Vec<f64>,
    /// Upper bounds.
    pub upper: Vec<f64>,
}

impl Bounds {
    /// No bounds on `n` unknowns.
    pub fn none(n: usize) -> Self {
        Self {
            lower: vec![f64::NEG_INFINITY; n],
            upper: vec![f64::INFINITY; n],
        }
    }
    fn project(&self, z: &mut DVector<f64>) {
        for k in 0..z.len() {
            z[k] = z[k].clamp(self.lower[k], self.upper[k]);
        }
    }
}

fn weights_and_cost(r: &[f64], huber: Option<&Huber>, w: &mut [f64]) -> f64 {
    w.iter_mut().for_each(|x| *x = 1.0);
    let Some(h) = huber else {
        return 0.5 * r.iter().map(|x| x * x).sum::<f64>();
    };
    let g = h.group.max(1);
    let rows = h.rows.min(r.len());
    let mut cost = 0.0;
    let mut i = 0;
    while i < rows {
        let e = (i + g).min(rows);
        let a = r[i..e].iter().map(|x| x * x).sum::<f64>().sqrt();
        cost += h.rho(a);
        let wt = h.weight(a);
        w[i..e].iter_mut().for_each(|x| *x = wt);
        i = e;
    }
    cost + 0.5 * r[rows..].iter().map(|x| x * x).sum::<f64>()
}

/// Largest cosine between the (weighted) residual and a free unknown's Jacobian
/// column below which a fit that stopped moving is at a stationary point
/// (MINPACK's `gtol` test). A step or a decrease below the tolerance while a
/// column still correlates more than this with the residual is not a minimum: the
/// damping grew until the steps vanished (rejected trials, e.g. rows whose solve
/// failed at the trial point, or a Jacobian that does not match the residuals).
pub const STATIONARY_COSINE: f64 = 1e-2;

/// `max_k |g_k| / sqrt(a_kk sum w r^2)` over the free unknowns (0 when nothing is
/// left: a zero residual or no free column).
pub fn gradient_cosine(
    a: &DMatrix<f64>,
    g: &DVector<f64>,
    r: &[f64],
    w: &[f64],
    free: &[usize],
) -> f64 {
    let rr: f64 = r.iter().zip(w).map(|(r, w)| w * r * r).sum();
    free.iter()
        .filter(|&&k| a[(k, k)] > 0.0 && rr > 0.0)
        .map(|&k| g[k].abs() / (a[(k, k)] * rr).sqrt())
        .fold(0.0, f64::max)
}

/// Relative size of the undamped Gauss-Newton step (`|h| <= GN_STEP (|z| + GN_STEP)`)
/// below which a fit that stopped moving is at a stationary point whatever the
/// cosine: at a zero-residual optimum the residual is rounding, and its cosine with
/// a column means nothing.
pub const GN_STEP: f64 = 1e-4;

/// The status of a fit that stopped moving: [`LmStatus::Converged`] at a
/// stationary point (the residual orthogonal to the free columns, or an undamped
/// Gauss-Newton step that would not move it), else [`LmStatus::Stalled`] (no false
/// convergence).
fn stopped(
    a: &DMatrix<f64>,
    g: &DVector<f64>,
    r: &[f64],
    w: &[f64],
    free: &[usize],
    z: &DVector<f64>,
) -> LmStatus {
    if gradient_cosine(a, g, r, w, free) <= STATIONARY_COSINE {
        return LmStatus::Converged;
    }
    let nf = free.len();
    let af = DMatrix::from_fn(nf, nf, |i, j| a[(free[i], free[j])]);
    let gf = DVector::from_fn(nf, |i, _| -g[free[i]]);
    match af.cholesky().map(|c| c.solve(&gf)) {
        Some(h) if h.norm() <= GN_STEP * (z.norm() + GN_STEP) => LmStatus::Converged,
        _ => LmStatus::Stalled,
    }
}

/// `res` with the reason of the last rejected trial.
fn rejected(last: &Option<String>, mut res: LmResult) -> LmResult {
    res.last_rejection.clone_from(last);
    res
}

/// Minimise the problem's cost from `z0` within `bounds` (see the module docs).
/// `observer` sees every trial. The starting point must evaluate; later failures
/// are rejected trials.
pub fn levenberg_marquardt<P: LeastSquares + ?Sized>(
    p: &mut P,
    z0: &[f64],
    bounds: &Bounds,
    s: &LmSettings,
    observer: &mut dyn FnMut(&LmIteration),
) -> Result<LmResult, P::Error>
where
    P::Error: std::fmt::Display,
{
    let (n, m) = (p.unknowns(), p.residual_count());
    let mut z = DVector::from_column_slice(z0);
    bounds.project(&mut z);
    let mut r = vec![0.0; m];
    p.residuals(z.as_slice(), &mut r)?;
    let mut evaluations = 1;
    let mut w = vec![1.0; m];
    let mut cost = weights_and_cost(&r, s.huber.as_ref(), &mut w);
    let mut jac = DMatrix::zeros(m, n);
    p.jacobian(z.as_slice(), &r, &mut jac)?;
    let normal = |jac: &DMatrix<f64>, r: &[f64], w: &[f64]| {
        let mut jw = jac.clone();
        for (i, wi) in w.iter().enumerate() {
            jw.row_mut(i).scale_mut(*wi);
        }
        let a = jac.transpose() * &jw;
        let g = jw.transpose() * DVector::from_column_slice(r);
        (a, g)
    };
    let (mut a, mut g) = normal(&jac, &r, &w);
    let mut damping = Damping::new(DampingRule::Nielsen, s.initial_damping);
    let mut iterations = 0;
    let mut r_new = vec![0.0; m];
    let mut w_new = vec![1.0; m];
    let mut jac_new = DMatrix::zeros(m, n);
    let mut last_rejection: Option<String> = None;
    let finish = |z: DVector<f64>, status, iterations, evaluations, cost, r, w, jac| LmResult {
        z: z.as_slice().to_vec(),
        status,
        iterations,
        evaluations,
        cost,
        residuals: r,
        weights: w,
        jacobian: jac,
        last_rejection: None,
    };
    // no damping gives a decrease: the last accepted point, with the reason
    macro_rules! stall {
        () => {
            return Ok(rejected(
                &last_rejection,
                finish(
                    z,
                    LmStatus::Stalled,
                    iterations,
                    evaluations,
                    cost,
                    r,
                    w,
                    jac,
                ),
            ))
        };
    }
    loop {
        if iterations >= s.max_iterations {
            return Ok(rejected(
                &last_rejection,
                finish(
                    z,
                    LmStatus::MaxIterations,
                    iterations,
                    evaluations,
                    cost,
                    r,
                    w,
                    jac,
                ),
            ));
        }
        // free set: not held at a bound by an outward gradient
        let free: Vec<usize> = (0..n)
            .filter(|&k| {
                !((z[k] <= bounds.lower[k] && g[k] > 0.0)
                    || (z[k] >= bounds.upper[k] && g[k] < 0.0))
            })
            .collect();
        let gmax = free.iter().fold(0.0f64, |acc, &k| acc.max(g[k].abs()));
        if free.is_empty() || gmax <= 1e-15 * (1.0 + cost) {
            return Ok(rejected(
                &last_rejection,
                finish(
                    z,
                    LmStatus::Converged,
                    iterations,
                    evaluations,
                    cost,
                    r,
                    w,
                    jac,
                ),
            ));
        }
        let nf = free.len();
        let dmax = a.diagonal().max().max(f64::MIN_POSITIVE);
        let mut damped = DMatrix::zeros(nf, nf);
        let mut rhs = DVector::zeros(nf);
        for (i, &ki) in free.iter().enumerate() {
            for (j, &kj) in free.iter().enumerate() {
                damped[(i, j)] = a[(ki, kj)];
            }
            damped[(i, i)] += damping.mu() * a[(ki, ki)].max(1e-12 * dmax);
            rhs[i] = -g[ki];
        }
        let Some(hf) = damped.cholesky().map(|c| c.solve(&rhs)) else {
            last_rejection = Some("the damped normal equations are not positive definite".into());
            if !damping.rejected() {
                stall!();
            }
            continue;
        };
        let mut z_new = z.clone();
        for (i, &k) in free.iter().enumerate() {
            z_new[k] += hf[i];
        }
        bounds.project(&mut z_new);
        let h = &z_new - &z;
        if h.norm() <= s.tolerance * (z.norm() + s.tolerance) {
            let status = stopped(&a, &g, &r, &w, &free, &z);
            return Ok(rejected(
                &last_rejection,
                finish(z, status, iterations, evaluations, cost, r, w, jac),
            ));
        }
        // predicted decrease of the local quadratic model (undamped, projected step)
        let predicted = -(g.dot(&h) + 0.5 * h.dot(&(&a * &h)));
        let trial = p.residuals(z_new.as_slice(), &mut r_new);
        evaluations += 1;
        let accepted = match trial {
            Err(e) => {
                last_rejection = Some(format!("the trial point's residuals failed: {e}"));
                false
            }
            Ok(()) if !r_new.iter().all(|x| x.is_finite()) => {
                last_rejection = Some("the trial point's residuals are not finite".into());
                false
            }
            Ok(()) => {
                let cost_new = weights_and_cost(&r_new, s.huber.as_ref(), &mut w_new);
                let gain = (cost - cost_new) / predicted.max(f64::MIN_POSITIVE);
                // a point whose Jacobian cannot be evaluated (e.g. a perturbed model
                // solve fails) is rejected like a failed trial
                let jac_ok = if gain > 0.0 && cost_new < cost {
                    match p.jacobian(z_new.as_slice(), &r_new, &mut jac_new) {
                        Ok(()) => true,
                        Err(e) => {
                            last_rejection =
                                Some(format!("the Jacobian at the trial point failed: {e}"));
                            false
                        }
                    }
                } else {
                    last_rejection = Some(format!(
                        "the cost did not decrease (cost {cost:.6e} -> {cost_new:.6e})"
                    ));
                    false
                };
                if jac_ok {
                    let decrease = cost - cost_new;
                    z = z_new;
                    std::mem::swap(&mut r, &mut r_new);
                    std::mem::swap(&mut w, &mut w_new);
                    std::mem::swap(&mut jac, &mut jac_new);
                    cost = cost_new;
                    (a, g) = normal(&jac, &r, &w);
                    damping.accepted(gain);
                    iterations += 1;
                    observer(&LmIteration {
                        iteration: iterations,
                        cost,
                        damping: damping.mu(),
                        accepted: true,
                    });
                    if decrease <= s.tolerance * cost.max(f64::MIN_POSITIVE) {
                        let free: Vec<usize> = (0..n)
                            .filter(|&k| {
                                !((z[k] <= bounds.lower[k] && g[k] > 0.0)
                                    || (z[k] >= bounds.upper[k] && g[k] < 0.0))
                            })
                            .collect();
                        let status = stopped(&a, &g, &r, &w, &free, &z);
                        return Ok(rejected(
                            &last_rejection,
                            finish(z, status, iterations, evaluations, cost, r, w, jac),
                        ));
                    }
                    true
                } else {
                    false
                }
            }
        };
        if !accepted {
            let go_on = damping.rejected();
            observer(&LmIteration {
                iteration: iterations,
                cost,
                damping: damping.mu(),
                accepted: false,
            });
            if !go_on {
                stall!();
            }
        }
    }
}
