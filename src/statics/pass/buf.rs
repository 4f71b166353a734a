//! The buffers of a pass ([`PassBuf`], sized once per plan) and what a pass records
//! ([`Recording`]: samples, disk and section-end poses).

use super::{condensed, lowrank, LOCAL_TOL, SETTLE_TERMS};
use crate::integrate::{strains, Coeffs, State};
use crate::math::Real;
#[cfg(doc)]
use crate::statics::plan::ParamSite;
use crate::statics::plan::{Plan, JUMP_DIRS};
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

impl Pose {
    /// The pose of a pass's state `y` (its values, without derivatives).
    pub(crate) fn of<T: Real>(y: &State<T>) -> Self {
        let v = y.value();
        Self {
            position: v.r,
            rotation: v.rot,
        }
    }
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

impl Sample {
    /// The sample at arc length `s` of a pass's state `y`, with the strains of the
    /// section coefficients `c`.
    pub(crate) fn of<T: Real>(s: f64, y: &State<T>, c: &Coeffs) -> Self {
        let v = y.value();
        let (vv, u) = strains(&v, c);
        Self {
            s,
            r: v.r,
            rotation: v.rot,
            n: v.n,
            m: v.m,
            u,
            v: vv,
        }
    }
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
    pub(in crate::statics::pass) lengths_ck: Vec<T>,
    /// Arc coupling: the tension of each cable's chord on from the current disk (N),
    /// computed once per disk for the rounds of `arc::guide_chords`.
    pub(in crate::statics::pass) arc_t: Vec<T>,
    /// Arc coupling: each cable's actuator tension (N) for this pass
    /// (`actuator_tension` at the pass's load scale), set at the pass's start so
    /// that a disk reads it instead of assembling it for every cable through it.
    pub(in crate::statics::pass) arc_act: Vec<T>,
    /// Arc coupling: what the rounds of the last two guides of this pass changed of
    /// their first guess (chords on, force and moment in each guide's frame), newest
    /// first, and the guide of the newest (`usize::MAX`: none yet).
    pub(in crate::statics::pass) arc_corr: [(Vector3<T>, Vector3<T>); 2],
    pub(in crate::statics::pass) arc_corr_g: usize,
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
    pub(in crate::statics::pass) jump_b: Vec<f64>,
    /// Local iteration of `f64` passes: the Broyden terms of `H` beyond the sweep's
    /// `C K` (vectors `u_t`, `v_t` of length `L`, row by row; `settle_n` of them),
    /// last error and step.
    pub(in crate::statics::pass) settle_u: Vec<f64>,
    pub(in crate::statics::pass) settle_v: Vec<f64>,
    pub(in crate::statics::pass) settle_n: usize,
    /// Local iteration scratch: error, step, secant and `H` times secant (`4 L`).
    pub(in crate::statics::pass) settle_tmp: Vec<f64>,
    pub(in crate::statics::pass) prev_err: Vec<f64>,
    pub(in crate::statics::pass) prev_step: Vec<f64>,
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
    pub(in crate::statics::pass) z_anchor: Vec<Vec<f64>>,
    /// `f64` passes: `z - z_anchor` of the guide being transported (scratch).
    pub(in crate::statics::pass) dz: Vec<f64>,
    /// Dual passes: the first outer direction this pass is seeded along and the
    /// width `W` of the full sweep (set by `sweep`).
    pub sweep_c0: usize,
    pub sweep_w: usize,
    /// Scratch for the per-segment linear solve of a dual pass.
    pub(in crate::statics::pass) lin: Vec<f64>,
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
            arc_act: vec![T::zero(); if plan.arc { plan.cables.len() } else { 0 }],
            arc_corr: [(z, z); 2],
            arc_corr_g: usize::MAX,
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

crate::math::warm::warm_by_copy!(Pose, Sample);

impl crate::math::warm::WarmCopy for Recording {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src, copy: [samples, guides, section_tips], keep: []);
    }
}

impl<T: Real + crate::math::warm::WarmCopy> crate::math::warm::WarmCopy for PassBuf<T> {
    /// Everything, except the hole positions of a dual (sweep) buffer: a pass writes
    /// each disk's holes before anything reads them, and in a sweep buffer (`T` wider
    /// than `f64`) they are most of the buffer (nine cables through dozens of disks
    /// with tens of derivative directions each), so copying them was most of the
    /// rollback's cost. The `f64` buffer's holes are the solution's (read after the
    /// solve) and are copied.
    fn warm_copy_from(&mut self, src: &Self) {
        if std::mem::size_of::<T>() == std::mem::size_of::<f64>()
            || self.holes.len() != src.holes.len()
        {
            crate::math::warm::WarmCopy::warm_copy_from(&mut self.holes, &src.holes);
        }
        crate::math::warm::warm_fields!(self, src, copy: [
            x, theta, res, lengths, lengths_ck, arc_t, arc_act, arc_corr, arc_corr_g,
            rhs_evals, retries, local_tol, next, mlin, mlin_terms, mlin_valid, seg_map,
            seg_map_valid, jump_b, settle_u, settle_v, settle_n, settle_tmp, prev_err,
            prev_step, anchor, dnext, dnext_valid, z_anchor, dz, sweep_c0, sweep_w, lin,
            watch, conjugate_at,
        ], keep: [holes]);
    }
}

impl<T: Real + crate::math::warm::WarmCopy> PassBuf<T> {
    /// The rollback's copy of a buffer under a coupling that is not `condensed`
    /// (`Workspace`'s `WarmCopy`): what a later pass or sweep reads of it. The
    /// condensed coupling's carried state (next holes, their anchors and
    /// predictors, the segments' matrices, the settle's Broyden terms) is never read
    /// then (`plan.condensed` guards every use), and neither is a dual buffer's
    /// scratch: a sweep seeds `x`, and a pass writes its residual, holes, lengths
    /// and arc-coupling terms before it reads them. Left out, those were most of the
    /// copy (three dual buffers of `Dual<3>`, `Dual<6>` and `Dual<15>`, ~30 KB of
    /// ~45 KB on the FTDCR v4 scene). Copied: the load parameters (a sweep reads
    /// their values), the counters, and for the `f64` buffer (`solution`) the
    /// evaluated point, its residual, holes and lengths, which the accessors read
    /// after a rollback.
    pub(crate) fn warm_copy_uncondensed(&mut self, src: &Self, solution: bool) {
        use crate::math::warm::WarmCopy;
        if solution {
            crate::math::warm::warm_fields!(self, src, copy: [
                x, theta, res, holes, lengths, rhs_evals, retries, local_tol,
            ], keep: [
                lengths_ck, arc_t, arc_act, arc_corr, arc_corr_g, next, mlin, mlin_terms,
                mlin_valid, seg_map, seg_map_valid, jump_b, settle_u, settle_v, settle_n,
                settle_tmp, prev_err, prev_step, anchor, dnext, dnext_valid, z_anchor, dz,
                sweep_c0, sweep_w, lin, watch, conjugate_at,
            ]);
        } else {
            self.theta.warm_copy_from(&src.theta);
            self.rhs_evals = src.rhs_evals;
            self.retries = src.retries;
        }
    }

    /// Debug builds: fill what [`PassBuf::warm_copy_uncondensed`] leaves out with
    /// NaN after a rollback, so that a test whose results depend on it fails (the
    /// bit-identical rows of `tests/rollback.rs`).
    pub(crate) fn poison_uncopied(&mut self, solution: bool) {
        let nan = T::cst(f64::NAN);
        let v = Vector3::new(nan, nan, nan);
        let v64 = Vector3::repeat(f64::NAN);
        if !solution {
            self.x.fill(nan);
            self.res.fill(nan);
            self.holes.iter_mut().for_each(|h| h.fill(v));
            self.lengths.fill(nan);
        }
        self.lengths_ck.fill(nan);
        self.arc_t.fill(nan);
        self.arc_act.fill(nan);
        self.arc_corr = [(v, v); 2];
        self.next.iter_mut().for_each(|h| h.fill(v64));
        self.mlin.iter_mut().for_each(|m| m.fill(f64::NAN));
        self.seg_map.iter_mut().for_each(|m| m.fill(f64::NAN));
        self.dnext.iter_mut().for_each(|m| m.fill(f64::NAN));
        self.z_anchor.iter_mut().for_each(|m| m.fill(f64::NAN));
        for v in [
            &mut self.jump_b,
            &mut self.settle_u,
            &mut self.settle_v,
            &mut self.settle_tmp,
            &mut self.prev_err,
            &mut self.prev_step,
            &mut self.dz,
            &mut self.lin,
        ] {
            v.fill(f64::NAN);
        }
        self.anchor
            .iter_mut()
            .for_each(|a| *a = (v64, Matrix3::repeat(f64::NAN)));
    }
}
