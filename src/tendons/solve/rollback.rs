//! The rollback of a failed solve: the warm state kept before each solve and
//! restored before the next one when it did not converge
//! ([`TendonWorkspace::set_rollback`]).

use super::TendonWorkspace;

/// What a [`TendonWorkspace`] keeps to roll a failed solve back (the policy is on
/// [`TendonWorkspace::set_rollback`]).
#[derive(Clone)]
pub(super) struct Rollback {
    pub(super) enabled: bool,
    /// The whole warm state at the start of the current solve: the state the last
    /// converged solve left (or the reference), with the caller's changes since.
    pub(super) good: Option<Box<TendonWorkspace>>,
    /// The last solve did not converge: the next solve (or change of the
    /// workspace) starts from `good`.
    pub(super) pending: bool,
}

impl TendonWorkspace {
    /// Rollback policy (on by default). On: a solve that does not converge leaves
    /// the warm state as it was before that solve, i.e. as the last converged solve
    /// (or the construction's reference solve) left it, with any change the caller
    /// made since (settings, extra parameters, loads through
    /// [`TendonWorkspace::workspace_mut`]). The rows after a failed one are then
    /// bit-identical to the same rows of a stream without it. The failed attempt
    /// stays readable through the `&self` accessors ([`TendonWorkspace::report`],
    /// [`TendonWorkspace::tip_position`], [`TendonWorkspace::tensions`],
    /// [`TendonWorkspace::diagnose`], `workspace_mut().solution()`) until the next
    /// solve, `set_extra`, `set_tendon_settings` or [`TendonWorkspace::apply_rollback`],
    /// which first restore the kept state. The cost is one copy per solve of the
    /// state a later solve reads (no allocation; the pass buffers' scratch is not
    /// copied: `PassBuf::warm_copy_uncondensed`), about 1 % of a warm FTDCR v4
    /// row. Off: the next solve starts from wherever the failed one stopped (what a
    /// caller with its own policy, e.g. an estimator's inner
    /// iterations, wants). Turning it off drops a pending rollback.
    /// (Turning it on allocates the kept copy, off frees it.)
    pub fn set_rollback(&mut self, on: bool) {
        self.rollback.enabled = on;
        if on {
            if self.rollback.good.is_none() {
                self.rollback.good = Some(Box::new(self.clone()));
            }
        } else {
            self.rollback.pending = false;
            self.rollback.good = None;
        }
    }

    /// This workspace with the rollback off ([`TendonWorkspace::set_rollback`]).
    pub fn without_rollback(mut self) -> Self {
        self.set_rollback(false);
        self
    }

    /// Whether the rollback policy is on ([`TendonWorkspace::set_rollback`]).
    pub fn rollback(&self) -> bool {
        self.rollback.enabled
    }

    /// The last solve did not converge and its warm state will be replaced by the
    /// kept one at the next `&mut` call ([`TendonWorkspace::set_rollback`]).
    pub fn rollback_pending(&self) -> bool {
        self.rollback.pending
    }

    /// Restore the kept state now if a rollback is pending (no allocation).
    pub fn apply_rollback(&mut self) {
        use crate::math::warm::WarmCopy;
        if !self.rollback.pending {
            return;
        }
        self.rollback.pending = false;
        if let Some(good) = self.rollback.good.take() {
            WarmCopy::warm_copy_from(self, &*good);
            self.rollback.good = Some(good);
            // what the copy leaves out is not read before it is written again:
            // debug builds check it (NaN there would reach the results)
            if cfg!(debug_assertions) {
                self.ws.poison_uncopied();
                self.joint.poison_scratch();
            }
        }
    }

    /// Keep the current state as the one to return to (no allocation).
    pub(super) fn keep_state(&mut self) {
        use crate::math::warm::WarmCopy;
        if let Some(mut good) = self.rollback.good.take() {
            WarmCopy::warm_copy_from(&mut *good, &*self);
            self.rollback.good = Some(good);
        }
    }
}
