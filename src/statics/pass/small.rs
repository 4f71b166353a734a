//! Small dense linear algebra of the pass (row-major slices, no allocation).

/// Determinant by Gaussian elimination with partial pivoting (destroys `a`).
pub(super) fn det_small(a: &mut [f64], n: usize) -> f64 {
    let mut det = 1.0;
    for col in 0..n {
        let piv = (col..n)
            .max_by(|&x, &y| a[x * n + col].abs().total_cmp(&a[y * n + col].abs()))
            .unwrap_or(col);
        if a[piv * n + col] == 0.0 {
            return 0.0;
        }
        if piv != col {
            for c in 0..n {
                a.swap(piv * n + c, col * n + c);
            }
            det = -det;
        }
        let d = a[col * n + col];
        det *= d;
        for r in col + 1..n {
            let f = a[r * n + col] / d;
            for c in col..n {
                a[r * n + c] -= f * a[col * n + c];
            }
        }
    }
    det
}

/// Solve `a x = b` in place (`a` is `n x n`, `b` is `n x w`, row-major) by Gaussian
/// elimination with partial pivoting; `false` when `a` is singular.
pub(super) fn solve_small(a: &mut [f64], n: usize, b: &mut [f64], w: usize) -> bool {
    for col in 0..n {
        let piv = (col..n)
            .max_by(|&x, &y| a[x * n + col].abs().total_cmp(&a[y * n + col].abs()))
            .unwrap_or(col);
        if a[piv * n + col].abs() < 1e-14 {
            return false;
        }
        if piv != col {
            for c in 0..n {
                a.swap(piv * n + c, col * n + c);
            }
            for c in 0..w {
                b.swap(piv * w + c, col * w + c);
            }
        }
        let inv = 1.0 / a[col * n + col];
        for r in col + 1..n {
            let f = a[r * n + col] * inv;
            if f != 0.0 {
                for c in col..n {
                    a[r * n + c] -= f * a[col * n + c];
                }
                for c in 0..w {
                    b[r * w + c] -= f * b[col * w + c];
                }
            }
        }
    }
    for col in (0..n).rev() {
        let inv = 1.0 / a[col * n + col];
        for c in 0..w {
            let mut v = b[col * w + c];
            for k in col + 1..n {
                v -= a[col * n + k] * b[k * w + c];
            }
            b[col * w + c] = v * inv;
        }
    }
    true
}
