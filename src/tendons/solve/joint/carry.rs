//! The Broyden-updated inverse carried over to another active set, without a sweep.
//!
//! The generalized Jacobian's rows (module docs of `joint`) are the shooting rows,
//! one taut row `[-dl_i/dx, c_i e_i - dl_i/dT]` per taut tendon and the exact row
//! `a_i e_i` per slack one. A chord step reuses `H`, the inverse of the last sweep's
//! Jacobian improved by Broyden's updates since, only while the active set is the
//! one `H` was made for. When a tendon has switched since (between rows, the usual
//! case), this recovers the improved Jacobian `J = H^-1` (one `m x m`
//! factorisation, `m = n + p` ~15), exchanges the switched tendons' rows (a slack
//! row is exact; a taut row comes from the last sweep's partials: `tendon_row`, as
//! in `JointBufs::assemble`) and inverts again: two small factorisations instead of a
//! sweep (~9 `f64` passes on the FTDCR v4 scene). The chord step from it is tried
//! like any other, and a fresh sweep follows when it fails.
//!
//! Why: on the 443 FTDCR v4 val rows warm (3 laps), half the sweeps (218 of 415)
//! were taken only because the active set had changed since the last one. Measured
//! with `examples/tendon_profile` (`f64` / dual RHS a row; pass units `f64` / 120 +
//! 9.4 x dual / 120, a sweep costing ~9.4 passes):
//!
//! | rows | before | carried at a row's start (kept) | carried at every iteration |
//! |---|---|---|---|
//! | val, scene tolerances | 558 / 37.5, 7.59 | 579 / 31.3, 7.28 | 583 / 30.2, 7.22 |
//! | train | 521 / 27.0, 6.46 | 543 / 21.3, 6.19 | 547 / 20.2, 6.13 |
//! | val, tolerances 1e-10 / 1e-12 m | 1 076 / 45.8, 12.55 | 1 094 / 38.2, 12.11 | 1 115 / 39.3, 12.37 |
//!
//! Cold rows and 1 kHz ticks follow other rules (unchanged). Tried and not kept:
//! also solving the chord step's own active set on the carried inverse at a row's
//! start (the primal-dual search of `active_set`): 7.02 on val, 12.07 at the tight
//! tolerances; but its sign tests on a stale Jacobian made the solves at nearby
//! parameters take different paths, and the central differences of
//! `tests/calibrate_exact_sensitivities.rs` (through full solves) moved 9.5e-6 from
//! the exact sensitivities where the test allows 9.4e-6 (this way: 7.0e-7; before:
//! 5.7e-7). Carrying at every iteration: 3.3e-6 there.

use super::super::{Iterate, Tendons};
use super::jacobian::{factor_and_invert, tendon_row};
use super::JointBufs;

impl JointBufs {
    /// Carry the reused inverse `H` (made for the active set `lu_taut`) over to the
    /// iterate's active set (of `it`, module docs). `false` when a factorisation is
    /// singular; then `lu_valid` is false and a fresh sweep follows.
    pub(super) fn carry_to_iterate(&mut self, td: &Tendons, it: &Iterate) -> bool {
        let (n, p) = (self.x.len(), td.driven.len());
        let m = n + p;
        let w = n + it.theta.len();
        self.lu.matrix_mut().copy_from_slice(&self.h);
        if !factor_and_invert(&mut self.lu, &mut self.jinv) {
            self.lu_valid = false;
            return false;
        }
        for (i, &j) in td.driven.iter().enumerate() {
            let taut = it.taut[i];
            if self.lu_taut[i] == taut {
                continue;
            }
            let row = &mut self.jinv[(n + i) * m..(n + i + 1) * m];
            let c = td.compliance(i, taut, it.free[i], it.t[i], it.mean_factor[i]);
            let sweep_row = &self.jac_m[j * w..j * w + m];
            tendon_row(row, n + i, taut, sweep_row, c, td.geo[i]);
        }
        self.lu_taut.copy_from_slice(&it.taut);
        self.lu.matrix_mut().copy_from_slice(&self.jinv);
        self.lu_valid = factor_and_invert(&mut self.lu, &mut self.h);
        self.lu_valid
    }
}

#[cfg(test)]
mod tests {
    use crate::math::broyden::{inverse_update, SkipTest, TailWeight};
    use crate::math::DenseLu;
    use crate::Scene;

    /// Largest entry of `a - b` against the largest of `b`.
    fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
        let top = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
            / top
    }

    /// The inverse of the row-major `m x m` matrix `a`.
    fn inverse(a: &[f64], m: usize) -> Vec<f64> {
        let mut lu = DenseLu::new(m);
        lu.matrix_mut().copy_from_slice(a);
        assert!(lu.factor().is_some());
        let mut inv = vec![0.0; m * m];
        lu.inverse_into(&mut inv);
        inv
    }

    /// On the shipped FTDCR v4 scene at a solved row with a slack tendon, to the set
    /// with the first taut tendon slack and the first slack one taut:
    /// - from a freshly swept inverse, the carried inverse is the one assembled for
    ///   that set from the same sweep (1e-9 of its largest entry: two 15 x 15
    ///   inversions' round-off, condition ~1e4);
    /// - after a Broyden update, the carried Jacobian keeps the updated one's rows
    ///   of the shooting residual and of the tendons that kept their branch (1e-9),
    ///   its new slack row is exactly `a_i e_i` and its new taut row the sweep's.
    #[test]
    fn a_carried_inverse_is_the_inverse_of_the_exchanged_rows() {
        let scene = Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
        let mut tw = scene.tendon_workspace().expect("workspace");
        let (n, p) = (tw.ws.unknowns(), tw.tendons.driven.len());
        let (m, w) = (n + p, n + tw.iter.theta.len());
        let mut q = vec![0.0; p];
        q[0] = 0.002;
        q[3] = -0.004;
        assert!(tw.solve_readings(&q).expect("valid").status.is_converged());
        tw.joint.x.copy_from_slice(tw.ws.unknowns_vector());
        assert!(tw.joint_evaluate().is_some());
        assert!(tw.joint.factor(&mut tw.ws, &tw.tendons, &tw.iter));
        let set0 = tw.joint.lu_taut.clone();
        let to_slack = set0.iter().position(|&t| t).expect("a taut tendon");
        let to_taut = set0.iter().position(|&t| !t).expect("a slack tendon");
        let mut set1 = set0.clone();
        set1[to_slack] = false;
        set1[to_taut] = true;
        // from the sweep's inverse: carried against assembled
        tw.iter.taut.copy_from_slice(&set1);
        assert!(tw.joint.carry_to_iterate(&tw.tendons, &tw.iter));
        let carried = tw.joint.h.clone();
        tw.joint.lu_taut.copy_from_slice(&set1);
        assert!(tw.joint.assemble(&tw.tendons, &tw.iter));
        let d = rel_diff(&carried, &tw.joint.h);
        assert!(d < 1e-9, "carried vs assembled: {d:e}");
        // after a Broyden update whose secant differs from the sweep's Jacobian
        // (as a nonlinear residual's does) on every row but the slack ones
        tw.joint.lu_taut.copy_from_slice(&set0);
        assert!(tw.joint.assemble(&tw.tendons, &tw.iter));
        let j0 = inverse(&tw.joint.h, m);
        let s: Vec<f64> = (0..m).map(|k| 0.01 * (k as f64 + 1.0).sin()).collect();
        let mut y: Vec<f64> = (0..m)
            .map(|r| (0..m).map(|k| j0[r * m + k] * s[k]).sum())
            .collect();
        for (k, yk) in y.iter_mut().enumerate() {
            if k < n || set0[k - n] {
                *yk *= 1.0 + 0.05 * (k as f64 + 0.3).cos();
            }
        }
        let (mut hy, mut sth) = (vec![0.0; m], vec![0.0; m]);
        inverse_update(
            &mut tw.joint.h,
            &s,
            &y,
            TailWeight::NONE,
            SkipTest::StepLength,
            &mut hy,
            &mut sth,
        );
        let updated = inverse(&tw.joint.h, m);
        assert!(rel_diff(&updated, &j0) > 1e-6, "the update changed nothing");
        assert!(tw.joint.carry_to_iterate(&tw.tendons, &tw.iter));
        assert_eq!(tw.joint.lu_taut, set1);
        let j1 = inverse(&tw.joint.h, m);
        for r in 0..m {
            let row = &j1[r * m..(r + 1) * m];
            if r == n + to_slack {
                let i = to_slack;
                let a = tw.tendons.mech[i].compliance(tw.iter.free[i], tw.iter.mean_factor[i])
                    + tw.tendons.geo[i];
                for (k, v) in row.iter().enumerate() {
                    let want = if k == r { a } else { 0.0 };
                    assert!((v - want).abs() < 1e-9 * a, "slack row, column {k}: {v}");
                }
            } else if r == n + to_taut {
                let (i, j) = (to_taut, tw.tendons.driven[to_taut]);
                let c = tw.tendons.mech[i].compliance(tw.iter.free[i], tw.iter.mean_factor[i]);
                let sweep: Vec<f64> = (0..m)
                    .map(|k| -tw.joint.jac_m[j * w + k] + if k == r { c } else { 0.0 })
                    .collect();
                let d = rel_diff(row, &sweep);
                assert!(d < 1e-9, "taut row: {d:e}");
            } else {
                let d = rel_diff(row, &updated[r * m..(r + 1) * m]);
                assert!(d < 1e-9, "row {r} kept: {d:e}");
            }
        }
    }
}
