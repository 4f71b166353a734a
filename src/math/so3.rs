//! Rotation helpers over any [`Real`] scalar.

use super::{gram, mat_mul, Real};
use nalgebra::{Matrix3, Vector3};

/// The hat map `u -> u^`, thesis eq. 2.5: `u^ w = u x w`.
#[inline(always)]
pub fn skew<T: Real>(u: &Vector3<T>) -> Matrix3<T> {
    let z = T::zero();
    Matrix3::new(z, -u.z, u.y, u.z, z, -u.x, -u.y, u.x, z)
}

/// One Newton-Schulz step towards the nearest rotation: `R (3 I - R^T R) / 2`.
///
/// A polynomial map, so it is exact for dual numbers; applied after every
/// integration step it keeps `R^T R = I` to round-off (drift of RK4 is O(h^5)).
#[inline(always)]
pub fn orthonormalize<T: Real>(r: &Matrix3<T>) -> Matrix3<T> {
    let mut m = gram(r);
    m.iter_mut().for_each(|x| *x = x.scale(-0.5));
    let half3 = T::cst(1.5);
    m[(0, 0)] += half3;
    m[(1, 1)] += half3;
    m[(2, 2)] += half3;
    mat_mul(r, &m)
}

/// Rodrigues' formula for a rotation vector (axis times angle, rad).
pub fn exp_so3(w: &Vector3<f64>) -> Matrix3<f64> {
    let th = w.norm();
    let k = skew(w);
    if th < 1e-12 {
        return Matrix3::identity() + k;
    }
    Matrix3::identity() + k * (th.sin() / th) + k * k * ((1.0 - th.cos()) / (th * th))
}
