//! One iteration's pieces of the joint estimator (module docs of `joint`): the cost
//! `f` and the merit's constraint violation, the `f64` pass at a point, the
//! linearisation by one sweep with the reduced normal equations, and the model's
//! predicted cost.

use super::super::{EstimateStatus, Estimator};
use super::JointState;

/// `f` of the module docs at loads `th` and lengths `len`.
pub(super) fn data_cost(est: &Estimator, th: &[f64], len: &[f64]) -> f64 {
    let mut cost = 0.0;
    for j in 0..est.c {
        if est.wts[j] > 0.0 {
            let e = len[j] - est.ref_len[j] - est.meas[j];
            cost += est.wts[j] * e * e;
        }
    }
    for k in 0..est.p {
        let d = th[k] - est.prior_mean[k];
        cost += est.prior_w[k] * d * d;
    }
    0.5 * cost
}

/// Constraint violation of the merit: `sum_i max(|r_i| - tau, 0)`, the `l1` norm
/// with a dead zone `tau` (half the forward solver's tolerance) below which a
/// residual counts as satisfied. Without it, round-off-level residuals (1e-13)
/// times the penalty (up to ~1e7 with noise weights 1e10) swamp the cost near the
/// solution and every final step is rejected.
pub(super) fn l1(v: &[f64], tau: f64) -> f64 {
    v.iter().map(|x| (x.abs() - tau).max(0.0)).sum::<f64>()
        + if v.iter().any(|x| x.is_nan()) {
            f64::INFINITY
        } else {
            0.0
        }
}

pub(super) fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |a, x| {
        if x.is_nan() {
            f64::INFINITY
        } else {
            a.max(x.abs())
        }
    })
}

/// `f64` pass at `(x, theta)` (current: into `r`, `est.len`) or at
/// `(x_trial, theta_trial)` (trial: into `r_trial`, `l_trial`); `false` when the
/// integration failed or produced non-finite values.
pub(super) fn eval(est: &mut Estimator, st: &mut JointState, trial: bool) -> bool {
    let ok = if trial {
        est.ws.set_theta(&est.theta_trial);
        let ok = est.ws.shooting_residual(&st.x_trial, &mut st.r_trial);
        est.ws.cable_lengths_into(&mut st.l_trial);
        ok && st.r_trial.iter().chain(&st.l_trial).all(|v| v.is_finite())
    } else {
        est.ws.set_theta(&est.theta);
        let ok = est.ws.shooting_residual(&st.x, &mut st.r);
        est.ws.cable_lengths_into(&mut est.len);
        ok && st.r.iter().chain(&est.len).all(|v| v.is_finite())
    };
    if trial {
        // the workspace's theta follows the accepted point, not the trial
        est.ws.set_theta(&est.theta);
    }
    ok
}

/// One joint linearisation at the current point: `R`, `C` by one sweep, `R_x`
/// factorised, then `a`, `B`, `G` (into `est.g`), `l~` and the reduced normal
/// equations (into `est.h`, `est.grad`). `Err(status)` when it cannot be done.
pub(super) fn linearise(est: &mut Estimator, st: &mut JointState) -> Result<(), EstimateStatus> {
    let (n, p, c) = (st.n, est.p, est.c);
    let w = n + p;
    est.jac_evals += 1;
    if !est.ws.joint_jacobians(&st.x, &mut st.jr, &mut st.jc) {
        return Err(EstimateStatus::ForwardFailed);
    }
    let m = st.lu.matrix_mut();
    for i in 0..n {
        m[i * n..(i + 1) * n].copy_from_slice(&st.jr[i * w..i * w + n]);
    }
    match st.lu.factor() {
        // same conditioning threshold as the forward solver's Newton
        Some(rc) if rc > 1e-14 => {}
        _ => return Err(EstimateStatus::Stalled),
    }
    // least-squares multipliers of the constraint at the current point, from
    // d/dx of the Lagrangian f + lambda^T r: R_x^T lambda = -C_x^T W e
    // (N&W eq. 18.21); the l1 penalty is exact for nu > ||lambda||_inf (N&W
    // theorem 17.3), so nu never drops below it (safety factor 2)
    let mt = st.lut.matrix_mut();
    for i in 0..n {
        for k in 0..n {
            mt[k * n + i] = st.jr[i * w + k];
        }
    }
    if st.lut.factor().is_some() {
        for i in 0..n {
            let mut v = 0.0;
            for j in 0..c {
                if est.wts[j] > 0.0 {
                    let e = est.len[j] - est.ref_len[j] - est.meas[j];
                    v -= st.jc[j * w + i] * est.wts[j] * e;
                }
            }
            st.col[i] = v;
        }
        st.lut.solve_in_place(&mut st.col);
        let lam = max_abs(&st.col);
        if lam.is_finite() {
            st.nu = st.nu.max(2.0 * lam);
        }
    }
    for i in 0..n {
        st.a[i] = -st.r[i];
    }
    st.lu.solve_in_place(&mut st.a);
    for k in 0..p {
        for i in 0..n {
            st.col[i] = -st.jr[i * w + n + k];
        }
        st.lu.solve_in_place(&mut st.col);
        for i in 0..n {
            st.b[i * p + k] = st.col[i];
        }
    }
    for j in 0..c {
        let row = &st.jc[j * w..(j + 1) * w];
        let mut lt = est.len[j];
        for i in 0..n {
            lt += row[i] * st.a[i];
        }
        st.lt[j] = lt;
        for k in 0..p {
            let mut g = row[n + k];
            for i in 0..n {
                g += row[i] * st.b[i * p + k];
            }
            est.g[j * p + k] = g;
        }
    }
    est.g_valid = true;
    est.g_exact = true;
    // reduced normal equations: residual l~ - l_ref - m, Jacobian G
    est.normal_equations_at(&st.lt);
    Ok(())
}

/// Predicted value of `f` after the step `(alpha a + B s, s)` (`s = est.step`)
/// from the linear models of `l` and `theta`.
pub(super) fn model_cost(est: &Estimator, st: &JointState, alpha: f64) -> f64 {
    let p = est.p;
    let mut cost = 0.0;
    for j in 0..est.c {
        if est.wts[j] > 0.0 {
            let mut e = est.len[j] + alpha * (st.lt[j] - est.len[j]) - est.ref_len[j] - est.meas[j];
            for k in 0..p {
                e += est.g[j * p + k] * est.step[k];
            }
            cost += est.wts[j] * e * e;
        }
    }
    for k in 0..p {
        let d = est.theta[k] + est.step[k] - est.prior_mean[k];
        cost += est.prior_w[k] * d * d;
    }
    0.5 * cost
}
