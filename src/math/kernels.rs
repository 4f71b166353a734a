//! 3x3 kernels written out by hand over any [`Real`].
//!
//! nalgebra's generic products go through `blas_uninit::array_axcpy` for scalar
//! types it cannot specialise (our [`super::Dual`]): a profile of the cold two-section
//! solve spent 64 % of its time there. These fixed, fully unrolled forms are what the
//! integrator's hot loop uses instead; they compute the same sums in the same order as
//! the textbook definitions, with each product after the first fused into its sum
//! ([`super::fma`]).

use super::Real;
use nalgebra::{Matrix3, Vector3};

/// `a0 b0 + a1 b1 + a2 b2`, summed in that order, the last two products fused
/// ([`super::fma`]).
#[inline(always)]
fn dot3<T: Real>(a0: T, b0: T, a1: T, b1: T, a2: T, b2: T) -> T {
    a2.mul_add_r(b2, a1.mul_add_r(b1, a0 * b0))
}

/// `a0 k0 + a1 k1 + a2 k2` for plain `f64` factors, likewise.
#[inline(always)]
fn dot3_f64<T: Real>(a0: T, k0: f64, a1: T, k1: f64, a2: T, k2: f64) -> T {
    a2.scale_add(k2, a1.scale_add(k1, a0.scale(k0)))
}

/// `a b - c d`, the first product fused.
#[inline(always)]
fn det2<T: Real>(a: T, b: T, c: T, d: T) -> T {
    a.mul_add_r(b, -(c * d))
}

/// `a b`.
#[inline(always)]
pub fn mat_vec<T: Real>(a: &Matrix3<T>, b: &Vector3<T>) -> Vector3<T> {
    let row = |i: usize| dot3(a[(i, 0)], b.x, a[(i, 1)], b.y, a[(i, 2)], b.z);
    Vector3::new(row(0), row(1), row(2))
}

/// `a^T b`.
#[inline(always)]
pub fn mat_t_vec<T: Real>(a: &Matrix3<T>, b: &Vector3<T>) -> Vector3<T> {
    let col = |j: usize| dot3(a[(0, j)], b.x, a[(1, j)], b.y, a[(2, j)], b.z);
    Vector3::new(col(0), col(1), col(2))
}

/// `a b` for a plain `f64` vector `b` (a constant offset carried by a dual frame).
#[inline(always)]
pub fn mat_vec_f64<T: Real>(a: &Matrix3<T>, b: &Vector3<f64>) -> Vector3<T> {
    let row = |i: usize| dot3_f64(a[(i, 0)], b.x, a[(i, 1)], b.y, a[(i, 2)], b.z);
    Vector3::new(row(0), row(1), row(2))
}

/// `a u^` (thesis eq. 2.5 hat map): row `i` of the product is `a_i x u`.
#[inline(always)]
pub fn mat_skew<T: Real>(a: &Matrix3<T>, u: &Vector3<T>) -> Matrix3<T> {
    let row = |i: usize| {
        let (a0, a1, a2) = (a[(i, 0)], a[(i, 1)], a[(i, 2)]);
        [
            det2(a1, u.z, a2, u.y),
            det2(a2, u.x, a0, u.z),
            det2(a0, u.y, a1, u.x),
        ]
    };
    let (r0, r1, r2) = (row(0), row(1), row(2));
    Matrix3::new(
        r0[0], r0[1], r0[2], r1[0], r1[1], r1[2], r2[0], r2[1], r2[2],
    )
}

/// `a b`.
#[inline(always)]
pub fn mat_mul<T: Real>(a: &Matrix3<T>, b: &Matrix3<T>) -> Matrix3<T> {
    let e = |i: usize, j: usize| {
        dot3(
            a[(i, 0)],
            b[(0, j)],
            a[(i, 1)],
            b[(1, j)],
            a[(i, 2)],
            b[(2, j)],
        )
    };
    Matrix3::new(
        e(0, 0),
        e(0, 1),
        e(0, 2),
        e(1, 0),
        e(1, 1),
        e(1, 2),
        e(2, 0),
        e(2, 1),
        e(2, 2),
    )
}

/// `a^T a` (symmetric: six distinct entries).
#[inline(always)]
pub fn gram<T: Real>(a: &Matrix3<T>) -> Matrix3<T> {
    let e = |i: usize, j: usize| {
        dot3(
            a[(0, i)],
            a[(0, j)],
            a[(1, i)],
            a[(1, j)],
            a[(2, i)],
            a[(2, j)],
        )
    };
    let (g00, g01, g02, g11, g12, g22) = (e(0, 0), e(0, 1), e(0, 2), e(1, 1), e(1, 2), e(2, 2));
    Matrix3::new(g00, g01, g02, g01, g11, g12, g02, g12, g22)
}

/// `a x b`.
#[inline(always)]
pub fn cross<T: Real>(a: &Vector3<T>, b: &Vector3<T>) -> Vector3<T> {
    Vector3::new(
        det2(a.y, b.z, a.z, b.y),
        det2(a.z, b.x, a.x, b.z),
        det2(a.x, b.y, a.y, b.x),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::skew;

    #[test]
    fn kernels_match_nalgebra() {
        let a = Matrix3::new(1.0, -2.0, 0.5, 3.0, 0.25, -1.5, 2.0, 4.0, -0.75);
        let b = Matrix3::new(0.3, 1.0, -2.0, 0.7, -0.1, 0.4, 1.1, 2.2, -3.3);
        let v = Vector3::new(0.2, -1.3, 2.7);
        let w = Vector3::new(-0.6, 0.9, 1.4);
        assert!((mat_vec(&a, &v) - a * v).norm() < 1e-14);
        assert!((mat_t_vec(&a, &v) - a.transpose() * v).norm() < 1e-14);
        assert!((mat_vec_f64(&a, &v) - a * v).norm() < 1e-14);
        assert!((mat_skew(&a, &v) - a * skew(&v)).norm() < 1e-14);
        assert!((mat_mul(&a, &b) - a * b).norm() < 1e-13);
        assert!((gram(&a) - a.transpose() * a).norm() < 1e-13);
        assert!((cross(&v, &w) - v.cross(&w)).norm() < 1e-14);
    }
}
