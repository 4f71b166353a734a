//! An evaluated iterate of the joint path, kept across the trials from it.
//!
//! When every trial from an iterate fails (a chord step at a row's start that does
//! not contract, a predicted start that is worse than the previous row's solution),
//! the next step starts from that iterate again. Its evaluation (path lengths, `G`,
//! active set, residual `[r; G]`, merit) is restored from a copy instead of being
//! evaluated again: one `f64` pass saved each time, and the same arithmetic after it,
//! since the sweep and the step from the iterate read only these and the iterate's
//! unknowns and tensions. On the 443 FTDCR v4 val rows warm, 3 laps:
//! 371 returns after a failed chord step and 186 rejected predicted starts, 0.42 of
//! a row's ~5.9 passes. Not under the condensed coupling
//! ([`crate::statics::Workspace::settles_holes`]): its passes settle the next holes
//! from the last pass, so the evaluation is repeated there as before.

use super::super::Iterate;
use super::JointBufs;
use crate::statics::Workspace;

/// The copy (sized once with the workspace).
#[derive(Clone, Debug, Default)]
pub(in crate::tendons::solve) struct Kept {
    lengths: Vec<f64>,
    g: Vec<f64>,
    taut: Vec<bool>,
    f: Vec<f64>,
    l2: f64,
}

impl Kept {
    pub(super) fn new(m: usize, p: usize, cables: usize) -> Self {
        Self {
            lengths: vec![0.0; cables],
            g: vec![0.0; p],
            taut: vec![true; p],
            f: vec![0.0; m],
            l2: f64::INFINITY,
        }
    }
}

impl JointBufs {
    /// Keep the evaluation of the current iterate (`x`, the tensions of `it`,
    /// evaluated last).
    pub(super) fn keep(&mut self, it: &Iterate) {
        let k = &mut self.kept;
        k.lengths.copy_from_slice(&it.lengths);
        k.g.copy_from_slice(&it.g);
        k.taut.copy_from_slice(&it.taut);
        k.f.copy_from_slice(&self.f_now);
        k.l2 = self.l2;
    }

    /// Restore the kept evaluation into `it` (and `ws`'s tensions); the caller has
    /// put `x` and the tensions back to the kept iterate's. `false` (nothing
    /// restored: evaluate it) when the workspace's passes depend on the last pass.
    pub(super) fn restore(&mut self, ws: &mut Workspace, it: &mut Iterate) -> bool {
        if ws.settles_holes() {
            return false;
        }
        let p = it.t.len();
        let k = &self.kept;
        it.lengths.copy_from_slice(&k.lengths);
        it.g.copy_from_slice(&k.g);
        it.taut.copy_from_slice(&k.taut);
        self.f_now.copy_from_slice(&k.f);
        self.l2 = k.l2;
        // the sweep reads the tensions from the inner workspace
        it.theta[..p].copy_from_slice(&it.t);
        ws.set_theta(&it.theta);
        true
    }
}

impl crate::math::warm::WarmCopy for Kept {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src, copy: [lengths, g, taut, f, l2], keep: []);
    }
}

#[cfg(test)]
mod tests {
    use crate::Scene;

    /// A restored evaluation is the evaluation: on the shipped FTDCR v4 scene, after
    /// a row and a trial elsewhere, restoring the kept iterate gives bit for bit what
    /// evaluating it again gives (lengths, `G`, active set, residual, merit), and the
    /// sweep from there the same Jacobian.
    #[test]
    fn a_restored_evaluation_is_the_evaluation() {
        let scene = Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
        let mut tw = scene.tendon_workspace().expect("workspace");
        let p = tw.tendons.driven.len();
        let mut q = vec![0.0; p];
        q[0] = 0.001;
        q[4] = -0.002;
        assert!(tw.solve_readings(&q).expect("valid").status.is_converged());
        // the iterate: the solution with other readings (off the equilibrium)
        q[1] = 0.0005;
        tw.solve_readings(&vec![0.0; p]).expect("valid");
        tw.solve_readings(&q).expect("valid");
        tw.joint.x.copy_from_slice(tw.ws.unknowns_vector());
        let (x0, t0) = (tw.joint.x.clone(), tw.iter.t.clone());
        tw.iter.free[2] += 1e-4;
        assert!(tw.joint_evaluate().is_some());
        tw.joint.keep(&tw.iter);
        // a trial elsewhere, then back
        tw.joint.x[0] += 0.3;
        tw.iter.t.iter_mut().for_each(|t| *t *= 1.05);
        assert!(tw.joint_evaluate().is_some());
        tw.joint.x.copy_from_slice(&x0);
        tw.iter.t.copy_from_slice(&t0);
        assert!(tw.joint.restore(&mut tw.ws, &mut tw.iter));
        let restored = (
            tw.iter.lengths.clone(),
            tw.iter.g.clone(),
            tw.iter.taut.clone(),
            tw.joint.f_now.clone(),
            tw.joint.l2,
        );
        assert!(tw.joint.factor(&mut tw.ws, &tw.tendons, &tw.iter));
        let (jac_s, jac_m) = (tw.joint.jac_s.clone(), tw.joint.jac_m.clone());
        assert!(tw.joint_evaluate().is_some());
        assert_eq!(restored.0, tw.iter.lengths);
        assert_eq!(restored.1, tw.iter.g);
        assert_eq!(restored.2, tw.iter.taut);
        assert_eq!(restored.3, tw.joint.f_now);
        assert_eq!(restored.4, tw.joint.l2);
        assert!(tw.joint.factor(&mut tw.ws, &tw.tendons, &tw.iter));
        assert_eq!(jac_s, tw.joint.jac_s);
        assert_eq!(jac_m, tw.joint.jac_m);
    }
}
