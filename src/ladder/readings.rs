//! Every rung driven by actuator readings of displacement-driven tendons.
//!
//! [`ReadingsModel`] is the readings-side twin of [`super::ForwardModel`]: readings
//! (m, one per displacement-driven tendon in cable order, positive = pulled) in, tip
//! and cable lengths out. The curvature rungs answer with the constant-curvature
//! kinematics (module `kinematics`, Webster & Jones 2010: no mechanics, no loads, one
//! arc per section); the rod rungs with [`TendonWorkspace`] (tendon stretch,
//! pretension, slack and the scene's loads, solved through the shooting model with the
//! rung's [`SolverSettings`]).
//!
//! The automatic choice over loads ([`super::choose`]) does not rank these models;
//! [`super::choose_readings`] does, on rows of readings (`cablesense solve SCENE
//! --readings FILE --model auto`), and `cablesense pareto` charts them (its TDCR rows,
//! module `crate::experiments`).

use super::{ConstantCurvature, LadderError, LadderReport};
use super::{CurvatureModel, PiecewiseConstantCurvature, Rung, RungJob};
use crate::loads::Loads;
use crate::robot::Robot;
use crate::settings::SolverSettings;
use crate::statics::Start;
use crate::tendons::TendonWorkspace;
use nalgebra::Vector3;

/// A model of a fixed robot driven by tendon readings.
pub trait ReadingsModel {
    /// Solve for `readings_m`; `Start::Warm` from the previous solve where the model
    /// iterates (rod rungs), ignored by the closed-form kinematics.
    fn solve_readings(
        &mut self,
        readings_m: &[f64],
        start: Start,
    ) -> Result<LadderReport, LadderError>;
    /// Tip position of the last solve (m, world).
    fn tip_position(&self) -> Vector3<f64>;
    /// Cable lengths of the last solve (m, every cable) into `out`.
    fn cable_lengths_into(&self, out: &mut [f64]);
    /// Whether each driven tendon was taut in the last solve (reading order).
    fn taut(&self) -> Vec<bool>;
}

impl ReadingsModel for ConstantCurvature {
    fn solve_readings(&mut self, q: &[f64], _: Start) -> Result<LadderReport, LadderError> {
        ConstantCurvature::solve_readings(self, q)
    }
    fn tip_position(&self) -> Vector3<f64> {
        super::ForwardModel::tip_position(self)
    }
    fn cable_lengths_into(&self, out: &mut [f64]) {
        super::ForwardModel::cable_lengths_into(self, out)
    }
    fn taut(&self) -> Vec<bool> {
        self.kinematics().map_or(Vec::new(), |k| k.taut().to_vec())
    }
}

impl ReadingsModel for PiecewiseConstantCurvature {
    fn solve_readings(&mut self, q: &[f64], _: Start) -> Result<LadderReport, LadderError> {
        PiecewiseConstantCurvature::solve_readings(self, q)
    }
    fn tip_position(&self) -> Vector3<f64> {
        super::ForwardModel::tip_position(self)
    }
    fn cable_lengths_into(&self, out: &mut [f64]) {
        super::ForwardModel::cable_lengths_into(self, out)
    }
    fn taut(&self) -> Vec<bool> {
        self.kinematics().map_or(Vec::new(), |k| k.taut().to_vec())
    }
}

impl ReadingsModel for TendonWorkspace {
    fn solve_readings(&mut self, q: &[f64], start: Start) -> Result<LadderReport, LadderError> {
        let rep = self.solve_readings_from(q, start)?;
        Ok(LadderReport {
            status: rep.status,
            iterations: rep.iterations,
            // the tendon mismatch (m) scaled by the rod length, as the ladder's residuals
            residual: rep.residual_m / self.workspace().robot().length(),
        })
    }
    fn tip_position(&self) -> Vector3<f64> {
        TendonWorkspace::tip_position(self)
    }
    fn cable_lengths_into(&self, out: &mut [f64]) {
        for (o, l) in out.iter_mut().zip(self.lengths()) {
            *o = *l;
        }
    }
    fn taut(&self) -> Vec<bool> {
        TendonWorkspace::taut(self).to_vec()
    }
}

impl Rung {
    /// Build the rung as a [`ReadingsModel`] of `robot` under `loads` (the rod rungs'
    /// [`TendonWorkspace`] fixes each tendon's free length at the pretension under
    /// these loads; the kinematics ignores them). An error when no tendon is
    /// displacement-driven or the loads tension a displacement-driven tendon.
    pub fn build_readings(
        &self,
        robot: &Robot,
        loads: &Loads,
    ) -> Result<Box<dyn ReadingsModel>, LadderError> {
        self.build_for(robot.clone(), Readings { loads })
    }
}

/// The readings job ([`Rung::build_for`]): a rod rung is a [`TendonWorkspace`].
struct Readings<'a> {
    loads: &'a Loads,
}

impl RungJob for Readings<'_> {
    type Output = Box<dyn ReadingsModel>;
    fn curvature<F: CurvatureModel>(self, model: F) -> Result<Self::Output, LadderError> {
        let mut m = model;
        // fail here, not at the first solve, when there is nothing to drive
        let zeros = zeros(super::ForwardModel::robot(&m));
        m.solve_readings(&zeros, Start::Cold)?;
        Ok(Box::new(m))
    }
    fn rod(self, robot: Robot, settings: &SolverSettings) -> Result<Self::Output, LadderError> {
        Ok(Box::new(
            TendonWorkspace::new(robot, self.loads.clone(), settings.clone())?.without_rollback(),
        ))
    }
}

/// Zero readings (the tendons' zero offsets) for every displacement-driven tendon.
fn zeros(robot: &Robot) -> Vec<f64> {
    robot
        .cables()
        .iter()
        .filter(|c| c.actuation == crate::tendons::Actuation::Displacement)
        .map(|c| c.mechanics.map_or(0.0, |m| m.zero_offset_m))
        .collect()
}

/// The readings ladder of a TDCR: CC and PCC (4, 16 pieces per section) by the
/// kinematics (label `pcc/none/N`: the kinematics has no mass), and every rod
/// setting of [`super::auto_ladder`] (RK4 4..64 steps per section and adaptive 1e-8,
/// each guide-mass model) through the tendon solve: a tendon solve is a Newton
/// iteration of shooting solves, so the finer adaptive settings of the full ladder
/// would dominate the sweep's time without adding a point to the front. On a robot
/// with disks, each RK4 rod setting also with the arc coupling (label `.../arc`,
/// [`crate::settings::CableCoupling::Arc`]): the cheaper disk coupling of a tendon robot (on the FTDCR
/// v4 val rows 0.61x the instructions of the default coupling, tips within 84 um of
/// it; `tests/arc_coupling.rs`). Not with the adaptive setting: its steps, not the
/// coupling, set its cost.
pub fn readings_ladder(robot: &Robot) -> Vec<Rung> {
    super::LadderGrid::readings().rungs(robot)
}
