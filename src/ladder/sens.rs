//! Exact load sensitivities of the curvature rungs' cable lengths, by implicit
//! differentiation of their fixed points (what lets them sit under the estimator).
//!
//! Both curvature rungs solve a fixed point `u = Phi(u, theta)` on the stacked
//! curvatures `u` (one `Vector3` per section for CC, per piece for PCC), and their
//! cable lengths are a function `l(u)` of the shape alone. Differentiating the fixed
//! point at a converged `u` (implicit function theorem, e.g. Griewank & Walther 2008,
//! *Evaluating Derivatives*, 2nd ed., section 15.1):
//!
//! `du/dtheta = (I - Phi_u)^-1 Phi_theta`,  `dl/dtheta = l_theta + l_u du/dtheta`.
//!
//! `Phi_u`, `Phi_theta`, `l_u` come from the rung's own sweep evaluated over
//! [`Dual<6>`] in chunks of six seeded directions of `[u; theta]` (the same generic
//! code the f64 solver runs, so there is no second copy of the physics); `I - Phi_u`
//! is factorised once per call by the dense LU. The result is exact to round-off at
//! the converged point: its only error is the fixed point's own residual
//! (`tolerance`) times `|(I - Phi_u)^-1|`.

use crate::cables::path_length_t;
use crate::loads::{Frame, Loads};
use crate::math::{DenseLu, Dual, Real};
use crate::statics::ParamSite;
use nalgebra::Vector3;

/// Width of the dual numbers of a sensitivity sweep.
pub(crate) const W: usize = 6;
/// Dual scalar of the sensitivity sweeps.
pub(crate) type D6 = Dual<W>;

/// A point load resolved for a sweep over `T`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PointT<T: Real> {
    pub section: usize,
    /// Force in `frame` (N).
    pub force: Vector3<T>,
    /// Torque in `frame` (N m).
    pub torque: Vector3<T>,
    /// Body-frame (follower) force and torque.
    pub body: bool,
    /// Payload mass (kg), pulled by gravity.
    pub mass: T,
}

/// Loads resolved for a sweep over `T`: point loads, tensions and gravity.
#[derive(Clone, Debug)]
pub(crate) struct LoadsT<T: Real> {
    pub points: Vec<PointT<T>>,
    /// Tension of every cable (N), indexed like `robot.cables`.
    pub tensions: Vec<T>,
    /// Gravity (m/s^2, world).
    pub gravity: Vector3<f64>,
}

impl<T: Real> LoadsT<T> {
    /// Empty, for `cables` cables.
    pub fn new(cables: usize) -> Self {
        Self {
            points: Vec::new(),
            tensions: vec![T::zero(); cables],
            gravity: Vector3::zeros(),
        }
    }

    /// Copy `loads` as constants (no allocation once the point count was seen).
    pub fn set(&mut self, loads: &Loads) {
        self.gravity = Vector3::from(loads.gravity_m_s2);
        for (j, t) in self.tensions.iter_mut().enumerate() {
            *t = T::cst(loads.tension(j));
        }
        self.points.clear();
        self.points.extend(loads.point.iter().map(|p| PointT {
            section: p.section,
            force: Vector3::from(p.force_n).map(T::cst),
            torque: Vector3::from(p.torque_nm).map(T::cst),
            body: p.frame == Frame::Body,
            mass: T::cst(p.mass_kg),
        }));
    }
}

impl<T: Real> LoadsT<T> {
    /// Add `v` at `site`: a world-frame force/torque component, a payload mass or a
    /// tension, as [`ParamSite`] documents. No sign check: a trial step of an
    /// unbounded estimator may ask for a negative mass or tension, which the
    /// formulas extend to smoothly (an upward force, a pushing cable), as the
    /// shooting workspace does. `false` for a site outside these loads or a force or
    /// torque site on a body-frame point load (the caller gives such sites their own
    /// world-frame point load).
    pub fn add_at(&mut self, site: &ParamSite, v: T) -> bool {
        match *site {
            ParamSite::Tension { cable } => match self.tensions.get_mut(cable) {
                Some(t) => *t += v,
                None => return false,
            },
            ParamSite::Force { point, axis } | ParamSite::Torque { point, axis } => {
                let Some(p) = self.points.get_mut(point) else {
                    return false;
                };
                if p.body || axis > 2 {
                    return false;
                }
                if matches!(site, ParamSite::Force { .. }) {
                    p.force[axis] += v;
                } else {
                    p.torque[axis] += v;
                }
            }
            ParamSite::Mass { point } => match self.points.get_mut(point) {
                Some(p) => p.mass += v,
                None => return false,
            },
        }
        true
    }
}

/// `(x / |x|)` over `T`, `x` itself when it is zero.
#[inline]
pub(crate) fn unit_t<T: Real>(a: Vector3<T>) -> Vector3<T> {
    let n2 = a.dot(&a);
    if n2.re() > 0.0 {
        let inv = T::one() / n2.sqrt();
        a * inv
    } else {
        a
    }
}

/// Buffers of the implicit solve, sized once for `n` fixed-point unknowns, `p`
/// parameters and `c` cables.
#[derive(Clone, Debug)]
pub(crate) struct Implicit {
    pub n: usize,
    pub p: usize,
    pub c: usize,
    /// `d Phi / d[u; theta]`, row-major `n x (n + p)`.
    pub phi: Vec<f64>,
    /// `d l / d[u; theta]`, row-major `c x (n + p)`.
    pub len: Vec<f64>,
    lu: DenseLu,
    col: Vec<f64>,
}

impl Implicit {
    pub fn new(n: usize, p: usize, c: usize) -> Self {
        Self {
            n,
            p,
            c,
            phi: vec![0.0; n * (n + p)],
            len: vec![0.0; c * (n + p)],
            lu: DenseLu::new(n),
            col: vec![0.0; n],
        }
    }

    /// Width `n + p` of the seeded directions.
    pub fn width(&self) -> usize {
        self.n + self.p
    }

    /// Record one dual sweep seeded at columns `c0..`: the new curvatures `u_new`
    /// into the rows of `Phi`, the cable lengths from `base_holes` through the route
    /// holes `hole_pts`, plus `continuous` (the lengths of straight continuous paths,
    /// zero for disk-routed cables), into the rows of `l`.
    pub fn record_sweep(
        &mut self,
        c0: usize,
        u_new: &[Vector3<D6>],
        base_holes: &[Vector3<f64>],
        hole_pts: &[Vec<Vector3<D6>>],
        continuous: &[D6],
    ) {
        let w = self.width();
        for (i, u) in u_new.iter().enumerate() {
            for a in 0..3 {
                scatter(&mut self.phi, w, 3 * i + a, &u[a], c0);
            }
        }
        for (j, pts) in hole_pts.iter().enumerate() {
            let base = base_holes[j].map(D6::constant);
            let l = path_length_t(&base, pts) + continuous[j];
            scatter(&mut self.len, w, j, &l, c0);
        }
    }

    /// `out = l_theta + l_u (I - Phi_u)^-1 Phi_theta`, row-major `c x p`. `false` when
    /// `I - Phi_u` is singular to working precision (reciprocal pivot ratio below
    /// 1e-14: the fixed point is at a turning point of the load path).
    pub fn solve(&mut self, out: &mut [f64]) -> bool {
        let (n, p, c) = (self.n, self.p, self.c);
        let w = n + p;
        let a = self.lu.matrix_mut();
        for r in 0..n {
            for q in 0..n {
                a[r * n + q] = if r == q { 1.0 } else { 0.0 } - self.phi[r * w + q];
            }
        }
        match self.lu.factor() {
            Some(rc) if rc > 1e-14 => {}
            _ => return false,
        }
        for k in 0..p {
            for r in 0..n {
                self.col[r] = self.phi[r * w + n + k];
            }
            self.lu.solve_in_place(&mut self.col);
            for j in 0..c {
                let row = &self.len[j * w..(j + 1) * w];
                let g: f64 = row[n + k]
                    + row[..n]
                        .iter()
                        .zip(&self.col)
                        .map(|(a, b)| a * b)
                        .sum::<f64>();
                out[j * p + k] = g;
            }
        }
        out[..c * p].iter().all(|g| g.is_finite())
    }
}

/// Seed the stacked curvatures `u` (directions `c0..c0 + W` of `[u; theta]`).
pub(crate) fn seed_u(u64: &[Vector3<f64>], ud: &mut [Vector3<D6>], c0: usize) {
    for (i, (src, dst)) in u64.iter().zip(ud.iter_mut()).enumerate() {
        for a in 0..3 {
            let k = 3 * i + a;
            dst[a] = if k >= c0 && k < c0 + W {
                D6::variable(src[a], k - c0)
            } else {
                D6::constant(src[a])
            };
        }
    }
}

/// Seed the parameters whose direction `n + k` falls in `c0..c0 + W`.
pub(crate) fn seed_theta(
    base: &LoadsT<f64>,
    out: &mut LoadsT<D6>,
    params: &[ParamSite],
    n: usize,
    c0: usize,
) -> bool {
    out.gravity = base.gravity;
    for (t, b) in out.tensions.iter_mut().zip(&base.tensions) {
        *t = D6::constant(*b);
    }
    out.points.clear();
    out.points.extend(base.points.iter().map(|p| PointT {
        section: p.section,
        force: p.force.map(D6::constant),
        torque: p.torque.map(D6::constant),
        body: p.body,
        mass: D6::constant(p.mass),
    }));
    for (k, site) in params.iter().enumerate() {
        let d = n + k;
        if d >= c0 && d < c0 + W && !out.add_at(site, D6::variable(0.0, d - c0)) {
            return false;
        }
    }
    true
}

/// Copy the derivative parts of `values` (rows `row0..`) into `jac` (`rows x w`) at
/// columns `c0..`.
pub(crate) fn scatter(jac: &mut [f64], w: usize, row: usize, value: &D6, c0: usize) {
    let width = W.min(w - c0);
    jac[row * w + c0..row * w + c0 + width].copy_from_slice(&value.d[..width]);
}
