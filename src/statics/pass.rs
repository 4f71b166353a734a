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
mod condensed;
mod lowrank;
mod small;

use super::continuous;
use super::plan::{Event, ParamSite, Plan, JUMP_DIRS};
use crate::integrate::{dp45_step, rk4_step, strains, ErrScale, State};
use crate::math::{mat_vec_f64, Real};
use condensed::{
    fold_segment, jump_block, linear_retry, seed_jump, settle_segment, store_dnext, transport_next,
};
pub(crate) use condensed::{local_next, local_next_len, refine_local_next, set_local_next};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use small::det_small;

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
    /// Length of each continuously routed cable, integrated along the pass (m).
    pub lengths: Vec<T>,
    /// `lengths` at the condensed coupling's checkpoint.
    lengths_ck: Vec<T>,
    /// Arc coupling: the tension of each cable's chord on from the current disk (N),
    /// computed once per disk for the rounds of `arc::guide_chords`.
    arc_t: Vec<T>,
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
    /// Condensed coupling: per guide, `M = (I - dp/dq)^-1 = I + C K` as its factors
    /// and the Broyden terms kept from the last settle (`L = 3 * pending[g].len()`;
    /// layout in [`lowrank`]), written by dual passes.
    pub mlin: Vec<Vec<f64>>,
    /// Broyden terms kept in `mlin` per guide.
    pub mlin_terms: Vec<usize>,
    /// `mlin` holds matrices from a sweep (else the plain fixed point is used).
    pub mlin_valid: bool,
    /// Condensed coupling: per guide with pending chords, the segment's state map
    /// `d y(next disk) / d j` (`STATE_ROWS x JUMP_DIRS` row-major; rows `r`, `R`
    /// column by column, `n`, `m`) of the jump `j` of `(n, m)` at the guide, written
    /// by dual passes; `f64` passes correct a segment's end state with it instead of
    /// re-integrating the segment after a small local step (`condensed::linear_retry`).
    pub seg_map: Vec<Vec<f64>>,
    /// `seg_map` holds matrices from a sweep.
    pub seg_map_valid: bool,
    /// Dual passes: `B = d(n, m)/dq` of the last disk with pending chords
    /// (`6 x L` row-major).
    jump_b: Vec<f64>,
    /// Local iteration of `f64` passes: the Broyden terms of `H` beyond the sweep's
    /// `C K` (vectors `u_t`, `v_t` of length `L`, row by row; `settle_n` of them),
    /// last error and step.
    settle_u: Vec<f64>,
    settle_v: Vec<f64>,
    settle_n: usize,
    /// Local iteration scratch: error, step, secant and `H` times secant (`4 L`).
    settle_tmp: Vec<f64>,
    prev_err: Vec<f64>,
    prev_step: Vec<f64>,
    /// Condensed coupling: pose of each guide when its `next` holes were last
    /// settled (`f64` passes); a new pass carries `next` along rigidly from it.
    pub anchor: Vec<(Vector3<f64>, Matrix3<f64>)>,
    /// Condensed coupling: per guide, `D = d q_local / d z` of its pending next holes
    /// in the guide's frame (`q_local = R_g^T (q - r_g)`) against the outer unknowns
    /// `z = [x; theta]` (`3 L x W` row-major, `W = n + p`; the theta columns are zero
    /// after a sweep over `x` only), written by dual passes. `f64` passes use it to
    /// predict the next holes to first order in the change of `z` since they were
    /// last settled (see `transport_next`).
    pub dnext: Vec<Vec<f64>>,
    /// `dnext` holds matrices from a sweep.
    pub dnext_valid: bool,
    /// `f64` passes: per guide, `z` at which its `next` holes were last settled.
    z_anchor: Vec<Vec<f64>>,
    /// `f64` passes: `z - z_anchor` of the guide being transported (scratch).
    dz: Vec<f64>,
    /// Dual passes: the first outer direction this pass is seeded along and the
    /// width `W` of the full sweep (set by `sweep`).
    pub sweep_c0: usize,
    pub sweep_w: usize,
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
            lengths: vec![T::zero(); plan.cables.len()],
            lengths_ck: vec![T::zero(); plan.cables.len()],
            arc_t: vec![T::zero(); if plan.arc { plan.cables.len() } else { 0 }],
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
                .map(|p| vec![0.0; lowrank::stored_len(3 * p.len())])
                .collect(),
            mlin_terms: vec![0; plan.pending.len()],
            mlin_valid: false,
            seg_map: plan
                .pending
                .iter()
                .map(|p| {
                    if p.is_empty() {
                        Vec::new()
                    } else {
                        vec![0.0; condensed::STATE_ROWS * JUMP_DIRS]
                    }
                })
                .collect(),
            seg_map_valid: false,
            anchor: vec![(Vector3::zeros(), Matrix3::identity()); plan.pending.len()],
            dnext: plan
                .pending
                .iter()
                .map(|p| vec![0.0; 3 * p.len() * (plan.n_unknowns + plan.params.len())])
                .collect(),
            dnext_valid: false,
            z_anchor: vec![Vec::new(); plan.pending.len()],
            dz: vec![0.0; plan.n_unknowns + plan.params.len()],
            sweep_c0: 0,
            sweep_w: 0,
            lin: vec![0.0; 36 + JUMP_DIRS * (T::DIRS + 2 * plan.max_pending_dirs)],
            jump_b: vec![0.0; JUMP_DIRS * plan.max_pending_dirs],
            settle_u: vec![0.0; SETTLE_TERMS * plan.max_pending_dirs],
            settle_v: vec![0.0; SETTLE_TERMS * plan.max_pending_dirs],
            settle_n: 0,
            settle_tmp: vec![0.0; 4 * plan.max_pending_dirs],
            prev_err: vec![0.0; plan.max_pending_dirs],
            prev_step: vec![0.0; plan.max_pending_dirs],
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
                        // memory (a memcpy per step; `forward_warm` +20 %, session 7).
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
                (
                    mat_vec_f64(&y.rot, &p.force),
                    mat_vec_f64(&y.rot, &p.torque),
                )
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
            if plan.arc {
                arc::guide_chords(plan, g, y, buf, load_scale);
                return;
            }
            for &(j, k) in &plan.guide_cables[g] {
                let c = &plan.cables[j];
                let arm = mat_vec_f64(&y.rot, &c.hole_local[k]);
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
                let t = actuator_tension(plan, buf, j, load_scale);
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
                    let next = v3::<T>(&buf.next[j][k]);
                    if T::DIRS > 0 {
                        // this chord's share of B = d(n, m)/dq (folded at the next disk)
                        let pos = plan.pending[g].iter().position(|&(jj, _)| jj == j);
                        let chord = buf.next[j][k] - p.map(|x| x.re());
                        let l = 3 * plan.pending[g].len();
                        let (arm_re, t_re) = (arm.map(|x| x.re()), t_next.re());
                        jump_block(buf, l, pos.unwrap_or(0), chord, arm_re, t_re);
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
            if T::DIRS > 0 && plan.condensed && !plan.pending[g].is_empty() {
                seed_jump(y);
            }
        }
    }
}

/// Tension of cable `j` at its actuator (N) at `load_scale`: the given value plus its
/// load parameter, if any (the chords' shares follow from the capstan factors).
#[inline]
fn actuator_tension<T: Real>(plan: &Plan, buf: &PassBuf<T>, j: usize, load_scale: f64) -> T {
    let mut t = T::cst(plan.cables[j].tension);
    if let Some(k) = plan.tension_param[j] {
        t += buf.theta[k];
    }
    t.scale(load_scale)
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

trait ZerosT<T: Real> {
    fn zeros_generic_t() -> Vector3<T>;
}
impl<T: Real> ZerosT<T> for Vector3<T> {
    fn zeros_generic_t() -> Vector3<T> {
        Vector3::new(T::zero(), T::zero(), T::zero())
    }
}
