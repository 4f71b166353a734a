//! One integration pass from base to tip over any [`Real`] scalar: the shooting
//! residual for given unknowns, and (for `f64`) the recorded shape.
//!
//! Unknowns `x` (scaled): `m(0)/M` when `n(0)` is known in closed form, else
//! `[n(0)/F, m(0)/M]`; then, for each tensioned cable, the assumed world positions
//! `/L` of its holes on route disks 1..K-1 (needed for the chord towards the next,
//! not yet integrated, disk). Residuals: `m(L+)/M` (and `n(L+)/F`), plus computed
//! minus assumed hole positions `/L`. `F = EI/L^2`, `M = EI/L`.
//!
//! With the condensed coupling the hole positions are not unknowns: they are solved
//! inside the pass (module `condensed`).

mod arc;
// The pass's buffers and what it records.
mod buf;
mod condensed;
// The continuous tendons' terms inside the pass (Rucker & Webster 2011).
mod continuous;
// The jumps at section ends, point loads and disks.
mod event;
mod lowrank;
mod small;

use super::plan::{Event, ParamSite, Plan};
use crate::integrate::{dp45_step, rk4_step, ErrScale, State};
use crate::math::Real;
pub(crate) use buf::{PassBuf, PassError, Recording};
pub use buf::{Pose, Sample};
use condensed::{
    fold_segment, jump_block, linear_retry, seed_jump, settle_segment, store_dnext, transport_next,
};
pub(crate) use condensed::{local_next, local_next_len, refine_local_next, set_local_next};
pub(crate) use continuous::cable_length;
use event::{actuator_tension, apply_event, wrench_det};
use nalgebra::{Matrix3, Vector3};

/// Condensed coupling: a segment's next holes must agree to this fraction of the rod
/// length once the outer iteration is close (see [`PassBuf::local_tol`]), or stop
/// improving below `condensed::LOCAL_FLOOR`. The boundary residual moves by about
/// `T L^2 / (EI h)` times a scaled hole error (~100-1000 on the shipped rods), so the
/// outer tolerance of 1e-10..1e-11 needs hole errors near round-off.
pub(crate) const LOCAL_TOL: f64 = 1e-15;
/// Condensed coupling: segment re-integrations allowed per disk.
const MAX_LOCAL_ITERATIONS: usize = 60;
/// Room for a local iteration's Broyden terms: the kept ones plus one update per
/// iteration (an update that finds no room is skipped: `H` stays a valid inverse
/// estimate, only convergence slows).
const SETTLE_TERMS: usize = lowrank::KEPT_TERMS + MAX_LOCAL_ITERATIONS + 2;

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
    // no guide of this pass has corrected its rounds yet (`arc`)
    buf.arc_corr_g = usize::MAX;
    if plan.arc {
        for j in 0..plan.cables.len() {
            buf.arc_act[j] = event::actuator_tension(plan, buf, j, load_scale);
        }
    }
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
    buf.lengths.iter_mut().for_each(|l| *l = T::zero());
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
                // continuously routed tendons over this interval
                let act = continuous::active(plan, buf, iv, load_scale);
                match plan.integrator {
                    crate::settings::Integrator::Rk4 { .. } => {
                        let h = (iv.s1 - iv.s0) / iv.steps as f64;
                        // Two loops, not a branch per step: with the routed step as an
                        // alternative inside one loop, the plain step's state went through
                        // memory (a memcpy per step; `forward_warm` +20 %).
                        match &act {
                            Some(a) => {
                                for k in 0..iv.steps {
                                    let s = iv.s0 + h * k as f64;
                                    y = continuous::rk4_step(
                                        plan,
                                        &y,
                                        s,
                                        h,
                                        &c,
                                        a,
                                        &mut buf.lengths,
                                    );
                                    let s1 = iv.s0 + h * (k + 1) as f64;
                                    after_rk4_step(plan, buf, rec.as_deref_mut(), s1, &y, &c);
                                }
                            }
                            None => {
                                for k in 0..iv.steps {
                                    y = rk4_step(&y, h, &c);
                                    let s1 = iv.s0 + h * (k + 1) as f64;
                                    after_rk4_step(plan, buf, rec.as_deref_mut(), s1, &y, &c);
                                }
                            }
                        }
                    }
                    crate::settings::Integrator::Adaptive { tol, max_steps } => {
                        let mut s = iv.s0;
                        while s < iv.s1 {
                            let h = h_adapt.min(iv.s1 - s);
                            let (out, inc) = match &act {
                                Some(a) => {
                                    continuous::dp45_step(plan, &y, s, h, &c, a, tol, &scale)
                                }
                                None => (
                                    dp45_step(&y, h, &c, tol, &scale),
                                    [T::zero(); continuous::MAX_ROUTED],
                                ),
                            };
                            buf.rhs_evals += 7;
                            steps_taken += 1;
                            if steps_taken > max_steps {
                                return Err(PassError::TooManySteps);
                            }
                            let err = if out.err.is_finite() { out.err } else { 1e10 };
                            if err <= 1.0 {
                                y = out.y;
                                if let Some(a) = &act {
                                    continuous::commit(plan, a, &inc, &mut buf.lengths);
                                }
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
                if act.is_some() {
                    continuous::terminate(plan, buf, iv, &mut y, load_scale);
                }
                iv.events.start
            }
        };
        for e in first_event..iv.events.end {
            if let (true, Event::Guide(g)) = (plan.condensed, plan.events[e]) {
                if let Some(ck) = check.as_mut().filter(|ck| ck.g + 1 == g) {
                    if T::DIRS > 0 {
                        fold_segment(plan, buf, &mut y, ck.g);
                        store_dnext(plan, buf, &y, &ck.y, ck.g);
                    } else if !settle_segment_linear(
                        plan, buf, &mut y, ck, load_scale, &mut rec, &c,
                    ) {
                        if ck.iterations > MAX_LOCAL_ITERATIONS {
                            return Err(PassError::Coupling(iv.s1));
                        }
                        // re-integrate the segment with the updated next holes
                        buf.retries += 1;
                        y = ck.y;
                        // continuous tendons' lengths as they were at the checkpoint
                        buf.lengths.clone_from_slice(&buf.lengths_ck);
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
                    buf.lengths_ck.clone_from_slice(&buf.lengths);
                    check = Some(Checkpoint {
                        g,
                        iv: i,
                        ev: e,
                        y,
                        samples: rec.as_deref().map_or(0, |r| r.samples.len()),
                        h_adapt,
                        iterations: 0,
                        last_error: f64::INFINITY,
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

/// [`settle_segment`], with small local steps carried to the segment's end by
/// [`linear_retry`] (no re-integration) while they last: `true` once the holes agree;
/// `false` with the assumed holes updated for a re-integration of the segment.
fn settle_segment_linear<T: Real>(
    plan: &Plan,
    buf: &mut PassBuf<T>,
    y: &mut State<T>,
    ck: &mut Checkpoint<T>,
    load_scale: f64,
    rec: &mut Option<&mut Recording>,
    c: &crate::integrate::Coeffs,
) -> bool {
    let mut linear = false;
    loop {
        if settle_segment(plan, buf, y, ck) {
            break;
        }
        if ck.iterations > MAX_LOCAL_ITERATIONS || !linear_retry(plan, buf, y, ck, load_scale) {
            return false;
        }
        linear = true;
    }
    if let (true, Some(r)) = (linear, rec.as_deref_mut()) {
        // the sample at this disk holds the state before the correction
        if r.samples.len() > ck.samples {
            if let Some(last) = r.samples.pop() {
                push_sample(r, last.s, y, c);
            }
        }
    }
    true
}

/// Bookkeeping after one RK4 step ending at arc length `s1`: the RHS count, the
/// conjugate-point watch (sign of the wrench Jacobian's determinant) and the
/// recorder's sample.
#[inline(always)]
fn after_rk4_step<T: Real>(
    plan: &Plan,
    buf: &mut PassBuf<T>,
    rec: Option<&mut Recording>,
    s1: f64,
    y: &State<T>,
    c: &crate::integrate::Coeffs,
) {
    buf.rhs_evals += 4;
    if T::DIRS > 0 && buf.watch && buf.conjugate_at.is_none() && wrench_det(plan, y) <= 0.0 {
        buf.conjugate_at = Some(s1);
    }
    if let Some(r) = rec {
        push_sample(r, s1, y, c);
    }
}

fn push_sample<T: Real>(r: &mut Recording, s: f64, y: &State<T>, c: &crate::integrate::Coeffs) {
    r.samples.push(Sample::of(s, y, c));
}

trait ZerosT<T: Real> {
    fn zeros_generic_t() -> Vector3<T>;
}
impl<T: Real> ZerosT<T> for Vector3<T> {
    fn zeros_generic_t() -> Vector3<T> {
        Vector3::new(T::zero(), T::zero(), T::zero())
    }
}
