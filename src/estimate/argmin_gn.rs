//! argmin's `GaussNewton` on the nested problem, through its `Executor`: the
//! owner's reference method for offline comparison. Residuals are the weighted
//! cable residuals plus prior rows; the Jacobian comes from the crate's implicit
//! sensitivities. Allocates per iteration (argmin works on `DVector`/`DMatrix`)
//! and, as argmin 0.11 inverts `J^T J`, fails on rank loss: reported as `Stalled`.

use super::{EstimateStatus, EstimationModel, Estimator};
use crate::nalgebra::{DMatrix, DVector};
use argmin::core::{CostFunction, Error, Executor, Jacobian, Operator, State};
use argmin::solver::gaussnewton::GaussNewton;
use std::cell::RefCell;

struct Nested<'a, M> {
    est: RefCell<&'a mut Estimator<M>>,
}

impl<M: EstimationModel> Nested<'_, M> {
    fn rows(est: &Estimator<M>) -> usize {
        est.c + est.prior_w.iter().filter(|w| **w > 0.0).count()
    }
    fn at(&self, theta: &DVector<f64>) -> Result<(), Error> {
        let mut est = self.est.borrow_mut();
        for k in 0..est.p {
            est.theta_trial[k] = theta[k];
        }
        if est.forward(true) {
            Ok(())
        } else {
            Err(argmin::core::ArgminError::InvalidParameter {
                text: "forward model did not converge".into(),
            }
            .into())
        }
    }
}

impl<M: EstimationModel> Operator for Nested<'_, M> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, theta: &Self::Param) -> Result<Self::Output, Error> {
        self.at(theta)?;
        let est = self.est.borrow();
        let mut r = DVector::zeros(Self::rows(&est));
        for j in 0..est.c {
            if est.wts[j] > 0.0 {
                r[j] = est.wts[j].sqrt() * (est.len[j] - est.ref_len[j] - est.meas[j]);
            }
        }
        let mut i = est.c;
        for k in 0..est.p {
            if est.prior_w[k] > 0.0 {
                r[i] = est.prior_w[k].sqrt() * (theta[k] - est.prior_mean[k]);
                i += 1;
            }
        }
        Ok(r)
    }
}

impl<M: EstimationModel> CostFunction for Nested<'_, M> {
    type Param = DVector<f64>;
    type Output = f64;
    fn cost(&self, theta: &Self::Param) -> Result<f64, Error> {
        Ok(0.5 * self.apply(theta)?.norm_squared())
    }
}

impl<M: EstimationModel> Jacobian for Nested<'_, M> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, theta: &Self::Param) -> Result<Self::Jacobian, Error> {
        self.at(theta)?;
        let mut guard = self.est.borrow_mut();
        let est = &mut **guard;
        est.jac_evals += 1;
        if !est.ws.length_sensitivities(&mut est.g, &mut est.len) {
            return Err(argmin::core::ArgminError::InvalidParameter {
                text: "singular shooting Jacobian".into(),
            }
            .into());
        }
        est.g_valid = true;
        let (p, c) = (est.p, est.c);
        let mut jm = DMatrix::zeros(Self::rows(est), p);
        for j in 0..c {
            let w = est.wts[j].sqrt();
            for k in 0..p {
                jm[(j, k)] = w * est.g[j * p + k];
            }
        }
        let mut i = c;
        for k in 0..p {
            if est.prior_w[k] > 0.0 {
                jm[(i, k)] = est.prior_w[k].sqrt();
                i += 1;
            }
        }
        Ok(jm)
    }
}

/// Run argmin's Gauss-Newton from the current estimate. On failure the previous
/// estimate and its shape are kept.
pub(super) fn run<M: EstimationModel>(est: &mut Estimator<M>) -> EstimateStatus {
    let before = est.theta.clone();
    let status = run_argmin(est);
    if matches!(
        status,
        EstimateStatus::Stalled | EstimateStatus::ForwardFailed
    ) {
        est.theta.copy_from_slice(&before);
        est.forward(false);
        est.cost = est.cost_at(false);
    }
    status
}

/// argmin's stopping rule is a change of the residual norm, which forward-solve
/// round-off can keep above a tight tolerance; at its iteration limit we therefore
/// check stationarity ourselves: the Gauss-Newton step at its best point is below
/// the spec's step tolerance.
fn stationary<M: EstimationModel>(est: &mut Estimator<M>) -> bool {
    est.jac_evals += 1;
    if !est.ws.length_sensitivities(&mut est.g, &mut est.len) {
        return false;
    }
    est.g_valid = true;
    est.g_exact = true;
    est.normal_equations();
    est.active.iter_mut().for_each(|a| *a = false);
    est.solve_step(0.0);
    (0..est.p).all(|k| est.step[k].abs() <= est.spec.tolerance * (1.0 + est.theta[k].abs()))
}

fn run_argmin<M: EstimationModel>(est: &mut Estimator<M>) -> EstimateStatus {
    let theta0 = DVector::from_column_slice(&est.theta);
    let max_iters = est.spec.max_iterations as u64;
    let tol = est.spec.tolerance;
    let problem = Nested {
        est: RefCell::new(est),
    };
    let solver = GaussNewton::<f64>::new()
        .with_tolerance(tol)
        .unwrap_or_else(|_| GaussNewton::new());
    let result = Executor::new(problem, solver)
        .configure(|s| s.param(theta0).max_iters(max_iters))
        .run();
    match result {
        Ok(res) => {
            let iters = res.state().get_iter() as usize;
            let best = res.state().get_best_param().cloned();
            let est = res
                .problem
                .problem
                .expect("argmin returns the problem")
                .est
                .into_inner();
            est.iterations = iters;
            match best {
                Some(b) if b.iter().all(|v| v.is_finite()) => {
                    for k in 0..est.p {
                        est.theta[k] = b[k];
                    }
                    if !est.forward(false) {
                        return EstimateStatus::ForwardFailed;
                    }
                    est.cost = est.cost_at(false);
                    if iters as u64 >= max_iters && !stationary(est) {
                        EstimateStatus::MaxIterations
                    } else {
                        EstimateStatus::Converged
                    }
                }
                _ => EstimateStatus::Stalled,
            }
        }
        Err(_) => EstimateStatus::Stalled,
    }
}
