//! Anderson acceleration of a fixed point `x = g(x)` over vectors of `Vector3`
//! (Walker & Ni 2011, "Anderson acceleration for fixed-point iterations", SIAM J.
//! Numer. Anal. 49(4), eq. (2.1)-(2.2) with a mixing parameter `beta`):
//!
//! `f_k = g(x_k) - x_k`; `gamma = argmin || f_k - dF gamma ||_2` over the last `m`
//! differences `dF = [f_{i+1} - f_i]`, `dX = [x_{i+1} - x_i]`;
//! `x_{k+1} = x_k + beta f_k - (dX + beta dF) gamma`.
//!
//! The small least-squares problem is solved by its normal equations with a relative
//! Tikhonov term of 1e-12 (m <= 5, so conditioning is watched by the caller's
//! restart on growth).

// Index loops mirror the small dense formulas (normal equations, elimination).
#![allow(clippy::needless_range_loop)]

use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// Largest history kept.
pub(crate) const MAX_DEPTH: usize = 5;

/// Anderson mixing state, sized once.
#[derive(Clone, Debug)]
pub(crate) struct Anderson {
    depth: usize,
    dx: Vec<Vec<V3>>,
    df: Vec<Vec<V3>>,
    len: usize,
    head: usize,
    x_prev: Vec<V3>,
    f_prev: Vec<V3>,
    has_prev: bool,
}

fn dot(a: &[V3], b: &[V3]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x.dot(y)).sum()
}

impl Anderson {
    /// History `depth` (clamped to 1..=[`MAX_DEPTH`]) for vectors of `n` entries.
    pub fn new(depth: usize, n: usize) -> Self {
        let depth = depth.clamp(1, MAX_DEPTH);
        Self {
            depth,
            dx: vec![vec![V3::zeros(); n]; depth],
            df: vec![vec![V3::zeros(); n]; depth],
            len: 0,
            head: 0,
            x_prev: vec![V3::zeros(); n],
            f_prev: vec![V3::zeros(); n],
            has_prev: false,
        }
    }

    /// Forget the history (after a residual growth).
    pub fn reset(&mut self) {
        self.len = 0;
        self.head = 0;
        self.has_prev = false;
    }

    /// Replace `x` by the next iterate given `f = g(x) - x`.
    pub fn step(&mut self, x: &mut [V3], f: &[V3], beta: f64) {
        if self.has_prev {
            let h = self.head;
            for i in 0..x.len() {
                self.dx[h][i] = x[i] - self.x_prev[i];
                self.df[h][i] = f[i] - self.f_prev[i];
            }
            self.head = (self.head + 1) % self.depth;
            self.len = (self.len + 1).min(self.depth);
        }
        self.x_prev.copy_from_slice(x);
        self.f_prev.copy_from_slice(f);
        self.has_prev = true;
        let m = self.len;
        let mut gamma = [0.0; MAX_DEPTH];
        if m > 0 {
            let mut a = [[0.0; MAX_DEPTH]; MAX_DEPTH];
            let mut b = [0.0; MAX_DEPTH];
            let mut diag: f64 = 0.0;
            for i in 0..m {
                for j in 0..=i {
                    let v = dot(&self.df[i], &self.df[j]);
                    a[i][j] = v;
                    a[j][i] = v;
                }
                b[i] = dot(&self.df[i], f);
                diag = diag.max(a[i][i]);
            }
            for (i, row) in a.iter_mut().enumerate().take(m) {
                row[i] += 1e-12 * diag + f64::MIN_POSITIVE;
            }
            if solve_small(&mut a, &mut b, m) {
                gamma[..m].copy_from_slice(&b[..m]);
            } else {
                self.reset();
            }
        }
        for i in 0..x.len() {
            let mut step = f[i] * beta;
            for (k, g) in gamma.iter().enumerate().take(m) {
                step -= (self.dx[k][i] + self.df[k][i] * beta) * *g;
            }
            x[i] += step;
        }
    }
}

/// Gaussian elimination with partial pivoting on the leading `m x m` block; the
/// solution replaces `b`. `false` when singular or not finite.
fn solve_small(a: &mut [[f64; MAX_DEPTH]; MAX_DEPTH], b: &mut [f64; MAX_DEPTH], m: usize) -> bool {
    for c in 0..m {
        let p = (c..m)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .unwrap_or(c);
        if a[p][c] == 0.0 || !a[p][c].is_finite() {
            return false;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..m {
            let k = a[r][c] / a[c][c];
            for j in c..m {
                a[r][j] -= k * a[c][j];
            }
            b[r] -= k * b[c];
        }
    }
    for c in (0..m).rev() {
        let mut s = b[c];
        for j in c + 1..m {
            s -= a[c][j] * b[j];
        }
        b[c] = s / a[c][c];
    }
    b[..m].iter().all(|x| x.is_finite())
}
