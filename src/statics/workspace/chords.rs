//! Workspace methods for tendon mechanics (`crate::tendons`): the world positions of
//! each cable's holes after the last pass, and the per-chord tension factors that
//! capstan friction sets.
//!
//! A child module of `workspace` (declared there with `#[path]`), like `joint.rs`, so
//! it reads the private pass buffer without widening its visibility.

use super::super::pass::LOCAL_TOL;
use super::Workspace;
use nalgebra::Vector3;

impl Workspace {
    /// World positions (m) of cable `j`'s holes on its route disks, base to
    /// termination, from the last `f64` pass (after a converged solve: of the
    /// solution). Empty for an unknown cable.
    pub fn cable_holes(&self, j: usize) -> &[Vector3<f64>] {
        self.bufs.b64.holes.get(j).map_or(&[], |h| &h[..])
    }

    /// World position (m) of cable `j`'s hole in the base plate.
    pub fn base_hole_world(&self, j: usize) -> Vector3<f64> {
        self.prob
            .plan
            .cables
            .get(j)
            .map_or(Vector3::zeros(), |c| c.base_hole)
    }

    /// Set the tension of each chord of cable `j` relative to the actuator's
    /// (`factors[k]` for the chord ending at route disk `k`); missing entries are 1.
    /// Takes effect from the next pass; no allocation.
    pub fn set_chord_factors(&mut self, j: usize, factors: &[f64]) {
        if let Some(c) = self.prob.plan.cables.get_mut(j) {
            for (k, f) in c.factor.iter_mut().enumerate() {
                *f = factors.get(k).copied().unwrap_or(1.0);
            }
            // the last pass no longer matches the plan
            self.bufs.last_pass = None;
        }
    }

    /// Per-chord tension factors of cable `j` now in effect.
    pub fn chord_factors(&self, j: usize) -> &[f64] {
        self.prob.plan.cables.get(j).map_or(&[], |c| &c.factor[..])
    }
}

impl Workspace {
    /// Condensed coupling: tolerance of the next-hole settle of the following `f64`
    /// passes, as a fraction of the rod length ([`Self::settle_tolerance`]: clamped to
    /// `[LOCAL_TOL, 1e-9]`, or `LOCAL_TOL` on a plan without a settle; `LOCAL_TOL` =
    /// 1e-15 is the default and what every solve ends with); returns the value set.
    /// For an outer iteration that evaluates points far from its solution (inexact
    /// Newton: an inner error far below the outer residual does not change the step);
    /// the caller restores `LOCAL_TOL` before it reports a point.
    pub(crate) fn set_local_tolerance(&mut self, frac: f64) -> f64 {
        let t = self.settle_tolerance(frac);
        self.bufs.b64.local_tol = t;
        t
    }

    /// The settle tolerance a pass may use for `frac`: `frac` clamped to
    /// `[LOCAL_TOL, 1e-9]` when the plan settles next holes (the condensed coupling),
    /// else `LOCAL_TOL` (NaN too). Why: only the condensed coupling's passes read it
    /// (`statics/pass/condensed.rs`); under the arc and exact couplings, and on a rod
    /// without tensioned cables through disks, a loose value changed nothing but made
    /// every solve that converged from it re-evaluate its point "with settled holes":
    /// one `f64` pass spent on the same arithmetic.
    pub(super) fn settle_tolerance(&self, frac: f64) -> f64 {
        if !self.settles_holes() || frac.is_nan() {
            LOCAL_TOL
        } else {
            frac.clamp(LOCAL_TOL, 1e-9)
        }
    }

    /// A pass here depends on more than the unknowns and `theta`: the condensed
    /// coupling settles the next holes from where the last pass left them. Elsewhere
    /// an evaluation can be kept and restored instead of repeated.
    pub(crate) fn settles_holes(&self) -> bool {
        self.prob.plan.condensed
    }
}

#[cfg(test)]
mod tests {
    use super::LOCAL_TOL;
    use crate::{CableCoupling, Scene};

    /// The settle tolerance is loose only where a pass settles next holes: the FTDCR
    /// v4 scene on the condensed coupling clamps it to `[LOCAL_TOL, 1e-9]`; the same
    /// scene on the arc or exact coupling, whose passes never read it, always gets
    /// `LOCAL_TOL` (a loose value there only cost a confirming pass).
    #[test]
    fn only_a_settling_plan_gets_a_loose_settle_tolerance() {
        let mut scene = Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
        for coupling in [
            CableCoupling::Condensed,
            CableCoupling::Arc,
            CableCoupling::Exact,
        ] {
            scene.numerics.cable_coupling = coupling;
            let ws = scene.tendon_workspace().expect("workspace");
            let ws = ws.workspace();
            let settles = coupling == CableCoupling::Condensed;
            assert_eq!(ws.prob.plan.condensed, settles, "{coupling:?}");
            for (frac, want) in [(1e-12, 1e-12), (1.0, 1e-9), (0.0, LOCAL_TOL)] {
                let want = if settles { want } else { LOCAL_TOL };
                assert_eq!(ws.settle_tolerance(frac), want, "{coupling:?} {frac}");
            }
            assert_eq!(ws.settle_tolerance(f64::NAN), LOCAL_TOL, "{coupling:?}");
        }
    }
}
