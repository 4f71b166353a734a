//! Integration layer: the rod state, the Cosserat ODE right-hand side written once
//! over any [`Real`] scalar, and the two steppers (fixed RK4, adaptive DP5(4)).

mod steppers;

pub use steppers::{
    dp45_step, dp45_step_with, rk4_step, rk4_step_with, Dp45Outcome, ErrScale, DP45_B, DP45_C,
    RK4_B, RK4_C,
};

use crate::math::{cross, mat_skew, mat_t_vec, mat_vec, Real};
use nalgebra::{Matrix3, Vector3};

/// Backbone state at one arc length, all in the world frame:
/// position `r`, orientation `R`, internal force `n` and internal moment `m`
/// (the force/moment the distal part exerts on the proximal part, thesis 2.7).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State<T: Real> {
    /// Position `r(s)` (m).
    pub r: Vector3<T>,
    /// Orientation `R(s)`: columns are the local axes in world coordinates.
    pub rot: Matrix3<T>,
    /// Internal force `n(s)` (N).
    pub n: Vector3<T>,
    /// Internal moment `m(s)` (N m).
    pub m: Vector3<T>,
}

impl<T: Real> State<T> {
    /// `self + h k` for a derivative `k`.
    #[inline(always)]
    pub fn add_scaled(&self, k: &State<T>, h: f64) -> State<T> {
        let mut out = *self;
        out.axpy(k, h);
        out
    }
    /// `self += h k` in place (the same arithmetic as [`State::add_scaled`]).
    #[inline(always)]
    pub fn axpy(&mut self, k: &State<T>, h: f64) {
        let axpy = |o: &mut [T], k: &[T]| {
            for (oi, ki) in o.iter_mut().zip(k) {
                *oi = ki.scale_add(h, *oi);
            }
        };
        axpy(self.r.as_mut_slice(), k.r.as_slice());
        axpy(self.rot.as_mut_slice(), k.rot.as_slice());
        axpy(self.n.as_mut_slice(), k.n.as_slice());
        axpy(self.m.as_mut_slice(), k.m.as_slice());
    }
    /// `self = y + h k`, overwriting `self` (no copy of `y` first: for a dual state
    /// of `Dual<21>` the copy was a `memcpy` of 3 kB per RK4 stage).
    #[inline(always)]
    pub fn set_add_scaled(&mut self, y: &State<T>, k: &State<T>, h: f64) {
        let set = |o: &mut [T], y: &[T], k: &[T]| {
            for ((oi, yi), ki) in o.iter_mut().zip(y).zip(k) {
                *oi = ki.scale_add(h, *yi);
            }
        };
        set(self.r.as_mut_slice(), y.r.as_slice(), k.r.as_slice());
        set(self.rot.as_mut_slice(), y.rot.as_slice(), k.rot.as_slice());
        set(self.n.as_mut_slice(), y.n.as_slice(), k.n.as_slice());
        set(self.m.as_mut_slice(), y.m.as_slice(), k.m.as_slice());
    }
    /// Value parts as plain `f64`.
    pub fn value(&self) -> State<f64> {
        State {
            r: self.r.map(|x| x.re()),
            rot: self.rot.map(|x| x.re()),
            n: self.n.map(|x| x.re()),
            m: self.m.map(|x| x.re()),
        }
    }
    /// True when every value part is finite.
    ///
    /// As one sum of `x * 0` (zero for every finite `x`, NaN for an infinite or NaN
    /// one, and NaN stays NaN through the sum): one branch instead of eighteen; the
    /// pass checks this once per interval (1.9 % of a warm solve on 100 disks).
    pub fn is_finite(&self) -> bool {
        let z = |a: f64, x: &T| a + x.re() * 0.0;
        let acc = self.r.iter().fold(0.0, z);
        let acc = self.rot.iter().fold(acc, z);
        let acc = self.n.iter().fold(acc, z);
        self.m.iter().fold(acc, z) == 0.0
    }
}

/// Coefficients of the ODE on one interval (constant between events).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coeffs {
    /// `C^-1` diagonal (1 / (N m^2)).
    pub inv_c: Vector3<f64>,
    /// `D^-1` diagonal (1 / N); unused for a Kirchhoff rod.
    pub inv_d: Vector3<f64>,
    /// Precurvature `u*` (1/m).
    pub u_star: Vector3<f64>,
    /// Distributed force per unit length `f` (N/m), world frame (gravity times linear density).
    pub f: Vector3<f64>,
    /// `true`: Kirchhoff rod, `v = e3`.
    pub kirchhoff: bool,
}

#[inline(always)]
fn cmul<T: Real>(a: &Vector3<T>, k: &Vector3<f64>) -> Vector3<T> {
    Vector3::new(a.x.scale(k.x), a.y.scale(k.y), a.z.scale(k.z))
}

/// Right-hand side of the rod ODE.
///
/// Symbols (thesis chapter II): `v = D^-1 R^T n + e3` (eq. 2.10, `v* = e3`),
/// `u = C^-1 R^T m + u*` (eq. 2.12 inverted), `r' = R v` (eq. 2.3), `R' = R u^`
/// (eq. 2.4), `n' = -f` (eq. 2.6 differentiated), `m' = -r' x n` (eq. 2.11
/// differentiated, no distributed moment `l`). Eq. 2.13 is the same law written for
/// `u'`; carrying `m` instead makes stiffness jumps between sections automatic
/// (`u+ = C+^-1 (C- (u- - u-*) - R^T tau) + u+*`, section 3.5 generalised).
#[inline(always)]
pub fn rhs<T: Real>(y: &State<T>, c: &Coeffs) -> State<T> {
    let v = if c.kirchhoff {
        Vector3::new(T::zero(), T::zero(), T::one())
    } else {
        let mut v = cmul(&mat_t_vec(&y.rot, &y.n), &c.inv_d);
        v.z += T::one();
        v
    };
    let mut u = cmul(&mat_t_vec(&y.rot, &y.m), &c.inv_c);
    for i in 0..3 {
        if c.u_star[i] != 0.0 {
            u[i] += T::cst(c.u_star[i]);
        }
    }
    let rdot = mat_vec(&y.rot, &v);
    State {
        r: rdot,
        rot: mat_skew(&y.rot, &u),
        n: Vector3::new(T::cst(-c.f.x), T::cst(-c.f.y), T::cst(-c.f.z)),
        m: cross(&y.n, &rdot),
    }
}

/// The strains `(v, u)` at a state, in the local frame.
pub fn strains(y: &State<f64>, c: &Coeffs) -> (Vector3<f64>, Vector3<f64>) {
    let rt = y.rot.transpose();
    let v = if c.kirchhoff {
        Vector3::z()
    } else {
        (rt * y.n).component_mul(&c.inv_d) + Vector3::z()
    };
    let u = (rt * y.m).component_mul(&c.inv_c) + c.u_star;
    (v, u)
}

impl<T: Real> crate::math::warm::WarmCopy for State<T> {
    #[inline]
    fn warm_copy_from(&mut self, src: &Self) {
        *self = *src;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    /// `is_finite` is false for any infinite or NaN component, true for large finite
    /// ones (the sum of `x * 0` cannot overflow).
    #[test]
    fn is_finite_flags_every_bad_component() {
        let y = State {
            r: Vector3::new(1e308, -1e308, 0.5),
            rot: Matrix3::identity() * 1e300,
            n: Vector3::new(-1e308, 1e308, 1e308),
            m: Vector3::zeros(),
        };
        assert!(y.is_finite());
        for bad in [f64::INFINITY, f64::NEG_INFINITY, f64::NAN] {
            for k in 0..18 {
                let mut z = y;
                match k {
                    0..=2 => z.r[k] = bad,
                    3..=11 => z.rot[k - 3] = bad,
                    12..=14 => z.n[k - 12] = bad,
                    _ => z.m[k - 15] = bad,
                }
                assert!(!z.is_finite(), "{bad} at {k}");
            }
        }
    }
}
