//! Banded LU with partial pivoting on a buffer allocated once (the LAPACK `gbtrf`
//! scheme: row interchanges applied as a sequence `P_k L_k`, earlier multipliers are
//! not swapped), for the block-bidiagonal Jacobians of multiple shooting.
//!
//! A matrix with lower bandwidth `kl` and upper bandwidth `ku` keeps, after
//! pivoting, its fill within `kl + ku` above the diagonal. Row `r` is stored over the
//! columns `r - kl ..= r + kl + ku` (width `2 kl + ku + 1`). Factoring costs about
//! `n kl (kl + ku)` multiply-adds instead of the dense `n^3 / 3`.

/// In-place banded LU workspace for an `n x n` system.
#[derive(Clone, Debug)]
pub struct BandedLu {
    n: usize,
    kl: usize,
    ku: usize,
    w: usize,
    a: Vec<f64>,
    piv: Vec<usize>,
}

impl BandedLu {
    /// Workspace for an `n x n` matrix with bandwidths `kl` (below) and `ku` (above).
    pub fn new(n: usize, kl: usize, ku: usize) -> Self {
        let w = 2 * kl + ku + 1;
        Self {
            n,
            kl,
            ku,
            w,
            a: vec![0.0; n * w],
            piv: vec![0; n],
        }
    }

    #[inline(always)]
    fn idx(&self, r: usize, c: usize) -> usize {
        debug_assert!(c + self.kl >= r && c <= r + self.kl + self.ku, "({r}, {c})");
        r * self.w + (c + self.kl - r)
    }

    /// Zero the matrix before assembling a new one.
    pub fn clear(&mut self) {
        self.a.fill(0.0);
    }

    /// Set entry `(r, c)`; it must lie in the band (`r - kl <= c <= r + ku`).
    #[inline]
    pub fn set(&mut self, r: usize, c: usize, v: f64) {
        debug_assert!(c <= r + self.ku, "({r}, {c}) above the band");
        let i = self.idx(r, c);
        self.a[i] = v;
    }

    /// Entry `(r, c)` of the stored (possibly factored) band.
    pub fn get(&self, r: usize, c: usize) -> f64 {
        self.a[self.idx(r, c)]
    }

    /// Factor in place. Returns the reciprocal pivot ratio `min |pivot| / max |pivot|`,
    /// or `None` when a pivot is zero or not finite.
    pub fn factor(&mut self) -> Option<f64> {
        let (n, kl, ku) = (self.n, self.kl, self.ku);
        let (mut pmin, mut pmax) = (f64::INFINITY, 0.0f64);
        for k in 0..n {
            let last = (k + kl).min(n - 1);
            let mut p = k;
            let mut best = self.a[self.idx(k, k)].abs();
            for i in k + 1..=last {
                let v = self.a[self.idx(i, k)].abs();
                if v > best {
                    best = v;
                    p = i;
                }
            }
            if !best.is_finite() || best <= 0.0 {
                return None;
            }
            self.piv[k] = p;
            let cmax = (k + kl + ku).min(n - 1);
            if p != k {
                for c in k..=cmax {
                    let (i, j) = (self.idx(k, c), self.idx(p, c));
                    self.a.swap(i, j);
                }
            }
            pmin = pmin.min(best);
            pmax = pmax.max(best);
            let inv = 1.0 / self.a[self.idx(k, k)];
            for i in k + 1..=last {
                let ik = self.idx(i, k);
                let l = self.a[ik] * inv;
                self.a[ik] = l;
                if l != 0.0 {
                    let (ri, rk) = (self.idx(i, k + 1), self.idx(k, k + 1));
                    for t in 0..cmax - k {
                        self.a[ri + t] -= l * self.a[rk + t];
                    }
                }
            }
        }
        Some(if n == 0 { 1.0 } else { pmin / pmax })
    }

    /// Sign of the determinant (+1 or -1) from the last successful factorisation.
    pub fn det_sign(&self) -> f64 {
        let mut sign = 1.0;
        for k in 0..self.n {
            if self.piv[k] != k {
                sign = -sign;
            }
            if self.a[self.idx(k, k)] < 0.0 {
                sign = -sign;
            }
        }
        sign
    }

    /// Solve `A x = b` in place with the last factorisation.
    #[allow(clippy::needless_range_loop)] // band indices address `a` and `b` together
    pub fn solve_in_place(&self, b: &mut [f64]) {
        let (n, kl, ku) = (self.n, self.kl, self.ku);
        for k in 0..n {
            b.swap(k, self.piv[k]);
            let bk = b[k];
            if bk != 0.0 {
                for i in k + 1..=(k + kl).min(n.saturating_sub(1)) {
                    b[i] -= self.a[self.idx(i, k)] * bk;
                }
            }
        }
        for k in (0..n).rev() {
            let mut s = b[k];
            for c in k + 1..=(k + kl + ku).min(n - 1) {
                s -= self.a[self.idx(k, c)] * b[c];
            }
            b[k] = s / self.a[self.idx(k, k)];
        }
    }
}

impl crate::math::warm::WarmCopy for BandedLu {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src, copy: [n, kl, ku, w, a, piv], keep: []);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::DenseLu;

    /// A pseudo-random banded matrix whose first pivots need row swaps: the banded
    /// solve agrees with the dense LU (1e-12 relative) and so does the determinant's sign.
    #[test]
    fn agrees_with_the_dense_lu() {
        let (n, kl, ku) = (23, 4, 6);
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let mut band = BandedLu::new(n, kl, ku);
        let mut dense = DenseLu::new(n);
        for r in 0..n {
            for c in r.saturating_sub(kl)..=(r + ku).min(n - 1) {
                // a small diagonal forces pivoting
                let v = if r == c { 1e-3 * rnd() } else { rnd() };
                band.set(r, c, v);
                dense.matrix_mut()[r * n + c] = v;
            }
        }
        let b: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let (mut xb, mut xd) = (b.clone(), b.clone());
        assert!(band.factor().is_some());
        assert!(dense.factor().is_some());
        band.solve_in_place(&mut xb);
        dense.solve_in_place(&mut xd);
        let scale = xd.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for (u, v) in xb.iter().zip(&xd) {
            assert!((u - v).abs() < 1e-12 * scale, "{u} vs {v}");
        }
        assert_eq!(band.det_sign(), dense.det_sign());
    }

    #[test]
    fn singular_band_is_reported() {
        let mut band = BandedLu::new(3, 1, 1);
        band.set(0, 0, 1.0);
        band.set(0, 1, 2.0);
        band.set(1, 0, 2.0);
        band.set(1, 1, 4.0);
        band.set(2, 2, 1.0);
        assert!(band.factor().is_none());
    }
}
