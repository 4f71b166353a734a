//! The reusable solver workspace: buffers sized once per plan, Newton with an exact
//! dual-number Jacobian, backtracking line search, warm starts, load continuation.

use super::floor::residual_floor;
use super::intensity::load_intensity;
use super::multiple::Multi;
use super::pass::{pass, PassBuf, Recording, LOCAL_TOL};
use super::plan::{ParamSite, Plan};
use super::{GuidePose, Solution, SolveReport, SolveStatus};
use crate::cables::{segments, CableLength};
use crate::error::ModelError;
use crate::loads::Loads;
use crate::math::{DenseLu, Dual};
use crate::robot::Robot;
use crate::settings::SolverSettings;
use nalgebra::Vector3;

/// Directions of the arc coupling's sweep buffer (`b_arc`): the shooting unknowns and
/// up to nine tensions, a three-segment, nine-tendon robot's `[x; T]`.
const ARC_SWEEP: usize = 15;

// Joint-estimator methods (linearisation at any point): a child module, so it reads
// the parts (`parts.rs`) without widening their visibility.
pub(super) mod joint;

// Tendon mechanics: hole positions and per-chord tension factors.
mod chords;

// Dual-number sweeps: the Jacobian passes and the condensed coupling's buffers.
mod sweep;
use sweep::{sweep, Wide};

mod broyden;
use broyden::Broyden;

mod predict;
use predict::Secant;

mod continuation;
mod multi;
mod newton;
mod noise;
use noise::SettleNoise;
mod output;
mod sens;
// The solve entry: warm Newton, the cold path, the report.
mod solve;
// The state in typed parts.
mod parts;
use parts::{Iterate, Jacobian, Multiple, Outcome, Passes, Path, Problem, Sensitivities};

/// Where Newton starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// From the rigid straight-rod reactions; continuation if that fails.
    Cold,
    /// From the previous solution in this workspace (cold if there is none).
    Warm,
}

/// Solver state for repeated solves of one robot: allocate once, solve many times.
///
/// [`Workspace::set_loads`] with the same load structure and [`Workspace::solve`]
/// with [`Start::Warm`] do not allocate.
#[derive(Clone)]
pub struct Workspace {
    prob: Problem,
    it: Iterate,
    path: Path,
    jac: Jacobian,
    bufs: Passes,
    sens: Sensitivities,
    out: Outcome,
    multi: Multiple,
}

impl Workspace {
    /// Validate and build the plan and buffers.
    pub fn new(robot: Robot, loads: Loads, settings: SolverSettings) -> Result<Self, ModelError> {
        Self::with_params(robot, loads, settings, &[])
    }

    /// Like [`Workspace::new`], with load parameters `theta` that add to the scene's
    /// loads (all zero initially; see [`Workspace::set_theta`]).
    pub fn with_params(
        robot: Robot,
        loads: Loads,
        settings: SolverSettings,
        params: &[ParamSite],
    ) -> Result<Self, ModelError> {
        let plan = Plan::new(&robot, &loads, &settings, params)?;
        let multi_supported = Multi::supports(&plan);
        let (n, p, c) = (plan.n_unknowns, params.len(), robot.cables().len());
        let (tol, naux) = (settings.tolerance, super::pass::local_next_len(&plan));
        Ok(Self {
            it: Iterate {
                x: vec![0.0; n],
                x_trial: vec![0.0; n],
                dx: vec![0.0; n],
                res: vec![0.0; n],
                x_best: vec![0.0; n],
                best_res: f64::INFINITY,
                tol,
                noise: SettleNoise::new(n, plan.condensed),
                verdict: false,
            },
            path: Path {
                x_ok: vec![0.0; n],
                x_prev: vec![0.0; n],
                x_start: vec![0.0; n],
                x_first: vec![0.0; n],
                first_taken: false,
                x_tan: vec![0.0; n],
                tip_ok: Vector3::zeros(),
                tip_tan: Vector3::zeros(),
                tip_start: Vector3::zeros(),
                tip_first: Vector3::zeros(),
                secant: Secant::new(n, naux),
                holes_aux: vec![0.0; naux],
                last_intensity: 0.0,
            },
            jac: Jacobian {
                lu: DenseLu::new(n),
                lu_valid: false,
                broyden: Broyden::new(n),
                use_broyden: false,
                evals: 0,
            },
            bufs: Passes {
                b64: PassBuf::new(&plan),
                b3: PassBuf::new(&plan),
                b6: PassBuf::new(&plan),
                wide: Wide::new(&plan),
                b_arc: plan.arc.then(|| Box::new(PassBuf::new(&plan))),
                last_pass: None,
            },
            sens: Sensitivities {
                dres: vec![0.0; n * (n + p)],
                dlen: vec![0.0; c * (n + p)],
                col: vec![0.0; n],
                dxdtheta: vec![0.0; n * p],
                dxdtheta_valid: false,
            },
            out: Outcome {
                tip: Vector3::zeros(),
                tip_axis: Vector3::z(),
                report: SolveReport {
                    status: SolveStatus::NonFinite,
                    iterations: 0,
                    residual: f64::INFINITY,
                    tolerance: tol,
                    rhs_evals: 0,
                    jacobian_evals: 0,
                    continuation_steps: 0,
                    unknowns: n,
                },
                has_solution: false,
            },
            multi: Multiple {
                solver: Multi::new(),
                active: false,
            },
            prob: Problem {
                robot,
                loads,
                settings,
                plan,
                multi_supported,
            },
        })
    }

    /// The robot.
    pub fn robot(&self) -> &Robot {
        &self.prob.robot
    }
    /// The current loads.
    pub fn loads(&self) -> &Loads {
        &self.prob.loads
    }
    /// The settings.
    pub fn settings(&self) -> &SolverSettings {
        &self.prob.settings
    }
    /// Replace [`SolverSettings::tendons`] alone: the shooting solve never reads
    /// them (only the owning [`crate::tendons::TendonWorkspace`] does), so nothing is
    /// rebuilt. The caller has validated them.
    pub(crate) fn set_tendon_settings(&mut self, tendons: crate::settings::TendonSettings) {
        self.prob.settings.tendons = tendons;
    }
    /// Report of the last solve.
    pub fn report(&self) -> &SolveReport {
        &self.out.report
    }
    /// Number of shooting unknowns for the current loads.
    pub fn unknowns(&self) -> usize {
        self.prob.plan.n_unknowns
    }

    /// Replace the loads. Keeps the warm start and does not allocate when the load
    /// structure (point-load sites and frames, set of tensioned cables) is unchanged.
    pub fn set_loads(&mut self, loads: &Loads) -> Result<(), ModelError> {
        loads.validate(&self.prob.robot)?;
        if self.prob.plan.same_structure(loads) {
            self.it.noise.forget();
            self.prob.plan.set_load_values(loads);
            self.prob.loads.clone_from(loads);
        } else {
            let theta = self.bufs.b64.theta.clone();
            let params = self.prob.plan.params.clone();
            *self = Self::with_params(
                self.prob.robot.clone(),
                loads.clone(),
                self.prob.settings.clone(),
                &params,
            )?;
            self.set_theta(&theta);
        }
        Ok(())
    }

    /// Load parameters of this workspace.
    pub fn params(&self) -> &[ParamSite] {
        &self.prob.plan.params
    }

    /// Set the load parameters `theta` (units per [`ParamSite`]); no allocation.
    pub fn set_theta(&mut self, theta: &[f64]) {
        for (k, v) in theta.iter().enumerate().take(self.prob.plan.params.len()) {
            if self.bufs.set_theta(k, *v) {
                // the residual belongs to the old value
                self.it.noise.forget();
            }
        }
    }

    /// Set `theta` and move the shooting unknowns by the first-order predictor
    /// `dx = (dx/dtheta) dtheta` from the last [`Workspace::length_sensitivities`]
    /// (so the following warm solve starts O(dtheta^2) from the equilibrium).
    /// No allocation.
    pub fn set_theta_predicted(&mut self, theta: &[f64]) {
        let (n, p) = (self.prob.plan.n_unknowns, self.prob.plan.params.len());
        if self.sens.dxdtheta_valid && self.out.has_solution {
            for r in 0..n {
                let row = &self.sens.dxdtheta[r * p..(r + 1) * p];
                let dx: f64 = row
                    .iter()
                    .zip(theta)
                    .zip(&self.bufs.b64.theta)
                    .map(|((d, t), t0)| d * (t - t0))
                    .sum();
                self.it.x[r] += dx;
            }
        }
        self.set_theta(theta);
    }

    /// The plan its passes run (tests of the pass itself).
    #[cfg(test)]
    pub(crate) fn plan_mut(&mut self) -> &mut Plan {
        &mut self.prob.plan
    }

    /// Current load parameters.
    pub fn theta(&self) -> &[f64] {
        &self.bufs.b64.theta
    }

    /// Replace the settings (rebuilds the plan; allocates). The load parameters and
    /// their values `theta` are kept, as in [`Workspace::set_loads`]: a workspace
    /// owned by a [`crate::tendons::TendonWorkspace`] carries the tensions there, and
    /// dropping them would make its next solve panic on a length mismatch. The
    /// unknowns are kept too when their number is unchanged, as a starting point for
    /// [`Workspace::adopt_unknowns`] callers; the workspace holds no solution (a
    /// `Start::Warm` solve starts cold).
    pub fn set_settings(&mut self, settings: SolverSettings) -> Result<(), ModelError> {
        let theta = self.bufs.b64.theta.clone();
        let params = self.prob.plan.params.clone();
        let x = std::mem::take(&mut self.it.x);
        *self = Self::with_params(
            self.prob.robot.clone(),
            self.prob.loads.clone(),
            settings,
            &params,
        )?;
        self.set_theta(&theta);
        if x.len() == self.it.x.len() {
            self.it.x = x;
        }
        Ok(())
    }
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |a, x| {
        if x.is_nan() {
            f64::INFINITY
        } else {
            a.max(x.abs())
        }
    })
}

fn norm2(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

impl crate::math::warm::WarmCopy for Workspace {
    /// Everything a solve changes; the problem (robot, loads, settings and plan) is
    /// configuration (changed only by the caller) and stays as it is.
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src, copy: [
            it, path, jac, sens, out, multi,
        ], keep: [prob, bufs]);
        let condensed = self.prob.plan.condensed || src.prob.plan.condensed;
        self.bufs.warm_copy_from(&src.bufs, condensed);
        // the plan is configuration but for the friction's capstan factors per
        // chord, which a tendon solve updates (`set_chord_factors`)
        for (a, b) in self.prob.plan.cables.iter_mut().zip(&src.prob.plan.cables) {
            crate::math::warm::WarmCopy::warm_copy_from(&mut a.factor, &b.factor);
        }
    }
}

impl Workspace {
    /// Debug builds, after a rollback: the pass buffers' state the rollback does
    /// not copy set to NaN ([`crate::statics::pass::PassBuf::poison_uncopied`]).
    pub(crate) fn poison_uncopied(&mut self) {
        self.bufs.poison_uncopied(self.prob.plan.condensed);
    }
}
