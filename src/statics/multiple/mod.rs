//! Multiple shooting for large loads: the rod's state at `K` nodes along the rod as
//! unknowns, continuity residuals between consecutive intervals, a Newton iteration
//! with the exact (dual-number) Jacobian factored by a banded LU, and a load
//! continuation from rest with step control and branch checks.
//!
//! **Why.** Single shooting (`statics::pass`) integrates base to tip; under a tensile
//! load `P` the map from the base moment to the tip grows like `exp(sqrt(P L^2/EI))`
//! (the decay length of bending is `sqrt(EI/P)`), past `1e14` near `P L^2/EI = 200`:
//! the residual stalls and Newton returns `unstable` or `stalled` from about 50 on.
//! Shooting over intervals of about one decay length each keeps every interval's map
//! near `e` ([`intervals`]).
//!
//! **Why multiple shooting and not collocation.** Both give a banded system. We chose
//! multiple shooting because it reuses, unchanged, the integrators, the event handling
//! and the dual-number right-hand side of single shooting (thesis eqs. 2.3-2.13,
//! `crate::integrate::rhs`), so at a load where both converge they solve the same
//! discrete equations when the steps agree, and the step control of the adaptive
//! integrator keeps working; a collocation scheme would be a second discretisation to
//! validate. Measured (`benches/reach.rs`, 2 shared cores): a cold solve at
//! `P L^2/EI = 1000` in 6.2 ms (285 unknowns, 7 continuation steps, 10 Jacobians), a
//! warm one in 0.42 ms; the tip within 3.5e-8 L of the elastica
//! (`tests/reach_elastica.rs`). Collocation was not built, so the choice rests on
//! the reuse argument above and on these figures meeting the 20 ms target, not on a
//! measured comparison.
//!
//! **Unknowns** (scaled, `F = EI/L^2`, `M = EI/L`). Node 0 (the base, `r(0)`, `R(0)`
//! given): `n(0)/F`, `m(0)/M` (6). Node `k >= 1`: a rotation increment `theta`
//! (`R_k <- R_k exp(theta^)`, folded into `R_k` after every step, so the Jacobian is
//! taken at `theta = 0`), `n/F`, `m/M` (9). Positions are not unknowns: with point
//! forces and torques (world or body), gravity and passive cables `r` does not enter
//! the equations of `R`, `n`, `m` (eq. 2.3 only feeds eq. 2.11 through `r'`), so each
//! node's `r` is the previous interval's end, exactly. Tensioned cables' chords read
//! the disks' positions: then a node starts at every cable disk and `r/L` is a node
//! unknown too (12), with a position continuity residual ([`cables`]).
//!
//! **Residuals.** Interval `k < K - 1`: `vee(skew(R_{k+1}^T R_end))` (the rotation
//! mismatch, 3), `(n_end - n_{k+1})/F`, `(m_end - m_{k+1})/M`; the last interval:
//! `n(L+)/F`, `m(L+)/M` (free tip, thesis table 2.1). Ordered interval by interval,
//! the Jacobian is block bidiagonal with lower and upper bandwidths 11 and 14
//! (a dense LU of the 285 unknowns at 1000 would cost about `n^3/3 = 7.7e6`
//! multiply-adds per factorisation against `n kl (kl + ku) = 7.8e4` banded; not timed).
//! `d(residual_k)/d(node k)` comes from one `Dual<9>` integration of interval `k`;
//! `d(residual_k)/d(node k + 1)` is `-(tr(E) I - E)/2` for the rotation rows
//! (`E = R_{k+1}^T R_end`, from `vee(W E + E^T W) = (tr E I - E) w`) and `-I` for the
//! others. The banded LU with partial pivoting ([`crate::math::BandedLu`]) solves it
//! in `O(K)`; condensing the blocks into one `6 x 6` system would rebuild the
//! ill-conditioned single-shooting matrix.
//!
//! **Branch checks** ([`continuation`]): the load continuation from rest keeps the sign
//! of `det J` of the discretised problem (its determinant is, up to a fixed sign, that
//! of the condensed base-to-tip map, so a change marks a fold or a bifurcation where a
//! single eigenvalue crosses zero), and after world-fixed loads Jacobi's test runs on
//! the nodes with re-orthonormalised directions (`conjugate_point`).
//!
//! Not handled here: workspaces with load parameters (the estimator's: its
//! sensitivities are single shooting's), continuously routed tendons, and tensioned
//! cables whose routes skip a disk; the workspace keeps single shooting for them.

mod cables;
mod continuation;
mod intervals;
mod newton;
mod output;

pub(crate) use continuation::MultiArgs;

use super::plan::{Event, Plan};
use super::{SolveReport, SolveStatus};
use crate::integrate::State;
use crate::math::BandedLu;
use intervals::Layout;
use nalgebra::Vector3;

/// Load intensity above which a cold solve uses multiple shooting (when the loads are
/// supported). Below it single shooting is faster and well-conditioned: on the track
/// demo its default cold solve holds the branch to 40 (20 at RK4 32 down/up), and a
/// cold multiple-shooting solve costs a continuation from rest.
pub(crate) const MULTI_INTENSITY: f64 = 20.0;
/// Largest load intensity multiple shooting attempts (the layout grows like
/// `sqrt(I)` nodes and steps); above, the single-shooting status stands.
pub(crate) const MULTI_MAX_INTENSITY: f64 = 4096.0;
/// Rows and columns of node `k >= 1`.
const NODE: usize = 9;
/// Rows and columns of the base node and of the tip conditions.
const BASE: usize = 6;
/// Rows and columns of node `k >= 1` with tensioned cables (`theta, n, m, r`).
const NODE_R: usize = 12;
/// Dual directions of an interval's pass with tensioned cables: its own node's
/// [`NODE_R`], then the previous and the next cable disk's pose (`theta, r`, 6 each).
const CABLE_DIRS: usize = NODE_R + 12;
const KL: usize = 11;
const KU: usize = 14;

/// Multiple-shooting state and buffers (sized by the layout, rebuilt when the design
/// intensity changes).
#[derive(Clone)]
pub(crate) struct Multi {
    layout: Option<Layout>,
    /// Node states (`r` of node `k >= 1` is the end of interval `k - 1`).
    nodes: Vec<State<f64>>,
    trial: Vec<State<f64>>,
    /// Continuation: the last accepted point.
    ok: Vec<State<f64>>,
    /// End state of each interval at the last evaluation.
    ends: Vec<State<f64>>,
    res: Vec<f64>,
    res_trial: Vec<f64>,
    dx: Vec<f64>,
    /// Continuation: tangent `dx/dlam` at `ok`, and the summed corrector move.
    tan: Vec<f64>,
    moved: Vec<f64>,
    /// Continuation: the tangent at the accepted point before `ok` (second-order
    /// predictor), and scratch for the tangent at `ok` while a step is tried.
    tan_prev: Vec<f64>,
    tan_ok: Vec<f64>,
    lu: BandedLu,
    lu_valid: bool,
    /// Unknowns per node `k >= 1` ([`NODE`] or [`NODE_R`]).
    width: usize,
    /// Fresh Jacobians of the last Newton run.
    fresh: usize,
    /// Sign of `det J` at the last converged point (NaN: unknown, e.g. after a re-mesh).
    sign: f64,
    /// Recording of the last solve's node states (samples, poses, holes).
    last: intervals::Rec,
    has_solution: bool,
    report: SolveReport,
    rhs_evals: u64,
    jac_evals: u64,
}

impl Multi {
    pub fn new() -> Self {
        Self {
            layout: None,
            nodes: Vec::new(),
            trial: Vec::new(),
            ok: Vec::new(),
            ends: Vec::new(),
            res: Vec::new(),
            res_trial: Vec::new(),
            dx: Vec::new(),
            tan: Vec::new(),
            moved: Vec::new(),
            tan_prev: Vec::new(),
            tan_ok: Vec::new(),
            lu: BandedLu::new(0, KL, KU),
            lu_valid: false,
            width: NODE,
            fresh: 0,
            sign: f64::NAN,
            last: intervals::Rec::default(),
            has_solution: false,
            report: SolveReport {
                status: SolveStatus::NonFinite,
                iterations: 0,
                residual: f64::INFINITY,
                tolerance: 0.0,
                rhs_evals: 0,
                jacobian_evals: 0,
                continuation_steps: 0,
                unknowns: 0,
            },
            rhs_evals: 0,
            jac_evals: 0,
        }
    }

    /// Whether multiple shooting handles the plan: no load parameters (a workspace
    /// with parameters serves the estimator, whose sensitivities and linearisation are
    /// single shooting's), no continuously routed tendon, and tensioned cables only
    /// through consecutive guides strictly inside the rod (a node starts at each of
    /// their disks, whose pose the neighbouring disks' chords read).
    pub fn supports(plan: &Plan) -> bool {
        // continuously routed tendons (`statics::pass::continuous`) change the right-hand
        // side and carry integrated lengths: the intervals here do not model them
        if plan.cables.iter().any(|c| c.routed) || !plan.routed.is_empty() {
            return false;
        }
        if !plan.params.is_empty() {
            return false;
        }
        // the arc coupling's chords point at predicted holes (`pass::arc`); the
        // intervals here have the next disk as a node and would solve the exact
        // routing instead: another model than the single pass's
        if plan.arc {
            return false;
        }
        if !plan.cables.iter().any(|c| c.tensioned) {
            return true;
        }
        // (allocation-free: called by every solve of a workspace)
        let tensioned_disk = |g: usize| {
            plan.guide_cables[g]
                .iter()
                .any(|&(j, _)| plan.cables[j].tensioned)
        };
        // every tensioned cable's route runs through guides g, g + 1, ...
        let consecutive = plan.guide_cables.iter().enumerate().all(|(g, cs)| {
            cs.iter().all(|&(j, k)| {
                !plan.cables[j].tensioned
                    || k == 0
                    || (g > 0 && plan.guide_cables[g - 1].contains(&(j, k - 1)))
            })
        });
        // cable disks past the base, at distinct arc lengths (one per event group)
        let disks_in = |r: std::ops::Range<usize>| {
            plan.events[r]
                .iter()
                .filter(|e| matches!(e, Event::Guide(g) if tensioned_disk(*g)))
                .count()
        };
        consecutive
            && disks_in(plan.start_events.clone()) == 0
            && plan
                .intervals
                .iter()
                .all(|iv| disks_in(iv.events.clone()) <= 1)
    }

    /// The last solve converged here (a warm start exists).
    pub fn has_solution(&self) -> bool {
        self.has_solution
    }

    /// Number of unknowns of the current layout.
    fn n_unknowns(&self) -> usize {
        self.nodes.len().saturating_sub(1) * self.width + BASE
    }

    /// Build the layout for `design` and size the buffers (allocates).
    fn build(&mut self, plan: &Plan, design: f64) {
        let layout = Layout::new(plan, design);
        let k = layout.len();
        let base = State {
            r: plan.base_r,
            rot: plan.base_rot,
            n: Vector3::zeros(),
            m: Vector3::zeros(),
        };
        self.nodes = vec![base; k];
        self.trial = vec![base; k];
        self.ok = vec![base; k];
        self.ends = vec![base; k];
        let w = layout.width;
        let n = (k - 1) * w + BASE;
        self.width = w;
        self.res = vec![0.0; n];
        self.res_trial = vec![0.0; n];
        self.dx = vec![0.0; n];
        self.tan = vec![0.0; n];
        self.moved = vec![0.0; n];
        self.tan_prev = vec![0.0; n];
        self.tan_ok = vec![0.0; n];
        let (kl, ku) = if w == NODE {
            (KL, KU)
        } else {
            band(&layout, w)
        };
        self.lu = BandedLu::new(n, kl, ku);
        self.lu_valid = false;
        self.layout = Some(layout);
    }

    /// The straight rod along the base axis (node states), `n = m = 0`.
    fn straight(&mut self, plan: &Plan) {
        let Some(layout) = self.layout.as_ref() else {
            return;
        };
        let axis = plan.base_rot * Vector3::z();
        for (k, y) in self.nodes.iter_mut().enumerate() {
            y.r = plan.base_r + axis * layout.node_s(k);
            y.rot = plan.base_rot;
            y.n = Vector3::zeros();
            y.m = Vector3::zeros();
        }
    }

    /// Tip position of the last evaluation (m).
    pub fn tip(&self) -> Vector3<f64> {
        self.ends.last().map_or(Vector3::zeros(), |y| y.r)
    }

    /// Tip axis `R(L) e_z` of the current state (world frame).
    pub fn tip_axis(&self) -> Vector3<f64> {
        self.ends
            .last()
            .map_or(Vector3::z(), |y| y.rot.column(2).into_owned())
    }

    /// Base internal force and moment `(n(0), m(0))` of the current state.
    pub fn base_wrench(&self) -> (Vector3<f64>, Vector3<f64>) {
        self.nodes
            .first()
            .map_or((Vector3::zeros(), Vector3::zeros()), |y| (y.n, y.m))
    }
}

/// Column (and residual row) offset of node `k`'s unknowns (`w` per node `k >= 1`).
fn offset(w: usize, k: usize) -> usize {
    if k == 0 {
        0
    } else {
        BASE + w * (k - 1)
    }
}

/// Lower and upper bandwidths of the Jacobian with tensioned cables: interval `i`'s
/// rows (from `w i`) reach its own node, node `i + 1`, and the nodes of the previous
/// and next cable disks of the disk that ends it.
fn band(layout: &Layout, w: usize) -> (usize, usize) {
    let kn = layout.len();
    let (mut kl, mut ku) = (0usize, 0usize);
    for i in 0..kn {
        let rows = (w * i, w * i + if i + 1 < kn { w } else { BASE } - 1);
        let mut lo = offset(w, i);
        let mut hi = if i + 1 < kn {
            offset(w, i + 1) + w - 1
        } else {
            offset(w, i) + if i == 0 { BASE } else { w } - 1
        };
        if let Some(g) = layout.end_disk[i] {
            let prev = g.checked_sub(1).and_then(|p| layout.disk_node[p]);
            if let Some(j) = prev.filter(|&j| j > 0) {
                lo = lo.min(offset(w, j));
            }
            if let Some(j) = layout.disk_node.get(g + 1).copied().flatten() {
                hi = hi.max(offset(w, j) + w - 1);
            }
        }
        kl = kl.max(rows.1.saturating_sub(lo));
        ku = ku.max(hi.saturating_sub(rows.0));
    }
    (kl, ku)
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |a, x| {
        if x.is_nan() {
            f64::INFINITY
        } else {
            a.max(x.abs())
        }
    })
}

fn norm2(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

impl crate::math::warm::WarmCopy for Multi {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src, copy: [
            layout, nodes, trial, ok, ends, res, res_trial, dx, tan, moved, tan_prev, tan_ok,
            lu, lu_valid, width, fresh, sign, last, has_solution, report, rhs_evals, jac_evals,
        ], keep: []);
    }
}
