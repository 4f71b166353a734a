//! One integration pass from base to tip over any [`Real`] scalar: the shooting
//! residual for given unknowns, and (for `f64`) the recorded shape.
//!
//! Unknowns `x` (scaled): `m(0)/M` when `n(0)` is known in closed form, else
//! `[n(0)/F, m(0)/M]`; then, for each tensioned cable, the assumed world positions
//! `/L` of its holes on route disks 1..K-1 (needed for the chord towards the next,
//! not yet integrated, disk). Residuals: `m(L+)/M` (and `n(L+)/F`), plus computed
//! minus assumed hole positions `/L`. `F = EI/L^2`, `M = EI/L`.
//!
//! With the condensed coupling ([`crate::settings::CableCoupling::Condensed`]) the
//! hole positions are not unknowns: at each disk the assumed next-hole positions
//! `q` of the tensioned cables are solved inside the pass so that the next disk's
//! computed holes `p(q)` equal them. An `f64` pass iterates the segment,
//! `q <- q + M (p(q) - q)` with `M = (I - dp/dq)^-1` from the last dual sweep (the
//! plain fixed point `M = I` before any sweep; the map contracts by roughly
//! `T (h^2/6 + rho h/2) / EI` for chord `h` and hole radius `rho`). A dual pass does not
//! iterate: it seeds `q` along extra local directions, and at the next disk folds
//! them into the outer ones with `dq/dz = (I - dp/dq)^-1 dp/dz|_q` (the implicit
//! function theorem for the segment), so its outer derivatives are exact.

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
    /// Condensed coupling: segment re-integrations (local iterations) so far.
    pub retries: u64,
    /// Condensed coupling: tolerance of the local iteration as a fraction of the rod
    /// length; [`LOCAL_TOL`] unless the outer Newton is still far away (inexact
    /// Newton: an inner error far below the outer residual does not change the step).
    pub local_tol: f64,
    /// Condensed coupling: assumed position of hole `k + 1` used by the chord at
    /// route disk `k`, per cable (world, m). Solved by `f64` passes, read by sweeps.
    pub next: Vec<Vec<Vector3<f64>>>,
    /// Condensed coupling: per guide, `M = (I - dp/dq)^-1` (`L x L` row-major,
    /// `L = 3 * pending[g].len()`), written by dual passes.
    pub mlin: Vec<Vec<f64>>,
    /// `mlin` holds matrices from a sweep (else the plain fixed point is used).
    pub mlin_valid: bool,
    /// Condensed coupling: pose of each guide when its `next` holes were last
    /// settled (`f64` passes); a new pass carries `next` along rigidly from it.
    pub anchor: Vec<(Vector3<f64>, Matrix3<f64>)>,
    /// Scratch for the per-segment linear solve of a dual pass.
    lin: Vec<f64>,
    /// Dual passes: watch `det d(n, m)(s) / d(n0, m0)` (or `det dm(s)/dm0` when `n(0)`
    /// is in closed form) along the rod for a sign change (a conjugate point).
    pub watch: bool,
    /// First arc length (m) where the watched determinant changed sign.
    pub conjugate_at: Option<f64>,
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
            retries: 0,
            local_tol: LOCAL_TOL,
            next: plan
                .cables
                .iter()
                .map(|c| vec![Vector3::zeros(); c.len])
                .collect(),
            mlin: plan
                .pending
                .iter()
                .map(|p| vec![0.0; 9 * p.len() * p.len()])
                .collect(),
            mlin_valid: false,
            anchor: vec![(Vector3::zeros(), Matrix3::identity()); plan.pending.len()],
            lin: vec![0.0; plan.max_local * (plan.max_local + T::DIRS + plan.max_local)],
            watch: false,
            conjugate_at: None,
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
    /// Condensed coupling: the next-hole positions of a segment ending at this arc
    /// length did not settle.
    Coupling(f64),
}

/// Condensed coupling: a segment's next holes must agree to this fraction of the rod
/// length once the outer iteration is close (see [`PassBuf::local_tol`]), or stop
/// improving below [`LOCAL_FLOOR`]. The boundary residual moves by about
/// `T L^2 / (EI h)` times a scaled hole error (~100-1000 on the shipped rods), so the
/// outer tolerance of 1e-10..1e-11 needs hole errors near round-off.
pub(crate) const LOCAL_TOL: f64 = 1e-15;
/// Condensed coupling: a segment whose hole error is below this fraction of the rod
/// length and no longer halves per iteration has reached round-off.
const LOCAL_FLOOR: f64 = 1e-13;
/// Condensed coupling: segment re-integrations allowed per disk.
const MAX_LOCAL_ITERATIONS: usize = 60;

/// Where a pass can return to re-integrate a segment (condensed coupling).
struct Checkpoint<T: Real> {
    /// Guide whose chords use the assumed next holes.
    g: usize,
    /// Interval whose events include that guide, and the event's index.
    iv: usize,
    ev: usize,
    /// State before the guide's event.
    y: State<T>,
    /// Recorded samples at that point.
    samples: usize,
    /// Adaptive step size there, so that every attempt (and a dual pass) takes the
    /// same steps for the same state.
    h_adapt: f64,
    iterations: usize,
    /// Largest hole error of the previous attempt (m).
    last_error: f64,
    /// Local iteration matrix (`L x L`) and the previous attempt's error and step.
    h: [f64; MAX_LOCAL * MAX_LOCAL],
    prev_err: [f64; MAX_LOCAL],
    prev_step: [f64; MAX_LOCAL],
}

/// Largest number of local directions (3 per condensed cable).
const MAX_LOCAL: usize = 3 * super::plan::MAX_CONDENSED_CABLES;

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
    let mut check: Option<Checkpoint<T>> = None;
    let mut resume: Option<usize> = None;
    let mut i = 0;
    'intervals: while i < plan.intervals.len() {
        let iv = &plan.intervals[i];
        let c = plan.coeffs_for(iv, load_scale);
        let first_event = match resume.take() {
            Some(e) => e,
            None => {
                if let Some(r) = rec.as_deref_mut() {
                    push_sample(r, iv.s0, &y, &c);
                }
                match plan.integrator {
                    crate::settings::Integrator::Rk4 { .. } => {
                        let h = (iv.s1 - iv.s0) / iv.steps as f64;
                        for k in 0..iv.steps {
                            y = rk4_step(&y, h, &c);
                            buf.rhs_evals += 4;
                            if T::DIRS > 0
                                && buf.watch
                                && buf.conjugate_at.is_none()
                                && wrench_det(plan, &y) <= 0.0
                            {
                                buf.conjugate_at = Some(iv.s0 + h * (k + 1) as f64);
                            }
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
                                if T::DIRS > 0
                                    && buf.watch
                                    && buf.conjugate_at.is_none()
                                    && wrench_det(plan, &y) <= 0.0
                                {
                                    buf.conjugate_at = Some(s + h);
                                }
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
                iv.events.start
            }
        };
        for e in first_event..iv.events.end {
            if let (true, Event::Guide(g)) = (plan.condensed, plan.events[e]) {
                if let Some(ck) = check.as_mut().filter(|ck| ck.g + 1 == g) {
                    if T::DIRS > 0 {
                        fold_segment(plan, buf, &mut y, ck.g);
                    } else if !settle_segment(plan, buf, &y, ck) {
                        if ck.iterations > MAX_LOCAL_ITERATIONS {
                            return Err(PassError::Coupling(iv.s1));
                        }
                        // re-integrate the segment with the updated next holes
                        buf.retries += 1;
                        y = ck.y;
                        h_adapt = ck.h_adapt;
                        if let Some(r) = rec.as_deref_mut() {
                            r.samples.truncate(ck.samples);
                        }
                        i = ck.iv;
                        resume = Some(ck.ev);
                        continue 'intervals;
                    }
                    check = None;
                }
                if !plan.pending[g].is_empty() && check.as_ref().is_none_or(|ck| ck.g != g) {
                    if T::DIRS == 0 {
                        transport_next(plan, buf, &y, g);
                    }
                    check = Some(Checkpoint {
                        g,
                        iv: i,
                        ev: e,
                        y,
                        samples: rec.as_deref().map_or(0, |r| r.samples.len()),
                        h_adapt,
                        iterations: 0,
                        last_error: f64::INFINITY,
                        h: [0.0; MAX_LOCAL * MAX_LOCAL],
                        prev_err: [0.0; MAX_LOCAL],
                        prev_step: [0.0; MAX_LOCAL],
                    });
                }
            }
            apply_event(
                plan,
                plan.events[e],
                &mut y,
                buf,
                load_scale,
                rec.as_deref_mut(),
            );
        }
        i += 1;
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
                // the cable pulls the disk along both straight chords (thesis 3.8.1
                // routing); with friction each chord has its own share of the
                // actuator's tension (capstan factors, `crate::tendons::friction`)
                let (t, t_next) = if k + 1 < c.len {
                    (t.scale(c.factor[k]), t.scale(c.factor[k + 1]))
                } else {
                    (t.scale(c.factor[k]), t)
                };
                let mut f = unit(prev - p).map(|x| x * t);
                if k + 1 < c.len && plan.condensed {
                    let mut next = v3::<T>(&buf.next[j][k]);
                    if T::DIRS > 0 {
                        // local directions of this segment (folded at the next disk)
                        let pos = plan.pending[g].iter().position(|&(jj, _)| jj == j);
                        let base = T::DIRS - plan.max_local + 3 * pos.unwrap_or(0);
                        for a in 0..3 {
                            next[a].eps_mut()[base + a] = 1.0;
                        }
                    }
                    f += unit(next - p).map(|x| x * t_next);
                } else if k + 1 < c.len {
                    if let Some(u) = c.unknowns {
                        let i0 = u + 3 * k;
                        let next = Vector3::new(buf.x[i0], buf.x[i0 + 1], buf.x[i0 + 2])
                            .map(|x| x.scale(ls));
                        f += unit(next - p).map(|x| x * t_next);
                    }
                }
                y.n -= f;
                y.m -= arm.cross(&f);
            }
        }
    }
}

/// Computed position of hole `k + 1` of cable `j` at the current disk.
#[inline]
fn next_hole<T: Real>(plan: &Plan, y: &State<T>, j: usize, k: usize) -> Vector3<T> {
    y.r + y.rot * v3::<T>(&plan.cables[j].hole_local[k + 1])
}

/// `f64` pass reaching guide `g`: move the assumed next holes rigidly with the disk
/// from where they were last settled (`q <- r + R R_a^T (q - r_a)`), so that only
/// the segment's change of shape is left for the local iteration.
fn transport_next<T: Real>(plan: &Plan, buf: &mut PassBuf<T>, y: &State<T>, g: usize) {
    let (r, rot) = (y.r.map(|x| x.re()), y.rot.map(|x| x.re()));
    let (ra, rota) = buf.anchor[g];
    let map = rot * rota.transpose();
    for &(j, k) in &plan.pending[g] {
        let q = &mut buf.next[j][k];
        *q = r + map * (*q - ra);
    }
    buf.anchor[g] = (r, rot);
}

/// `f64` pass at the disk after `ck.g`: compare the computed holes with the assumed
/// ones; `true` when they agree, else update the assumed ones (Newton with the
/// sweep's `M`, or the plain fixed point) and count the iteration.
fn settle_segment<T: Real>(
    plan: &Plan,
    buf: &mut PassBuf<T>,
    y: &State<T>,
    ck: &mut Checkpoint<T>,
) -> bool {
    let pend = &plan.pending[ck.g];
    let l = 3 * pend.len();
    let mut err = [0.0; 3 * super::plan::MAX_CONDENSED_CABLES];
    let mut worst = 0.0f64;
    for (i, &(j, k)) in pend.iter().enumerate() {
        let p = next_hole(plan, y, j, k).map(|x| x.re());
        for a in 0..3 {
            err[3 * i + a] = p[a] - buf.next[j][k][a];
            worst = worst.max(err[3 * i + a].abs());
        }
    }
    // round-off: Newton with the sweep's M converges quadratically, so an error that
    // stops shrinking is the floor; from the plain fixed point the secant updates
    // start slowly, so that gets a floor 100x lower
    let floor = if buf.mlin_valid {
        LOCAL_FLOOR
    } else {
        1e-2 * LOCAL_FLOOR
    };
    let stagnated = worst <= floor * plan.length && worst > 0.5 * ck.last_error;
    if worst <= buf.local_tol * plan.length || stagnated {
        return true;
    }
    ck.last_error = worst;
    // H approximates -(dg/dq)^-1 for g(q) = p(q) - q: the sweep's (I - A)^-1, or I
    // (the plain fixed point) before any sweep, improved by Broyden's inverse update
    // from the last attempt's secant (dg dq: observed change of g over step dq),
    // H <- H - (dq + H dg) dg^T / (dg^T dg), so a stale M or strong coupling near
    // doubling back still converges superlinearly.
    if ck.iterations == 0 {
        for r in 0..l {
            for c in 0..l {
                ck.h[r * l + c] = if buf.mlin_valid {
                    buf.mlin[ck.g][r * l + c]
                } else if r == c {
                    1.0
                } else {
                    0.0
                };
            }
        }
    } else {
        let mut dg = [0.0; 3 * super::plan::MAX_CONDENSED_CABLES];
        let mut dd = 0.0;
        for r in 0..l {
            dg[r] = err[r] - ck.prev_err[r];
            dd += dg[r] * dg[r];
        }
        if dd > 0.0 {
            for r in 0..l {
                let hdg: f64 = (0..l).map(|c| ck.h[r * l + c] * dg[c]).sum();
                let u = (ck.prev_step[r] + hdg) / dd;
                for (hc, dgc) in ck.h[r * l..(r + 1) * l].iter_mut().zip(&dg[..l]) {
                    *hc -= u * dgc;
                }
            }
        }
    }
    for (i, &(j, k)) in pend.iter().enumerate() {
        for a in 0..3 {
            let r = 3 * i + a;
            let step: f64 = (0..l).map(|c| ck.h[r * l + c] * err[c]).sum();
            ck.prev_step[r] = step;
            ck.prev_err[r] = err[r];
            buf.next[j][k][a] += step;
        }
    }
    ck.iterations += 1;
    false
}

/// Dual pass at the disk after `g`: with `a = dp/dz` (outer directions) and
/// `A = dp/dq` (the segment's local directions) read off the computed holes, the
/// consistent `dq/dz = (I - A)^-1 a` is folded into the state, which then carries
/// exact outer derivatives only. Also stores `M = (I - A)^-1` for `f64` passes.
fn fold_segment<T: Real>(plan: &Plan, buf: &mut PassBuf<T>, y: &mut State<T>, g: usize) {
    let pend = &plan.pending[g];
    let l = 3 * pend.len();
    let nout = T::DIRS - plan.max_local;
    let w = nout + l;
    let (mat, rhs) = buf.lin.split_at_mut(plan.max_local * plan.max_local);
    // (I - A) into mat (l x l), [a | I] into rhs (l x w)
    for (i, &(j, k)) in pend.iter().enumerate() {
        let p = next_hole(plan, y, j, k);
        for a in 0..3 {
            let r = 3 * i + a;
            let e = p[a].eps();
            for c in 0..l {
                mat[r * l + c] = if r == c { 1.0 } else { 0.0 } - e[nout + c];
                rhs[r * w + nout + c] = if r == c { 1.0 } else { 0.0 };
            }
            rhs[r * w..r * w + nout].copy_from_slice(&e[..nout]);
        }
    }
    if !solve_small(&mut mat[..l * l], l, &mut rhs[..l * w], w) {
        // singular segment map: leave the local parts unfolded (the Jacobian is then
        // inexact, which the outer Newton's line search tolerates) and drop M
        buf.mlin_valid = false;
        return;
    }
    let m = &mut buf.mlin[g];
    for r in 0..l {
        m[r * l..(r + 1) * l].copy_from_slice(&rhs[r * w + nout..(r + 1) * w]);
    }
    buf.mlin_valid = true;
    let fold = |z: &mut T| {
        let e = z.eps_mut();
        for c in 0..l {
            let lc = e[nout + c];
            if lc != 0.0 {
                for o in 0..nout {
                    e[o] += lc * rhs[c * w + o];
                }
            }
            e[nout + c] = 0.0;
        }
    };
    y.r.iter_mut().for_each(fold);
    y.rot.iter_mut().for_each(fold);
    y.n.iter_mut().for_each(fold);
    y.m.iter_mut().for_each(fold);
}

/// Determinant of `d(n, m)/d(n0, m0)` (6 x 6), or of `dm/dm0` (3 x 3) when `n(0)` is
/// in closed form, from the first derivative directions of a dual state seeded along
/// the base wrench. It is positive at the base; a zero crossing along the rod is a
/// conjugate point (Jacobi's condition), past which the equilibrium is not a minimum
/// of the potential energy of the clamped-free rod under dead loads.
fn wrench_det<T: Real>(plan: &Plan, y: &State<T>) -> f64 {
    let k = if plan.closed_form { 3 } else { 6 };
    let mut a = [0.0; 36];
    for c in 0..k {
        for r in 0..3 {
            if k == 3 {
                a[r * 3 + c] = y.m[r].eps()[c];
            } else {
                a[r * 6 + c] = y.n[r].eps()[c];
                a[(r + 3) * 6 + c] = y.m[r].eps()[c];
            }
        }
    }
    det_small(&mut a[..k * k], k)
}

/// Determinant by Gaussian elimination with partial pivoting (destroys `a`).
fn det_small(a: &mut [f64], n: usize) -> f64 {
    let mut det = 1.0;
    for col in 0..n {
        let piv = (col..n)
            .max_by(|&x, &y| a[x * n + col].abs().total_cmp(&a[y * n + col].abs()))
            .unwrap_or(col);
        if a[piv * n + col] == 0.0 {
            return 0.0;
        }
        if piv != col {
            for c in 0..n {
                a.swap(piv * n + c, col * n + c);
            }
            det = -det;
        }
        let d = a[col * n + col];
        det *= d;
        for r in col + 1..n {
            let f = a[r * n + col] / d;
            for c in col..n {
                a[r * n + c] -= f * a[col * n + c];
            }
        }
    }
    det
}

/// Solve `a x = b` in place (`a` is `n x n`, `b` is `n x w`, row-major) by Gaussian
/// elimination with partial pivoting; `false` when `a` is singular.
fn solve_small(a: &mut [f64], n: usize, b: &mut [f64], w: usize) -> bool {
    for col in 0..n {
        let piv = (col..n)
            .max_by(|&x, &y| a[x * n + col].abs().total_cmp(&a[y * n + col].abs()))
            .unwrap_or(col);
        if a[piv * n + col].abs() < 1e-14 {
            return false;
        }
        if piv != col {
            for c in 0..n {
                a.swap(piv * n + c, col * n + c);
            }
            for c in 0..w {
                b.swap(piv * w + c, col * w + c);
            }
        }
        let inv = 1.0 / a[col * n + col];
        for r in col + 1..n {
            let f = a[r * n + col] * inv;
            if f != 0.0 {
                for c in col..n {
                    a[r * n + c] -= f * a[col * n + c];
                }
                for c in 0..w {
                    b[r * w + c] -= f * b[col * w + c];
                }
            }
        }
    }
    for col in (0..n).rev() {
        let inv = 1.0 / a[col * n + col];
        for c in 0..w {
            let mut v = b[col * w + c];
            for k in col + 1..n {
                v -= a[col * n + k] * b[k * w + c];
            }
            b[col * w + c] = v * inv;
        }
    }
    true
}

trait ZerosT<T: Real> {
    fn zeros_generic_t() -> Vector3<T>;
}
impl<T: Real> ZerosT<T> for Vector3<T> {
    fn zeros_generic_t() -> Vector3<T> {
        Vector3::new(T::zero(), T::zero(), T::zero())
    }
}
