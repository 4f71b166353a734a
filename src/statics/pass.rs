//! One integration pass from base to tip over any [`Real`] scalar: the shooting
//! residual for given unknowns, and (for `f64`) the recorded shape.
//!
//! Unknowns `x` (scaled): `m(0)/M` when `n(0)` is known in closed form, else
//! `[n(0)/F, m(0)/M]`; then, for each tensioned cable, the assumed world positions
//! `/L` of its holes on route disks 1..K-1 (needed for the chord towards the next,
//! not yet integrated, disk). Residuals: `m(L+)/M` (and `n(L+)/F`), plus computed
//! minus assumed hole positions `/L`. `F = EI/L^2`, `M = EI/L`.

use super::plan::{Event, ParamSite, Plan};
use crate::integrate::{dp45_step, rk4_step, strains, ErrScale, State};
use crate::math::Real;
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// A rigid pose: position and orientation in the world frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position (m).
    pub position: Vector3<f64>,
    /// Orientation; columns are the local x, y, z axes.
    pub rotation: Matrix3<f64>,
}

/// The backbone at one arc length.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// Arc length from the base (m).
    pub s: f64,
    /// Position `r` (m), world.
    pub r: Vector3<f64>,
    /// Orientation `R`.
    pub rotation: Matrix3<f64>,
    /// Internal force `n` (N), world.
    pub n: Vector3<f64>,
    /// Internal moment `m` (N m), world.
    pub m: Vector3<f64>,
    /// Curvature/twist `u` (1/m), local.
    pub u: Vector3<f64>,
    /// Shear/stretch `v` (-), local.
    pub v: Vector3<f64>,
}

/// What a pass records when asked (f64 passes only).
#[derive(Clone, Debug, Default)]
pub(crate) struct Recording {
    pub samples: Vec<Sample>,
    pub guides: Vec<Pose>,
    pub section_tips: Vec<Pose>,
}

/// Scratch space for passes over scalar `T`, sized once per plan.
#[derive(Clone, Debug)]
pub(crate) struct PassBuf<T: Real> {
    pub x: Vec<T>,
    /// Load parameters `theta` (see [`ParamSite`]).
    pub theta: Vec<T>,
    pub res: Vec<T>,
    /// Hole positions per cable per route disk (world).
    pub holes: Vec<Vec<Vector3<T>>>,
    pub rhs_evals: u64,
}

impl<T: Real> PassBuf<T> {
    pub fn new(plan: &Plan) -> Self {
        let z = Vector3::new(T::zero(), T::zero(), T::zero());
        Self {
            x: vec![T::zero(); plan.n_unknowns],
            theta: vec![T::zero(); plan.params.len()],
            res: vec![T::zero(); plan.n_unknowns],
            holes: plan.cables.iter().map(|c| vec![z; c.len]).collect(),
            rhs_evals: 0,
        }
    }
}

/// Why a pass could not finish.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum PassError {
    /// The state became NaN or infinite at this arc length.
    NonFinite(f64),
    /// The adaptive integrator hit its step limit.
    TooManySteps,
}

#[inline]
fn v3<T: Real>(v: &Vector3<f64>) -> Vector3<T> {
    v.map(T::cst)
}

#[inline]
fn unit<T: Real>(a: Vector3<T>) -> Vector3<T> {
    let nn = a.dot(&a);
    if nn.re() > 0.0 {
        let inv = T::one() / nn.sqrt();
        a * inv
    } else {
        a
    }
}

/// Integrate base to tip with the unknowns in `buf.x`; fills `buf.res` and `buf.holes`.
pub(crate) fn pass<T: Real>(
    plan: &Plan,
    buf: &mut PassBuf<T>,
    load_scale: f64,
    mut rec: Option<&mut Recording>,
) -> Result<State<T>, PassError> {
    let (fs, ms, ls) = (plan.force_scale, plan.moment_scale, plan.length);
    debug_assert_eq!(buf.theta.len(), plan.params.len());
    let mut y = State {
        r: v3::<T>(&plan.base_r),
        rot: plan.base_rot.map(T::cst),
        n: Vector3::zeros_generic_t(),
        m: Vector3::zeros_generic_t(),
    };
    if plan.closed_form {
        let mut n0 = v3::<T>(&plan.closed_n0);
        for (k, p) in plan.params.iter().enumerate() {
            match *p {
                ParamSite::Force { axis, .. } => n0[axis] += buf.theta[k],
                ParamSite::Mass { .. } => n0 += v3::<T>(&plan.gravity).map(|g| g * buf.theta[k]),
                _ => {}
            }
        }
        y.n = n0.map(|x| x.scale(load_scale));
        y.m = Vector3::new(buf.x[0], buf.x[1], buf.x[2]).map(|x| x.scale(ms));
    } else {
        y.n = Vector3::new(buf.x[0], buf.x[1], buf.x[2]).map(|x| x.scale(fs));
        y.m = Vector3::new(buf.x[3], buf.x[4], buf.x[5]).map(|x| x.scale(ms));
    }
    if let Some(r) = rec.as_deref_mut() {
        r.samples.clear();
        r.guides.clear();
        r.guides.resize(
            plan.n_guides,
            Pose {
                position: Vector3::zeros(),
                rotation: Matrix3::identity(),
            },
        );
        r.section_tips.clear();
        r.section_tips.resize(
            plan.n_sections,
            Pose {
                position: Vector3::zeros(),
                rotation: Matrix3::identity(),
            },
        );
    }
    for e in plan.start_events.clone() {
        apply_event(
            plan,
            plan.events[e],
            &mut y,
            buf,
            load_scale,
            rec.as_deref_mut(),
        );
    }
    let scale = ErrScale {
        length: ls,
        force: fs,
        moment: ms,
    };
    let mut h_adapt = ls / 16.0;
    let mut steps_taken = 0usize;
    for iv in &plan.intervals {
        let c = plan.coeffs_for(iv, load_scale);
        if let Some(r) = rec.as_deref_mut() {
            push_sample(r, iv.s0, &y, &c);
        }
        match plan.integrator {
            crate::settings::Integrator::Rk4 { .. } => {
                let h = (iv.s1 - iv.s0) / iv.steps as f64;
                for k in 0..iv.steps {
                    y = rk4_step(&y, h, &c);
                    buf.rhs_evals += 4;
                    if let Some(r) = rec.as_deref_mut() {
                        push_sample(r, iv.s0 + h * (k + 1) as f64, &y, &c);
                    }
                }
            }
            crate::settings::Integrator::Adaptive { tol, max_steps } => {
                let mut s = iv.s0;
                while s < iv.s1 {
                    let h = h_adapt.min(iv.s1 - s);
                    let out = dp45_step(&y, h, &c, tol, &scale);
                    buf.rhs_evals += 7;
                    steps_taken += 1;
                    if steps_taken > max_steps {
                        return Err(PassError::TooManySteps);
                    }
                    let err = if out.err.is_finite() { out.err } else { 1e10 };
                    if err <= 1.0 {
                        y = out.y;
                        s = if iv.s1 - s - h <= 1e-14 * ls {
                            iv.s1
                        } else {
                            s + h
                        };
                        if let Some(r) = rec.as_deref_mut() {
                            push_sample(r, s, &y, &c);
                        }
                    }
                    let fac = if err == 0.0 {
                        5.0
                    } else {
                        (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
                    };
                    let clipped = h < h_adapt;
                    h_adapt = if err <= 1.0 && clipped {
                        h_adapt.max(h * fac)
                    } else {
                        h * fac
                    };
                    if h_adapt < 1e-14 * ls {
                        return Err(PassError::NonFinite(s));
                    }
                }
            }
        }
        if !y.is_finite() {
            return Err(PassError::NonFinite(iv.s1));
        }
        for e in iv.events.clone() {
            apply_event(
                plan,
                plan.events[e],
                &mut y,
                buf,
                load_scale,
                rec.as_deref_mut(),
            );
        }
    }
    let off = if plan.closed_form {
        0
    } else {
        for i in 0..3 {
            buf.res[i] = y.n[i].scale(1.0 / fs);
        }
        3
    };
    for i in 0..3 {
        buf.res[off + i] = y.m[i].scale(1.0 / ms);
    }
    if buf.res.iter().any(|r| !r.re().is_finite()) {
        return Err(PassError::NonFinite(ls));
    }
    Ok(y)
}

fn push_sample<T: Real>(r: &mut Recording, s: f64, y: &State<T>, c: &crate::integrate::Coeffs) {
    let v = y.value();
    let (vv, u) = strains(&v, c);
    r.samples.push(Sample {
        s,
        r: v.r,
        rotation: v.rot,
        n: v.n,
        m: v.m,
        u,
        v: vv,
    });
}

fn apply_event<T: Real>(
    plan: &Plan,
    e: Event,
    y: &mut State<T>,
    buf: &mut PassBuf<T>,
    load_scale: f64,
    rec: Option<&mut Recording>,
) {
    let ls = plan.length;
    match e {
        Event::SectionEnd(k) => {
            if let Some(r) = rec {
                let v = y.value();
                r.section_tips[k] = Pose {
                    position: v.r,
                    rotation: v.rot,
                };
            }
        }
        Event::Point(i) => {
            // n+ = n- - F, m+ = m- - tau (thesis 3.5.1 and 3.5.3: m(s+) = m(s-) - tau_st)
            let p = &plan.points[i];
            let (mut f, tau) = if p.body {
                (y.rot * v3::<T>(&p.force), y.rot * v3::<T>(&p.torque))
            } else {
                (v3::<T>(&p.force), v3::<T>(&p.torque))
            };
            let mut tau = tau;
            f += v3::<T>(&(plan.gravity * p.mass));
            for &k in &plan.point_params[i] {
                let th = buf.theta[k];
                match plan.params[k] {
                    ParamSite::Force { axis, .. } => f[axis] += th,
                    ParamSite::Torque { axis, .. } => tau[axis] += th,
                    ParamSite::Mass { .. } => f += v3::<T>(&plan.gravity).map(|g| g * th),
                    ParamSite::Tension { .. } => {}
                }
            }
            y.n -= f.map(|x| x.scale(load_scale));
            y.m -= tau.map(|x| x.scale(load_scale));
        }
        Event::Guide(g) => {
            if let Some(r) = rec {
                let v = y.value();
                r.guides[g] = Pose {
                    position: v.r,
                    rotation: v.rot,
                };
            }
            if plan.point_guides {
                y.n -= v3::<T>(&(plan.gravity * (plan.guide_mass[g] * load_scale)));
            }
            for &(j, k) in &plan.guide_cables[g] {
                let c = &plan.cables[j];
                let arm = y.rot * v3::<T>(&c.hole_local[k]);
                let p = y.r + arm;
                buf.holes[j][k] = p;
                if let Some(u) = c.unknowns {
                    if k >= 1 {
                        let i0 = u + 3 * (k - 1);
                        for a in 0..3 {
                            buf.res[i0 + a] = (p[a] - buf.x[i0 + a].scale(ls)).scale(1.0 / ls);
                        }
                    }
                }
                if !c.tensioned {
                    continue;
                }
                let mut t = T::cst(c.tension);
                if let Some(k) = plan.tension_param[j] {
                    t += buf.theta[k];
                }
                let t = t.scale(load_scale);
                let prev = if k == 0 {
                    v3::<T>(&c.base_hole)
                } else {
                    buf.holes[j][k - 1]
                };
                // the cable pulls the disk along both straight chords (thesis 3.8.1 routing)
                let mut f = unit(prev - p).map(|x| x * t);
                if k + 1 < c.len {
                    if let Some(u) = c.unknowns {
                        let i0 = u + 3 * k;
                        let next = Vector3::new(buf.x[i0], buf.x[i0 + 1], buf.x[i0 + 2])
                            .map(|x| x.scale(ls));
                        f += unit(next - p).map(|x| x * t);
                    }
                }
                y.n -= f;
                y.m -= arm.cross(&f);
            }
        }
    }
}

trait ZerosT<T: Real> {
    fn zeros_generic_t() -> Vector3<T>;
}
impl<T: Real> ZerosT<T> for Vector3<T> {
    fn zeros_generic_t() -> Vector3<T> {
        Vector3::new(T::zero(), T::zero(), T::zero())
    }
}
