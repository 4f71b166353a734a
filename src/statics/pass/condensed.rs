//! Condensed coupling ([`crate::settings::CableCoupling::Condensed`]): the
//! hole positions are not unknowns: at each disk the assumed next-hole positions
//! `q` of the tensioned cables are solved inside the pass so that the next disk's
//! computed holes `p(q)` equal them. An `f64` pass iterates the segment,
//! `q <- q + M (p(q) - q)` with `M = (I - dp/dq)^-1` from the last dual sweep (the
//! plain fixed point `M = I` before any sweep; the map contracts by roughly
//! `T (h^2/6 + rho h/2) / EI` for chord `h` and hole radius `rho`). A dual pass does not
//! iterate. The assumed holes act on the rod only through the jump `j` of `(n, m)`
//! at their disk, `dj = B dq` (`B`, 6 x 3k, from the chord directions), so the pass
//! seeds six local directions on that jump and reads `a = dp/dz` (outer directions)
//! and `C = dp/dj` at the next disk. The consistent `dq = a dz + C B dq` gives the
//! jump's derivative `dj/dz = (I - B C)^-1 B a` (push-through identity: a 6 x 6
//! solve whatever the number `k` of cables), which is folded into the outer
//! directions (the implicit function theorem for the segment), so the outer
//! derivatives are exact; `M = I + C (I - B C)^-1 B` (Woodbury) is handed to the
//! `f64` passes as its factors `C` and `K = (I - B C)^-1 B` (`lowrank`: a rank-6
//! correction of `I` costs `12 L` per product, not `L^2`).

use super::lowrank::{self, KEPT_TERMS};
use super::small::solve_small;
use super::{Checkpoint, PassBuf};
use crate::integrate::State;
use crate::math::{mat_t_vec, mat_vec_f64, Real};
use crate::statics::plan::{Plan, JUMP_DIRS};
use nalgebra::{Matrix3, Vector3};

/// Rows of a segment's state map ([`PassBuf::seg_map`]): `r` (3), `R` (9, column by
/// column), `n` (3), `m` (3).
pub(crate) const STATE_ROWS: usize = 18;

/// Largest local step (fraction of the rod length, any hole coordinate) that an `f64`
/// pass carries to the segment's end through the sweep's state map instead of
/// re-integrating the segment (see [`linear_retry`]). The step after the load-path
/// predictor is about this size. At 1e-11 the map's staleness (a fraction of the
/// step) showed as noise in central differences of the converged poses over a 1e-5
/// relative parameter step: `tests/calibrate_exact_sensitivities.rs` saw 2.2e-4
/// relative disagreement against its 1e-4 (2.6e-6 at 1e-13, as before the change).
pub(super) const LINEAR_STEP: f64 = 1e-13;

/// A segment whose hole error is below this fraction of the rod length and no longer
/// halves per iteration has reached round-off.
pub(super) const LOCAL_FLOOR: f64 = 1e-13;

/// Computed position of hole `k + 1` of cable `j` at the current disk.
#[inline]
pub(super) fn next_hole<T: Real>(plan: &Plan, y: &State<T>, j: usize, k: usize) -> Vector3<T> {
    y.r + mat_vec_f64(&y.rot, &plan.cables[j].hole_local[k + 1])
}

/// `f64` pass reaching guide `g`: move the assumed next holes rigidly with the disk
/// from where they were last settled (`q <- r + R R_a^T (q - r_a)`), so that only
/// the segment's change of shape is left for the local iteration; with a sweep's
/// `D = d q_local/dz` (`dnext`), that change is predicted too, to first order in the
/// change of the outer unknowns since the last settle:
/// `q <- r + R (R_a^T (q - r_a) + D (z - z_a))`. The local iteration then starts
/// from an error second order in that change (plus `D`'s own staleness) instead of
/// first order, and needs fewer re-integrations of the segment.
pub(super) fn transport_next<T: Real>(plan: &Plan, buf: &mut PassBuf<T>, y: &State<T>, g: usize) {
    let (r, rot) = (y.r.map(|x| x.re()), y.rot.map(|x| x.re()));
    let (ra, rota) = buf.anchor[g];
    let n = buf.x.len();
    let w = n + buf.theta.len();
    let za = &buf.z_anchor[g];
    let predict = buf.dnext_valid && za.len() == w && buf.dz.len() >= w;
    if predict {
        // the change of the outer unknowns since the last settle, once per guide
        let (dx, dt) = buf.dz[..w].split_at_mut(n);
        for ((d, x), a) in dx.iter_mut().zip(&buf.x).zip(&za[..n]) {
            *d = x.re() - a;
        }
        for ((d, t), a) in dt.iter_mut().zip(&buf.theta).zip(&za[n..]) {
            *d = t.re() - a;
        }
    }
    let (d, dz) = (&buf.dnext[g], &buf.dz[..w.min(buf.dz.len())]);
    for (i, &(j, k)) in plan.pending[g].iter().enumerate() {
        let q = &mut buf.next[j][k];
        let mut local = rota.transpose() * (*q - ra);
        if predict {
            // the three rows' dot products side by side: three independent chains
            // instead of one dependent chain of additions per row (the same sums in
            // the same order as `iter().sum()`, which starts from -0.0: bit-identical)
            let (r0, rest) = d[3 * i * w..(3 * i + 3) * w].split_at(w);
            let (r1, r2) = rest.split_at(w);
            let mut acc = [-0.0f64; 3];
            for ((&z, (&a0, &a1)), &a2) in dz.iter().zip(r0.iter().zip(r1)).zip(r2) {
                acc[0] += a0 * z;
                acc[1] += a1 * z;
                acc[2] += a2 * z;
            }
            for (l, a) in local.iter_mut().zip(acc) {
                *l += a;
            }
        }
        *q = r + rot * local;
    }
    buf.anchor[g] = (r, rot);
    let za = &mut buf.z_anchor[g];
    za.clear();
    za.extend(buf.x.iter().chain(&buf.theta).map(|v| v.re()));
}

/// Condensed coupling: how many values [`local_next`] writes (3 per pending chord).
pub(crate) fn local_next_len(plan: &Plan) -> usize {
    if plan.condensed {
        3 * plan.pending.iter().map(Vec::len).sum::<usize>()
    } else {
        0
    }
}

/// Condensed coupling: the assumed next holes as last settled, each in the frame of
/// the guide whose chord uses it (`q_local = R_g^T (q - r_g)`, guide by guide), into
/// `out` (length [`local_next_len`]). The warm solve's load-path predictor
/// extrapolates these with the unknowns (`workspace/predict.rs`).
pub(crate) fn local_next(plan: &Plan, buf: &PassBuf<f64>, out: &mut [f64]) {
    let mut o = 0;
    for (g, pend) in plan.pending.iter().enumerate().filter(|_| plan.condensed) {
        let (ra, rota) = buf.anchor[g];
        for &(j, k) in pend {
            let local = rota.transpose() * (buf.next[j][k] - ra);
            out[o..o + 3].copy_from_slice(local.as_slice());
            o += 3;
        }
    }
}

/// Condensed coupling: move the next holes `local` (as [`local_next`] writes them,
/// settled at the unknowns `x`) to first order to the unknowns `x + dx`, with the
/// last sweep's `D = d q_local / d x` (`dnext`); unchanged without a valid sweep.
/// The load-path predictor keeps solutions refined by a chord step (`dx`) and their
/// holes must follow them: holes 1e-11 L off the refined unknowns cost a gap
/// re-integration each where a 1e-13 L step is carried linearly
/// (`tests/continuous_routing.rs`, 40 disks: 0.098 -> 0.305 re-integrations a gap
/// without this).
pub(crate) fn refine_local_next(plan: &Plan, buf: &PassBuf<f64>, dx: &[f64], local: &mut [f64]) {
    let n = buf.x.len();
    let w = n + buf.theta.len();
    if !plan.condensed || !buf.dnext_valid || dx.len() != n {
        return;
    }
    let mut o = 0;
    for (g, pend) in plan.pending.iter().enumerate() {
        let d = &buf.dnext[g];
        if d.len() < 3 * pend.len() * w {
            return;
        }
        for row in d.chunks_exact(w).take(3 * pend.len()) {
            local[o] += row[..n].iter().zip(dx).map(|(a, b)| a * b).sum::<f64>();
            o += 1;
        }
    }
}

/// Condensed coupling: adopt predicted next holes `local` (as [`local_next`] writes
/// them) for unknowns `z = [x; theta]`: the next pass carries them along with each
/// guide's pose and predicts from `z` on (see `transport_next`).
pub(crate) fn set_local_next(plan: &Plan, buf: &mut PassBuf<f64>, local: &[f64], x: &[f64]) {
    let mut o = 0;
    for (g, pend) in plan.pending.iter().enumerate().filter(|_| plan.condensed) {
        let (ra, rota) = buf.anchor[g];
        for &(j, k) in pend {
            buf.next[j][k] = ra + rota * Vector3::new(local[o], local[o + 1], local[o + 2]);
            o += 3;
        }
        if !pend.is_empty() {
            let za = &mut buf.z_anchor[g];
            za.clear();
            za.extend(x.iter().chain(&buf.theta));
        }
    }
}

/// Dual pass at the disk after `g`, after the fold: `D = d q_local/dz` of the pending
/// next holes in guide `g`'s frame (`yg`: the state at guide `g`), columns
/// `sweep_c0..` of this pass's outer directions (see `dnext`).
pub(super) fn store_dnext<T: Real>(
    plan: &Plan,
    buf: &mut PassBuf<T>,
    y: &State<T>,
    yg: &State<T>,
    g: usize,
) {
    let nout = T::DIRS - JUMP_DIRS;
    let (c0, sw) = (buf.sweep_c0, buf.sweep_w);
    // rows have the full width `n + p` whatever this sweep covers
    let w = buf.x.len() + buf.theta.len();
    if sw == 0 || c0 >= sw || sw > w {
        return;
    }
    let width = nout.min(sw - c0);
    let d = &mut buf.dnext[g];
    if d.len() < 3 * plan.pending[g].len() * w {
        return;
    }
    for (i, &(j, k)) in plan.pending[g].iter().enumerate() {
        let local = mat_t_vec(&yg.rot, &(next_hole(plan, y, j, k) - yg.r));
        for a in 0..3 {
            let e = local[a].eps();
            let row = &mut d[(3 * i + a) * w..(3 * i + a + 1) * w];
            row[c0..c0 + width].copy_from_slice(&e[..width]);
        }
    }
}

/// `f64` pass at the disk after `ck.g`: compare the computed holes with the assumed
/// ones; `true` when they agree, else update the assumed ones (Newton with the
/// sweep's `M`, or the plain fixed point) and count the iteration.
pub(super) fn settle_segment<T: Real>(
    plan: &Plan,
    buf: &mut PassBuf<T>,
    y: &State<T>,
    ck: &mut Checkpoint<T>,
) -> bool {
    let pend = &plan.pending[ck.g];
    let l = 3 * pend.len();
    // scratch in the buffer, not stack arrays (their zeroing was a memset per call)
    let err = &mut buf.settle_tmp[..l];
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
        if ck.iterations > 1 && buf.mlin_valid {
            // keep the Broyden-improved H for the next pass (rows between sweeps
            // otherwise start every segment from the last sweep's stale M): its
            // terms, when there are at most KEPT_TERMS (else the sweep's M again)
            let n = buf.settle_n;
            let keep = if n <= KEPT_TERMS { n } else { 0 };
            let (ku, kv) = lowrank::kept_mut(&mut buf.mlin[ck.g], l);
            ku[..keep * l].copy_from_slice(&buf.settle_u[..keep * l]);
            kv[..keep * l].copy_from_slice(&buf.settle_v[..keep * l]);
            buf.mlin_terms[ck.g] = keep;
        }
        return true;
    }
    ck.last_error = worst;
    // H approximates -(dg/dq)^-1 for g(q) = p(q) - q: the sweep's (I - A)^-1 = I + C K
    // with the terms kept from the last settle, or I (the plain fixed point) before
    // any sweep, improved by Broyden's inverse update from the last attempt's secant
    // (dg dq: observed change of g over step dq),
    // H <- H - (dq + H dg) dg^T / (dg^T dg), so a stale M or strong coupling near
    // doubling back still converges superlinearly. H is kept in low-rank form
    // (`lowrank`): each update appends the term u = -(dq + H dg) / (dg^T dg), v = dg.
    let (err, rest) = buf.settle_tmp.split_at_mut(l);
    let (step, rest) = rest.split_at_mut(l);
    let (dg, hdg) = rest.split_at_mut(l);
    let g = ck.g;
    let base = buf.mlin_valid.then(|| lowrank::base(&buf.mlin[g], l));
    if ck.iterations == 0 {
        let (ku, kv) = lowrank::kept(&buf.mlin[g], l);
        let kt = if buf.mlin_valid { buf.mlin_terms[g] } else { 0 };
        lowrank::apply(base, l, ku, kv, kt, err, step);
    } else {
        if ck.iterations == 1 {
            // the working terms start as the kept ones
            let kt = if buf.mlin_valid { buf.mlin_terms[g] } else { 0 };
            let (ku, kv) = lowrank::kept(&buf.mlin[g], l);
            buf.settle_u[..kt * l].copy_from_slice(&ku[..kt * l]);
            buf.settle_v[..kt * l].copy_from_slice(&kv[..kt * l]);
            buf.settle_n = kt;
        }
        let mut dd = 0.0;
        for r in 0..l {
            dg[r] = err[r] - buf.prev_err[r];
            dd += dg[r] * dg[r];
        }
        let n = buf.settle_n;
        if dd > 0.0 && (n + 1) * l <= buf.settle_u.len() {
            let (su, sv) = (&buf.settle_u, &buf.settle_v);
            lowrank::apply(base, l, su, sv, n, dg, hdg);
            for r in 0..l {
                buf.settle_u[n * l + r] = -(buf.prev_step[r] + hdg[r]) / dd;
                buf.settle_v[n * l + r] = dg[r];
            }
            buf.settle_n = n + 1;
        }
        let (su, sv) = (&buf.settle_u, &buf.settle_v);
        lowrank::apply(base, l, su, sv, buf.settle_n, err, step);
    }
    for (i, &(j, k)) in pend.iter().enumerate() {
        for a in 0..3 {
            let r = 3 * i + a;
            buf.prev_step[r] = step[r];
            buf.prev_err[r] = err[r];
            buf.next[j][k][a] += step[r];
        }
    }
    ck.iterations += 1;
    false
}

/// Dual pass at guide `g`: `B = d(n, m)/dq` of the chord of pending cable number
/// `pos` towards its assumed next hole `q` (columns `3 pos..3 pos + 3` of the
/// `6 x L` matrix), at the point's real values. The chord force is
/// `F = t u`, `u = (q - p)/|q - p|`, so `dF/dq = t (I - u u^T)/|q - p|`; the jump is
/// `(dn, dm) = -(F, arm x F)`.
pub(super) fn jump_block<T: Real>(
    buf: &mut PassBuf<T>,
    l: usize,
    pos: usize,
    chord: Vector3<f64>,
    arm: Vector3<f64>,
    t: f64,
) {
    let len = chord.norm();
    // a zero chord exerts no force along a direction (see `unit`): no dependence on q,
    // and the block must not keep another disk's values (the buffer is reused)
    let d = if len > 0.0 {
        let u = chord / len;
        (Matrix3::identity() - u * u.transpose()) * (t / len)
    } else {
        Matrix3::zeros()
    };
    let md = arm.cross_matrix() * d;
    for r in 0..3 {
        for c in 0..3 {
            buf.jump_b[r * l + 3 * pos + c] = -d[(r, c)];
            buf.jump_b[(r + 3) * l + 3 * pos + c] = -md[(r, c)];
        }
    }
}

/// Dual pass after the chords at a guide with pending cables: seed the local
/// directions on the jump of `(n, m)` (they are zero here: folded at this disk).
pub(super) fn seed_jump<T: Real>(y: &mut State<T>) {
    let base = T::DIRS - JUMP_DIRS;
    for a in 0..3 {
        y.n[a].eps_mut()[base + a] = 1.0;
        y.m[a].eps_mut()[base + 3 + a] = 1.0;
    }
}

/// Dual pass at the disk after `g`: with `a = dp/dz` (outer directions) and
/// `C = dp/dj` (the jump's local directions) read off the computed holes and `B` from
/// guide `g`, fold `dj/dz = (I - B C)^-1 B a` into the outer directions, so the state
/// carries exact outer derivatives only (the continuous tendons' integrated lengths
/// included). Also stores `M = I + C (I - B C)^-1 B` for
/// `f64` passes.
pub(super) fn fold_segment<T: Real>(plan: &Plan, buf: &mut PassBuf<T>, y: &mut State<T>, g: usize) {
    let pend = &plan.pending[g];
    let l = 3 * pend.len();
    let nout = T::DIRS - JUMP_DIRS;
    let w = nout + l;
    let (s, rest) = buf.lin.split_at_mut(36);
    let (rhs, cmat) = rest.split_at_mut(JUMP_DIRS * (T::DIRS + plan.max_pending_dirs));
    let rhs = &mut rhs[..JUMP_DIRS * w];
    // s = I - B C (6 x 6); rhs = [B a | B] (6 x w); cmat = C (l x 6)
    s.fill(0.0);
    rhs.fill(0.0);
    for r in 0..JUMP_DIRS {
        s[r * 7] = 1.0;
        rhs[r * w + nout..(r + 1) * w].copy_from_slice(&buf.jump_b[r * l..(r + 1) * l]);
    }
    for (i, &(j, k)) in pend.iter().enumerate() {
        let p = next_hole(plan, y, j, k);
        for a in 0..3 {
            let q = 3 * i + a;
            let e = p[a].eps();
            let (eo, ec) = e.split_at(nout);
            cmat[q * JUMP_DIRS..(q + 1) * JUMP_DIRS].copy_from_slice(ec);
            for r in 0..JUMP_DIRS {
                let b = buf.jump_b[r * l + q];
                if b != 0.0 {
                    let row = &mut rhs[r * w..r * w + nout];
                    row.iter_mut().zip(eo).for_each(|(v, x)| *v += b * x);
                    let srow = &mut s[r * JUMP_DIRS..(r + 1) * JUMP_DIRS];
                    srow.iter_mut().zip(ec).for_each(|(v, x)| *v -= b * x);
                }
            }
        }
    }
    let solved = solve_small(s, JUMP_DIRS, rhs, w);
    if solved {
        // M = I + C K with K = (I - B C)^-1 B (the last l columns of rhs), stored as
        // its factors (`lowrank`)
        let m = &mut buf.mlin[g];
        let (cs, ks) = m[..2 * JUMP_DIRS * l].split_at_mut(JUMP_DIRS * l);
        cs.copy_from_slice(&cmat[..JUMP_DIRS * l]);
        for (t, row) in ks.chunks_exact_mut(l).enumerate() {
            row.copy_from_slice(&rhs[t * w + nout..t * w + nout + l]);
        }
        buf.mlin_terms[g] = 0;
    }
    // the segment's state map d y / d j, before the fold (see `seg_map`)
    if let Some(map) = buf
        .seg_map
        .get_mut(g)
        .filter(|m| m.len() == STATE_ROWS * JUMP_DIRS)
    {
        let rows =
            y.r.iter()
                .chain(y.rot.iter())
                .chain(y.n.iter())
                .chain(y.m.iter());
        for (row, z) in map.chunks_exact_mut(JUMP_DIRS).zip(rows) {
            row.copy_from_slice(&z.eps()[nout..nout + JUMP_DIRS]);
        }
    }
    // a singular segment map leaves the Jacobian inexact (the outer Newton's line
    // search tolerates that) and drops M
    buf.mlin_valid = solved;
    let fold = |z: &mut T| {
        let (eo, ec) = z.eps_mut().split_at_mut(nout);
        for (c, lc) in ec[..JUMP_DIRS].iter_mut().enumerate() {
            if *lc != 0.0 && solved {
                let row = &rhs[c * w..c * w + nout];
                eo.iter_mut().zip(row).for_each(|(v, r)| *v += *lc * r);
            }
            *lc = 0.0;
        }
    };
    y.r.iter_mut().for_each(fold);
    y.rot.iter_mut().for_each(fold);
    y.n.iter_mut().for_each(fold);
    y.m.iter_mut().for_each(fold);
    // the continuous tendons' lengths integrated over the segment are states too
    // (`statics::pass::continuous`: `int |q_i| ds` depends on the jump through the strains);
    // a robot without them has nothing to fold
    if !plan.routed.is_empty() {
        buf.lengths.iter_mut().for_each(fold);
    }
}

/// `f64` pass at the disk after `ck.g`, right after [`settle_segment`] moved the
/// assumed next holes by its step (`prev_step`): when that step is at most
/// [`LINEAR_STEP`] of the rod length, carry its effect to the segment's end state to
/// first order, `y += S dj`, instead of re-integrating the segment, and return `true`.
/// `dj` is the exact change of the chord jump of `(n, m)` at guide `ck.g`
/// (`-(df, arm x df)`, `df = t (u(q + dq) - u(q))`, as `apply_event` applies it) and
/// `S = d y / d j` the segment's state map from the last dual sweep (`seg_map`).
///
/// Why it is accurate: a re-integration would move the end state by `S dj + O(dj^2)`;
/// with steps below `LINEAR_STEP`, the neglected `O(dj^2)` is below round-off, and
/// `S`'s staleness since the sweep (the segment's shape change over some load steps,
/// a small fraction of `S`) leaves a fraction of a 1e-13 L step, near `LOCAL_TOL`.
/// The holes are then checked again against the corrected state by
/// [`settle_segment`]. Measured (`examples/till_ramp_profile.rs`, Till's robot on 100
/// disks, 5 000 warm ramp solves): gap re-integrations 108.4 -> 6.2 and `f64` RHS
/// 1 164 -> 755 a solve, tips within 5e-11 m of the re-integrating pass (which is
/// itself 4e-11 m from a solve at the tolerance floor); FTDCR v4 val rows
/// (`examples/tendon_profile.rs`): `f64` RHS 2 403 -> 2 238 a row, tips within
/// 1e-11 m, statuses and taut flags unchanged.
/// Only with fixed RK4 steps (an adaptive re-integration may choose other steps) and
/// without continuously routed tendons (their integrated lengths are states the map
/// does not carry).
pub(super) fn linear_retry<T: Real>(
    plan: &Plan,
    buf: &PassBuf<T>,
    y: &mut State<T>,
    ck: &Checkpoint<T>,
    load_scale: f64,
) -> bool {
    let pend = &plan.pending[ck.g];
    let l = 3 * pend.len();
    let map = &buf.seg_map[ck.g];
    let usable = T::DIRS == 0
        && buf.seg_map_valid
        && map.len() == STATE_ROWS * JUMP_DIRS
        && plan.routed.is_empty()
        && matches!(plan.integrator, crate::settings::Integrator::Rk4 { .. });
    let small = |d: &f64| d.abs() <= LINEAR_STEP * plan.length;
    if !usable || !buf.prev_step[..l].iter().all(small) {
        return false;
    }
    let (r, rot) = (ck.y.r.map(|x| x.re()), ck.y.rot.map(|x| x.re()));
    let mut dj = [0.0; JUMP_DIRS];
    for (i, &(j, k)) in pend.iter().enumerate() {
        let c = &plan.cables[j];
        let arm = rot * c.hole_local[k];
        let p = r + arm;
        // as `apply_event`'s chord towards the next hole
        let t_next = super::actuator_tension(plan, buf, j, load_scale).re() * c.factor[k + 1];
        let q = buf.next[j][k];
        let dq = Vector3::new(
            buf.prev_step[3 * i],
            buf.prev_step[3 * i + 1],
            buf.prev_step[3 * i + 2],
        );
        let df = (super::unit(q - p) - super::unit(q - dq - p)) * t_next;
        let dm = arm.cross(&df);
        for a in 0..3 {
            dj[a] -= df[a];
            dj[3 + a] -= dm[a];
        }
    }
    // rows r (3), R (9, column-major as stored), n (3), m (3); indexed, not a chain
    // of iterators (that was most of this function's cost)
    let mut d = [0.0; STATE_ROWS];
    for (dr, row) in d.iter_mut().zip(map.chunks_exact(JUMP_DIRS)) {
        *dr = (0..JUMP_DIRS).map(|c| row[c] * dj[c]).sum();
    }
    for a in 0..3 {
        y.r[a] = T::cst(y.r[a].re() + d[a]);
        y.n[a] = T::cst(y.n[a].re() + d[12 + a]);
        y.m[a] = T::cst(y.m[a].re() + d[15 + a]);
    }
    for (z, da) in y.rot.as_mut_slice().iter_mut().zip(&d[3..12]) {
        *z = T::cst(z.re() + da);
    }
    true
}
