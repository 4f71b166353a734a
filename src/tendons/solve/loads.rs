//! Exact sensitivities of a solve from readings with respect to the extra load
//! parameters `phi` (tip force components, payload mass, ...: the sites given to
//! [`TendonWorkspace::with_params`]), for estimating unknown loads
//! (`crate::estimate::TendonLoadEstimator`).
//!
//! At a converged solve every driven tendon satisfies the NCP of the parent module,
//! `G_i(T, phi) = 0`. With the active set held (strict complementarity: each tendon
//! clearly taut or clearly slack), implicit differentiation gives, per taut tendon,
//!
//! ```text
//! c_i dT_i - sum_k (dl_i/dT_k) dT_k - (dl_i/dphi) dphi = 0
//! ```
//!
//! (from `c_i T_i + L_f,i - l_i(T, phi) = 0`, the readings and so `L_f` fixed), and
//! `dT_i = 0` per slack tendon. So `J dT/dphi = B` with `J` the generalized Jacobian
//! of the semi-smooth Newton step (taut row `c_i e_i - dl_i/dT`, slack row
//! `(c_i + a_i) e_i`) and `B` the rows `dl_i/dphi` (taut) or 0 (slack). The path
//! lengths of every cable then change by `dl/dphi = dl/dphi|_T + dl/dT dT/dphi`. The
//! partials `dl/d[T; phi]` at fixed `(T, phi)` are the shooting workspace's exact
//! ones ([`crate::Workspace::length_sensitivities`], implicit differentiation of the
//! shooting problem). With friction the capstan factors are frozen at their last
//! values, as in the forward solve's Jacobian: the result is then not exact (their
//! dependence on the shape is second order in `mu`, parent module docs).

use super::TendonWorkspace;
use crate::error::ModelError;
use crate::loads::Loads;
use crate::robot::Actuation;

impl TendonWorkspace {
    /// Number of extra load parameters (after the tensions).
    pub fn extra_count(&self) -> usize {
        self.tendons.n_extra
    }

    /// Replace the scene's external loads (gravity, point loads and payloads, and
    /// the tensions of tension-driven cables) on a live workspace, keeping its warm
    /// start: the next solve starts from the last converged state, now under these
    /// loads, instead of a new workspace's cold reference solve. Displacement-driven
    /// and passive cables must have tension 0 here (their tensions follow from the
    /// readings, as in [`TendonWorkspace::new`]). Each driven tendon's free length at
    /// reading 0, `L0`, stays the one of the reference solve at construction: a
    /// payload does not change a tendon's length, so the solves that follow are those
    /// of the same robot carrying the new loads (not those of a workspace built from
    /// a scene with these loads, whose reference would fix other `L0`). A pending
    /// rollback is applied first. An invalid value is an error naming the field and
    /// changes nothing. Allocates (a copy of the shooting unknowns and one of the
    /// state for the rollback; when the load structure changes, the inner
    /// workspace's rebuild, [`crate::Workspace::set_loads`], whose straight-rod start
    /// is replaced by the last shape): not for a hot loop.
    pub fn set_loads(&mut self, loads: &Loads) -> Result<(), ModelError> {
        for (j, c) in self.ws.robot().cables().iter().enumerate() {
            if c.actuation != Actuation::Tension && loads.tension(j) != 0.0 {
                return Err(ModelError::Invalid {
                    field: format!("loads.tensions_n[{j}]"),
                    why: format!(
                        "cable `{}` is not tension-driven: its tension follows from the readings (0 here)",
                        c.name
                    ),
                });
            }
        }
        self.apply_rollback();
        let x = self.ws.unknowns_vector().to_vec();
        self.ws.set_loads(loads)?;
        if self.ws.unknowns_vector() != &x[..] {
            // a new load structure rebuilt the shooting workspace from the straight
            // rod: its warm start is the last state's shape (the tensions are kept
            // here), evaluated under the new loads
            self.ws.adopt_unknowns(&x, true);
        }
        // the extrapolation history, the cached lengths and sensitivities belong to
        // the old loads
        self.joint.forget_history();
        self.nested.sens_fresh = false;
        if self.rollback.enabled {
            // the kept state must have the new loads' structure (warm copies need it)
            self.rollback.good = None;
            self.rollback.good = Some(Box::new(self.clone()));
        }
        Ok(())
    }

    /// The readings (m) that mean `q = 0` for every driven tendon (each tendon's
    /// encoder zero offset): the reference state that fixed `L0`.
    pub fn zero_readings(&self) -> Vec<f64> {
        self.tendons.mech.iter().map(|m| m.zero_offset_m).collect()
    }

    /// Check a row of readings without solving: one per driven tendon, finite,
    /// leaving a positive free length (the errors of
    /// [`TendonWorkspace::solve_readings`]).
    pub fn validate_readings(&self, readings_m: &[f64]) -> Result<(), ModelError> {
        self.tendons.check_readings(readings_m)
    }

    /// At the last converged solve: the total sensitivities of every cable's path
    /// length, `dl/dphi` (`dl`, row-major `cables x extra`, m per unit of each
    /// parameter), and of the driven tendons' tensions, `dT/dphi` (`dt`, row-major
    /// `driven x extra`, N per unit), with respect to the extra load parameters
    /// (module docs). One dual sweep of the shooting problem and one LU of the
    /// `driven x driven` generalized Jacobian; no allocation. `false` when the sweep
    /// fails or the Jacobian is singular.
    pub fn load_sensitivities(&mut self, dl: &mut [f64], dt: &mut [f64]) -> bool {
        let (tendons, iter, nb) = (&self.tendons, &mut self.iter, &mut self.nested);
        let p = tendons.driven.len();
        let e = tendons.n_extra;
        let np = iter.theta.len();
        let nc = iter.lengths.len();
        // (the sweep rewrites `lengths`: the next row evaluates its start)
        self.joint.at_solution = false;
        if !self
            .ws
            .length_sensitivities(&mut nb.sens, &mut iter.lengths)
        {
            return false;
        }
        nb.sens_fresh = true;
        // the generalized Jacobian of the Newton step at this point (same rows)
        if !nb.factor_tension_jacobian(tendons, iter) {
            return false;
        }
        for k in 0..e {
            // right-hand side B e_k into the step scratch, then dT/dphi_k
            for i in 0..p {
                let j = tendons.driven[i];
                nb.step[i] = if iter.taut[i] {
                    nb.sens[j * np + p + k]
                } else {
                    0.0
                };
            }
            nb.lu.solve_in_place(&mut nb.step);
            for i in 0..p {
                dt[i * e + k] = if iter.taut[i] { nb.step[i] } else { 0.0 };
            }
            for jc in 0..nc {
                let mut v = nb.sens[jc * np + p + k];
                for i in 0..p {
                    v += nb.sens[jc * np + i] * dt[i * e + k];
                }
                dl[jc * e + k] = v;
            }
        }
        dl.iter().chain(dt.iter()).all(|v| v.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use crate::loads::{Loads, PointLoad};
    use crate::statics::Start;
    use crate::Scene;

    /// A 2 g payload at the FTDCR v4's tip set on a live workspace: the warm row is
    /// the row a cold solve under the same loads gives (to 1 um; seen 0.27 um) in
    /// fewer rod evaluations, from a scene with a 0 kg load site (same structure) and
    /// from one without (a structure change rebuilds the shooting workspace: from its
    /// straight rod the row stalled 21 mm off before the last shape was adopted). A
    /// driven tendon's tension in the loads is refused and changes nothing.
    #[test]
    fn a_payload_on_a_live_workspace_is_solved_warm() {
        let base = Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
        let payload = |m: f64| Loads {
            point: vec![PointLoad {
                section: 2,
                mass_kg: m,
                ..PointLoad::default()
            }],
            ..base.loads.clone()
        };
        let mut q = vec![0.0; 9];
        q[0] = 2e-3;
        q[4] = 1e-3;
        let mut sited = base.clone();
        sited.loads = payload(0.0);
        let mut cold = sited.tendon_workspace().expect("workspace");
        cold.set_loads(&payload(0.002)).expect("valid loads");
        let rc = cold.solve_readings_from(&q, Start::Cold).expect("valid");
        assert!(rc.status.is_converged(), "{rc:?}");
        for scene in [&sited, &base] {
            let mut ws = scene.tendon_workspace().expect("workspace");
            let before = ws.solve_readings(&q).expect("valid");
            assert!(before.status.is_converged(), "{before:?}");
            let tip0 = ws.tip_position();
            ws.set_loads(&payload(0.002)).expect("valid loads");
            let rw = ws.solve_readings(&q).expect("valid");
            assert!(rw.status.is_converged(), "{rw:?}");
            let off = (ws.tip_position() - cold.tip_position()).norm();
            assert!(off < 1e-6, "{off} m from the cold row");
            assert!(
                (ws.tip_position() - tip0).norm() > 5e-5,
                "the payload moves the tip"
            );
            assert!(rw.forward_solves < rc.forward_solves, "{rw:?} vs {rc:?}");
            let mut bad = payload(0.003);
            bad.tensions_n = vec![1.0];
            let e = ws.set_loads(&bad).expect_err("a driven tendon's tension");
            assert!(e.to_string().contains("loads.tensions_n[0]"), "{e}");
            assert_eq!(ws.workspace().loads(), &payload(0.002));
        }
    }
}
