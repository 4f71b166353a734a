//! The budget of one solve call ([`TendonSettings::max_passes`],
//! [`TendonSettings::time_budget_s`]): where the call stands against it, and what a
//! budgeted call does when the warm joint path does not reach its row.
//!
//! Policy. A budgeted call runs the joint path only (no nested fallback: one nested
//! shooting solve cannot be interrupted by the checks and costs ~10 ms on the FTDCR
//! v4 robot). When the warm joint path hands back, the call spends what is left of
//! its budget on the cold joint path from the reference equilibrium (`x_ref`, the
//! tensions at the pretensions: what `Start::Cold` runs). Why: a row cut short is
//! rolled back, so the next row starts from the last converged one, a step farther
//! away, and the warm path from there needs more passes still; the cold path's cost
//! does not depend on how far the last converged row is. The call stays a function
//! of the warm state and the readings only, so the rollback's guarantee holds: the
//! rows after a failed one are bit-identical to a stream without it.
//!
//! The cap-only policy ([`TendonWorkspace::set_budget_cap_only`]) is for trial
//! points near a converged one: the unbudgeted path, cut where the budget runs
//! out. Why not the policy above for them: on the inverse kinematics' trial steps
//! (`examples/ik_tick_profile.rs 20`, 8 839 ticks, 25 673 forward solves) it
//! skipped the warm continuation that some trials need and sent them to
//! the cold path (budget 100 000: p99 203 passes a solve, was 8; 30 calls out of
//! budget, was 0).
//!
//! [`TendonSettings::max_passes`]: crate::settings::TendonSettings::max_passes
//! [`TendonSettings::time_budget_s`]: crate::settings::TendonSettings::time_budget_s

use super::TendonWorkspace;
use crate::settings::{SolverSettings, TendonSettings};
use std::time::{Duration, Instant};

/// Where the current call stands against its budget (set at the start of every
/// solve: not warm state).
#[derive(Clone, Copy, Default)]
pub(super) struct Budget {
    /// The cap-only policy ([`TendonWorkspace::set_budget_cap_only`]); kept
    /// across calls (configuration).
    cap_only: bool,
    /// A budget is set (`max_passes` or `time_budget_s`).
    pub(super) limited: bool,
    /// `time_budget_s` after the call's start.
    deadline: Option<Instant>,
    /// The budget ran out: every later evaluation of this call is refused.
    pub(super) spent: bool,
}

impl Budget {
    /// Start the call's budget under `settings`.
    pub(super) fn begin(&mut self, settings: &SolverSettings) {
        let s = &settings.tendons;
        *self = Budget {
            cap_only: self.cap_only,
            limited: s.max_passes.is_some() || s.time_budget_s.is_some(),
            deadline: s
                .time_budget_s
                .map(|t| Instant::now() + Duration::from_secs_f64(t)),
            spent: false,
        };
    }

    /// Under a budget the warm joint path (`cold` false) is the row's predictor and
    /// Newton from the last converged row only: when they do not reach the row, the
    /// cold path follows at once instead of the warm continuation in the readings
    /// (module docs).
    pub(super) fn skips_continuation(&self, cold: bool) -> bool {
        self.steers() && !cold
    }

    /// The budget chooses the path (the policy above): a budget is set and the
    /// cap-only policy is off.
    pub(super) fn steers(&self) -> bool {
        self.limited && !self.cap_only
    }

    /// May this call, with `passes` rod evaluations run, run one more? `false` once
    /// its budget ([`TendonSettings::max_passes`], `time_budget_s`) is spent; the
    /// call then ends with [`SolveStatus::BudgetExhausted`] (`Status::conclude`).
    /// No allocation.
    ///
    /// [`TendonSettings::max_passes`]: crate::settings::TendonSettings::max_passes
    /// [`SolveStatus::BudgetExhausted`]: crate::statics::SolveStatus::BudgetExhausted
    pub(super) fn allows(&mut self, settings: &TendonSettings, passes: usize) -> bool {
        if self.spent {
            return false;
        }
        let spent = settings.max_passes.is_some_and(|m| passes >= m)
            || self.deadline.is_some_and(|d| Instant::now() >= d);
        self.spent = spent;
        !spent
    }

    /// After the joint paths did not converge: does the budget end the call here?
    /// It does whenever a budget is set: a budgeted call does not run the nested
    /// fallback (module docs). The call then ends with `BudgetExhausted`.
    pub(super) fn ends_call(&mut self) -> bool {
        if self.steers() {
            self.spent = true;
        }
        self.spent
    }
}

impl TendonWorkspace {
    /// The cap-only policy of a budgeted call (off by default): the path of an
    /// unbudgeted call (the warm joint path with its continuation in the readings,
    /// then the nested fallback), stopped where the budget runs out (`within_budget`
    /// is checked before every rod evaluation and every nested shooting solve;
    /// each nested shooting solve counts as one). Up to that point the call is the
    /// unbudgeted one, so a call that ends within the budget is unchanged. For a
    /// caller whose solves are trial points near a converged one, which it would
    /// rather reject than solve at any cost (the inverse kinematics' trial steps,
    /// `command::ik`). No effect without a budget.
    pub fn set_budget_cap_only(&mut self, on: bool) {
        self.budget.cap_only = on;
    }

    /// The warm joint path handed back within the budget: the cold path from the
    /// reference gets the rest (module docs). Sets the tensions to the pretensions.
    pub(super) fn budget_second_chance(&mut self) {
        for (t, m) in self.iter.t.iter_mut().zip(&self.tendons.mech) {
            *t = m.pretension_n;
        }
        self.joint.cold = true;
    }

    /// [`Budget::allows`] one more rod evaluation of this call.
    pub(super) fn within_budget(&mut self) -> bool {
        let passes = self.status.report.forward_solves;
        self.budget.allows(&self.ws.settings().tendons, passes)
    }
}
