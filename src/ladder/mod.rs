//! Ladder of forward models behind one interface, from a closed-form constant-curvature
//! arc per section up to the full Cosserat rod, and an automatic choice of the cheapest
//! rung that meets an accuracy target.
//!
//! | rung | model | cost | exact when |
//! |---|---|---|---|
//! | [`ConstantCurvature`] | one arc per section, curvature = section moment / EI | closed form (a fixed point only with point forces) | pure bending torques, no gravity |
//! | [`PiecewiseConstantCurvature`] | one arc per piece between disks/loads, fixed point on the shape | O(pieces) per iteration | never; error O(h^2) in the piece length |
//! | [`RodRung`] Kirchhoff | inextensible, unshearable rod by shooting | Newton on the ODE | no shear and no extension (PL/(GA), T/(EA) -> 0) |
//! | [`RodRung`] Cosserat | full rod (thesis eqs. 2.3-2.13) by shooting | Newton on the ODE | reference |
//!
//! Every rung answers the same question through [`ForwardModel`]: loads in, tip and
//! section-end poses, guide poses and cable lengths out (cable lengths always from the
//! guide transforms of thesis 3.8.1, [`crate::cables::path_length`]). Every rung can
//! also sit under the estimator ([`crate::estimate::Estimator::on_rung`]): rod rungs
//! through their [`SolverSettings`] ([`Rung::solver_settings`]) and the shooting
//! workspace, the curvature rungs through [`Differentiable`], their exact cable-length
//! sensitivities by implicit differentiation of their fixed points.
//!
//! **Displacement-driven tendons.** Every rung can also be driven by actuator
//! readings ([`ReadingsModel`], [`Rung::build_readings`]): CC with displacement
//! control is the classic constant-curvature kinematics of Webster & Jones 2010
//! (readings -> one arc per section in closed form, [`TendonKinematics`]); PCC takes
//! the same arcs per section; the rod rungs solve the tendon mechanics
//! ([`crate::tendons::TendonWorkspace`]).
//!
//! **Labels and building.** [`Rung::label`] names a rung (`cc`, `pcc/point/8`,
//! `cosserat/accurate/adaptive-1e-8`, ...) and [`Rung::from_label`] reads the name
//! back (module `label`; `--model LABEL` on the command line). One match,
//! `Rung::build_for`, turns a rung into its model; [`Rung::build`],
//! [`Rung::build_readings`] and the estimator each adapt what it gives.

mod anderson;
mod arc;
mod auto;
mod auto_readings;
mod cc;
mod grid;
mod kinematics;
mod label;
mod pcc;
mod readings;
mod rod;
mod sens;

pub use arc::{arc_pose, ArcJacobian};
pub use auto::{
    choose, parse_length, AutoChoice, AutoSettings, CandidateReport, LengthParseError, Verdict,
};
pub use auto_readings::{choose_readings, probe_rows, PROBE_ROWS};
pub use cc::{CcSettings, ConstantCurvature};
pub use grid::{CurvatureRungs, LadderGrid, MassChoice};
pub use kinematics::TendonKinematics;
pub use label::{guide_mass_name, ADAPTIVE_MAX_STEPS, LABEL_SPELLINGS};
pub use pcc::{PccSettings, PiecewiseConstantCurvature};
pub use readings::{readings_ladder, ReadingsModel};
pub use rod::RodRung;

use crate::error::ModelError;
use crate::loads::Loads;
use crate::robot::Robot;
use crate::settings::{GuideMass, Integrator, RodModel, SolverSettings};
use crate::statics::{ParamSite, Pose, SolveStatus, Start};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Why a rung could not be built or run. Non-convergence is not an error: see
/// [`LadderReport::status`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LadderError {
    /// Invalid robot, loads or settings.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A setting of a curvature rung is out of range.
    #[error("{field} = {} is out of range: {why}", crate::error::Num(*.value))]
    Setting {
        /// Field path, e.g. `pcc.pieces_per_section`.
        field: String,
        /// Rejected value.
        value: f64,
        /// What is allowed.
        why: String,
    },
    /// The automatic choice was given no candidate rung or no probe load.
    #[error("no candidate rung: {0}")]
    NoCandidate(String),
    /// A rung label that names no rung ([`Rung::from_label`]).
    #[error("model label `{label}`: {why}; labels are {}", LABEL_SPELLINGS)]
    Label {
        /// The label as given.
        label: String,
        /// Which part is wrong and why.
        why: String,
    },
}

/// Counts and outcome of one ladder solve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LadderReport {
    /// How the solve ended (the rod rungs' [`SolveStatus`]; the curvature rungs use
    /// `Converged`, `MaxIterations` and `NonFinite` with the same meaning).
    pub status: SolveStatus,
    /// Iterations: Newton iterations (rod), fixed-point sweeps (curvature rungs).
    pub iterations: usize,
    /// Final residual: scaled boundary residual (rod), largest curvature change of
    /// the last sweep times the rod length (curvature rungs), dimensionless.
    pub residual: f64,
}

/// Everything a rung computes, allocating (see [`ForwardModel::output`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LadderOutput {
    /// Outcome of the solve that produced this output.
    pub report: LadderReport,
    /// Pose of each section's end, base to tip (the last is the tip).
    pub section_tips: Vec<Pose>,
    /// Pose of each guide disk centre, base to tip.
    pub guides: Vec<Pose>,
    /// Cable lengths from the base plate (m), indexed like `robot.cables`.
    pub cable_lengths: Vec<f64>,
}

impl LadderOutput {
    /// Tip pose.
    pub fn tip(&self) -> Option<&Pose> {
        self.section_tips.last()
    }
}

/// One rung of the ladder: a forward model of a fixed robot.
///
/// `solve` is the hot call (it updates the tip and the cable lengths; the rod rungs do
/// not allocate after the first call with a given load structure); `output` is the
/// allocating snapshot with every pose.
pub trait ForwardModel {
    /// Solve for `loads`. [`Start::Warm`] starts from the previous solution when the
    /// rung iterates (rod and piecewise rungs), [`Start::Cold`] from the straight rod.
    fn solve(&mut self, loads: &Loads, start: Start) -> Result<LadderReport, LadderError>;
    /// Tip position of the last solve (m, world).
    fn tip_position(&self) -> Vector3<f64>;
    /// Cable lengths of the last solve (m) into `out` (indexed like `robot.cables`).
    fn cable_lengths_into(&self, out: &mut [f64]);
    /// Poses and lengths of the last solve (allocates).
    fn output(&mut self) -> LadderOutput;
    /// The robot.
    fn robot(&self) -> &Robot;
}

/// A curvature rung whose cable lengths can be differentiated with respect to load
/// parameters (what the estimator needs besides [`ForwardModel`]).
pub trait Differentiable: ForwardModel {
    /// [`ForwardModel::solve`] for `loads` plus `theta_k` at `params[k]` (no
    /// allocation after the first call). `loads` is validated; the parameter values
    /// are not sign-checked (see the estimator's trial steps). Error on an invalid
    /// site (index out of range, force/torque on a body-frame point load).
    fn solve_params(
        &mut self,
        loads: &Loads,
        params: &[ParamSite],
        theta: &[f64],
        start: Start,
    ) -> Result<LadderReport, LadderError>;
    /// Exact `d l_j / d theta_k` at the last solve's loads and shape, row-major
    /// `c x p` into `out` (`theta_k` adds at `params[k]`, as for the shooting
    /// workspace; force and torque sites must be world-frame point loads), the
    /// lengths into `lengths`. No allocation after the first call. `false` when the
    /// last solve did not converge or the derivative does not exist there.
    fn length_sensitivities(
        &mut self,
        params: &[ParamSite],
        out: &mut [f64],
        lengths: &mut [f64],
    ) -> bool;
}

impl Differentiable for ConstantCurvature {
    fn solve_params(
        &mut self,
        loads: &Loads,
        params: &[ParamSite],
        theta: &[f64],
        start: Start,
    ) -> Result<LadderReport, LadderError> {
        ConstantCurvature::solve_params(self, loads, params, theta, start)
    }
    fn length_sensitivities(
        &mut self,
        params: &[ParamSite],
        out: &mut [f64],
        lengths: &mut [f64],
    ) -> bool {
        ConstantCurvature::length_sensitivities(self, params, out, lengths)
    }
}

impl Differentiable for PiecewiseConstantCurvature {
    fn solve_params(
        &mut self,
        loads: &Loads,
        params: &[ParamSite],
        theta: &[f64],
        start: Start,
    ) -> Result<LadderReport, LadderError> {
        PiecewiseConstantCurvature::solve_params(self, loads, params, theta, start)
    }
    fn length_sensitivities(
        &mut self,
        params: &[ParamSite],
        out: &mut [f64],
        lengths: &mut [f64],
    ) -> bool {
        PiecewiseConstantCurvature::length_sensitivities(self, params, out, lengths)
    }
}

/// A rung and its settings: a plain, serializable description.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Rung {
    /// Constant curvature per section.
    ConstantCurvature(CcSettings),
    /// Piecewise constant curvature between disks and load points.
    PiecewiseConstantCurvature(PccSettings),
    /// Rod by shooting (Kirchhoff or Cosserat per `rod_model`).
    Rod(SolverSettings),
}

impl Rung {
    /// The reference of the ladder: full Cosserat, accurate guide mass (thesis 3.8),
    /// adaptive Dormand-Prince at tol 1e-12, Newton to a scaled residual of 1e-11.
    pub fn reference() -> Self {
        Self::Rod(SolverSettings {
            rod_model: RodModel::Cosserat,
            guide_mass: GuideMass::Accurate,
            integrator: Integrator::Adaptive {
                tol: 1e-12,
                max_steps: 1_000_000,
            },
            tolerance: 1e-11,
            ..SolverSettings::default()
        })
    }

    /// Family name: `cc`, `pcc`, `kirchhoff` or `cosserat`.
    pub fn family(&self) -> &'static str {
        match self {
            Self::ConstantCurvature(_) => "cc",
            Self::PiecewiseConstantCurvature(_) => "pcc",
            Self::Rod(s) if s.rod_model == RodModel::Kirchhoff => "kirchhoff",
            Self::Rod(_) => "cosserat",
        }
    }

    /// The shooting settings of a rod rung (`None` for the curvature rungs).
    pub fn solver_settings(&self) -> Option<&SolverSettings> {
        match self {
            Self::Rod(s) => Some(s),
            _ => None,
        }
    }
}

/// What a curvature rung is to every job: a forward model with exact length
/// sensitivities that readings can also drive, cloneable (an estimator keeps a copy
/// of its model to fall back to).
pub(crate) trait CurvatureModel: Differentiable + ReadingsModel + Clone + 'static {}

impl<T: Differentiable + ReadingsModel + Clone + 'static> CurvatureModel for T {}

/// One job's adapter from a rung's model ([`Rung::build_for`]).
pub(crate) trait RungJob {
    /// What the job makes of the rung.
    type Output;
    /// The job on a built curvature rung.
    fn curvature<F: CurvatureModel>(self, model: F) -> Result<Self::Output, LadderError>;
    /// The job on a rod rung of `robot` with these settings.
    fn rod(self, robot: Robot, settings: &SolverSettings) -> Result<Self::Output, LadderError>;
}

impl Rung {
    /// Build this rung of `robot` for `job`: the one place a rung becomes its model.
    /// Each job adapts the result to what it needs: the forward model
    /// ([`Rung::build`]), the readings model ([`Rung::build_readings`]) and the
    /// estimator's model ([`crate::estimate::Estimator::on_rung`]).
    ///
    /// A curvature rung is one concrete model for every job (it is a
    /// [`ForwardModel`], a [`Differentiable`] one and a [`ReadingsModel`]), so it is
    /// built here. A rod rung is a different solver per job (the shooting
    /// [`crate::statics::Workspace`] with or without load parameters, the tendon solve
    /// [`crate::tendons::TendonWorkspace`]), so each job builds it from the rung's
    /// [`SolverSettings`]. A new rung family whose model implements the three traits
    /// is a new arm of this match and reaches every job with no other change.
    pub(crate) fn build_for<J: RungJob>(
        &self,
        robot: Robot,
        job: J,
    ) -> Result<J::Output, LadderError> {
        match self {
            Self::ConstantCurvature(s) => job.curvature(ConstantCurvature::new(robot, *s)?),
            Self::PiecewiseConstantCurvature(s) => {
                job.curvature(PiecewiseConstantCurvature::new(robot, *s)?)
            }
            Self::Rod(s) => job.rod(robot, s),
        }
    }

    /// Build the model for `robot`.
    pub fn build(&self, robot: &Robot) -> Result<Box<dyn ForwardModel>, LadderError> {
        self.build_for(robot.clone(), Forward)
    }
}

/// The forward job: the rung as a [`ForwardModel`] (a rod rung is a [`RodRung`]).
struct Forward;

impl RungJob for Forward {
    type Output = Box<dyn ForwardModel>;
    fn curvature<F: CurvatureModel>(self, model: F) -> Result<Self::Output, LadderError> {
        Ok(Box::new(model))
    }
    fn rod(self, robot: Robot, settings: &SolverSettings) -> Result<Self::Output, LadderError> {
        Ok(Box::new(RodRung::new(robot, settings.clone())?))
    }
}

/// Guide-mass models worth distinguishing on `robot`: `none` alone for a robot
/// without disks (they would all give the same answer), else average, accurate, point.
pub fn guide_mass_choices(robot: &Robot) -> Vec<GuideMass> {
    if robot.guides().iter().all(|g| g.mass == 0.0) {
        vec![GuideMass::None]
    } else {
        vec![GuideMass::Average, GuideMass::Accurate, GuideMass::Point]
    }
}

/// The full ladder used by `cablesense pareto`: CC; PCC at 4..32 pieces per section
/// (both left out on a robot with continuously routed tendons: [`reject_continuous`]);
/// Kirchhoff and Cosserat with every relevant guide-mass model, RK4 at 4..64 steps
/// per section and the adaptive pair at tol 1e-4..1e-10.
pub fn full_ladder(robot: &Robot) -> Vec<Rung> {
    LadderGrid::full().rungs(robot)
}

/// A smaller ladder for `--model auto` (each candidate is solved on every probe load):
/// CC; PCC 4/16; Kirchhoff and Cosserat with each guide-mass model at RK4 4, 8, 16,
/// 32, 64 steps per section and adaptive 1e-8.
pub fn auto_ladder(robot: &Robot) -> Vec<Rung> {
    LadderGrid::auto().rungs(robot)
}

/// Load parameters added to resolved loads, or the site that is invalid.
pub(crate) fn add_params(
    out: &mut sens::LoadsT<f64>,
    params: &[ParamSite],
    theta: &[f64],
) -> Result<(), LadderError> {
    for (k, (site, v)) in params.iter().zip(theta).enumerate() {
        if !out.add_at(site, *v) {
            return Err(LadderError::Model(ModelError::Invalid {
                field: format!("load parameter {k}"),
                why: format!("{site:?} is not a cable or a world-frame point load"),
            }));
        }
    }
    Ok(())
}

/// The curvature rungs (CC, PCC) take a continuously routed tendon
/// (`statics::pass::continuous`) only on a straight path, and reject a helical or
/// tabulated one, naming the cable.
///
/// Why straight paths fit: a straight tendon at the constant offset `d` keeps its
/// section's curvature exactly constant without other loads (its tangent stays along
/// the backbone, so the rod carries the constant moment `T e3 x d`, the same as a
/// cable through dense disks at the hole `d`; `tests/continuous_routing.rs`,
/// `straight_tendon_without_gravity_is_an_exact_arc`). CC uses that moment per section
/// and PCC the exact free-body term at each piece's midpoint (module `pcc`); the
/// length is the path's arc length over the arcs, `sum h |e3 + u x d|`. A helical or
/// tabulated path does not keep it constant (`r(s)` turns, and the tendon's moment
/// and distributed force turn with it), so no CC rung can represent it.
///
/// The ladders ([`full_ladder`], [`auto_ladder`], [`readings_ladder`]) leave the
/// curvature rungs out on a robot with such a tendon, so `pareto`, `stability` and
/// `--model auto` rank the rod rungs only there.
pub fn reject_continuous(robot: &Robot) -> Result<(), LadderError> {
    use crate::robot::TendonPath;
    match robot
        .cables()
        .iter()
        .position(|c| matches!(c.path, Some(ref p) if !matches!(p, TendonPath::Straight(_))))
    {
        Some(j) => Err(LadderError::Model(ModelError::Invalid {
            field: format!("robot.cables[{j}].routing"),
            why: "a helical or tabulated continuous path is solved by the rod rungs only (it does not keep a section's curvature constant; straight paths are taken)".into(),
        })),
        None => Ok(()),
    }
}

/// Offset `d` (local, m) of each cable on a straight continuous path, `None` for
/// disk-routed cables (the curvature rungs' view of [`crate::robot::TendonPath`]).
pub(crate) fn straight_offsets(robot: &Robot) -> Vec<Option<Vector3<f64>>> {
    use crate::robot::TendonPath;
    robot
        .cables()
        .iter()
        .map(|c| match c.path {
            Some(TendonPath::Straight(d)) => Some(d),
            _ => None,
        })
        .collect()
}

/// Length of a straight continuous path at offset `d` over an arc of curvature `u`
/// (local) and length `h`: the path's tangent is `R (e3 + u x d)` (Kirchhoff: no
/// shear or extension), of constant norm on the arc.
#[inline]
pub(crate) fn straight_arc_length<T: crate::math::Real>(
    u: &Vector3<T>,
    d: &Vector3<f64>,
    h: f64,
) -> T {
    let t = Vector3::z().map(T::cst) + u.cross(&d.map(T::cst));
    t.dot(&t).sqrt().scale(h)
}

/// `loads` with point loads (forces, torques, payload masses) and cable tensions
/// multiplied by `factor`; gravity is left alone (it does not vary in service).
pub fn scale_loads(loads: &Loads, factor: f64) -> Loads {
    let mut out = loads.clone();
    for p in &mut out.point {
        p.force_n = p.force_n.map(|x| x * factor);
        p.torque_nm = p.torque_nm.map(|x| x * factor);
        p.mass_kg *= factor;
    }
    for t in &mut out.tensions_n {
        *t *= factor;
    }
    out
}
