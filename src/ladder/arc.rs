//! Closed-form pose along an arc of constant curvature/twist (a helix in general).
//!
//! With `v = e3` and a constant local curvature vector `u` over a length `h`, the rod
//! equations `R' = R u^`, `r' = R e3` (thesis eqs. 2.3-2.4) integrate exactly to
//! the exponential of a constant twist (Murray, Li & Sastry 1994, *A Mathematical
//! Introduction to Robotic Manipulation*, eq. 2.36; for continuum robots: Webster &
//! Jones 2010, *Design and kinematic modeling of constant curvature continuum robots*,
//! IJRR 29(13), section 3):
//!
//! `R(h) = R0 exp(phi^)`, `r(h) = r0 + h R0 J(phi) e3`, with `phi = h u`, `t = |phi|`,
//! `exp(phi^) = I + sin t / t phi^ + (1 - cos t) / t^2 phi^2` (Rodrigues) and the left
//! Jacobian of SO(3) `J(phi) = I + (1 - cos t) / t^2 phi^ + (t - sin t) / t^3 phi^2`.

use crate::math::{skew, Real};
use crate::statics::Pose;
use nalgebra::{Matrix3, Vector3};

/// The three scalar coefficients of Rodrigues' formula and of the left Jacobian,
/// with Taylor series below `t = 1e-3` (truncation error < 1e-19).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArcJacobian {
    /// `sin t / t`.
    pub a: f64,
    /// `(1 - cos t) / t^2`.
    pub b: f64,
    /// `(t - sin t) / t^3`.
    pub c: f64,
}

impl ArcJacobian {
    /// Coefficients for the rotation vector `phi` (rad).
    pub fn new(phi: &Vector3<f64>) -> Self {
        let t2 = phi.norm_squared();
        if t2 < 1e-6 {
            Self {
                a: 1.0 - t2 / 6.0 + t2 * t2 / 120.0,
                b: 0.5 - t2 / 24.0 + t2 * t2 / 720.0,
                c: 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0,
            }
        } else {
            let t = t2.sqrt();
            let (s, co) = t.sin_cos();
            Self {
                a: s / t,
                b: (1.0 - co) / t2,
                c: (t - s) / (t2 * t),
            }
        }
    }
}

/// A pose over any [`Real`] scalar: `f64` in the solvers, [`crate::math::Dual`] in
/// the sensitivity sweeps of the curvature rungs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PoseT<T: Real> {
    /// Position (m, world).
    pub position: Vector3<T>,
    /// Orientation (local to world).
    pub rotation: Matrix3<T>,
}

impl<T: Real> PoseT<T> {
    /// The constant pose `p` (zero derivatives).
    pub fn constant(p: &Pose) -> Self {
        Self {
            position: p.position.map(T::cst),
            rotation: p.rotation.map(T::cst),
        }
    }
}

impl PoseT<f64> {
    /// As the public [`Pose`].
    pub fn pose(&self) -> Pose {
        Pose {
            position: self.position,
            rotation: self.rotation,
        }
    }
}

/// Pose after an arc of length `h` (m) with constant local curvature `u` (1/m) from
/// `start` (module docs for the formula).
#[inline]
pub fn arc_pose(start: &Pose, u: &Vector3<f64>, h: f64) -> Pose {
    arc_pose_t(&PoseT::constant(start), u, h).pose()
}

/// [`arc_pose`] over any [`Real`]: the same formulas, so dual numbers give its exact
/// derivatives (the coefficients of [`ArcJacobian`] are differentiated through
/// `sin`, `cos` and `sqrt`, or through their Taylor series in `t^2` near 0).
#[inline]
pub(crate) fn arc_pose_t<T: Real>(start: &PoseT<T>, u: &Vector3<T>, h: f64) -> PoseT<T> {
    let phi = u.map(|x| x.scale(h));
    let t2 = phi.dot(&phi);
    let (a, b, c) = if t2.re() < 1e-6 {
        let t4 = t2 * t2;
        (
            T::one() - t2.scale(1.0 / 6.0) + t4.scale(1.0 / 120.0),
            T::cst(0.5) - t2.scale(1.0 / 24.0) + t4.scale(1.0 / 720.0),
            T::cst(1.0 / 6.0) - t2.scale(1.0 / 120.0) + t4.scale(1.0 / 5040.0),
        )
    } else {
        let t = t2.sqrt();
        let (s, co) = t.sin_cos();
        (s / t, (T::one() - co) / t2, (t - s) / (t2 * t))
    };
    let w = skew(&phi);
    let w2 = w * w;
    let exp = Matrix3::identity() + w * a + w2 * b;
    // J e3 = e3 + b phi x e3 + c phi x (phi x e3)
    let e3 = Vector3::new(T::zero(), T::zero(), T::one());
    let pe = phi.cross(&e3);
    let je3 = e3 + pe * b + phi.cross(&pe) * c;
    PoseT {
        position: start.position + start.rotation * je3.map(|x| x.scale(h)),
        rotation: start.rotation * exp,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planar_arc_matches_circle() {
        // curvature k about local y: the rod bends towards +x, r = ((1 - cos ks)/k, 0, sin ks / k)
        let start = Pose {
            position: Vector3::zeros(),
            rotation: Matrix3::identity(),
        };
        for &k in &[1e-9, 1e-4, 0.3, 5.0, 40.0] {
            let h = 0.2;
            let p = arc_pose(&start, &Vector3::new(0.0, k, 0.0), h);
            // 1 - cos x = 2 sin^2(x / 2), without cancellation for tiny k
            let want = Vector3::new(
                2.0 * (0.5 * k * h).sin().powi(2) / k,
                0.0,
                (k * h).sin() / k,
            );
            assert!(
                (p.position - want).norm() < 1e-15 + 1e-13 * want.norm(),
                "k = {k}"
            );
            let t = p.rotation.column(2);
            assert!((t[0] - (k * h).sin()).abs() < 1e-14);
        }
    }

    #[test]
    fn dual_arc_matches_central_differences() {
        use crate::math::Dual;
        let start = Pose {
            position: Vector3::new(0.1, -0.2, 0.3),
            rotation: crate::math::exp_so3(&Vector3::new(0.3, -0.1, 0.7)),
        };
        // one curvature above and one below the Taylor switch (t^2 = 1e-6)
        for u in [
            Vector3::new(2.0, -3.0, 1.5),
            Vector3::new(1e-3, 2e-3, -1e-3),
        ] {
            let ud = Vector3::from_fn(|i, _| Dual::<3>::variable(u[i], i));
            let got = arc_pose_t(&PoseT::constant(&start), &ud, 0.4);
            for k in 0..3 {
                let h = 1e-6 * (1.0 + u.amax());
                let mut up = u;
                let mut um = u;
                up[k] += h;
                um[k] -= h;
                let (p, m) = (arc_pose(&start, &up, 0.4), arc_pose(&start, &um, 0.4));
                let dr = (p.position - m.position) / (2.0 * h);
                let dq = (p.rotation - m.rotation) / (2.0 * h);
                for i in 0..3 {
                    assert!((got.position[i].d[k] - dr[i]).abs() < 1e-8, "r {i} {k}");
                    for j in 0..3 {
                        assert!((got.rotation[(i, j)].d[k] - dq[(i, j)]).abs() < 1e-8);
                    }
                }
            }
        }
    }

    #[test]
    fn composition_of_two_halves_is_the_whole() {
        let start = Pose {
            position: Vector3::new(0.1, -0.2, 0.3),
            rotation: crate::math::exp_so3(&Vector3::new(0.3, -0.1, 0.7)),
        };
        let u = Vector3::new(2.0, -3.0, 1.5);
        let whole = arc_pose(&start, &u, 0.4);
        let half = arc_pose(&arc_pose(&start, &u, 0.2), &u, 0.2);
        assert!((whole.position - half.position).norm() < 1e-15);
        assert!((whole.rotation - half.rotation).norm() < 1e-14);
    }
}
