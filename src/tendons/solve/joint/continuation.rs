//! A row that the first Newton step cannot reach (its step is larger than the
//! step limit, or its line search failed): continuation in the readings, the free
//! lengths going from the row's start to the row's in steps each solved by the
//! joint Newton from the last; failing that, once more with a larger step limit;
//! then the nested method (`joint_hand_back`).

use super::super::TendonWorkspace;
use super::MAX_STEP;

/// Step limit of a row's second continuation, when the first (at [`MAX_STEP`])
/// failed (`TendonWorkspace::joint_retry`): three times it.
pub(super) const MAX_STEP_RETRY: f64 = 3.0 * MAX_STEP;
/// Continuation steps of a row aim at first Newton steps of this fraction of the
/// step limit (so that the step's nonlinearity leaves room).
const SUBSTEP_FRACTION: f64 = 0.5;
/// Most continuation steps of one row (a row further away goes to the nested method).
const MAX_SUBSTEPS: usize = 16;
/// Continuation steps (accepted or failed) of one row before it hands back.
const MAX_SUBSTEP_ATTEMPTS: usize = 10;
/// Smallest continuation step, as a fraction of the row's change of readings.
const MIN_SUBSTEP: f64 = 1.0 / 16.0;
/// Merit at which an intermediate continuation step is done (in units of the
/// tolerances, like the merit): it only has to start the next one within Newton's
/// reach, which a residual of 1e4 tolerances (~1e-6 in the scaled unknowns) does.
const SUBSTEP_MERIT: f64 = 1e4;

/// Continuation steps for a row whose first Newton step was `first` (largest
/// component in the scaled shooting unknowns), each aimed at a first step of half
/// the step limit `max_step`: `None` when it is unknown (the first pass or
/// factorisation failed) or needs more than [`MAX_SUBSTEPS`]. At least 2.
fn joint_substeps(first: f64, max_step: f64) -> Option<usize> {
    let k = (first / (SUBSTEP_FRACTION * max_step)).ceil();
    (k.is_finite() && k <= MAX_SUBSTEPS as f64).then_some((k as usize).max(2))
}

impl TendonWorkspace {
    /// The row by continuation in the readings from its start (`joint.x0`, `t0`,
    /// free lengths `joint.free_prev`) to the row's (`joint.free_row`), with steps up
    /// to `joint.max_step`; `false` (with the row's free lengths back) when it failed.
    pub(super) fn joint_continuation(&mut self, first: f64) -> bool {
        let p = self.tendons.driven.len();
        let Some(k_steps) = joint_substeps(first, self.joint.max_step) else {
            return false;
        };
        let mut iterations = self.status.report.iterations;
        self.iter.t.copy_from_slice(&self.joint.t0);
        self.joint.x.copy_from_slice(&self.joint.x0);
        self.joint.x_ok.copy_from_slice(&self.joint.x0);
        self.joint.t_ok.copy_from_slice(&self.joint.t0);
        // adaptive steps in the readings: a failed step is retried at half the size
        // from the last converged one. Why: on the FTDCR v4 val rows that handed back
        // to the nested method, the failure is a tendon going slack within a step
        // (the line search stalls at the kink of the NCP function), and a shorter
        // step crosses the switch with Newton's active-set change instead
        let (mut done, mut ds) = (0.0f64, 1.0 / k_steps as f64);
        let mut attempts = 0;
        while done < 1.0 {
            let s = if done + ds > 1.0 - 1e-12 {
                1.0
            } else {
                done + ds
            };
            for i in 0..p {
                let (a, b) = (self.joint.free_prev[i], self.joint.free_row[i]);
                self.iter.free[i] = a + s * (b - a);
            }
            let tol = if s == 1.0 { 1.0 } else { SUBSTEP_MERIT };
            let out = self.joint_newton(tol, None);
            iterations += self.status.report.iterations;
            attempts += 1;
            if out.is_ok() {
                done = s;
                self.joint.x_ok.copy_from_slice(&self.joint.x);
                self.joint.t_ok.copy_from_slice(&self.iter.t);
                continue;
            }
            ds *= 0.5;
            if attempts >= MAX_SUBSTEP_ATTEMPTS || ds < MIN_SUBSTEP {
                self.iter.free.copy_from_slice(&self.joint.free_row);
                return false;
            }
            self.joint.x.copy_from_slice(&self.joint.x_ok);
            self.iter.t.copy_from_slice(&self.joint.t_ok);
        }
        self.status.report.iterations = iterations;
        true
    }

    /// The row's second continuation, when the first did not reach it: steps up to
    /// [`MAX_STEP_RETRY`] (three times [`MAX_STEP`]); else
    /// [`Self::joint_hand_back`]. Why: [`MAX_STEP`] counts a step's change of the
    /// base force, and a row that releases every tendon changes it by the sum of the
    /// tensions however short the continuation step (a tendon released by more than
    /// its pretension's stretch drops to zero at once). On the 1 620 FTDCR v4 train
    /// rows solved cold, 132 rows (one tendon pulled, the eight others paid out
    /// 6-8 mm and slack) first stepped 130-250 in the scaled unknowns with the right
    /// active set, their continuation steps failed too, and the nested method took
    /// 59 % of all dual right-hand sides of the 1 620 rows. The tighter limit stays
    /// first: on the val rows it is the cheaper way through a row that steps 100-300.
    pub(super) fn joint_retry(&mut self, first: f64) -> bool {
        self.joint_inner_tolerance(0.0);
        self.joint.lu_valid = false;
        self.joint.max_step = MAX_STEP_RETRY;
        let ok = self.joint_continuation(first);
        self.joint.max_step = MAX_STEP;
        ok || self.joint_hand_back()
    }
}
