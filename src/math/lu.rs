//! Dense LU with partial pivoting on a buffer allocated once.
//!
//! nalgebra's `DMatrix::lu` consumes its matrix, so every Newton step would clone;
//! shooting systems here are small (3 to ~100 unknowns) and solved every iteration,
//! so the factorisation works in place on a reusable buffer instead.

/// In-place LU factorisation workspace for an `n x n` system.
#[derive(Clone, Debug)]
pub struct DenseLu {
    n: usize,
    a: Vec<f64>,
    piv: Vec<usize>,
    /// Calls of [`DenseLu::factor`] so far (tells users of the factors when they changed).
    factorizations: u64,
}

impl DenseLu {
    /// Workspace for systems up to `n x n`.
    pub fn new(n: usize) -> Self {
        Self {
            n,
            a: vec![0.0; n * n],
            piv: vec![0; n],
            factorizations: 0,
        }
    }

    /// Number of factorisations so far (a new value means new factors).
    pub fn factorizations(&self) -> u64 {
        self.factorizations
    }

    /// Mutable row-major storage of the matrix to factor: `a[i * n + j]`.
    pub fn matrix_mut(&mut self) -> &mut [f64] {
        &mut self.a
    }

    /// Factor in place. Returns the reciprocal condition estimate
    /// `min |pivot| / max |pivot|`, or `None` when a pivot is zero or not finite.
    pub fn factor(&mut self) -> Option<f64> {
        self.factorizations += 1;
        let n = self.n;
        let a = &mut self.a;
        let (mut pmin, mut pmax) = (f64::INFINITY, 0.0f64);
        for k in 0..n {
            let mut p = k;
            let mut best = a[k * n + k].abs();
            for i in k + 1..n {
                let v = a[i * n + k].abs();
                if v > best {
                    best = v;
                    p = i;
                }
            }
            if best.is_nan() || best <= 0.0 || !best.is_finite() {
                return None;
            }
            self.piv[k] = p;
            if p != k {
                for j in 0..n {
                    a.swap(k * n + j, p * n + j);
                }
            }
            pmin = pmin.min(best);
            pmax = pmax.max(best);
            let inv = 1.0 / a[k * n + k];
            // rows below the pivot row, as slices (no bounds checks in the update)
            let (top, below) = a.split_at_mut((k + 1) * n);
            let pivot_row = &top[k * n + k + 1..(k + 1) * n];
            for row in below.chunks_exact_mut(n) {
                let l = row[k] * inv;
                row[k] = l;
                if l != 0.0 {
                    for (x, y) in row[k + 1..].iter_mut().zip(pivot_row) {
                        *x -= l * y;
                    }
                }
            }
        }
        Some(if n == 0 { 1.0 } else { pmin / pmax })
    }

    /// Sign of `det A` (+1 or -1) from the last successful factorisation: the signs of
    /// the pivots times the parity of the row swaps. Continuation uses it to notice a
    /// fold or bifurcation (the determinant changes sign there).
    pub fn det_sign(&self) -> f64 {
        let n = self.n;
        let mut sign = 1.0;
        for k in 0..n {
            if self.piv[k] != k {
                sign = -sign;
            }
            if self.a[k * n + k] < 0.0 {
                sign = -sign;
            }
        }
        sign
    }

    /// Solve `A x = b` in place (`b` becomes `x`) with the last factorisation.
    pub fn solve_in_place(&self, b: &mut [f64]) {
        let n = self.n;
        let a = &self.a;
        for k in 0..n {
            b.swap(k, self.piv[k]);
        }
        for i in 0..n {
            let mut s = b[i];
            for j in 0..i {
                s -= a[i * n + j] * b[j];
            }
            b[i] = s;
        }
        for i in (0..n).rev() {
            let mut s = b[i];
            for j in i + 1..n {
                s -= a[i * n + j] * b[j];
            }
            b[i] = s / a[i * n + i];
        }
    }

    /// The inverse `A^-1` from the last factorisation, row-major into `inv`
    /// (`n x n`): the `n` solves of [`DenseLu::solve_in_place`] on the identity's
    /// columns, done row by row over all columns at once (contiguous, so they
    /// vectorise), with the same operations in the same order per column: the
    /// same bits as the column solves.
    pub fn inverse_into(&self, inv: &mut [f64]) {
        let n = self.n;
        let a = &self.a;
        let inv = &mut inv[..n * n];
        inv.fill(0.0);
        for k in 0..n {
            inv[k * n + k] = 1.0;
        }
        for k in 0..n {
            let p = self.piv[k];
            if p != k {
                for j in 0..n {
                    inv.swap(k * n + j, p * n + j);
                }
            }
        }
        for i in 0..n {
            let (done, rest) = inv.split_at_mut(i * n);
            let row = &mut rest[..n];
            for j in 0..i {
                let l = a[i * n + j];
                for (x, y) in row.iter_mut().zip(&done[j * n..(j + 1) * n]) {
                    *x -= l * y;
                }
            }
        }
        for i in (0..n).rev() {
            let (head, done) = inv.split_at_mut((i + 1) * n);
            let row = &mut head[i * n..];
            for j in i + 1..n {
                let u = a[i * n + j];
                let y = &done[(j - i - 1) * n..(j - i) * n];
                for (x, y) in row.iter_mut().zip(y) {
                    *x -= u * y;
                }
            }
            let d = a[i * n + i];
            for x in row.iter_mut() {
                *x /= d;
            }
        }
    }
}

impl crate::math::warm::WarmCopy for DenseLu {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src, copy: [n, a, piv, factorizations], keep: []);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The row-wise inverse is the column solves' bit for bit (same operations in
    /// the same order per column), and `A A^-1 = I` to 1e-13, on a system that
    /// pivots.
    #[test]
    fn the_inverse_is_the_column_solves() {
        let n = 5;
        let a: Vec<f64> = (0..n * n)
            .map(|k| ((k * 7 % 11) as f64 - 5.0) * 0.3 + if k % 6 == 0 { 0.1 } else { 0.0 })
            .collect();
        let mut lu = DenseLu::new(n);
        lu.matrix_mut().copy_from_slice(&a);
        assert!(lu.factor().is_some());
        assert!((0..n).any(|k| lu.piv[k] != k), "the test system must pivot");
        let mut inv = vec![f64::NAN; n * n];
        lu.inverse_into(&mut inv);
        for c in 0..n {
            let mut col = vec![0.0; n];
            col[c] = 1.0;
            lu.solve_in_place(&mut col);
            for r in 0..n {
                assert_eq!(inv[r * n + c].to_bits(), col[r].to_bits(), "({r}, {c})");
            }
        }
        for r in 0..n {
            for c in 0..n {
                let v: f64 = (0..n).map(|k| a[r * n + k] * inv[k * n + c]).sum();
                let want = if r == c { 1.0 } else { 0.0 };
                assert!((v - want).abs() < 1e-13, "({r}, {c}): {v}");
            }
        }
    }

    #[test]
    fn solves_a_pivoting_system() {
        let mut lu = DenseLu::new(3);
        lu.matrix_mut()
            .copy_from_slice(&[0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0]);
        assert!(lu.factor().is_some());
        let mut b = [5.0, 3.0, 4.0]; // A (1, 2, 1)
        lu.solve_in_place(&mut b);
        for (x, e) in b.iter().zip([1.0, 2.0, 1.0]) {
            assert!((x - e).abs() < 1e-14, "{b:?}");
        }
        // det = -5 (cofactors along the first row), with two row swaps on the way
        assert_eq!(lu.det_sign(), -1.0);
        lu.matrix_mut()
            .copy_from_slice(&[0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 2.0]);
        assert!(lu.factor().is_some());
        assert_eq!(lu.det_sign(), -1.0, "one swap, positive pivots");
        lu.matrix_mut()
            .copy_from_slice(&[2.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -3.0]);
        assert!(lu.factor().is_some());
        assert_eq!(lu.det_sign(), 1.0, "two negative pivots");
    }

    #[test]
    fn singular_matrix_is_reported() {
        let mut lu = DenseLu::new(2);
        lu.matrix_mut().copy_from_slice(&[1.0, 2.0, 2.0, 4.0]);
        assert!(lu.factor().is_none());
    }
}
