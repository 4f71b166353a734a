//! Forward-mode dual numbers `a + sum_i b_i eps_i` with `N` infinitesimal directions.
//!
//! Evaluating the shooting residual over `Dual<N>` gives the residual and `N` exact
//! columns of its Jacobian in one pass (no finite differences).

use super::{fma, Real};
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// A dual number with `N` derivative directions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual<const N: usize> {
    /// Value.
    pub v: f64,
    /// Derivatives along each seeded direction.
    pub d: [f64; N],
}

impl<const N: usize> Dual<N> {
    /// A constant.
    #[inline(always)]
    pub fn constant(v: f64) -> Self {
        Self { v, d: [0.0; N] }
    }
    /// A variable seeded along direction `k` (`k >= N` gives a constant).
    #[inline(always)]
    pub fn variable(v: f64, k: usize) -> Self {
        let mut d = [0.0; N];
        if k < N {
            d[k] = 1.0;
        }
        Self { v, d }
    }
}

impl<const N: usize> num_traits::Zero for Dual<N> {
    fn zero() -> Self {
        Self::constant(0.0)
    }
    fn is_zero(&self) -> bool {
        self.v == 0.0 && self.d.iter().all(|x| *x == 0.0)
    }
}

impl<const N: usize> num_traits::One for Dual<N> {
    fn one() -> Self {
        Self::constant(1.0)
    }
}

impl<const N: usize> Add for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn add(mut self, o: Self) -> Self {
        self += o;
        self
    }
}
impl<const N: usize> AddAssign for Dual<N> {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
        self.v += o.v;
        for i in 0..N {
            self.d[i] += o.d[i];
        }
    }
}
impl<const N: usize> Sub for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn sub(mut self, o: Self) -> Self {
        self -= o;
        self
    }
}
impl<const N: usize> SubAssign for Dual<N> {
    #[inline(always)]
    fn sub_assign(&mut self, o: Self) {
        self.v -= o.v;
        for i in 0..N {
            self.d[i] -= o.d[i];
        }
    }
}
impl<const N: usize> Mul for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        let mut d = [0.0; N];
        for (i, di) in d.iter_mut().enumerate() {
            *di = fma(self.d[i], o.v, self.v * o.d[i]);
        }
        Self { v: self.v * o.v, d }
    }
}
impl<const N: usize> MulAssign for Dual<N> {
    #[inline(always)]
    fn mul_assign(&mut self, o: Self) {
        *self = *self * o;
    }
}
impl<const N: usize> Div for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        let inv = 1.0 / o.v;
        let v = self.v * inv;
        let mut d = [0.0; N];
        for (i, di) in d.iter_mut().enumerate() {
            *di = fma(-v, o.d[i], self.d[i]) * inv;
        }
        Self { v, d }
    }
}
impl<const N: usize> DivAssign for Dual<N> {
    #[inline(always)]
    fn div_assign(&mut self, o: Self) {
        *self = *self / o;
    }
}
impl<const N: usize> Neg for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        let mut d = self.d;
        for di in d.iter_mut() {
            *di = -*di;
        }
        Self { v: -self.v, d }
    }
}

impl<const N: usize> Real for Dual<N> {
    #[inline(always)]
    fn cst(x: f64) -> Self {
        Self::constant(x)
    }
    #[inline(always)]
    fn re(&self) -> f64 {
        self.v
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        let k = if s > 0.0 { 0.5 / s } else { 0.0 };
        let mut d = self.d;
        for di in d.iter_mut() {
            *di *= k;
        }
        Self { v: s, d }
    }
    #[inline(always)]
    fn scale(self, k: f64) -> Self {
        let mut d = self.d;
        for di in d.iter_mut() {
            *di *= k;
        }
        Self { v: self.v * k, d }
    }
    const DIRS: usize = N;
    #[inline(always)]
    fn eps(&self) -> &[f64] {
        &self.d
    }
    #[inline(always)]
    fn eps_mut(&mut self) -> &mut [f64] {
        &mut self.d
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = self.v.sin_cos();
        let mut ds = self.d;
        let mut dc = self.d;
        for (a, b) in ds.iter_mut().zip(dc.iter_mut()) {
            *a *= c;
            *b *= -s;
        }
        (Self { v: s, d: ds }, Self { v: c, d: dc })
    }
    #[inline(always)]
    fn mul_add_r(self, a: Self, b: Self) -> Self {
        // (s a + b)' = s' a + s a' + b': two fused operations per direction
        let mut d = [0.0; N];
        for (i, di) in d.iter_mut().enumerate() {
            *di = fma(self.d[i], a.v, fma(self.v, a.d[i], b.d[i]));
        }
        // the value as an `f64` pass computes it (`Real for f64`): fused too
        Self {
            v: fma(self.v, a.v, b.v),
            d,
        }
    }
    #[inline(always)]
    fn scale_add(self, k: f64, b: Self) -> Self {
        let mut d = [0.0; N];
        for (i, di) in d.iter_mut().enumerate() {
            *di = fma(self.d[i], k, b.d[i]);
        }
        Self {
            v: fma(self.v, k, b.v),
            d,
        }
    }
    #[inline(always)]
    fn add_cst(self, c: f64) -> Self {
        Self {
            v: self.v + c,
            d: self.d,
        }
    }
    #[inline(always)]
    fn chain(&self, f: f64, df: f64) -> Self {
        let mut d = self.d;
        for di in d.iter_mut() {
            *di *= df;
        }
        Self { v: f, d }
    }
}

impl<const N: usize> crate::math::warm::WarmCopy for Dual<N> {
    #[inline]
    fn warm_copy_from(&mut self, src: &Self) {
        *self = *src;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn product_quotient_and_sqrt_rules() {
        let x = Dual::<2>::variable(3.0, 0);
        let y = Dual::<2>::variable(2.0, 1);
        let f = (x * y + x / y).sqrt();
        // f = sqrt(xy + x/y) at (3,2): sqrt(7.5)
        let v = 7.5f64.sqrt();
        assert!((f.v - v).abs() < 1e-15);
        // df/dx = (y + 1/y) / (2f), df/dy = (x - x/y^2) / (2f)
        assert!((f.d[0] - 2.5 / (2.0 * v)).abs() < 1e-15);
        assert!((f.d[1] - 2.25 / (2.0 * v)).abs() < 1e-15);
    }

    /// The fused forms against the product and sum they fuse (1e-15, one rounding
    /// fewer), and the value part of a dual exactly as the `f64` form computes it.
    #[test]
    fn fused_multiply_add_rules() {
        let x = Dual::<2>::variable(1.5, 0);
        let y = Dual::<2>::variable(-0.75, 1);
        let z = Dual::<2>::constant(0.3) + x.scale(2.0);
        let (f, g) = (x.mul_add_r(y, z), x * y + z);
        assert!((f.v - g.v).abs() < 1e-15);
        // d/dx (x y + 0.3 + 2x) = y + 2, d/dy = x
        assert!((f.d[0] - 1.25).abs() < 1e-15 && (f.d[1] - 1.5).abs() < 1e-15);
        assert!((g.d[0] - 1.25).abs() < 1e-15 && (g.d[1] - 1.5).abs() < 1e-15);
        let h = y.scale_add(4.0, x);
        assert!((h.v - (-1.5)).abs() < 1e-15 && h.d == [1.0, 4.0]);
        // a dual's value part is the f64 form's, bit for bit (the passes agree)
        assert_eq!(f.v, 1.5f64.mul_add_r(-0.75, z.v));
        assert_eq!(h.v, (-0.75f64).scale_add(4.0, 1.5));
        assert_eq!(
            1.5f64.mul_add_r(-0.75, 0.3),
            crate::math::fma(1.5, -0.75, 0.3)
        );
        // where the target fuses, one rounding: 0.1 * 10 - 1 is 0 unfused, the
        // product's rounding error (5.55e-17) fused
        let fused = cfg!(any(target_feature = "fma", target_arch = "aarch64"));
        let r = 0.1f64.mul_add_r(10.0, -1.0);
        assert_eq!(r != 0.0, fused, "{r:e}");
    }

    /// `add_cst` moves the value only; `chain` is the chain rule (here of `exp`).
    #[test]
    fn constant_sums_and_the_chain_rule() {
        let mut x = Dual::<2>::variable(0.5, 0);
        x.d[1] = -2.0;
        let y = x.add_cst(1.25);
        assert_eq!((y.v, y.d), (1.75, [1.0, -2.0]));
        assert_eq!(y.v, (x + Dual::constant(1.25)).v);
        let e = x.chain(x.v.exp(), x.v.exp());
        assert_eq!(e.v, 0.5f64.exp());
        assert_eq!(e.d, [0.5f64.exp(), -2.0 * 0.5f64.exp()]);
        assert_eq!(0.5f64.chain(3.0, 7.0), 3.0);
        assert_eq!(0.5f64.add_cst(0.25), 0.75);
    }

    #[test]
    fn sine_and_cosine_rules() {
        let x = Dual::<1>::variable(0.7, 0);
        let (s, c) = x.sin_cos();
        assert!((s.v - 0.7f64.sin()).abs() < 1e-16 && (s.d[0] - 0.7f64.cos()).abs() < 1e-16);
        assert!((c.v - 0.7f64.cos()).abs() < 1e-16 && (c.d[0] + 0.7f64.sin()).abs() < 1e-16);
    }
}
