//! Rigid transforms between the capture frame and the robot base: rotation
//! vectors and the closed-form best fit of one point set onto another
//! (Kabsch 1976; Umeyama 1991 with scale).

use crate::math::exp_so3;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// `x_to = R x_from + t`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RigidTransform {
    /// Rotation `R`.
    pub rotation: Matrix3<f64>,
    /// Translation `t` (m).
    pub translation: Vector3<f64>,
}

impl Default for RigidTransform {
    fn default() -> Self {
        Self {
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
        }
    }
}

impl RigidTransform {
    /// From a scene's transform (`[calibration] capture_to_base`: rotation vector,
    /// translation).
    pub fn from_spec(spec: &crate::scene::calibration::TransformSpec) -> Self {
        Self::from_vector(
            &Vector3::from(spec.rotation_vector),
            &Vector3::from(spec.translation_m),
        )
    }

    /// From a rotation vector (rad) and a translation (m).
    pub fn from_vector(rotation_vector: &Vector3<f64>, translation: &Vector3<f64>) -> Self {
        Self {
            rotation: exp_so3(rotation_vector),
            translation: *translation,
        }
    }
    /// The rotation vector (axis times angle, rad, angle in `[0, pi]`).
    pub fn rotation_vector(&self) -> Vector3<f64> {
        rotation_vector(&self.rotation)
    }
    /// Apply to a point.
    pub fn apply(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * x + self.translation
    }
}

/// Logarithm of a rotation matrix: the rotation vector (rad, angle in `[0, pi]`).
/// Through the unit quaternion (Shepperd's method): `theta = 2 atan2(|v|, w)`, exact
/// for small angles (`2 v / w`) and well conditioned near pi.
pub fn rotation_vector(r: &Matrix3<f64>) -> Vector3<f64> {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*r));
    let (mut w, mut v) = (q.w, q.imag());
    if w < 0.0 {
        w = -w;
        v = -v;
    }
    let s = v.norm();
    if s < 1e-8 {
        // theta = 2 s + O(s^3): 2 v / w to second order
        return v * (2.0 / w);
    }
    v * (2.0 * s.atan2(w) / s)
}

/// Best rigid transform (least squares) mapping `from[i]` onto `to[i]`: minimises
/// `sum |R from_i + t - to_i|^2` (Kabsch). `None` for fewer than 3 points or a
/// degenerate (collinear) set.
pub fn kabsch(from: &[Vector3<f64>], to: &[Vector3<f64>]) -> Option<RigidTransform> {
    umeyama(from, to, false).map(|(t, _)| t)
}

/// Umeyama's similarity fit `to_i ~ c R from_i + t`; with `with_scale = false`, `c = 1`
/// (Kabsch). Returns the transform (with `c` folded out: `rotation` is a rotation) and `c`.
pub fn umeyama(
    from: &[Vector3<f64>],
    to: &[Vector3<f64>],
    with_scale: bool,
) -> Option<(RigidTransform, f64)> {
    let n = from.len();
    if n < 3 || to.len() != n {
        return None;
    }
    let ca = from.iter().sum::<Vector3<f64>>() / n as f64;
    let cb = to.iter().sum::<Vector3<f64>>() / n as f64;
    let mut h = Matrix3::zeros();
    let mut var_a = 0.0;
    for (a, b) in from.iter().zip(to) {
        let (da, db) = (a - ca, b - cb);
        h += db * da.transpose();
        var_a += da.norm_squared();
    }
    let svd = h.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    // rank check: a collinear set leaves two singular values at zero
    let mut s = svd.singular_values;
    let smax = s.max();
    if smax.is_nan() || smax <= 0.0 || var_a <= 0.0 {
        return None;
    }
    let mut sorted = [s[0], s[1], s[2]];
    sorted.sort_by(|a, b| b.total_cmp(a));
    if sorted[1] <= 1e-12 * smax {
        return None;
    }
    let d = (u * v_t).determinant().signum();
    let mut dm = Matrix3::identity();
    // flip the direction of the smallest singular value when a reflection is best
    let kmin = (0..3).min_by(|&i, &j| s[i].total_cmp(&s[j])).unwrap_or(2);
    dm[(kmin, kmin)] = d;
    s[kmin] *= d;
    let rotation = u * dm * v_t;
    let c = if with_scale { s.sum() / var_a } else { 1.0 };
    let translation = cb - c * rotation * ca;
    Some((
        RigidTransform {
            rotation,
            translation,
        },
        c,
    ))
}
