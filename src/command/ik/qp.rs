//! The bounded least-squares step of each iteration as a clarabel QP.

use crate::error::ModelError;
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus,
};

/// The bounded least-squares step: a clarabel solver built once (dense upper
/// triangle of `P`, `A = [I; -I; -dT/du]`) and updated in place for every step.
pub(super) struct StepQp {
    solver: DefaultSolver<f64>,
    /// Upper triangle of `P`, column by column (the CSC order).
    pub(super) p_vals: Vec<f64>,
    /// `A` column by column: `[1, -1, -dT_0/du_col, .., -dT_{p-1}/du_col]`.
    pub(super) a_vals: Vec<f64>,
    pub(super) q_vals: Vec<f64>,
    pub(super) b_vals: Vec<f64>,
}

impl StepQp {
    pub(super) fn new(p: usize) -> Result<Self, ModelError> {
        let (mut colptr, mut rowval, mut nzval) = (vec![0usize], Vec::new(), Vec::new());
        for col in 0..p {
            for row in 0..=col {
                rowval.push(row);
                nzval.push(if row == col { 1.0 } else { 0.0 });
            }
            colptr.push(rowval.len());
        }
        let pm = CscMatrix::new(p, p, colptr, rowval, nzval.clone());
        // rows: u <= hi, -u <= -lo, then -dT/du u <= T (tensions stay >= 0)
        let (mut colptr, mut rowval, mut aval) = (vec![0usize], Vec::new(), Vec::new());
        for col in 0..p {
            rowval.push(col);
            aval.push(1.0);
            rowval.push(p + col);
            aval.push(-1.0);
            for k in 0..p {
                rowval.push(2 * p + k);
                aval.push(0.0);
            }
            colptr.push(rowval.len());
        }
        let am = CscMatrix::new(3 * p, p, colptr, rowval, aval.clone());
        let q = vec![0.0; p];
        let b = vec![1.0; 3 * p];
        let settings = DefaultSettingsBuilder::default()
            .verbose(false)
            .max_iter(60)
            .presolve_enable(false)
            .equilibrate_enable(false)
            .input_sparse_dropzeros(false)
            .build()
            .map_err(|e| ModelError::Invalid {
                field: "ik.qp".into(),
                why: format!("clarabel settings: {e:?}"),
            })?;
        let cones = [NonnegativeConeT(3 * p)];
        let solver = DefaultSolver::new(&pm, &q, &am, &b, &cones, settings).map_err(|e| {
            ModelError::Invalid {
                field: "ik.qp".into(),
                why: format!("clarabel: {e:?}"),
            }
        })?;
        Ok(Self {
            solver,
            p_vals: nzval,
            a_vals: aval,
            q_vals: q,
            b_vals: b,
        })
    }

    /// Solve with the current `p_vals`, `q_vals`, `b_vals`; the step into `out`.
    pub(super) fn solve(&mut self, out: &mut [f64]) -> bool {
        let s = &mut self.solver;
        if s.update_P(&self.p_vals).is_err()
            || s.update_A(&self.a_vals).is_err()
            || s.update_q(&self.q_vals).is_err()
            || s.update_b(&self.b_vals).is_err()
        {
            return false;
        }
        s.solve();
        match s.solution.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => {
                out.copy_from_slice(&s.solution.x);
                out.iter().all(|v| v.is_finite())
            }
            _ => false,
        }
    }
}
