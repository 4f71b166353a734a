//! Chord steps of the joint estimator: `x -= R_x^-1 r` with the factorisation at
//! hand, at the current point (polish, once `theta` is stationary) or at a trial
//! (second-order correction, N&W section 18.3).

use super::super::Estimator;
use super::model::{eval, max_abs};
use super::JointState;

/// Chord steps (reused factorisation) allowed to bring `r` below tolerance at a
/// stationary `theta`.
const MAX_POLISH: usize = 8;
/// A chord step must shrink `||r||_inf` by this factor to count as progress.
const POLISH_CONTRACTION: f64 = 0.5;

/// Chord steps `x -= R_x^-1 r` at fixed `theta` with the current factorisation
/// until `||r||_inf <= tol`. `(converged, moved)`; on failure the last contracting
/// point is kept (it is closer to equilibrium at the same `theta`).
pub(super) fn polish(est: &mut Estimator, st: &mut JointState, tol: f64) -> (bool, bool) {
    let n = st.n;
    let mut moved = false;
    for _ in 0..MAX_POLISH {
        let res = max_abs(&st.r);
        if res <= tol {
            return (true, moved);
        }
        st.col.copy_from_slice(&st.r);
        st.lu.solve_in_place(&mut st.col);
        for i in 0..n {
            st.x_trial[i] = st.x[i] - st.col[i];
        }
        est.theta_trial.copy_from_slice(&est.theta);
        if !eval(est, st, true) || max_abs(&st.r_trial) > POLISH_CONTRACTION * res {
            return (false, moved);
        }
        std::mem::swap(&mut st.x, &mut st.x_trial);
        std::mem::swap(&mut st.r, &mut st.r_trial);
        std::mem::swap(&mut est.len, &mut st.l_trial);
        moved = true;
    }
    (max_abs(&st.r) <= tol, moved)
}

/// Chord steps `x_trial -= R_x^-1 r(trial)` at `theta_trial` with the current
/// factorisation while they contract `||r||_inf` by [`POLISH_CONTRACTION`], until
/// it is at most `target` or [`MAX_POLISH`] steps. The trial buffers end at the
/// last contracting point.
pub(super) fn restore(est: &mut Estimator, st: &mut JointState, target: f64) {
    let n = st.n;
    let mut res = max_abs(&st.r_trial);
    for _ in 0..MAX_POLISH {
        if res <= target {
            return;
        }
        st.x_keep.copy_from_slice(&st.x_trial);
        st.r_keep.copy_from_slice(&st.r_trial);
        st.l_keep.copy_from_slice(&st.l_trial);
        st.col.copy_from_slice(&st.r_trial);
        st.lu.solve_in_place(&mut st.col);
        for i in 0..n {
            st.x_trial[i] -= st.col[i];
        }
        let ok = eval(est, st, true);
        let new = max_abs(&st.r_trial);
        if !ok || new > POLISH_CONTRACTION * res {
            std::mem::swap(&mut st.x_trial, &mut st.x_keep);
            std::mem::swap(&mut st.r_trial, &mut st.r_keep);
            std::mem::swap(&mut st.l_trial, &mut st.l_keep);
            return;
        }
        res = new;
    }
}
