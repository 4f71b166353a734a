//! The shooting intervals of multiple shooting and the integration of one of them.
//!
//! The plan's intervals (constant ODE coefficients between events) are cut at the
//! node arc lengths `s_k = k L / K` into pieces; node `k` owns the pieces between
//! `s_k` and `s_{k+1}`. Events at a piece's end are applied inside the owning
//! interval, so a node that falls on an event starts just after it.
//!
//! Resolution from the load intensity `I` (`intensity` module, `P L^2/EI` for a tip
//! force): a rod under a large tensile load bends in a boundary layer of width
//! `l = L / sqrt(I)` (the decay length `sqrt(EI/P)` of the linearised equation
//! `EI w'''' = P w''`), and the base-to-tip map grows like `exp(L / l)`. The node count
//! `K = ceil(sqrt(I_d) / NODE_SPAN)` keeps each interval's growth near
//! `exp(NODE_SPAN)`, and RK4 steps are at most `STEP_RES l` long. `I_d` is `I`
//! rounded up to a power of two (at least `MIN_DESIGN`), so the discretisation is a
//! function of that level only: a cold solve and a warm continuation ending at the
//! same load integrate the same intervals and steps.

use crate::integrate::{dp45_step, rk4_step, ErrScale, State};
use crate::math::{mat_vec_f64, Real};
use crate::settings::Integrator;
use crate::statics::pass::{Pose, Recording, Sample};
use crate::statics::plan::{Event, ParamSite, Plan};
use nalgebra::{Matrix3, Vector3};

/// Node span: the length of a shooting interval in boundary-layer widths `l`.
const NODE_SPAN: f64 = 1.0;
/// RK4 step at most this many boundary-layer widths.
pub(super) const STEP_RES: f64 = 0.1;
/// Smallest design intensity (the coarsest layout: 4 intervals).
pub(super) const MIN_DESIGN: f64 = 16.0;

/// A stretch of one plan interval integrated in one go.
#[derive(Clone, Copy, Debug)]
pub(super) struct Piece {
    /// Plan interval.
    pub iv: usize,
    pub s0: f64,
    pub s1: f64,
    /// RK4 steps (unused by the adaptive integrator).
    pub steps: usize,
    /// The plan interval's events are applied at `s1`.
    pub events: bool,
}

/// Node arc lengths and pieces.
#[derive(Clone, Debug)]
pub(super) struct Layout {
    pub pieces: Vec<Piece>,
    /// Pieces of each node's interval.
    pub nodes: Vec<std::ops::Range<usize>>,
    /// The design intensity `I_d` the layout was built for.
    pub design: f64,
    /// Unknowns per node `k >= 1`: 9 (`theta, n, m`), or 12 with tensioned cables
    /// (`theta, n, m, r`: the chords need the disks' positions).
    pub width: usize,
    /// With tensioned cables: per node interval, the cable disk (guide) whose event
    /// ends it, if any.
    pub end_disk: Vec<Option<usize>>,
    /// With tensioned cables: per guide, the node that starts at it (cable disks).
    pub disk_node: Vec<Option<usize>>,
}

/// Poses (position, rotation) of the previous and next cable disks (guides `g - 1`
/// and `g + 1`) of the disk whose event ends an interval: their holes end the chords
/// of the tensioned cables at that disk.
#[derive(Clone, Copy)]
pub(super) struct Nbr<T: Real> {
    pub prev: Option<(Vector3<T>, Matrix3<T>)>,
    pub next: Option<(Vector3<T>, Matrix3<T>)>,
}

/// Arc length of each guide's event (from the plan's intervals; 0 at the start).
pub(super) fn guide_s(plan: &Plan) -> Vec<f64> {
    let mut out = vec![0.0; plan.n_guides];
    for iv in &plan.intervals {
        for e in iv.events.clone() {
            if let Event::Guide(g) = plan.events[e] {
                out[g] = iv.s1;
            }
        }
    }
    out
}

/// Guides that carry a tensioned cable.
pub(super) fn cable_disks(plan: &Plan) -> Vec<bool> {
    let mut out = vec![false; plan.n_guides];
    for (g, cs) in plan.guide_cables.iter().enumerate() {
        out[g] = cs.iter().any(|&(j, _)| plan.cables[j].tensioned);
    }
    out
}

/// Design intensity (power of two, at least [`MIN_DESIGN`]) for intensity `i`.
pub(super) fn design_intensity(i: f64) -> f64 {
    let mut d = MIN_DESIGN;
    while d < i && d < 1e12 {
        d *= 2.0;
    }
    d
}

impl Layout {
    pub fn new(plan: &Plan, design: f64) -> Self {
        let l = plan.length;
        let tol = 1e-9 * l;
        let k = (design.sqrt() / NODE_SPAN).ceil().max(4.0) as usize;
        let h_res = STEP_RES * l / design.sqrt();
        let mut cuts: Vec<f64> = (1..k).map(|j| j as f64 * l / k as f64).collect();
        let cables = plan.cables.iter().any(|c| c.tensioned);
        let gs = guide_s(plan);
        let disks = cable_disks(plan);
        if cables {
            // a node starts at every cable disk (its pose is then a node unknown that
            // the chords of the neighbouring disks read); uniform cuts closer than a
            // quarter interval to a disk are dropped
            let dcuts: Vec<f64> = (0..plan.n_guides)
                .filter(|&g| disks[g] && gs[g] > tol && gs[g] < l - tol)
                .map(|g| gs[g])
                .collect();
            let near = 0.25 * l / k as f64;
            cuts.retain(|c| dcuts.iter().all(|d| (c - d).abs() > near));
            cuts.extend(dcuts);
            cuts.sort_by(f64::total_cmp);
            cuts.dedup_by(|a, b| (*a - *b).abs() <= tol);
        }
        let mut pieces = Vec::new();
        let mut owner = Vec::new();
        for (i, iv) in plan.intervals.iter().enumerate() {
            let h_plan = (iv.s1 - iv.s0) / iv.steps as f64;
            let h = h_plan.min(h_res);
            let mut s0 = iv.s0;
            let inner = cuts
                .iter()
                .copied()
                .filter(|&c| c > iv.s0 + tol && c < iv.s1 - tol);
            for s1 in inner.chain(std::iter::once(iv.s1)) {
                pieces.push(Piece {
                    iv: i,
                    s0,
                    s1,
                    steps: ((s1 - s0) / h).ceil().max(1.0) as usize,
                    events: s1 == iv.s1,
                });
                owner.push(cuts.iter().filter(|&&c| c <= s0 + tol).count());
                s0 = s1;
            }
        }
        let mut nodes: Vec<std::ops::Range<usize>> = Vec::new();
        for (p, &o) in owner.iter().enumerate() {
            if nodes.len() == o + 1 {
                if let Some(r) = nodes.last_mut() {
                    r.end = p + 1;
                }
            } else {
                nodes.push(p..p + 1);
            }
        }
        let mut end_disk = vec![None; nodes.len()];
        let mut disk_node = vec![None; plan.n_guides];
        if cables {
            for (i, r) in nodes.iter().enumerate() {
                let p = &pieces[r.end - 1];
                if !p.events {
                    continue;
                }
                for e in plan.intervals[p.iv].events.clone() {
                    if let Event::Guide(g) = plan.events[e] {
                        if disks[g] {
                            end_disk[i] = Some(g);
                            if i + 1 < nodes.len() {
                                disk_node[g] = Some(i + 1);
                            }
                        }
                    }
                }
            }
        }
        Self {
            pieces,
            nodes,
            design,
            width: if cables { 12 } else { 9 },
            end_disk,
            disk_node,
        }
    }

    /// Number of nodes (shooting intervals).
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Arc length where node `k` starts.
    pub fn node_s(&self, k: usize) -> f64 {
        self.pieces[self.nodes[k].start].s0
    }
}

/// What an `f64` integration records for the solution.
#[derive(Clone, Debug, Default)]
pub(super) struct Rec {
    pub rec: Recording,
    /// Hole positions per cable per route disk (world, m).
    pub holes: Vec<Vec<Vector3<f64>>>,
}

/// Loads that act inside a pass: the load scale and the load parameters.
#[derive(Clone, Copy)]
pub(super) struct LoadCtx<'a> {
    pub lam: f64,
    pub theta: &'a [f64],
}

/// Integrate node `k`'s interval from `y` (thesis eqs. 2.3-2.13 via
/// [`crate::integrate::rhs`]), applying the events at the pieces' ends (and the
/// plan's start events before node 0). `watch(s, y)` sees the state after every step.
/// `Err(s)` when the state is not finite at `s` (or the adaptive step limit is hit).
#[allow(clippy::too_many_arguments)]
pub(super) fn integrate<T: Real>(
    plan: &Plan,
    layout: &Layout,
    k: usize,
    mut y: State<T>,
    ld: LoadCtx,
    nb: Option<&Nbr<T>>,
    rhs_evals: &mut u64,
    mut rec: Option<&mut Rec>,
    watch: &mut dyn FnMut(f64, &State<T>),
) -> Result<State<T>, f64> {
    let ls = plan.length;
    if k == 0 {
        for e in plan.start_events.clone() {
            apply_event(plan, plan.events[e], &mut y, ld, None, rec.as_deref_mut());
        }
    }
    let scale = ErrScale {
        length: ls,
        force: plan.force_scale,
        moment: plan.moment_scale,
    };
    let mut h_adapt = ls / 16.0;
    let mut taken = 0usize;
    for p in &layout.pieces[layout.nodes[k].clone()] {
        let iv = &plan.intervals[p.iv];
        let c = plan.coeffs_for(iv, ld.lam);
        if let Some(r) = rec.as_deref_mut() {
            push_sample(&mut r.rec, p.s0, &y, &c);
        }
        match plan.integrator {
            Integrator::Rk4 { .. } => {
                let h = (p.s1 - p.s0) / p.steps as f64;
                for i in 0..p.steps {
                    y = rk4_step(&y, h, &c);
                    *rhs_evals += 4;
                    let s = p.s0 + h * (i + 1) as f64;
                    watch(s, &y);
                    if let Some(r) = rec.as_deref_mut() {
                        push_sample(&mut r.rec, s, &y, &c);
                    }
                }
            }
            Integrator::Adaptive { tol, max_steps } => {
                let mut s = p.s0;
                while s < p.s1 {
                    let h = h_adapt.min(p.s1 - s);
                    let out = dp45_step(&y, h, &c, tol, &scale);
                    *rhs_evals += 7;
                    taken += 1;
                    if taken > max_steps {
                        return Err(s);
                    }
                    let err = if out.err.is_finite() { out.err } else { 1e10 };
                    if err <= 1.0 {
                        y = out.y;
                        s = if p.s1 - s - h <= 1e-14 * ls {
                            p.s1
                        } else {
                            s + h
                        };
                        watch(s, &y);
                        if let Some(r) = rec.as_deref_mut() {
                            push_sample(&mut r.rec, s, &y, &c);
                        }
                    }
                    let fac = if err == 0.0 {
                        5.0
                    } else {
                        (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
                    };
                    h_adapt = if err <= 1.0 && h < h_adapt {
                        h_adapt.max(h * fac)
                    } else {
                        h * fac
                    };
                    if h_adapt < 1e-14 * ls {
                        return Err(s);
                    }
                }
            }
        }
        if !y.is_finite() {
            return Err(p.s1);
        }
        if p.events {
            for e in iv.events.clone() {
                apply_event(plan, plan.events[e], &mut y, ld, nb, rec.as_deref_mut());
            }
        }
    }
    Ok(y)
}

fn push_sample<T: Real>(r: &mut Recording, s: f64, y: &State<T>, c: &crate::integrate::Coeffs) {
    // a node restarts at the arc length where the previous interval ended
    if r.samples.last().is_some_and(|l| l.s == s) {
        r.samples.pop();
    }
    r.samples.push(Sample::of(s, y, c));
}

#[inline]
fn v3<T: Real>(v: &Vector3<f64>) -> Vector3<T> {
    v.map(T::cst)
}

/// The events of a passive rod (the cable-free part of `statics::pass`): point loads
/// `n+ = n- - F`, `m+ = m- - tau` (thesis 3.5.1, 3.5.3), world or body frame; point
/// guide masses; pose and hole records; the chord forces of tensioned cables at a
/// cable disk (as in `statics::pass`: thesis 3.8.1 routing, each chord pulls the disk
/// along itself, `n+ = n- - f`, `m+ = m- - arm x f`), the neighbouring holes from the
/// poses in `nb`.
fn apply_event<T: Real>(
    plan: &Plan,
    e: Event,
    y: &mut State<T>,
    ld: LoadCtx,
    nb: Option<&Nbr<T>>,
    rec: Option<&mut Rec>,
) {
    match e {
        Event::SectionEnd(k) => {
            if let Some(r) = rec {
                r.rec.section_tips[k] = Pose::of(y);
            }
        }
        Event::Point(i) => {
            let p = &plan.points[i];
            let (mut f, mut tau) = if p.body {
                (
                    mat_vec_f64(&y.rot, &p.force),
                    mat_vec_f64(&y.rot, &p.torque),
                )
            } else {
                (v3::<T>(&p.force), v3::<T>(&p.torque))
            };
            f += v3::<T>(&(plan.gravity * p.mass));
            for &k in &plan.point_params[i] {
                let th = T::cst(ld.theta[k]);
                match plan.params[k] {
                    ParamSite::Force { axis, .. } => f[axis] += th,
                    ParamSite::Torque { axis, .. } => tau[axis] += th,
                    ParamSite::Mass { .. } => f += v3::<T>(&plan.gravity).map(|g| g * th),
                    ParamSite::Tension { .. } => {}
                }
            }
            y.n -= f.map(|x| x.scale(ld.lam));
            y.m -= tau.map(|x| x.scale(ld.lam));
        }
        Event::Guide(g) => {
            if plan.point_guides {
                y.n -= v3::<T>(&(plan.gravity * (plan.guide_mass[g] * ld.lam)));
            }
            if let Some(r) = rec {
                let v = y.value();
                r.rec.guides[g] = Pose::of(y);
                for &(j, k) in &plan.guide_cables[g] {
                    r.holes[j][k] = v.r + v.rot * plan.cables[j].hole_local[k];
                }
            }
            if let Some(nb) = nb {
                chords(plan, g, y, ld.lam, nb);
            }
        }
    }
}

/// The tensioned cables' chord forces at guide `g` (mirrors `statics::pass`, with the
/// holes of the previous and next disks from `nb`; routes run through consecutive
/// guides, [`super::Multi::supports`]).
fn chords<T: Real>(plan: &Plan, g: usize, y: &mut State<T>, lam: f64, nb: &Nbr<T>) {
    for &(j, k) in &plan.guide_cables[g] {
        let c = &plan.cables[j];
        if !c.tensioned {
            continue;
        }
        let arm = mat_vec_f64(&y.rot, &c.hole_local[k]);
        let p = y.r + arm;
        let t = c.tension * lam;
        let prev = if k == 0 {
            v3::<T>(&c.base_hole)
        } else {
            let Some((r, rot)) = nb.prev else { continue };
            r + mat_vec_f64(&rot, &c.hole_local[k - 1])
        };
        let mut f = unit(prev - p).map(|x| x.scale(t * c.factor[k]));
        if k + 1 < c.len {
            if let Some((r, rot)) = nb.next {
                let next = r + mat_vec_f64(&rot, &c.hole_local[k + 1]);
                f += unit(next - p).map(|x| x.scale(t * c.factor[k + 1]));
            }
        }
        y.n -= f;
        y.m -= arm.cross(&f);
    }
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

/// A fresh recording sized for `plan`.
pub(super) fn new_rec(plan: &Plan) -> Rec {
    let pose = Pose {
        position: Vector3::zeros(),
        rotation: Matrix3::identity(),
    };
    Rec {
        rec: Recording {
            samples: Vec::new(),
            guides: vec![pose; plan.n_guides],
            section_tips: vec![pose; plan.n_sections],
        },
        holes: plan
            .cables
            .iter()
            .map(|c| vec![Vector3::zeros(); c.len])
            .collect(),
    }
}

crate::math::warm::warm_by_copy!(Piece);

impl crate::math::warm::WarmCopy for Layout {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src,
            copy: [pieces, nodes, design, width, end_disk, disk_node], keep: []);
    }
}

impl crate::math::warm::WarmCopy for Rec {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src, copy: [rec, holes], keep: []);
    }
}
