//! The bounded least-squares step of each iteration: a small convex QP, solved by
//! the allocation-free active-set method ([`super::active_set`]), with clarabel
//! (interior point) as the fallback when that gives up and as the reference the
//! tests compare it with.

use super::active_set::ActiveSetQp;
use crate::error::ModelError;
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus,
};

/// Which solver gave the step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum QpSolver {
    /// The active-set method (no allocation).
    ActiveSet,
    /// clarabel, after the active-set method gave up.
    Clarabel,
}

/// The step's QP in `p` variables (mm): `min 0.5 u^T H u + g^T u` subject to
/// `lo <= u <= hi` (`lo <= 0 <= hi`) and the linearised tensions staying
/// non-negative, `C u <= d` with `C = -dT/du` (`p x p`, N/mm) and `d = T >= 0`
/// (N): `u = 0` is feasible.
pub(super) struct StepQp {
    p: usize,
    /// Bounds (mm).
    pub(super) lo: Vec<f64>,
    pub(super) hi: Vec<f64>,
    /// `C`, row-major `p x p`, and `d`.
    pub(super) rows: Vec<f64>,
    pub(super) rhs: Vec<f64>,
    active: ActiveSetQp,
    clarabel: ClarabelStep,
}

impl StepQp {
    pub(super) fn new(p: usize) -> Result<Self, ModelError> {
        Ok(Self {
            p,
            lo: vec![-1.0; p],
            hi: vec![1.0; p],
            rows: vec![0.0; p * p],
            rhs: vec![1.0; p],
            active: ActiveSetQp::new(p, p),
            clarabel: ClarabelStep::new(p)?,
        })
    }

    /// The step for `h` (full `p x p`, row-major) and `g` with the current
    /// bounds and rows into `out`; the solver that gave it, `None` when neither
    /// did.
    pub(super) fn solve(&mut self, h: &[f64], g: &[f64], out: &mut [f64]) -> Option<QpSolver> {
        let r = self
            .active
            .solve(h, g, &self.lo, &self.hi, &self.rows, &self.rhs, out);
        if r.is_ok() {
            return Some(QpSolver::ActiveSet);
        }
        self.solve_clarabel(h, g, out).then_some(QpSolver::Clarabel)
    }

    /// The step by clarabel alone (the fallback, and the reference in tests).
    pub(super) fn solve_clarabel(&mut self, h: &[f64], g: &[f64], out: &mut [f64]) -> bool {
        let p = self.p;
        let c = &mut self.clarabel;
        // upper triangle of P column by column; A column by column
        let mut n = 0;
        for col in 0..p {
            for row in 0..=col {
                c.p_vals[n] = h[row * p + col];
                n += 1;
            }
        }
        for col in 0..p {
            for k in 0..p {
                c.a_vals[col * (p + 2) + 2 + k] = self.rows[k * p + col];
            }
        }
        c.q_vals.copy_from_slice(g);
        c.b_vals[..p].copy_from_slice(&self.hi);
        for (b, l) in c.b_vals[p..2 * p].iter_mut().zip(&self.lo) {
            *b = -l;
        }
        c.b_vals[2 * p..].copy_from_slice(&self.rhs);
        c.solve(out)
    }
}

/// The step's QP in clarabel: built once (dense upper triangle of `P`, `A = [I;
/// -I; -dT/du]`) and updated in place (`update_P/A/q/b`) for every step. Its
/// `solve` allocates (clarabel 0.11 rebuilds a map of its timers in each call).
struct ClarabelStep {
    solver: DefaultSolver<f64>,
    /// Upper triangle of `P`, column by column (the CSC order).
    p_vals: Vec<f64>,
    /// `A` column by column: `[1, -1, -dT_0/du_col, .., -dT_{p-1}/du_col]`.
    a_vals: Vec<f64>,
    /// `q` and `b` (clarabel's update takes sized data).
    q_vals: Vec<f64>,
    b_vals: Vec<f64>,
}

impl ClarabelStep {
    fn new(p: usize) -> Result<Self, ModelError> {
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

    /// Solve with the current `p_vals`, `a_vals`, `q_vals`, `b_vals`; the step into `out`.
    fn solve(&mut self, out: &mut [f64]) -> bool {
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

#[cfg(test)]
mod tests {
    //! The active-set step against clarabel on random QPs of the step's
    //! structure (`p` readings; box rows, and linearised-tension rows some of which
    //! are zero as a slack tendon's are).
    use super::*;
    use proptest::prelude::*;

    /// `0.5 u^T H u + g^T u`.
    fn objective(h: &[f64], g: &[f64], u: &[f64]) -> f64 {
        let p = g.len();
        (0..p)
            .map(|a| u[a] * (g[a] + 0.5 * (0..p).map(|b| h[a * p + b] * u[b]).sum::<f64>()))
            .sum()
    }

    /// `d^T H d`.
    fn h_norm2(h: &[f64], d: &[f64]) -> f64 {
        let p = d.len();
        (0..p)
            .map(|a| d[a] * (0..p).map(|b| h[a * p + b] * d[b]).sum::<f64>())
            .sum()
    }

    /// One QP: `H`, `g`, bounds `lo`, `hi`, rows `C`, `d`.
    struct Case {
        h: Vec<f64>,
        g: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
        rows: Vec<f64>,
        rhs: Vec<f64>,
    }

    /// A QP like the IK step's: `H = 2 J^T J + 2 mu I` with `J` (`rows x p`, mm/mm)
    /// and damping `mu`; `g = -2 J^T e`; bounds in [0, 2] mm, a fifth of them zero
    /// (a reading on its limit); tension rows `-dT/du` (N/mm) with `T` in [0, 5] N,
    /// a fifth of them a slack tendon's (`T = 0`, one entry: its own column).
    fn qp_case(p: usize, rows: usize, mu: f64, vals: &[f64]) -> Case {
        let mut it = vals.iter().copied().cycle();
        let mut next = || it.next().unwrap();
        let jac: Vec<f64> = (0..rows * p).map(|_| 5.0 * next()).collect();
        let e: Vec<f64> = (0..rows).map(|_| 4.0 * next()).collect();
        let mut h = vec![0.0; p * p];
        let mut g = vec![0.0; p];
        for r in 0..rows {
            for a in 0..p {
                g[a] -= 2.0 * jac[r * p + a] * e[r];
                for b in 0..p {
                    h[a * p + b] += 2.0 * jac[r * p + a] * jac[r * p + b];
                }
            }
        }
        for a in 0..p {
            h[a * p + a] += 2.0 * mu;
        }
        let bound = |v: f64| if v.abs() < 0.2 { 0.0 } else { 2.0 * v.abs() };
        let (mut lo, mut hi) = (vec![0.0; p], vec![0.0; p]);
        let (mut c, mut d) = (vec![0.0; p * p], vec![0.0; p]);
        for i in 0..p {
            hi[i] = bound(next());
            lo[i] = -bound(next());
            let t = next();
            let slack = t.abs() < 0.2;
            d[i] = if slack { 0.0 } else { 5.0 * t.abs() };
            for col in 0..p {
                let v = next();
                c[i * p + col] = if !slack || col == i { -3.0 * v } else { 0.0 };
            }
        }
        Case {
            h,
            g,
            lo,
            hi,
            rows: c,
            rhs: d,
        }
    }

    /// Solve one case both ways and compare: the active-set step is feasible (to
    /// 1e-9 mm), its objective is not above clarabel's by more than 1e-7 (1 + |f|),
    /// and the two steps differ by at most `tol` in the `H` norm (for a convex QP,
    /// `f(u) - f(u*) >= 0.5 |u - u*|_H^2`: clarabel's gap tolerance bounds it).
    fn compare(p: usize, rows: usize, mu: f64, vals: &[f64], tol: f64) -> Result<(), String> {
        let k = qp_case(p, rows, mu, vals);
        let mut qp = StepQp::new(p).map_err(|e| e.to_string())?;
        qp.lo.copy_from_slice(&k.lo);
        qp.hi.copy_from_slice(&k.hi);
        qp.rows.copy_from_slice(&k.rows);
        qp.rhs.copy_from_slice(&k.rhs);
        let (mut u_as, mut u_cl) = (vec![0.0; p], vec![0.0; p]);
        qp.active
            .solve(&k.h, &k.g, &k.lo, &k.hi, &k.rows, &k.rhs, &mut u_as)
            .map_err(|e| format!("active set: {e:?}"))?;
        if !qp.solve_clarabel(&k.h, &k.g, &mut u_cl) {
            return Err("clarabel failed".into());
        }
        for i in 0..p {
            if u_as[i] > k.hi[i] + 1e-9 || u_as[i] < k.lo[i] - 1e-9 {
                return Err(format!("bound {i} violated: {}", u_as[i]));
            }
            let cu: f64 = (0..p).map(|j| k.rows[i * p + j] * u_as[j]).sum();
            if cu > k.rhs[i] + 1e-9 {
                return Err(format!("row {i} violated: {cu} > {}", k.rhs[i]));
            }
        }
        let (f_as, f_cl) = (objective(&k.h, &k.g, &u_as), objective(&k.h, &k.g, &u_cl));
        if f_as > f_cl + 1e-7 * (1.0 + f_cl.abs()) {
            return Err(format!("objective {f_as} above clarabel's {f_cl}"));
        }
        let diff: Vec<f64> = u_as.iter().zip(&u_cl).map(|(x, y)| x - y).collect();
        let dist = h_norm2(&k.h, &diff).max(0.0).sqrt();
        let scale = 1.0 + h_norm2(&k.h, &u_cl).max(0.0).sqrt();
        // Where the steps differ by more than `tol`, clarabel's own objective gap must
        // account for it: with `u_as` optimal and `u_cl` feasible,
        // `f(u_cl) - f(u_as) >= 0.5 |u_cl - u_as|_H^2` (first-order optimality of a
        // convex QP), so a distance beyond that is the active set's error. (A case
        // with p = 4, mu = 0.23 differs by 7.2e-5 relative with clarabel's objective
        // the higher: clarabel's tolerance, not the active set's.)
        let gap = (f_cl - f_as).max(0.0) + 1e-9 * (1.0 + f_cl.abs());
        if dist > tol * scale && 0.5 * dist * dist > gap {
            return Err(format!(
                "steps differ by {dist:.3e} (H norm, scale {scale:.3e}; objective gap {gap:.3e}): {u_as:?} vs {u_cl:?}"
            ));
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

        /// Well-conditioned: as many least-squares rows as readings, damping 0.1
        /// to 1: the steps agree to 1e-5 in the `H` norm (relative).
        #[test]
        fn active_set_matches_clarabel_well_conditioned(
            p in 1usize..=9,
            mu in 0.1f64..1.0,
            vals in proptest::collection::vec(-1.0f64..1.0, 256),
        ) {
            let r = compare(p, p, mu, &vals, 1e-5);
            prop_assert!(r.is_ok(), "{}", r.unwrap_err());
        }

        /// Ill-conditioned as the IK step is near a solution: three position rows
        /// for up to nine readings and the smallest damping (1e-6, `H`'s condition
        /// up to about 1e8): the steps agree to 1e-4 in the `H` norm (relative).
        #[test]
        fn active_set_matches_clarabel_ill_conditioned(
            p in 3usize..=9,
            mu in 1e-6f64..1e-5,
            vals in proptest::collection::vec(-1.0f64..1.0, 256),
        ) {
            let r = compare(p, 3, mu, &vals, 1e-4);
            prop_assert!(r.is_ok(), "{}", r.unwrap_err());
        }
    }

    /// Bounds and a row, active and inactive, on cases worked by hand: `H = 2 I`,
    /// `g = (-4, 2, -1)` (the objective is `|u - (2, -1, 0.5)|^2` less a constant),
    /// `-0.5 <= u <= 1`. Without rows the solution clips to (1, -0.5, 0.5), the
    /// third interior. With `u_0 + u_1 + u_2 <= 0.5` it is (1, -0.5, 0): KKT with
    /// the row's multiplier 1 (from `u_2`: `2 (0 - 0.5) + 1 = 0`) and the bounds'
    /// 1 (`u_0` upper: `2 (1 - 2) + 1 + 1 = 0`) and 2 (`u_1` lower: `2 (-0.5 + 1) +
    /// 1 - 2 = 0`), all non-negative.
    #[test]
    fn box_and_row_cases_by_hand() {
        let p = 3;
        let mut qp = StepQp::new(p).unwrap();
        let h = [2.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 2.0];
        let g = [-4.0, 2.0, -1.0];
        qp.hi.copy_from_slice(&[1.0; 3]);
        qp.lo.copy_from_slice(&[-0.5; 3]);
        qp.rows.fill(0.0);
        let mut u = [0.0; 3];
        assert_eq!(qp.solve(&h, &g, &mut u), Some(QpSolver::ActiveSet));
        for (a, b) in u.iter().zip([1.0, -0.5, 0.5]) {
            assert!((a - b).abs() < 1e-14, "{u:?}");
        }
        qp.rows[..3].copy_from_slice(&[1.0, 1.0, 1.0]);
        qp.rhs.copy_from_slice(&[0.5, 1.0, 1.0]);
        assert_eq!(qp.solve(&h, &g, &mut u), Some(QpSolver::ActiveSet));
        for (a, b) in u.iter().zip([1.0, -0.5, 0.0]) {
            assert!((a - b).abs() < 1e-14, "{u:?}");
        }
    }
}
