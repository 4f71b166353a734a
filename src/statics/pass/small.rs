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
    let b = &mut b[..n * w];
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
            let (top, bottom) = b.split_at_mut(piv * w);
            top[col * w..(col + 1) * w].swap_with_slice(&mut bottom[..w]);
        }
        let inv = 1.0 / a[col * n + col];
        // rows below the pivot, as whole-row updates (slices: no bounds checks in
        // the inner loops, which run over the `w` right-hand sides)
        let (upper, lower) = b.split_at_mut((col + 1) * w);
        let prow = &upper[col * w..];
        for (i, brow) in lower.chunks_exact_mut(w).enumerate() {
            let r = col + 1 + i;
            let f = a[r * n + col] * inv;
            if f != 0.0 {
                for c in col..n {
                    a[r * n + c] -= f * a[col * n + c];
                }
                brow.iter_mut().zip(prow).for_each(|(v, p)| *v -= f * p);
            }
        }
    }
    for col in (0..n).rev() {
        let inv = 1.0 / a[col * n + col];
        let (upper, lower) = b.split_at_mut((col + 1) * w);
        let row = &mut upper[col * w..];
        for (i, krow) in lower.chunks_exact(w).enumerate() {
            let f = a[col * n + col + 1 + i];
            if f != 0.0 {
                row.iter_mut().zip(krow).for_each(|(v, k)| *v -= f * k);
            }
        }
        row.iter_mut().for_each(|v| *v *= inv);
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `solve_small` solves a pivoting-requiring system with several right-hand
    /// sides to round-off (residual check), and refuses a singular one.
    #[test]
    fn solve_small_solves_and_refuses_singular() {
        let (n, w) = (4, 3);
        let a0 = [
            0.0, 2.0, 1.0, -1.0, 3.0, 1.0, 0.5, 2.0, 1.0, -1.0, 4.0, 0.0, 2.0, 0.0, 1.0, 5.0,
        ];
        let b0: Vec<f64> = (0..n * w).map(|i| (i as f64 * 0.7).sin()).collect();
        let (mut a, mut b) = (a0, b0.clone());
        assert!(solve_small(&mut a, n, &mut b, w));
        for r in 0..n {
            for c in 0..w {
                let ax: f64 = (0..n).map(|k| a0[r * n + k] * b[k * w + c]).sum();
                assert!((ax - b0[r * w + c]).abs() < 1e-13, "{r} {c}");
            }
        }
        let mut s = [1.0, 2.0, 2.0, 4.0];
        let mut b = [1.0, 1.0];
        assert!(!solve_small(&mut s, 2, &mut b, 1));
    }
}
