//! The switch between single shooting (this workspace) and multiple shooting
//! (`statics::multiple`) for large loads.
//!
//! Multiple shooting answers a solve when the loads are ones it handles
//! (`Multi::supports`: no load parameters, no continuous tendon, tensioned cables
//! through consecutive disks) with intensity at most [`MULTI_MAX_INTENSITY`], and
//! - a cold solve (with `continuation`; or a warm one with no solution to start from)
//!   has intensity above [`MULTI_INTENSITY`];
//! - a warm solve above [`MULTI_INTENSITY`] follows a multiple-shooting solution
//!   (at or below it, single shooting takes over again from that solution's base
//!   wrench: faster, and well-conditioned there);
//! - single shooting's cold or warm solve ended without converging (or `unstable`),
//!   with `continuation`, at an intensity above [`MULTI_FALLBACK`] (above
//!   [`MULTI_INTENSITY`] with tensioned cables).
//!
//! So a control loop's warm solves stay on single shooting as long as it converges.
//! Everything the workspace hands out afterwards (tip, base wrench, cable lengths,
//! the [`Solution`], Jacobi's test) comes from the multiple-shooting node states until
//! a solve goes back to single shooting. Sensitivities and the estimator's
//! linearisation stay on single shooting (they run at the moderate loads of a control
//! loop).

use super::*;
use crate::statics::multiple::{MultiArgs, MULTI_INTENSITY, MULTI_MAX_INTENSITY};

/// Intensity above which a failed single-shooting solve is retried by multiple
/// shooting (below, single shooting's own continuation is the answer).
const MULTI_FALLBACK: f64 = 5.0;

impl Workspace {
    fn multi_allowed(&self, intensity: f64) -> bool {
        self.prob.multi_supported && intensity <= MULTI_MAX_INTENSITY
    }

    /// Multiple shooting instead of single shooting for this solve (module docs), or
    /// `None`.
    pub(super) fn multi_first(&mut self, start: Start, intensity: f64) -> Option<SolveReport> {
        if !self.multi_allowed(intensity) {
            self.multi.active = false;
            return None;
        }
        let large = intensity > MULTI_INTENSITY;
        let warm = start == Start::Warm && self.multi.active && self.multi.solver.has_solution();
        let warm_single = start == Start::Warm && !self.multi.active && self.out.has_solution;
        let cold = !warm && !warm_single && self.prob.settings.continuation && large;
        if !((warm && large) || cold) {
            self.multi.active = false;
            return None;
        }
        Some(self.run_multi(warm, intensity))
    }

    /// After single shooting ended with `status`: multiple shooting when it failed
    /// (module docs); its report if it converged, else `None` (single shooting's
    /// state and status stand).
    pub(super) fn multi_fallback(
        &mut self,
        status: SolveStatus,
        intensity: f64,
    ) -> Option<SolveReport> {
        // with tensioned cables only above MULTI_INTENSITY: below, single shooting's
        // status stands (near the tension fold, `T r L/EI` ~ 7.9-8.3, a solve on
        // multiple shooting's finer steps lands 0.1 mm from single shooting's branch
        // point, which `tests/stability.rs` tracks at 1 um)
        let tensioned = self.prob.plan.cables.iter().any(|c| c.tensioned);
        if status.is_converged()
            || !self.prob.settings.continuation
            || intensity <= MULTI_FALLBACK
            || (tensioned && intensity <= MULTI_INTENSITY)
            || !self.multi_allowed(intensity)
        {
            return None;
        }
        let rep = self.run_multi(false, intensity);
        if rep.status.is_converged() {
            Some(rep)
        } else {
            self.multi.active = false;
            None
        }
    }

    fn run_multi(&mut self, warm: bool, intensity: f64) -> SolveReport {
        let args = MultiArgs {
            plan: &self.prob.plan,
            theta: &self.bufs.b64.theta,
            intensity,
            tol: self.it.tol,
            max_iterations: self.prob.settings.max_iterations,
            max_continuation_steps: self.prob.settings.max_continuation_steps,
            jacobi: self.guarded(),
        };
        let rep = self.multi.solver.solve(&args, warm);
        self.multi.active = true;
        // the base wrench as single shooting's unknowns (a warm start if a later
        // solve goes back to it); a failed solve leaves single shooting's state alone
        let (n0, m0) = self.multi.solver.base_wrench();
        let p = &self.prob.plan;
        let converged = rep.status.is_converged();
        if converged && p.closed_form {
            for i in 0..3 {
                self.it.x[i] = m0[i] / p.moment_scale;
            }
        } else if converged && self.it.x.len() >= 6 {
            for i in 0..3 {
                self.it.x[i] = n0[i] / p.force_scale;
                self.it.x[3 + i] = m0[i] / p.moment_scale;
            }
        }
        self.out.has_solution = rep.status.is_converged();
        self.path.last_intensity = intensity;
        self.out.report = rep;
        rep
    }
}
