//! The Jacobian at the reference equilibrium, kept for cold starts.
//!
//! A cold solve from readings starts the joint Newton at the reference (zero
//! readings, the pretensions: `TendonWorkspace::reference`), so its first fresh
//! Jacobian is always the same one: the sweep at `x_ref` with the tensions at the
//! pretensions (only the tendon rows' compliance terms and the active set depend on
//! the row, and `joint_assemble` adds those). The first cold solve keeps that sweep's
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

use super::super::TendonWorkspace;

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

impl TendonWorkspace {
    /// After the first evaluation of a cold start (at `x_ref`): does the kept
    /// Jacobian belong to this model?
    pub(super) fn ref_check(&mut self) {
        let rj = &mut self.joint.rj;
        if !std::mem::take(&mut rj.pending) {
            return;
        }
        let tol = self.ws.report().tolerance;
        let close = |a: &[f64], b: &[f64], eps: f64| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= eps)
        };
        rj.at_ref = Some(
            rj.valid
                && rj.theta == self.iter.theta
                && close(&rj.res, self.ws.residual_vector(), RES_MATCH * tol)
                && close(&rj.lengths, &self.iter.lengths, LEN_MATCH),
        );
    }

    /// The Jacobian of a fresh step: the kept one at the reference when it matches,
    /// else a sweep (kept when it is the reference's). `false` when it is singular or
    /// the sweep failed.
    pub(super) fn joint_fresh_jacobian(&mut self) -> bool {
        let at_ref = self.joint.rj.at_ref.take();
        if at_ref == Some(true) {
            let jb = &mut self.joint;
            jb.jac_s.copy_from_slice(&jb.rj.jac_s);
            jb.jac_m.copy_from_slice(&jb.rj.jac_m);
            jb.lu_taut.copy_from_slice(&self.iter.taut);
            return self.joint_assemble();
        }
        let ok = self.joint_factor();
        if ok && at_ref == Some(false) {
            let jb = &mut self.joint;
            let rj = &mut jb.rj;
            rj.jac_s.clone_from(&jb.jac_s);
            rj.jac_m.clone_from(&jb.jac_m);
            rj.res.clear();
            rj.res.extend_from_slice(self.ws.residual_vector());
            rj.lengths.clone_from(&self.iter.lengths);
            rj.theta.clone_from(&self.iter.theta);
            rj.valid = true;
        }
        ok
    }

    /// Any evaluation (the iterate moved, or is evaluated again) ends what
    /// [`Self::ref_check`] found.
    pub(super) fn ref_leave(&mut self) {
        self.joint.rj.at_ref = None;
    }
}

impl crate::math::warm::WarmCopy for RefJacobian {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src,
            copy: [jac_s, jac_m, res, lengths, theta, valid, pending, at_ref], keep: []);
    }
}
