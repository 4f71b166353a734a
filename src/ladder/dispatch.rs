//! The one place a [`Rung`] becomes its model: [`Rung::build_for`] matches the rung
//! once and hands the result to a job ([`RungJob`]), which adapts it to what it
//! needs. The jobs are the forward model ([`Rung::build`], here), the readings model
//! ([`Rung::build_readings`], module `readings`) and the estimator's model
//! (`crate::estimate::model`).
//!
//! A curvature rung is one concrete model for every job (it is a [`ForwardModel`],
//! a [`Differentiable`] one and a [`ReadingsModel`]), so it is built here. A rod rung
//! is a different solver per job (the shooting [`crate::statics::Workspace`] with or
//! without load parameters, the tendon solve [`crate::tendons::TendonWorkspace`]),
//! so each job builds it from the rung's [`SolverSettings`]. A new rung family is a
//! new arm of the match in [`Rung::build_for`]: a new curvature-like model that
//! implements the three traits reaches every job with no other change.

use super::{ConstantCurvature, Differentiable, ForwardModel, LadderError, ReadingsModel};
use super::{PiecewiseConstantCurvature, RodRung, Rung};
use crate::robot::Robot;
use crate::settings::SolverSettings;

/// What a curvature rung is to every job: a forward model with exact length
/// sensitivities that readings can also drive, cloneable (an estimator keeps a copy
/// of its model to fall back to).
pub(crate) trait CurvatureModel: Differentiable + ReadingsModel + Clone + 'static {}

impl<T: Differentiable + ReadingsModel + Clone + 'static> CurvatureModel for T {}

/// One job's adapter from a rung's model (module docs).
pub(crate) trait RungJob {
    /// What the job makes of the rung.
    type Output;
    /// The job on a built curvature rung.
    fn curvature<F: CurvatureModel>(self, model: F) -> Result<Self::Output, LadderError>;
    /// The job on a rod rung of `robot` with these settings.
    fn rod(self, robot: Robot, settings: &SolverSettings) -> Result<Self::Output, LadderError>;
}

impl Rung {
    /// Build this rung of `robot` for `job` (module docs): the one match from a rung
    /// to its model.
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
