//! The constrained Gauss-Newton step: `min 0.5 s^T H s + g^T s` subject to
//! `lb - theta <= s <= ub - theta`, solved by clarabel (interior point, pure Rust).

use super::Estimator;
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus,
};

/// Fill `est.step` with the box-constrained step; `false` if clarabel failed (the
/// caller then falls back to the unconstrained step, which is then projected).
pub(super) fn box_step<M>(est: &mut Estimator<M>) -> bool {
    let p = est.p;
    // P: upper triangle of H (+ a tiny ridge so unobservable directions stay bounded)
    let trace: f64 = (0..p).map(|k| est.h[k * p + k]).sum();
    let ridge = 1e-12 * trace.max(1e-300);
    let (mut colptr, mut rowval, mut nzval) = (vec![0usize], Vec::new(), Vec::new());
    for col in 0..p {
        for row in 0..=col {
            let v = est.h[row * p + col] + if row == col { ridge } else { 0.0 };
            if v != 0.0 {
                rowval.push(row);
                nzval.push(v);
            }
        }
        colptr.push(rowval.len());
    }
    let pm = CscMatrix::new(p, p, colptr, rowval, nzval);
    // A s <= b: rows  s_k <= ub_k - theta_k  and  -s_k <= theta_k - lb_k (finite only)
    let mut rows: Vec<(usize, f64, f64)> = Vec::new(); // (k, sign, bound)
    for k in 0..p {
        if est.ub[k].is_finite() {
            rows.push((k, 1.0, est.ub[k] - est.theta[k]));
        }
        if est.lb[k].is_finite() {
            rows.push((k, -1.0, est.theta[k] - est.lb[k]));
        }
    }
    let m = rows.len();
    let mut colptr = vec![0usize; p + 1];
    let (mut rowval, mut nzval) = (Vec::with_capacity(m), Vec::with_capacity(m));
    for k in 0..p {
        for (i, (kk, sign, _)) in rows.iter().enumerate() {
            if *kk == k {
                rowval.push(i);
                nzval.push(*sign);
            }
        }
        colptr[k + 1] = rowval.len();
    }
    let a = CscMatrix::new(m, p, colptr, rowval, nzval);
    let b: Vec<f64> = rows.iter().map(|r| r.2.max(0.0)).collect();
    let q = est.grad.clone();
    let settings = match DefaultSettingsBuilder::default()
        .verbose(false)
        .max_iter(100)
        .build()
    {
        Ok(s) => s,
        Err(_) => return false,
    };
    let cones = [NonnegativeConeT(m)];
    let mut solver = match DefaultSolver::new(&pm, &q, &a, &b, &cones, settings) {
        Ok(s) => s,
        Err(_) => return false,
    };
    solver.solve();
    match solver.solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => {
            est.step.copy_from_slice(&solver.solution.x);
            est.step.iter().all(|s| s.is_finite())
        }
        _ => false,
    }
}
