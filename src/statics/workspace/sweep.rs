//! Dual-number sweeps: one forward-mode pass per chunk of directions of
//! `[x; theta]`, and the buffers of the condensed coupling (whose passes carry
//! [`JUMP_DIRS`] local directions besides the outer ones, see `statics::pass`).

use super::super::pass::cable_length;
use super::super::pass::{pass, PassBuf};
use super::super::plan::{Plan, JUMP_DIRS};
use crate::math::Dual;

/// Outer directions of the narrow condensed buffer (the shooting Jacobian, `n <= 6`).
const NARROW: usize = 6;
/// Outer directions of the broad condensed buffer (shooting unknowns and up to nine
/// tensions in one pass: a three-segment, nine-tendon robot's `[x; T]`).
const BROAD: usize = 15;

/// Sweep buffers of the condensed coupling: `NARROW` or `BROAD` outer directions
/// plus the [`JUMP_DIRS`] local ones. A width of `w` outer directions runs in one
/// narrow pass when `w <= 6`, else in passes of 15 (fewer, wider passes cost less:
/// a pass over `Dual<N>` costs about `N + 1` `f64` passes).
#[derive(Clone)]
pub(in crate::statics) struct Wide {
    pub narrow: PassBuf<Dual<{ NARROW + JUMP_DIRS }>>,
    pub broad: PassBuf<Dual<{ BROAD + JUMP_DIRS }>>,
}

impl Wide {
    /// Buffers for a plan with condensed coupling (`None` without).
    pub fn new(plan: &Plan) -> Option<Self> {
        debug_assert!(!plan.condensed || plan.max_local == JUMP_DIRS);
        plan.condensed.then(|| Self {
            narrow: PassBuf::new(plan),
            broad: PassBuf::new(plan),
        })
    }

    /// Set load parameter `k` (as a constant) in both buffers.
    pub fn set_theta(&mut self, k: usize, v: f64) {
        self.narrow.theta[k] = Dual::constant(v);
        self.broad.theta[k] = Dual::constant(v);
    }

    /// Right-hand-side evaluations of both buffers.
    pub fn rhs_evals(&self) -> u64 {
        self.narrow.rhs_evals + self.broad.rhs_evals
    }

    /// Sweeps over `w` outer directions of `[x (; theta)]` from the next-hole
    /// positions `b64` settled at `x` (see [`wide_sweeps`]).
    #[allow(clippy::too_many_arguments)]
    pub fn sweeps(
        &mut self,
        plan: &Plan,
        x: &[f64],
        w: usize,
        with_theta: bool,
        b64: &mut PassBuf<f64>,
        jac_s: &mut [f64],
        jac_m: &mut [f64],
        lam: f64,
    ) -> bool {
        if w <= NARROW {
            wide_sweeps(
                plan,
                x,
                w,
                with_theta,
                &mut self.narrow,
                b64,
                jac_s,
                jac_m,
                lam,
            )
        } else {
            wide_sweeps(
                plan,
                x,
                w,
                with_theta,
                &mut self.broad,
                b64,
                jac_s,
                jac_m,
                lam,
            )
        }
    }
}

/// One dual-number pass seeded along directions `c0..c0+N` of `[x; theta]` (theta only
/// when `with_theta`); writes d(residual) into `jac_s` (`n x w`) and, when `jac_m`
/// is non-empty, d(cable length) into `jac_m` (`c x w`), `w = n (+ p)`.
// Plain data in, two output matrices: a struct for the arguments would add nothing.
#[allow(clippy::too_many_arguments)]
pub(in crate::statics) fn sweep<const N: usize>(
    plan: &Plan,
    x: &[f64],
    c0: usize,
    with_theta: bool,
    buf: &mut PassBuf<Dual<N>>,
    jac_s: &mut [f64],
    jac_m: &mut [f64],
    lam: f64,
) -> bool {
    let n = x.len();
    let p = if with_theta { buf.theta.len() } else { 0 };
    let w = n + p;
    // the last `plan.max_local` directions are the condensed coupling's local ones
    let nout = N - plan.max_local;
    let seed = |i: usize, v: f64| {
        if i >= c0 && i < c0 + nout {
            Dual::variable(v, i - c0)
        } else {
            Dual::constant(v)
        }
    };
    for (i, (xi, bi)) in x.iter().zip(buf.x.iter_mut()).enumerate() {
        *bi = seed(i, *xi);
    }
    for k in 0..p {
        buf.theta[k] = seed(n + k, buf.theta[k].v);
    }
    buf.sweep_c0 = c0;
    buf.sweep_w = w;
    if pass(plan, buf, lam, None).is_err() {
        return false;
    }
    let width = nout.min(w - c0);
    for r in 0..n {
        for k in 0..width {
            jac_s[r * w + c0 + k] = buf.res[r].d[k];
        }
    }
    if !jac_m.is_empty() {
        for j in 0..plan.cables.len() {
            let l = cable_length(plan, buf, j);
            for k in 0..width {
                jac_m[j * w + c0 + k] = l.d[k];
            }
        }
    }
    true
}

/// Condensed coupling: sweeps over `[x (; theta)]` in chunks of `N - JUMP_DIRS` outer directions
/// from the next-hole positions `b64` settled at `x`; hands the segments' matrices `M`
/// back to `b64` and returns the seeded `theta` to constants. `false` if a pass failed.
#[allow(clippy::too_many_arguments)]
fn wide_sweeps<const N: usize>(
    plan: &Plan,
    x: &[f64],
    w: usize,
    with_theta: bool,
    b: &mut PassBuf<Dual<N>>,
    b64: &mut PassBuf<f64>,
    jac_s: &mut [f64],
    jac_m: &mut [f64],
    lam: f64,
) -> bool {
    b.next.clone_from(&b64.next);
    // columns a sweep over `x` alone does not reach (theta) predict nothing
    b.dnext.iter_mut().for_each(|d| d.fill(0.0));
    let ok = (0..w)
        .step_by(N - JUMP_DIRS)
        .all(|c0| sweep(plan, x, c0, with_theta, b, jac_s, jac_m, lam));
    for (t, v) in b.theta.iter_mut().zip(&b64.theta) {
        *t = Dual::constant(*v);
    }
    if ok && b.mlin_valid {
        b64.mlin.clone_from(&b.mlin);
        b64.mlin_terms.clone_from(&b.mlin_terms);
        b64.mlin_valid = true;
        b64.seg_map.clone_from(&b.seg_map);
        b64.seg_map_valid = true;
    }
    if ok {
        b64.dnext.clone_from(&b.dnext);
        b64.dnext_valid = true;
    }
    ok
}

impl crate::math::warm::WarmCopy for Wide {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src, copy: [narrow, broad], keep: []);
    }
}
