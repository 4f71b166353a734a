//! A small dense convex QP without allocation per solve: the step of each
//! iteration, which clarabel 0.11 solves with one allocation per call (its
//! `solve` rebuilds a hash map of its timers, `Timers::start_as_current`, and no
//! setting turns the timers off).
//!
//! ```text
//! minimise 0.5 u^T H u + g^T u   subject to   lo <= u <= hi,   C u <= d
//! ```
//!
//! with `H` positive definite, `lo <= 0 <= hi` and `d >= 0` (so `u = 0` is
//! feasible), `n` variables and `m` general rows.
//!
//! **Method.** The primal active-set method of Nocedal & Wright, *Numerical
//! Optimization*, 2nd ed., algorithm 16.3, started at `u = 0` with an empty working
//! set. A bound in the working set fixes its variable exactly (the variables are
//! split into fixed and free, as in Lawson & Hanson's bounded least squares, *Solving
//! Least Squares Problems*, 1974, ch. 23, and Stark & Parker's BVLS, 1995); a
//! general row in it is an equality on the free variables `F`. Each iteration solves
//! the equality-constrained problem (N&W eq. 16.39) for the step `s` from `u`:
//! with `H_FF = L L^T` (Cholesky of the free block) and `v = L^T s_F`, `v` is the
//! projection of `-c`, `c = L^-1 (H u + g)_F`, on the null space of `Y^T`,
//! `Y = L^-1 C_WF^T` (the range-space form of N&W section 16.2 on the Cholesky of
//! the normal matrix); with `Y = Q R` (Householder), `v = -Q_2 Q_2^T c` and the
//! rows' multipliers solve `R lambda = -Q_1^T c`; a fixed variable's multiplier is
//! its component of the gradient `H u + g + C_W^T lambda` with the sign of its
//! bound. A step that a bound or row outside the working set blocks is shortened to
//! it, and that constraint joins (N&W eq. 16.41); at the minimiser on the working
//! set the constraint with the most negative multiplier leaves it, and with none
//! negative `u` is the solution (the KKT conditions, N&W eq. 16.37).
//!
//! A general row with one non-zero entry is a bound and is merged into `lo, hi`
//! before the iteration (a slack tendon's linearised tension is such a row, the
//! same constraint as its bound: two parallel constraints would make the working
//! set degenerate); a zero row (`0 <= d`) is dropped. A variable with `lo = hi`
//! stays fixed. When rounding makes a row to add numerically dependent on the
//! working set, when `H_FF` is not numerically positive definite, or after
//! [`MAX_ITER_FACTOR`] `(n + m)` iterations (cycling on a degenerate vertex), the
//! solve reports the failure and the caller uses clarabel. All buffers are sized
//! once.

/// Iterations allowed per solve, in units of `n + m` (each iteration adds or
/// removes one constraint).
pub(super) const MAX_ITER_FACTOR: usize = 4;

/// Why an active-set solve gave no answer (the caller falls back to clarabel).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ActiveSetFailure {
    /// The free block of `H` is not numerically positive definite.
    NotPositiveDefinite,
    /// `lo > 0`, `hi < 0` or `d < 0`: `u = 0` is not feasible.
    InfeasibleStart,
    /// A row to add is numerically dependent on the working set.
    Dependent,
    /// The iteration limit was reached (cycling).
    Iterations,
    /// A non-finite number in the data or the iterates.
    NonFinite,
}

/// Where a variable is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Var {
    Free,
    AtLower,
    AtUpper,
    /// `lo = hi`: fixed for the whole solve.
    Fixed,
}

/// The solver's buffers for `n` variables and `m` general rows.
pub(super) struct ActiveSetQp {
    n: usize,
    m: usize,
    /// Bounds after merging the single-entry rows.
    lo: Vec<f64>,
    hi: Vec<f64>,
    var: Vec<Var>,
    /// The free variables, in index order.
    free: Vec<usize>,
    /// General rows scaled to unit length, their right-hand sides, whether each
    /// takes part (not merged or dropped) and is in the working set.
    rows: Vec<f64>,
    rhs: Vec<f64>,
    general: Vec<bool>,
    in_w: Vec<bool>,
    /// Working rows in the order they joined.
    w: Vec<usize>,
    /// Lower Cholesky factor of `H_FF` (row-major, leading dimension `n`).
    l: Vec<f64>,
    /// `Y = L^-1 C_WF^T`, column `j` at `j * n` (length `nf`), then its
    /// Householder vectors (below the diagonal) and `R` (on and above).
    y: Vec<f64>,
    tau: Vec<f64>,
    /// Current point, gradient `H u + g`, `c` then `Q^T c` (free part), step.
    u: Vec<f64>,
    grad: Vec<f64>,
    d: Vec<f64>,
    s: Vec<f64>,
    sf: Vec<f64>,
    lambda: Vec<f64>,
    /// Iterations of the current solve.
    iterations: usize,
}

impl ActiveSetQp {
    /// Buffers for `n` variables and `m` general rows.
    pub(super) fn new(n: usize, m: usize) -> Self {
        Self {
            n,
            m,
            lo: vec![0.0; n],
            hi: vec![0.0; n],
            var: vec![Var::Free; n],
            free: Vec::with_capacity(n),
            rows: vec![0.0; m * n],
            rhs: vec![0.0; m],
            general: vec![false; m],
            in_w: vec![false; m],
            w: Vec::with_capacity(m.max(n)),
            l: vec![0.0; n * n],
            y: vec![0.0; n * n],
            tau: vec![0.0; n],
            u: vec![0.0; n],
            grad: vec![0.0; n],
            d: vec![0.0; n],
            s: vec![0.0; n],
            sf: vec![0.0; n],
            lambda: vec![0.0; m.max(1)],
            iterations: 0,
        }
    }

    /// Solve with `h` (`n x n` row-major, symmetric positive definite), `g`,
    /// bounds `lo <= 0 <= hi`, rows `c` (`m x n` row-major) and `d >= 0`; the
    /// solution into `out`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn solve(
        &mut self,
        h: &[f64],
        g: &[f64],
        lo: &[f64],
        hi: &[f64],
        c: &[f64],
        d: &[f64],
        out: &mut [f64],
    ) -> Result<(), ActiveSetFailure> {
        let (n, m) = (self.n, self.m);
        debug_assert!(h.len() == n * n && g.len() == n && c.len() == m * n && d.len() == m);
        self.iterations = 0;
        let finite = |v: &f64| v.is_finite();
        if !(h.iter().all(finite) && g.iter().all(finite) && c.iter().all(finite)) {
            return Err(ActiveSetFailure::NonFinite);
        }
        if lo.iter().chain(hi).chain(d).any(|v| v.is_nan()) {
            return Err(ActiveSetFailure::NonFinite);
        }
        if lo.iter().any(|v| *v > 0.0) || hi.iter().any(|v| *v < 0.0) || d.iter().any(|v| *v < 0.0)
        {
            return Err(ActiveSetFailure::InfeasibleStart);
        }
        self.lo.copy_from_slice(lo);
        self.hi.copy_from_slice(hi);
        // rows: unit length; one entry -> a bound; none -> dropped
        for i in 0..m {
            let row = &c[i * n..(i + 1) * n];
            let mut nonzero = row.iter().enumerate().filter(|(_, v)| **v != 0.0);
            let first = nonzero.next();
            let single = first.is_some() && nonzero.next().is_none();
            self.general[i] = false;
            match (first, single) {
                (None, _) => {}
                (Some((j, &a)), true) => {
                    let bound = d[i] / a;
                    if a > 0.0 {
                        self.hi[j] = self.hi[j].min(bound);
                    } else {
                        self.lo[j] = self.lo[j].max(bound);
                    }
                }
                (Some(_), false) => {
                    let norm = row.iter().map(|v| v * v).sum::<f64>().sqrt();
                    for (r, v) in self.rows[i * n..(i + 1) * n].iter_mut().zip(row) {
                        *r = v / norm;
                    }
                    self.rhs[i] = d[i] / norm;
                    self.general[i] = true;
                }
            }
        }
        for j in 0..n {
            self.var[j] = if self.lo[j] == self.hi[j] {
                Var::Fixed
            } else {
                Var::Free
            };
        }
        self.u.fill(0.0);
        self.w.clear();
        self.in_w.fill(false);
        // multipliers below -lambda_tol are negative: relative to the gradient at
        // the start
        let g_norm = g.iter().map(|v| v * v).sum::<f64>().sqrt();
        let lambda_tol = 1e-11 * g_norm.max(1e-300);
        let mut at_minimiser = false;
        let max_iter = MAX_ITER_FACTOR * (n + m);
        loop {
            if self.iterations >= max_iter {
                return Err(ActiveSetFailure::Iterations);
            }
            self.iterations += 1;
            self.free.clear();
            self.free
                .extend((0..n).filter(|&j| self.var[j] == Var::Free));
            self.cholesky(h)?;
            self.factor_working_set()?;
            self.gradient(h, g);
            if at_minimiser {
                if !self.release_most_negative(lambda_tol) {
                    break;
                }
                at_minimiser = false;
                continue;
            }
            self.step();
            let s_norm = self.s.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let u_norm = self.u.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            if !s_norm.is_finite() {
                return Err(ActiveSetFailure::NonFinite);
            }
            if s_norm == 0.0 || s_norm <= 1e-14 * u_norm {
                at_minimiser = true;
                continue;
            }
            // the longest step along s that keeps every constraint (N&W eq. 16.41)
            let mut alpha = 1.0;
            let mut blocking = Blocking::None;
            for &j in &self.free {
                let sj = self.s[j];
                let t = if sj > 0.0 {
                    (self.hi[j] - self.u[j]) / sj
                } else if sj < 0.0 {
                    (self.lo[j] - self.u[j]) / sj
                } else {
                    continue;
                };
                if t < alpha {
                    alpha = t.max(0.0);
                    blocking = Blocking::Bound(j, sj > 0.0);
                }
            }
            for i in 0..m {
                if !self.general[i] || self.in_w[i] {
                    continue;
                }
                let row = &self.rows[i * n..(i + 1) * n];
                let (mut as_, mut scale) = (0.0, 0.0);
                for (r, v) in row.iter().zip(&self.s) {
                    as_ += r * v;
                    scale += (r * v).abs();
                }
                // a row the step runs along within rounding does not block
                if as_ <= 1e-11 * scale {
                    continue;
                }
                let au: f64 = row.iter().zip(&self.u).map(|(r, v)| r * v).sum();
                let t = ((self.rhs[i] - au) / as_).max(0.0);
                if t < alpha {
                    alpha = t;
                    blocking = Blocking::Row(i);
                }
            }
            for (u, s) in self.u.iter_mut().zip(&self.s) {
                *u += alpha * s;
            }
            match blocking {
                Blocking::Bound(j, upper) => {
                    if upper {
                        self.u[j] = self.hi[j];
                        self.var[j] = Var::AtUpper;
                    } else {
                        self.u[j] = self.lo[j];
                        self.var[j] = Var::AtLower;
                    }
                    at_minimiser = false;
                }
                Blocking::Row(i) => {
                    self.w.push(i);
                    self.in_w[i] = true;
                    at_minimiser = false;
                }
                Blocking::None => at_minimiser = true,
            }
        }
        out.copy_from_slice(&self.u);
        Ok(())
    }

    /// `H_FF = L L^T` into `l`; fails on a pivot that is not positive.
    fn cholesky(&mut self, h: &[f64]) -> Result<(), ActiveSetFailure> {
        let n = self.n;
        let f = &self.free;
        let l = &mut self.l;
        let scale = f.iter().fold(0.0f64, |a, &j| a.max(h[j * n + j].abs()));
        for (a, &ja) in f.iter().enumerate() {
            let mut dd = h[ja * n + ja];
            for k in 0..a {
                dd -= l[a * n + k] * l[a * n + k];
            }
            if dd.is_nan() || dd <= 1e-15 * scale {
                return Err(ActiveSetFailure::NotPositiveDefinite);
            }
            let dd = dd.sqrt();
            l[a * n + a] = dd;
            for (b, &jb) in f.iter().enumerate().skip(a + 1) {
                let mut v = h[jb * n + ja];
                for k in 0..a {
                    v -= l[b * n + k] * l[a * n + k];
                }
                l[b * n + a] = v / dd;
            }
        }
        Ok(())
    }

    /// `x <- L^-1 x` on the first `nf` entries (forward substitution).
    fn forward(l: &[f64], n: usize, nf: usize, x: &mut [f64]) {
        for i in 0..nf {
            let mut v = x[i];
            for k in 0..i {
                v -= l[i * n + k] * x[k];
            }
            x[i] = v / l[i * n + i];
        }
    }

    /// `Y = L^-1 C_WF^T` and its Householder QR in place (LAPACK `dgeqr2`'s
    /// reflectors `I - tau v v^T`, `v_j = 1`); fails when a column is
    /// numerically dependent on the ones before it (or there are more working
    /// rows than free variables).
    fn factor_working_set(&mut self) -> Result<(), ActiveSetFailure> {
        let n = self.n;
        let nf = self.free.len();
        let k = self.w.len();
        if k > nf {
            return Err(ActiveSetFailure::Dependent);
        }
        for (j, &i) in self.w.iter().enumerate() {
            let col = &mut self.y[j * n..j * n + nf];
            for (cv, &fj) in col.iter_mut().zip(&self.free) {
                *cv = self.rows[i * n + fj];
            }
            Self::forward(&self.l, n, nf, col);
        }
        for j in 0..k {
            let before: f64 = self.y[j * n..j * n + nf]
                .iter()
                .map(|v| v * v)
                .sum::<f64>()
                .sqrt();
            for r in 0..j {
                let (head, tail) = self.y.split_at_mut(j * n);
                Self::reflect(&head[r * n..r * n + nf], r, self.tau[r], &mut tail[..nf]);
            }
            let x = &mut self.y[j * n..j * n + nf];
            let sigma: f64 = x[j + 1..].iter().map(|v| v * v).sum();
            let alpha = x[j];
            let norm = (alpha * alpha + sigma).sqrt();
            if norm == 0.0 || norm <= 1e-10 * before {
                return Err(ActiveSetFailure::Dependent);
            }
            let beta = if alpha >= 0.0 { -norm } else { norm };
            self.tau[j] = (beta - alpha) / beta;
            let inv = 1.0 / (alpha - beta);
            for v in &mut x[j + 1..] {
                *v *= inv;
            }
            x[j] = beta;
        }
        Ok(())
    }

    /// `x <- (I - tau v v^T) x` with `v = [0..0, 1, v[r+1..]]`.
    fn reflect(v: &[f64], r: usize, tau: f64, x: &mut [f64]) {
        let mut dot = x[r];
        for (a, b) in v[r + 1..].iter().zip(&x[r + 1..]) {
            dot += a * b;
        }
        let f = tau * dot;
        x[r] -= f;
        for (xi, vi) in x[r + 1..].iter_mut().zip(&v[r + 1..]) {
            *xi -= f * vi;
        }
    }

    /// `grad = H u + g`; `d = Q^T L^-1 grad_F`.
    fn gradient(&mut self, h: &[f64], g: &[f64]) {
        let n = self.n;
        let nf = self.free.len();
        for a in 0..n {
            let mut v = g[a];
            for b in 0..n {
                v += h[a * n + b] * self.u[b];
            }
            self.grad[a] = v;
        }
        for (dv, &j) in self.d.iter_mut().zip(&self.free) {
            *dv = self.grad[j];
        }
        Self::forward(&self.l, n, nf, &mut self.d);
        for r in 0..self.w.len() {
            Self::reflect(
                &self.y[r * n..r * n + nf],
                r,
                self.tau[r],
                &mut self.d[..nf],
            );
        }
    }

    /// The step on the working set: `v = -Q [0; d_2]`, `s_F = L^-T v`, zero on
    /// the fixed variables.
    fn step(&mut self) {
        let n = self.n;
        let nf = self.free.len();
        let k = self.w.len();
        let sf = &mut self.sf[..nf];
        sf.fill(0.0);
        for (v, d) in sf[k..].iter_mut().zip(&self.d[k..nf]) {
            *v = -d;
        }
        for r in (0..k).rev() {
            Self::reflect(&self.y[r * n..r * n + nf], r, self.tau[r], sf);
        }
        for i in (0..nf).rev() {
            let mut v = sf[i];
            for (k2, x) in sf.iter().enumerate().skip(i + 1) {
                v -= self.l[k2 * n + i] * x;
            }
            sf[i] = v / self.l[i * n + i];
        }
        self.s.fill(0.0);
        for (a, &j) in self.free.iter().enumerate() {
            self.s[j] = sf[a];
        }
    }

    /// At the minimiser on the working set: the rows' multipliers (`R lambda =
    /// -d_1`) and the bounds' (the gradient with the rows' part, N&W eq. 16.42,
    /// signed by the bound); the most negative one below `-tol` leaves the working
    /// set (`true`), or none does (`false`: the solution).
    fn release_most_negative(&mut self, tol: f64) -> bool {
        let n = self.n;
        let k = self.w.len();
        for i in (0..k).rev() {
            let mut v = -self.d[i];
            for j in i + 1..k {
                v -= self.y[j * n + i] * self.lambda[j];
            }
            self.lambda[i] = v / self.y[i * n + i];
        }
        let mut most = -tol;
        let mut release = None;
        for (j, &l) in self.lambda[..k].iter().enumerate() {
            if l < most {
                most = l;
                release = Some(Blocking::Row(j));
            }
        }
        for j in 0..n {
            let upper = match self.var[j] {
                Var::AtUpper => true,
                Var::AtLower => false,
                Var::Free | Var::Fixed => continue,
            };
            let mut r = self.grad[j];
            for (p, &i) in self.w.iter().enumerate() {
                r += self.lambda[p] * self.rows[i * n + j];
            }
            let mu = if upper { -r } else { r };
            if mu < most {
                most = mu;
                release = Some(Blocking::Bound(j, upper));
            }
        }
        match release {
            None => false,
            Some(Blocking::Row(p)) => {
                let i = self.w.remove(p);
                self.in_w[i] = false;
                true
            }
            Some(Blocking::Bound(j, _)) => {
                self.var[j] = Var::Free;
                true
            }
            Some(Blocking::None) => false,
        }
    }
}

/// What ends a step: a bound (variable, upper?), a row, or nothing.
#[derive(Clone, Copy)]
enum Blocking {
    None,
    Bound(usize, bool),
    Row(usize),
}
