//! The Jacobian at the reference equilibrium, kept for cold starts.
//!
//! A cold solve from readings starts the joint Newton at the reference (zero
//! readings, the pretensions: `TendonWorkspace::reference`), so its first fresh
//! Jacobian is always the same one: the sweep at `x_ref` with the tensions at the
//! pretensions (only the tendon rows' compliance terms and the active set depend on
//! the row, and `JointBufs::assemble` adds those). The first cold solve keeps that sweep's
//! `d r / d[x; theta]` and `d l / d[x; theta]`; later cold solves assemble their
//! first Jacobian from it instead of sweeping (one `Dual<21>` sweep, ~15 `f64`
//! passes, of the ~4 a cold FTDCR v4 row takes).
//!
//! Why this is safe: the Jacobian only steers Newton; the residual of every iterate
//! is evaluated exactly, so a stale Jacobian could slow a solve, never change the
//! point it converges to. The kept one is still checked before use: the cold start's
//! own evaluation at `x_ref` (done anyway) must reproduce the kept residual within
//! [`RES_MATCH`] tolerances and the kept cable lengths within [`LEN_MATCH`], with the
//! same load parameters: a changed model (calibrated parameters, other settings
//! through `workspace_mut`) fails that and sweeps afresh (and keeps the new sweep).

use super::super::{Iterate, Tendons};
use super::JointBufs;
use crate::statics::Workspace;

/// Largest change of the scaled shooting residual at `x_ref`, in tolerances, for
/// the kept Jacobian to count as the model's (settling the next holes from other
/// starting guesses moves it; how far was not measured, the margin is a guess: a
/// miss only costs the sweep that would have run anyway).
const RES_MATCH: f64 = 10.0;
/// Largest change of a cable length at `x_ref` (m) for the same.
const LEN_MATCH: f64 = 1e-12;

/// The kept Jacobian and the evaluation it belongs to.
#[derive(Clone, Default)]
pub(in crate::tendons::solve) struct RefJacobian {
    jac_s: Vec<f64>,
    jac_m: Vec<f64>,
    res: Vec<f64>,
    lengths: Vec<f64>,
    theta: Vec<f64>,
    valid: bool,
    /// Set by the cold path: the next evaluation is at the reference.
    pub(in crate::tendons::solve) pending: bool,
    /// The iterate is the reference: `Some(true)` when the kept Jacobian matches
    /// it, `Some(false)` when it does not (keep the next sweep); `None` elsewhere.
    at_ref: Option<bool>,
}

impl RefJacobian {
    /// Buffers sized once for `n` shooting unknowns, `np` load parameters and
    /// `cables` cables, holding no Jacobian yet. Why sized here: a budgeted warm
    /// call may take the cold path (`budget` module) and keep its sweep here; a
    /// buffer first filled then would allocate, and again after every rollback
    /// to a state that never held one.
    pub(in crate::tendons::solve) fn new(n: usize, np: usize, cables: usize) -> Self {
        Self {
            jac_s: vec![0.0; n * (n + np)],
            jac_m: vec![0.0; cables * (n + np)],
            res: vec![0.0; n],
            lengths: vec![0.0; cables],
            theta: vec![0.0; np],
            ..Self::default()
        }
    }
}

impl RefJacobian {
    /// After the first evaluation of a cold start (at `x_ref`, evaluated by `ws`
    /// into `it`): does the kept Jacobian belong to this model?
    pub(super) fn check(&mut self, ws: &Workspace, it: &Iterate) {
        if !std::mem::take(&mut self.pending) {
            return;
        }
        let tol = ws.report().tolerance;
        let close = |a: &[f64], b: &[f64], eps: f64| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= eps)
        };
        self.at_ref = Some(
            self.valid
                && self.theta == it.theta
                && close(&self.res, ws.residual_vector(), RES_MATCH * tol)
                && close(&self.lengths, &it.lengths, LEN_MATCH),
        );
    }

    /// Any evaluation (the iterate moved, or is evaluated again) ends what
    /// [`Self::check`] found.
    pub(super) fn leave(&mut self) {
        self.at_ref = None;
    }
}

impl JointBufs {
    /// The Jacobian of a fresh step: the kept one at the reference when it matches,
    /// else a sweep (kept when it is the reference's). `false` when it is singular or
    /// the sweep failed.
    pub(super) fn fresh_jacobian(
        &mut self,
        ws: &mut Workspace,
        td: &Tendons,
        it: &Iterate,
    ) -> bool {
        let at_ref = self.rj.at_ref.take();
        if at_ref == Some(true) {
            self.jac_s.copy_from_slice(&self.rj.jac_s);
            self.jac_m.copy_from_slice(&self.rj.jac_m);
            self.lu_taut.copy_from_slice(&it.taut);
            return self.assemble(td, it);
        }
        let ok = self.factor(ws, td, it);
        if ok && at_ref == Some(false) {
            let rj = &mut self.rj;
            rj.jac_s.clone_from(&self.jac_s);
            rj.jac_m.clone_from(&self.jac_m);
            rj.res.clear();
            rj.res.extend_from_slice(ws.residual_vector());
            rj.lengths.clone_from(&it.lengths);
            rj.theta.clone_from(&it.theta);
            rj.valid = true;
        }
        ok
    }
}

impl crate::math::warm::WarmCopy for RefJacobian {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src,
            copy: [jac_s, jac_m, res, lengths, theta, valid, pending, at_ref], keep: []);
    }
}
