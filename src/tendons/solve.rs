//! Forward solve from actuator readings: the tendon conditions `G(T) = 0` of the
//! displacement-driven tendons and the shooting problem, solved by the joint Newton
//! path (`joint` submodule: shooting unknowns and tensions together) and, when it
//! hands back, by the nested method (`nested` submodule: semi-smooth Newton on the
//! tensions around converged shooting solves). This module holds the workspace, the
//! residual `G` they share, and the friction factors.
//!
//! Unknowns: the tensions `T` of the `p` displacement-driven tendons (load
//! parameters of the inner [`Workspace`], so the shooting Newton sees them as cable
//! tensions). Residual, per tendon, in metres (the NCP "min" function):
//!
//! ```text
//! G_i(T) = min( a_i T_i ,  c_i(L_f) T_i + L_f,i - l_i(T) )
//! ```
//!
//! with `c_i` the compliance (`L_f/EA_t + 1/k_s`, [`TendonMechanics::compliance`]),
//! `l_i(T)` the path length of the equilibrium at `T` and `a_i = c_i + r_i^2 L/EI` a
//! positive scale (any positive scale gives the same solution set; this one keeps
//! both branches in the same units and well scaled for inextensible tendons).
//! `G_i = 0` is exactly "taut with `T_i = (l_i - L_f,i)/c_i >= 0`" or "slack with
//! `T_i = 0` and `l_i <= L_f,i`". The generalized Jacobian row is `c_i e_i - dl_i/dT`
//! on the taut side (exact, from [`Workspace::length_sensitivities`]) and `a_i e_i`
//! on the slack side; steps are projected onto `T >= 0` and damped by a
//! backtracking line search on `|G|`.
//!
//! Friction (capstan factors per chord, [`super::capstan_factors`]) is coupled by a
//! lagged (Picard) update: the factors of the last equilibrium are frozen during a
//! Newton step and refreshed after it; the iteration ends when `G` is below
//! tolerance and the factors no longer change. The derivatives of the factors with
//! respect to the shape are not in the Jacobian (they are second order in `mu`
//! times the change of wrap angle per step).

use super::TendonMechanics;
use crate::error::ModelError;
pub use crate::settings::TendonSettings;
use crate::statics::{SolveStatus, Start, Workspace};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Joint solves per row while the capstan factors settle (the lagged friction
/// coupling's fixed point, [`TendonWorkspace::solve_joint_settled`]); then the
/// nested method. Each round after the first starts at the last equilibrium, so it
/// costs one or two Newton iterations; the factors' change contracts by about
/// `mu` times the wrap angle's sensitivity to the tension per round.
const FRICTION_ROUNDS: usize = 12;

// The warm fast path: Newton on the shooting unknowns and tensions together.
mod joint;
// The nested method: a converged shooting solve per tension iterate (the fallback).
mod nested;
// Sensitivities with respect to extra load parameters (load estimation).
mod loads;
// Why a row did not converge, with the tendons named by their readings columns.
mod diagnose;
// The budget of one call (`TendonSettings::max_passes`, `time_budget_s`).
mod budget;
// Construction and the reference solve at the pretensions.
mod build;
// The rollback of a failed solve.
mod rollback;
use rollback::Rollback;
// The capstan friction's state per tendon.
mod friction;

/// Outcome of one solve from readings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TendonReport {
    /// `converged` when both the shooting problem and the tendon conditions hold.
    pub status: SolveStatus,
    /// Newton iterations on the tensions.
    pub iterations: usize,
    /// `max_i |G_i|` at the returned point (m).
    pub residual_m: f64,
    /// Shooting solves and joint passes run (line-search trials included).
    pub forward_solves: usize,
    /// Of those, nested shooting solves (full Newton solves at fixed tensions; the
    /// rest are the joint path's single passes): what
    /// [`TendonSettings::max_shooting_solves`] bounds.
    pub shooting_solves: usize,
    /// Tendons that are slack at the returned point.
    pub slack: usize,
}

/// A robot driven by actuator readings: allocate once, solve every row. Its state
/// is in parts, each file working on the parts it names (docs/architecture.md).
#[derive(Clone)]
pub struct TendonWorkspace {
    /// The inner shooting workspace (its tensions are the driven tendons').
    ws: Workspace,
    tendons: Tendons,
    iter: Iterate,
    friction: friction::Friction,
    nested: nested::NestedBufs,
    joint: joint::JointBufs,
    status: Status,
    /// The warm state to return to after a solve that did not converge.
    rollback: Rollback,
    /// The current call's budget ([`TendonSettings::max_passes`], `time_budget_s`).
    budget: budget::Budget,
}

/// The driven tendons: configuration, fixed once the reference is solved.
#[derive(Clone)]
struct Tendons {
    /// Cable index of each displacement-driven tendon.
    driven: Vec<usize>,
    mech: Vec<TendonMechanics>,
    /// Columns of the readings, per driven tendon.
    columns: Vec<String>,
    /// `L0` per driven tendon (m).
    free0: Vec<f64>,
    /// Scale `a_i` of the slack branch (m/N) without the tendon's own compliance.
    geo: Vec<f64>,
    /// Extra load parameters (after the tensions in `Iterate::theta`).
    n_extra: usize,
    /// Scaled shooting unknowns of the reference equilibrium (zero readings, the
    /// pretensions): where a cold solve's joint path starts.
    x_ref: Vec<f64>,
}

/// The point of the tension iterate: the free lengths it belongs to, the tensions,
/// the path lengths evaluated there and the residual `G` with its active set.
#[derive(Clone)]
struct Iterate {
    /// `L_f = L0 - q` for the current readings (m).
    free: Vec<f64>,
    /// Tensions of the driven tendons (N).
    t: Vec<f64>,
    /// Full parameter vector of the inner workspace: tensions, then `extra`.
    theta: Vec<f64>,
    /// Path lengths of all cables (m), and the length-weighted mean capstan factor of
    /// each tendon's chords (`Friction::refresh`): what `G` is evaluated with.
    lengths: Vec<f64>,
    mean_factor: Vec<f64>,
    /// Residual `G` and the taut flags (module docs).
    g: Vec<f64>,
    taut: Vec<bool>,
}

/// The outcome of the current call: its report, whose status the paths record as
/// they end and [`Status::conclude`] decides.
#[derive(Clone, Copy)]
struct Status {
    report: TendonReport,
    /// A converged solve (or the reference) left a point to start warm from.
    has_solution: bool,
}

crate::math::warm::warm_by_copy!(TendonReport, Status);

impl crate::math::warm::WarmCopy for TendonWorkspace {
    /// The state a solve changes; the tendons' configuration, the friction law and
    /// the rollback's own copy stay as they are.
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src, copy: [
            ws, iter, friction, nested, status, joint,
        ], keep: [tendons, rollback, budget]);
    }
}

impl crate::math::warm::WarmCopy for Iterate {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src,
            copy: [free, t, theta, lengths, mean_factor, g, taut], keep: []);
    }
}

impl TendonReport {
    /// Nothing solved or counted yet, with `status`.
    fn unsolved(status: SolveStatus) -> Self {
        Self {
            status,
            iterations: 0,
            residual_m: f64::INFINITY,
            forward_solves: 0,
            shooting_solves: 0,
            slack: 0,
        }
    }
}

impl TendonWorkspace {
    /// Replace the tendon settings (they start as the scene's `numerics.tendons`).
    /// Checked as a scene's are ([`TendonSettings::validate`]): an error names the
    /// field, and the settings in effect stay as they were.
    pub fn set_tendon_settings(&mut self, settings: TendonSettings) -> Result<(), ModelError> {
        settings.validate()?;
        self.apply_rollback();
        self.ws.set_tendon_settings(settings);
        Ok(())
    }
    /// The tendon settings in effect: the inner workspace's
    /// [`SolverSettings::tendons`], their only copy (so that
    /// `workspace().settings()` and a `workspace_mut().set_settings(..)` agree with
    /// what this workspace runs).
    pub fn tendon_settings(&self) -> &TendonSettings {
        &self.ws.settings().tendons
    }
    /// Cable indices of the displacement-driven tendons, in reading order.
    pub fn driven(&self) -> &[usize] {
        &self.tendons.driven
    }
    /// Readings column of each driven tendon.
    pub fn columns(&self) -> &[String] {
        &self.tendons.columns
    }
    /// Mechanics of each driven tendon (stiffness, series spring, pretension).
    pub fn mechanics(&self) -> &[TendonMechanics] {
        &self.tendons.mech
    }
    /// Free length `L0` of each driven tendon at reading 0 (m).
    pub fn rest_free_lengths(&self) -> &[f64] {
        &self.tendons.free0
    }
    /// Tensions of the driven tendons at the last solve (N).
    pub fn tensions(&self) -> &[f64] {
        &self.iter.t
    }
    /// Whether each driven tendon is taut at the last solve.
    pub fn taut(&self) -> &[bool] {
        &self.iter.taut
    }
    /// Report of the last solve.
    pub fn report(&self) -> &TendonReport {
        &self.status.report
    }
    /// The inner shooting workspace (shape, lengths, solution).
    pub fn workspace(&self) -> &Workspace {
        &self.ws
    }
    /// The inner shooting workspace, mutable (e.g. to read a full `solution()`: after
    /// a solve that did not converge, the failed attempt's). To change its loads or
    /// settings after such a solve, call [`TendonWorkspace::apply_rollback`] first
    /// (else the rollback restores the solver's caches of the earlier loads under the
    /// new ones).
    pub fn workspace_mut(&mut self) -> &mut Workspace {
        &mut self.ws
    }
    /// Tip position of the last solve (m).
    pub fn tip_position(&self) -> Vector3<f64> {
        self.ws.tip_position()
    }
    /// Path lengths of all cables at the last solve (m).
    pub fn lengths(&self) -> &[f64] {
        &self.iter.lengths
    }
    /// Friction direction state of each driven tendon (-1 pulled in, +1 paid out, 0
    /// rest; in between while turning round under `robot.friction.slide_m`).
    pub fn friction_direction(&self) -> &[f64] {
        &self.friction.sign
    }
    /// Forget the friction's direction memory: every driven tendon at rest (direction
    /// 0) with its last reading 0, as at construction. The next solve's friction
    /// then depends on its own readings only, not on the rows solved before.
    pub fn forget_direction_memory(&mut self) {
        self.friction.forget_direction_memory();
    }

    /// Values of the extra load parameters (after the tensions).
    pub fn set_extra(&mut self, extra: &[f64]) {
        self.apply_rollback();
        let p = self.tendons.driven.len();
        self.joint.forget_history();
        for (k, v) in extra.iter().enumerate().take(self.tendons.n_extra) {
            self.iter.theta[p + k] = *v;
        }
    }

    /// Solve from the readings of the driven tendons (m, in [`Self::driven`]
    /// order), warm-started from the previous solve. No allocation.
    pub fn solve_readings(&mut self, readings_m: &[f64]) -> Result<TendonReport, ModelError> {
        self.solve_readings_from(readings_m, Start::Warm)
    }

    /// [`TendonWorkspace::solve_readings`] with a chosen start (`Cold` restarts the
    /// shooting from the straight rod and the tensions from the pretensions).
    /// A solve that does not converge is rolled back before the next one
    /// ([`TendonWorkspace::set_rollback`]); invalid readings are an error that
    /// changes nothing.
    pub fn solve_readings_from(
        &mut self,
        readings_m: &[f64],
        start: Start,
    ) -> Result<TendonReport, ModelError> {
        self.tendons.check_readings(readings_m)?;
        if self.rollback.enabled {
            if self.rollback.pending {
                self.apply_rollback();
            } else {
                self.keep_state();
            }
        }
        let report = self.solve_checked(readings_m, start);
        self.rollback.pending = self.rollback.enabled && !report.status.is_converged();
        Ok(report)
    }

    /// The solve of checked readings.
    fn solve_checked(&mut self, readings_m: &[f64], start: Start) -> TendonReport {
        let (tendons, iter) = (&self.tendons, &mut self.iter);
        self.budget.begin(self.ws.settings());
        // the free lengths the current point belongs to (joint path's continuation)
        self.joint.free_prev.copy_from_slice(&iter.free);
        for (i, reading) in readings_m.iter().enumerate() {
            let q = reading - tendons.mech[i].zero_offset_m;
            iter.free[i] = tendons.free0[i] - q;
            self.friction.follow_reading(i, q);
        }
        let start = if self.status.has_solution {
            start
        } else {
            Start::Cold
        };
        if start == Start::Cold {
            for (t, m) in iter.t.iter_mut().zip(&tendons.mech) {
                *t = m.pretension_n;
            }
        }
        self.status.begin();
        // the warm fast path (frictionless, or friction factors that stay put)
        self.joint.cold = start == Start::Cold;
        if start == Start::Warm && self.tendon_settings().joint_newton && self.solve_joint_settled()
        {
            self.joint.at_solution = true;
            return self.finish();
        }
        self.joint_failed();
        if self.budget.spent {
            return self.finish();
        }
        // a cold start takes the same path from the reference equilibrium (zero
        // readings, the pretensions: solved once at construction, so the start does
        // not depend on earlier rows), continued in the readings by `solve_joint`'s
        // adaptive steps; when that hands back, the nested method's cold solve from
        // the straight rod follows. Why: on the FTDCR v4 val rows the nested cold
        // solve costs ~1e5 `f64` right-hand sides a row (its shooting continuation
        // and branch checks at every tension iterate), the path from the reference
        // a few thousand. Under a budget a warm row that the joint path did not
        // reach takes this path too, with what is left of the budget (`budget`
        // module docs: a row cut short is rolled back, and the rows after it
        // then start a step farther away).
        let from_ref = start == Start::Cold || self.budget.steers();
        if from_ref && self.tendon_settings().joint_newton && !self.tendons.x_ref.is_empty() {
            if start == Start::Warm {
                self.budget_second_chance();
            }
            self.joint.free_prev.copy_from_slice(&self.tendons.free0);
            self.ws.adopt_unknowns(&self.tendons.x_ref, false);
            self.joint.forget_jacobian();
            self.joint.rj.pending = true;
            if self.solve_joint_settled() {
                self.joint.at_solution = true;
                return self.finish();
            }
            self.joint_failed();
        }
        if self.budget.ends_call() {
            return self.finish();
        }
        self.solve_nested(start)
    }

    /// The joint path did not reach the row: whatever status a step of it left
    /// (an intermediate continuation step or a friction round ends `Converged` at
    /// its own, looser target) is not the row's. Without this a budgeted call that
    /// stopped after such a step reported `converged` at a point that is not an
    /// equilibrium, kept it as warm state and started the next rows from there
    /// (FTDCR v4 val line 72 under `max_passes = 16`: the 60 rows after it ended
    /// `budget_exhausted`).
    fn joint_failed(&mut self) {
        self.joint.at_solution = false;
        self.status.set(SolveStatus::MaxIterations);
    }

    /// The joint path, then the capstan factors of its shape; while they move, the
    /// joint path again from there: the lagged friction coupling solved as a fixed
    /// point, at most [`FRICTION_ROUNDS`] joint solves. `true` when the last one
    /// converged with factors that stayed put (at once without friction).
    fn solve_joint_settled(&mut self) -> bool {
        for _ in 0..FRICTION_ROUNDS {
            if !self.solve_joint() {
                return false;
            }
            if self.refresh_factors() {
                return true;
            }
        }
        false
    }

    /// The end of every call: its status decided ([`Status::conclude`]), and a
    /// converged row kept for the next rows' predictor.
    fn finish(&mut self) -> TendonReport {
        let report = self.status.conclude(self.budget.spent, &self.iter);
        if report.status.is_converged() {
            let (x, it) = (self.ws.unknowns_vector(), &self.iter);
            self.joint.push_history(x, &it.t, &it.free);
        }
        report
    }
}

impl Tendons {
    /// Check readings: one per driven tendon, finite, leaving a positive free length.
    fn check_readings(&self, q: &[f64]) -> Result<(), ModelError> {
        if q.len() != self.driven.len() {
            return Err(ModelError::Invalid {
                field: "readings".into(),
                why: format!(
                    "{} readings for {} displacement-driven tendons",
                    q.len(),
                    self.driven.len()
                ),
            });
        }
        for (i, &v) in q.iter().enumerate() {
            // (the field name is built only on failure: no allocation per row)
            if !v.is_finite() {
                return Err(ModelError::NonFinite {
                    field: format!("readings[{i}] ({})", self.columns[i]),
                    value: v,
                });
            }
            let free = self.free0[i] - (v - self.mech[i].zero_offset_m);
            if free <= 0.0 {
                return Err(ModelError::OutOfRange {
                    field: format!("readings[{i}] ({})", self.columns[i]),
                    value: v,
                    why: format!(
                        "pulls in more than the whole tendon (free length {} m)",
                        self.free0[i]
                    ),
                });
            }
        }
        Ok(())
    }

    /// Tendon `i`'s compliance (m/N) at free length `free` (m) and mean capstan
    /// factor `mf`: the tangent one at the tension `t` (N) when `taut`, the secant
    /// one when slack (the generalized Jacobian's diagonal, module docs of `joint`).
    fn compliance(&self, i: usize, taut: bool, free: f64, t: f64, mf: f64) -> f64 {
        let mech = &self.mech[i];
        if taut {
            mech.tangent_compliance(free, t, mf)
        } else {
            mech.compliance(free, mf)
        }
    }
}

impl Iterate {
    /// `max_i |G_i|` (m).
    fn merit(&self) -> f64 {
        self.g.iter().fold(0.0, |m, g| m.max(g.abs()))
    }

    /// `G` and the taut flags from `t`, `lengths` and `mean_factor` (module docs).
    fn update_g(&mut self, tendons: &Tendons) {
        for (i, &j) in tendons.driven.iter().enumerate() {
            let m = &tendons.mech[i];
            let covered = m.covered(self.free[i], self.t[i], self.mean_factor[i]);
            let stretch_gap = covered - self.lengths[j];
            let a = m.compliance(self.free[i], self.mean_factor[i]) + tendons.geo[i];
            let slack_arm = a * self.t[i];
            // taut branch when the constitutive gap is the smaller argument of min
            self.taut[i] = stretch_gap <= slack_arm && (self.t[i] > 0.0 || stretch_gap < 0.0);
            self.g[i] = stretch_gap.min(slack_arm);
        }
    }

    /// Set the tension of every slack-branch tendon to 0; `true` if any was not.
    fn zero_slack_tensions(&mut self) -> bool {
        let mut changed = false;
        for (t, taut) in self.t.iter_mut().zip(&self.taut) {
            if !taut && *t != 0.0 {
                *t = 0.0;
                changed = true;
            }
        }
        changed
    }
}

impl Status {
    /// A call starts as not (yet) converged, with nothing counted.
    fn begin(&mut self) {
        self.report = TendonReport::unsolved(SolveStatus::MaxIterations);
    }

    /// Record the status a path ended with (the call's, unless a later path or
    /// [`Status::conclude`] replaces it).
    fn set(&mut self, status: SolveStatus) {
        self.report.status = status;
    }

    /// The call's status, decided here once its paths have ended: the last path's,
    /// except that a call whose budget was spent before it converged ends
    /// `BudgetExhausted`; with the residual and slack count of the point `iter`.
    fn conclude(&mut self, budget_spent: bool, iter: &Iterate) -> TendonReport {
        if budget_spent && !self.report.status.is_converged() {
            self.report.status = SolveStatus::BudgetExhausted;
        }
        self.report.residual_m = iter.merit();
        self.report.slack = iter.taut.iter().filter(|t| !**t).count();
        self.has_solution = self.report.status.is_converged() || self.has_solution;
        self.report
    }
}
