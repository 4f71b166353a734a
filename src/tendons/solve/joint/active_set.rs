//! The active set of a fresh joint step from its own linearisation.
//!
//! A fresh step is the semi-smooth Newton step of the generalized Jacobian whose
//! tendon rows follow the iterate's active set (taut: the stretch gap, slack: the
//! tension). When a tendon is about to switch, that step predicts the switch
//! itself: a taut tendon's tension crosses zero, or a slack tendon's linearised
//! stretch gap goes negative (its path would outgrow its free length). This module
//! then solves the linearised complementarity problem exactly, by the primal-dual
//! active-set method (Hintermüller, Ito & Kunisch 2002, "The primal-dual active set
//! strategy as a semismooth Newton method", SIAM J. Optim. 13(3)): flip the
//! violating tendons, step again from the same iterate and the same sweep, until
//! the step's active set agrees with its own prediction. Each round costs one
//! `m x m` factorisation (`m` ~15), nothing beside a pass.
//!
//! Why: a cold row starts from the reference equilibrium (every tendon taut), and a
//! row whose tendons go slack then spent fresh sweeps on active sets that the first
//! linearisation already ruled out (val row 147: three sweeps, eleven trial passes
//! backtracking to 1/16 of a step that slackened four tendons and tautened one
//! back). Measured with the FTDCR v4 scene (`examples/tendon_profile`, counts a row,
//! before -> after): the 443 val rows cold, `f64` right-hand sides 10 215 -> 5 231,
//! dual 458.9 -> 212.4; row 147 solved cold again and again, passes 18 -> 10, dual
//! 360 -> 240, 18.22 M -> 8.80 M instructions (callgrind); the 443 val rows warm,
//! 2 256 -> 2 191 and 116.7 -> 105.9, 2.321e9 -> 2.207e9 instructions; the 1 620
//! train rows warm, 2 223 -> 2 012 and 105.9 -> 87.6. Every tip within 1.9e-11 m of
//! the old one, every taut flag equal; 5 000 ticks of the 1 kHz loop bit-identical.

use super::super::{Iterate, Tendons};
use super::JointBufs;

/// Most active-set rounds on one linearisation (the method can cycle when the
/// Jacobian is not an M-matrix; the step's own set is kept then).
const ROUNDS: usize = 8;

impl JointBufs {
    /// Replace the fresh step `dz` (active set `lu_taut`, from `newton_step`) by
    /// the step whose active set solves the linearised complementarity problem
    /// (module docs); unchanged when none is found. Needs the iterate's branches
    /// (`save_branches`) and `ts` = the tensions of `it`.
    pub(super) fn linear_active_set(&mut self, td: &Tendons, it: &Iterate) {
        let (n, p) = (self.x.len(), td.driven.len());
        let w = n + it.theta.len();
        let m = n + p;
        self.sw_taut.copy_from_slice(&self.lu_taut);
        self.sw_dz.copy_from_slice(&self.dz);
        self.sw_f.copy_from_slice(&self.f_prev);
        for round in 0..=ROUNDS {
            // the tendons whose predicted branch disagrees with the assumed one
            let mut flipped = false;
            for (i, &j) in td.driven.iter().enumerate() {
                let flip = if self.lu_taut[i] {
                    self.ts[i] + self.dz[n + i] < 0.0
                } else {
                    let c =
                        td.mech[i].tangent_compliance(it.free[i], self.ts[i], it.mean_factor[i]);
                    let row = &self.jac_m[j * w..j * w + m];
                    let dl: f64 = row.iter().zip(&self.dz).map(|(a, b)| a * b).sum();
                    self.gap0[i] + c * self.dz[n + i] - dl < 0.0
                };
                if flip {
                    self.lu_taut[i] = !self.lu_taut[i];
                    flipped = true;
                }
            }
            if !flipped {
                return;
            }
            if round == ROUNDS || !self.step_with_set(td, it) {
                break;
            }
        }
        // no consistent set: the step's own
        self.unswitch(td, it);
    }

    /// Newton's step from the iterate (`xs`, `ts`, its branches from
    /// `save_branches`) with the active set `lu_taut` on the last sweep: the tendon
    /// rows of the residual are each tendon's branch in that set (the stretch gap
    /// when taut, the slack arm when slack); a slack tendon's step is exactly
    /// `-T_i`. `false` when that Jacobian is singular.
    fn step_with_set(&mut self, td: &Tendons, it: &Iterate) -> bool {
        let (n, p) = (self.x.len(), td.driven.len());
        let m = n + p;
        for i in 0..p {
            self.f_prev[n + i] = if self.lu_taut[i] {
                self.gap0[i]
            } else {
                self.arm0[i]
            };
        }
        if !self.assemble(td, it) {
            return false;
        }
        for (d, row) in self.dz.iter_mut().zip(self.h.chunks_exact(m)) {
            *d = -row
                .iter()
                .zip(&self.f_prev)
                .map(|(a, b)| a * b)
                .sum::<f64>();
        }
        for i in 0..p {
            if !self.lu_taut[i] {
                self.dz[n + i] = -self.ts[i];
            }
        }
        true
    }

    /// The iterate's two branches of each tendon's NCP function (the stretch gap
    /// `c_i T_i + L_f,i - l_i` and the slack arm `a_i T_i`), before a fresh step's
    /// trials overwrite the lengths.
    pub(super) fn save_branches(&mut self, td: &Tendons, it: &Iterate) {
        for (i, &j) in td.driven.iter().enumerate() {
            let m = &td.mech[i];
            let (f, mf) = (it.free[i], it.mean_factor[i]);
            self.gap0[i] = m.covered(f, it.t[i], mf) - it.lengths[j];
            self.arm0[i] = (m.compliance(f, mf) + td.geo[i]) * it.t[i];
        }
    }

    /// After a fresh step whose full-length trial changed the active set (to that
    /// of `it`, and was not accepted): the semi-smooth Newton step from the iterate
    /// with the trial's active set, from the same sweep (the generalized Jacobian's
    /// rows of the switched tendons exchanged, no new sweep). `false` (the step's
    /// own set restored) when that Jacobian is singular or the step too long. Why:
    /// on the FTDCR v4 val rows where a tendon goes slack within a row, the
    /// projected step (a taut tendon's tension clamped at 0) raised the merit
    /// 14-50x and the backtracking then crept along at 0.5-0.97 of it per fresh
    /// sweep until the row was handed back.
    pub(super) fn switch_step(&mut self, td: &Tendons, it: &Iterate) -> bool {
        self.sw_taut.copy_from_slice(&self.lu_taut);
        self.sw_dz.copy_from_slice(&self.dz);
        self.sw_f.copy_from_slice(&self.f_prev);
        self.lu_taut.copy_from_slice(&it.taut);
        let ok = self.step_with_set(td, it) && {
            let dx_max = self.step_max(self.x.len());
            dx_max.is_finite() && dx_max <= self.max_step
        };
        if !ok {
            self.unswitch(td, it);
        }
        ok
    }

    /// Undo [`Self::switch_step`]: the step, residual and factorisation of the
    /// step's own active set.
    pub(super) fn unswitch(&mut self, td: &Tendons, it: &Iterate) {
        self.lu_taut.copy_from_slice(&self.sw_taut);
        self.dz.copy_from_slice(&self.sw_dz);
        self.f_prev.copy_from_slice(&self.sw_f);
        self.assemble(td, it);
    }
}
