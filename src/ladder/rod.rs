//! Rungs (c) and (d): the Kirchhoff and Cosserat rods by shooting ([`Workspace`]), as a
//! [`ForwardModel`]. The rod model, guide-mass model and integrator are the
//! [`SolverSettings`]; the same settings run the estimator.

use super::{ForwardModel, LadderError, LadderOutput, LadderReport};
use crate::loads::Loads;
use crate::robot::Robot;
use crate::settings::SolverSettings;
use crate::statics::{SolveStatus, Start, Workspace};
use nalgebra::Vector3;

/// A rod rung: a [`Workspace`] built on the first solve and reused after.
pub struct RodRung {
    robot: Robot,
    settings: SolverSettings,
    ws: Option<Workspace>,
    report: LadderReport,
}

impl RodRung {
    /// A rod rung with these settings (validated here).
    pub fn new(robot: Robot, settings: SolverSettings) -> Result<Self, LadderError> {
        settings.validate()?;
        Ok(Self {
            robot,
            settings,
            ws: None,
            report: LadderReport {
                status: SolveStatus::NonFinite,
                iterations: 0,
                residual: f64::INFINITY,
            },
        })
    }

    /// The settings (what an estimator on this rung uses).
    pub fn settings(&self) -> &SolverSettings {
        &self.settings
    }

    /// The workspace, once a solve has built it.
    pub fn workspace(&mut self) -> Option<&mut Workspace> {
        self.ws.as_mut()
    }
}

impl ForwardModel for RodRung {
    fn solve(&mut self, loads: &Loads, start: Start) -> Result<LadderReport, LadderError> {
        let rep = match &mut self.ws {
            Some(ws) => {
                ws.set_loads(loads)?;
                ws.solve(start)
            }
            None => {
                let mut ws =
                    Workspace::new(self.robot.clone(), loads.clone(), self.settings.clone())?;
                let rep = ws.solve(Start::Cold);
                self.ws = Some(ws);
                rep
            }
        };
        self.report = LadderReport {
            status: rep.status,
            iterations: rep.iterations,
            residual: rep.residual,
        };
        Ok(self.report)
    }

    fn tip_position(&self) -> Vector3<f64> {
        match &self.ws {
            Some(ws) => ws.tip_position(),
            None => Vector3::repeat(f64::NAN),
        }
    }

    fn cable_lengths_into(&self, out: &mut [f64]) {
        match &self.ws {
            Some(ws) => ws.cable_lengths_into(out),
            None => out.iter_mut().for_each(|o| *o = f64::NAN),
        }
    }

    fn output(&mut self) -> LadderOutput {
        match &mut self.ws {
            Some(ws) => {
                let sol = ws.solution();
                LadderOutput {
                    report: self.report,
                    section_tips: sol.section_tips,
                    guides: sol.guides.iter().map(|g| g.pose).collect(),
                    cable_lengths: sol.cables.iter().map(|c| c.total_m).collect(),
                }
            }
            None => LadderOutput {
                report: self.report,
                section_tips: Vec::new(),
                guides: Vec::new(),
                cable_lengths: Vec::new(),
            },
        }
    }

    fn robot(&self) -> &Robot {
        &self.robot
    }
}
