//! Math layer: the scalar trait the rod equations are written over, forward-mode
//! dual numbers for exact Jacobians, a small dense LU with workspace, and SO(3) helpers.
//!
//! Nothing here knows about rods or robots.

mod banded;
pub(crate) mod broyden;
pub(crate) mod damping;
mod dual;
mod kernels;
mod lu;
pub(crate) mod newton;
mod so3;
pub(crate) mod step;
pub(crate) mod warm;

pub use banded::BandedLu;
pub use dual::Dual;
pub use kernels::{cross, gram, mat_mul, mat_skew, mat_t_vec, mat_vec, mat_vec_f64};
pub use lu::DenseLu;
pub use so3::{exp_so3, orthonormalize, skew};

use std::fmt::Debug;
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// `a b + c`, rounded once where the target has a fused multiply-add (x86-64 with
/// the `fma` feature, which `.cargo/config.toml`'s `x86-64-v3` turns on; every
/// aarch64), else as a product and a sum (a software `fma` would be far slower than
/// the two roundings it saves). The 3x3 kernels (`kernels.rs`) and the dual numbers'
/// derivative parts use it: two instructions per direction instead of four in a
/// `Dual`'s `a b + c`, one instead of two in an `f64` one (FTDCR v4 warm rows -11 %
/// of their instructions, a `Dual<15>` sweep -40 %: benches/README.md).
/// Results differ from the unfused sums in the last bits only; which one a build
/// gets depends on its target, so bit-identical comparisons hold within one build.
#[inline(always)]
pub fn fma(a: f64, b: f64, c: f64) -> f64 {
    #[cfg(any(target_feature = "fma", target_arch = "aarch64"))]
    {
        a.mul_add(b, c)
    }
    #[cfg(not(any(target_feature = "fma", target_arch = "aarch64")))]
    {
        a * b + c
    }
}

/// A real scalar the rod equations can be evaluated over: `f64` for values and
/// [`Dual`] for values plus exact directional derivatives (forward-mode AD).
///
/// The bounds are the ones nalgebra needs for fixed-size arithmetic
/// (`Vector3<T>`, `Matrix3<T>` products) plus a square root for chord lengths.
pub trait Real:
    Copy
    + Debug
    + PartialEq
    + 'static
    + num_traits::Zero
    + num_traits::One
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
{
    /// A constant (zero derivative).
    fn cst(x: f64) -> Self;
    /// The value part.
    fn re(&self) -> f64;
    /// Square root (derivative `1 / (2 sqrt(x))`).
    fn sqrt(self) -> Self;
    /// Multiply by a plain `f64` (cheaper than promoting it to `Self`).
    fn scale(self, k: f64) -> Self;
    /// Number of derivative directions carried (0 for `f64`).
    const DIRS: usize;
    /// The derivative parts (empty for `f64`).
    fn eps(&self) -> &[f64];
    /// The derivative parts, mutable (empty for `f64`).
    fn eps_mut(&mut self) -> &mut [f64];
    /// Sine and cosine (derivatives `cos x` and `-sin x`); the closed-form arcs of
    /// the curvature rungs need them.
    fn sin_cos(self) -> (Self, Self);
    /// `self a + b`, fused where the target fuses ([`fma`]): an `f64`, and a
    /// [`Dual`]'s value and derivative parts.
    fn mul_add_r(self, a: Self, b: Self) -> Self;
    /// `self k + b` for a plain `f64` factor, likewise.
    fn scale_add(self, k: f64, b: Self) -> Self;
    /// `self + c` for a plain `f64` constant: only the value part changes (a
    /// [`Dual`]'s derivative parts are left as they are, not added to zeros).
    fn add_cst(self, c: f64) -> Self;
    /// A scalar function `f` of `self` from its value `f(x)` and derivative `f'(x)`
    /// at `x = self.re()`: `f(x) + f'(x) dx` (the chain rule on every direction at
    /// once; an `f64` is just `f(x)`).
    fn chain(&self, f: f64, df: f64) -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn cst(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn re(&self) -> f64 {
        *self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn scale(self, k: f64) -> Self {
        self * k
    }
    const DIRS: usize = 0;
    #[inline(always)]
    fn eps(&self) -> &[f64] {
        &[]
    }
    #[inline(always)]
    fn eps_mut(&mut self) -> &mut [f64] {
        &mut []
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        f64::sin_cos(self)
    }
    #[inline(always)]
    fn mul_add_r(self, a: Self, b: Self) -> Self {
        fma(self, a, b)
    }
    #[inline(always)]
    fn scale_add(self, k: f64, b: Self) -> Self {
        fma(self, k, b)
    }
    #[inline(always)]
    fn add_cst(self, c: f64) -> Self {
        self + c
    }
    #[inline(always)]
    fn chain(&self, f: f64, _df: f64) -> Self {
        f
    }
}
