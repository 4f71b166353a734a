//! The start of a warm row of the joint path: the first residual without a pass,
//! then a start extrapolated from the last rows.
//!
//! At the previous row's solution `z_1 = [x; T]` (free lengths `f_1`), the new
//! readings change only the free lengths in the tendon rows `G`: the shooting
//! residual `r` and the path lengths `l` are those of the row's last pass, so the
//! first residual `F_0 = [r_1; G(z_1, f)]` costs no pass (and a row whose readings
//! moved by less than the tolerance is done without one). Measured on the 443
//! FTDCR v4 val rows: 2 885 -> 2 714 `f64` right-hand sides a row (one pass and its
//! settle iterations), dual unchanged.
//!
//! Rows of a pattern are ramps: when the change of free lengths `f - f_1` is
//! nearly collinear with the previous row's `f_1 - f_2` (cosine at least
//! [`COLLINEAR`]), `z` is extrapolated along that line, by the parabola through the
//! last three rows' solutions (Lagrange, in the coordinate along the line) when the
//! row before was collinear too, else by the secant through the last two. The
//! extrapolated point is kept when its residual (`l2` merit) is below `F_0`'s; its
//! step then updates the inverse Jacobian by Broyden's formula like any accepted
//! step. Measured on the same rows (`f64` / dual right-hand sides a row, callgrind
//! instructions a row): start at `z_1` 2 714 / 195.0, 17.3 M; secant only 2 672 /
//! 185.0, 16.7 M; parabola only (else `z_1`) 2 583 / 182.0, 16.3 M. Not kept: the
//! implicit-function tangent `z_1 - H F_0` with the Broyden-updated inverse of the
//! last row (2 920 / 208.0: its residual fell below `F_0`'s on only 222 of 443
//! rows; the path is curved over a row, a fresh Newton step from `z_1` also only
//! cuts the merit to 0.2-0.4), the tangent plus the secant's curvature (3 088 /
//! 204.0), and any of them followed by a chord step (no fresh sweep) at the row's
//! first iteration (the dual count fell to 156-165 but the `f64` one rose to
//! 2 864-3 608: 16.2-17.8 M).
//!
//! The extrapolated point's next holes settle to `1e-7` of the residual it is
//! expected to have, `F_0`'s merit times the last prediction's ratio of merits
//! (`JointBufs::pred_ratio`), not of `F_0`'s: 1 kHz control-loop ticks (the val
//! readings interpolated in time) extrapolate to ~1e-4 of `F_0`, where a settle from
//! `F_0`'s merit left noise that the next Newton step could not reduce (ratio
//! 0.9998): on 5 000 ticks 963 -> 491 `f64` and 188.4 -> 4.1 dual right-hand sides
//! a tick (settling fully: 496 / 3.3; from 1e-2 of `F_0`'s merit: 514 / 70.5); the
//! rows unchanged (2 026 / 139.2).

use super::super::TendonWorkspace;
use super::JointBufs;

/// Converged rows held for the extrapolation.
pub(super) const HISTORY: usize = 3;
/// Smallest cosine between consecutive rows' changes of free lengths for an
/// extrapolation along them. Measured (parabola, `f64` / dual right-hand sides a
/// row on the 443 FTDCR v4 val rows): 0.9 2 640 / 180.7, 0.97 2 614 / 181.8, 0.99
/// 2 583 / 182.0, 0.995 2 651 / 189.9, 0.999 2 706 / 194.5.
const COLLINEAR: f64 = 0.99;

/// How a row's joint Newton starts.
pub(super) enum RowStart {
    /// The previous solution solves this row (readings within the tolerance).
    Converged,
    /// From the current iterate, already evaluated: its merit.
    Evaluated(f64),
    /// From the previous solution, not yet evaluated (as without this module).
    Plain,
}

impl JointBufs {
    /// Record a converged row's solution (shooting unknowns, tensions, free lengths).
    pub(in crate::tendons::solve) fn push_history(&mut self, x: &[f64], t: &[f64], free: &[f64]) {
        let m = x.len() + t.len();
        let p = free.len();
        self.hist_z.copy_within(0..(HISTORY - 1) * m, m);
        self.hist_f.copy_within(0..(HISTORY - 1) * p, p);
        self.hist_z[..x.len()].copy_from_slice(x);
        self.hist_z[x.len()..m].copy_from_slice(t);
        self.hist_f[..p].copy_from_slice(free);
        self.hist_len = (self.hist_len + 1).min(HISTORY);
    }

    /// Forget the rows (the parameters changed: their solutions predict nothing).
    pub(in crate::tendons::solve) fn forget_history(&mut self) {
        self.hist_len = 0;
        self.at_solution = false;
    }

    /// Weights of the last rows' solutions (newest first) that extrapolate to the
    /// free lengths `free` (module docs), `None` when the rows are not a ramp.
    fn extrapolation(&self, free: &[f64]) -> Option<[f64; HISTORY]> {
        let p = free.len();
        let f = |k: usize, i: usize| self.hist_f[k * p + i];
        if self.hist_len < 2 || self.hist_f[..p] != self.free_prev[..] {
            return None;
        }
        // the line of the last change d0 = f_1 - f_2; d1 = f - f_1, dm = f_2 - f_3
        let (mut d0d0, mut d1d0, mut d1d1, mut dmd0, mut dmdm) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (i, fi) in free.iter().enumerate() {
            let d0 = f(0, i) - f(1, i);
            let d1 = fi - f(0, i);
            d0d0 += d0 * d0;
            d1d0 += d1 * d0;
            d1d1 += d1 * d1;
            if self.hist_len >= 3 {
                let dm = f(1, i) - f(2, i);
                dmd0 += dm * d0;
                dmdm += dm * dm;
            }
        }
        if d0d0 <= 0.0 || d1d1 <= 0.0 || d1d0 < COLLINEAR * (d0d0 * d1d1).sqrt() {
            return None;
        }
        let len0 = d0d0.sqrt();
        // coordinates along the line: f_1 at 0, f_2 at -|d0|, f at d1.u
        let (t1, t2, t) = (0.0, -len0, d1d0 / len0);
        if dmdm > 0.0 && dmd0 >= COLLINEAR * (d0d0 * dmdm).sqrt() {
            let t3 = t2 - dmd0 / len0;
            let w1 = (t - t2) * (t - t3) / ((t1 - t2) * (t1 - t3));
            let w2 = (t - t1) * (t - t3) / ((t2 - t1) * (t2 - t3));
            let w3 = (t - t1) * (t - t2) / ((t3 - t1) * (t3 - t2));
            return Some([w1, w2, w3]);
        }
        let s = t / len0;
        Some([1.0 + s, -s, 0.0])
    }
}

impl TendonWorkspace {
    /// The row's start (module docs). Leaves `joint.x`, `t` at the start.
    pub(super) fn joint_predict(&mut self) -> RowStart {
        let n = self.ws.unknowns();
        let p = self.tendons.driven.len();
        let m = n + p;
        // `F_0` needs the workspace still at the last row's final evaluation
        let at_solution = std::mem::take(&mut self.joint.at_solution);
        if !at_solution
            || self.ws.unknowns_vector() != self.joint.x.as_slice()
            || self.ws.theta() != self.iter.theta.as_slice()
        {
            return RowStart::Plain;
        }
        self.iter.update_g(&self.tendons);
        let tol = self.ws.report().tolerance;
        let tol_g = self.tendon_settings().tolerance_m;
        let g_max = self.iter.merit();
        self.joint.f_now[n..].copy_from_slice(&self.iter.g);
        let (l2_0, settle0) = self.joint.norms(tol, self.ws.settings());
        let jb = &mut self.joint;
        jb.l2 = l2_0;
        let r_max = jb.f_now[..n].iter().fold(0.0f64, |a, r| a.max(r.abs()));
        let merit0 = (r_max / tol).max(g_max / tol_g);
        if merit0 <= 1.0
            && self
                .iter
                .taut
                .iter()
                .zip(&self.iter.t)
                .all(|(k, t)| *k || *t == 0.0)
        {
            return RowStart::Converged;
        }
        let hist_ok = jb.hist_z[..n] == jb.x0[..] && jb.hist_z[n..m] == jb.t0[..];
        let Some(w) = jb.extrapolation(&self.iter.free).filter(|_| hist_ok) else {
            return RowStart::Evaluated(merit0);
        };
        for k in 0..m {
            jb.zp[k] = (0..HISTORY).map(|r| w[r] * jb.hist_z[r * m + k]).sum();
        }
        // evaluate there (the step from z_1 is Broyden's secant pair when kept)
        jb.f_prev.copy_from_slice(&jb.f_now);
        self.joint.keep(&self.iter);
        let jb = &mut self.joint;
        jb.xs.copy_from_slice(&jb.x0);
        jb.ts.copy_from_slice(&jb.t0);
        jb.x.copy_from_slice(&jb.zp[..n]);
        for i in 0..p {
            self.iter.t[i] = jb.zp[n + i].max(0.0);
        }
        // the next holes settle to 1e-7 of the residual the point is expected to
        // have: the start's times the last prediction's ratio (`joint.pred_ratio`)
        self.joint_inner_tolerance(settle0 * self.joint.pred_ratio);
        let ev = self.joint_evaluate();
        self.joint.pred_ratio = (self.joint.l2 / l2_0).clamp(1e-9, 1.0);
        match ev {
            Some(mp) if self.joint.l2 < l2_0 => {
                if self.joint.lu_valid {
                    self.joint.broyden(n, &self.iter.t, self.ws.settings());
                }
                self.joint.predicted = true;
                RowStart::Evaluated(mp)
            }
            _ => {
                // back to z_1: its kept evaluation (`keep`), else the plain start's
                // first evaluation (a `merit0` within the tolerance still evaluates:
                // the row would end at the restored point without a pass of its own)
                self.joint_inner_tolerance(0.0);
                self.iter.t.copy_from_slice(&self.joint.t0);
                self.joint.x.copy_from_slice(&self.joint.x0);
                if merit0 > 1.0 && self.joint.restore(&mut self.ws, &mut self.iter) {
                    return RowStart::Evaluated(merit0);
                }
                RowStart::Plain
            }
        }
    }
}
