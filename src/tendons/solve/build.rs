//! Building a [`TendonWorkspace`]: the driven tendons, their mechanics and moment
//! arms from the robot, and the reference solve at the pretensions that fixes each
//! tendon's free length `L0`.

use super::{budget, friction, joint, nested, Rollback};
use super::{Iterate, Status, TendonReport, TendonWorkspace, Tendons};
use crate::error::ModelError;
use crate::loads::Loads;
use crate::robot::Robot;
use crate::settings::SolverSettings;
use crate::statics::{ParamSite, SolveStatus, Start, Workspace};
use crate::tendons::Actuation;

impl TendonWorkspace {
    /// Build for a robot with displacement-driven tendons: validates, solves the
    /// reference (every driven tendon at its pretension) and fixes each `L0`.
    pub fn new(robot: Robot, loads: Loads, settings: SolverSettings) -> Result<Self, ModelError> {
        Self::with_params(robot, loads, settings, &[])
    }

    /// Like [`TendonWorkspace::new`] with extra load parameters (after the
    /// tensions in the inner workspace's `theta`), for estimation.
    pub fn with_params(
        robot: Robot,
        loads: Loads,
        settings: SolverSettings,
        extra: &[ParamSite],
    ) -> Result<Self, ModelError> {
        let mut driven = Vec::new();
        let mut mech = Vec::new();
        let mut columns = Vec::new();
        let mut geo = Vec::new();
        let ei = robot.min_bending_stiffness();
        for (j, c) in robot.cables().iter().enumerate() {
            let field = format!("robot.cables[{j}]");
            match c.actuation {
                Actuation::Displacement => {
                    if loads.tension(j) != 0.0 {
                        return Err(ModelError::Invalid {
                            field: format!("loads.tensions_n[{j}]"),
                            why: format!(
                                "cable `{}` is displacement-driven: its tension follows from its reading",
                                c.name
                            ),
                        });
                    }
                    let m = c.mechanics.ok_or_else(|| ModelError::Invalid {
                        field: format!("{field}.tendon.stiffness_n"),
                        why: "a displacement-driven tendon needs its axial stiffness".into(),
                    })?;
                    driven.push(j);
                    mech.push(m);
                    columns.push(c.reading.clone());
                    // the moment arm: the base hole, or a continuous path's largest
                    // offset (a table's may start on the axis)
                    let s_end = c.end_s;
                    let arm = c
                        .path
                        .as_ref()
                        .map_or(c.base_hole.norm(), |p| p.max_radius(s_end));
                    geo.push((arm.powi(2) * s_end / ei).max(1e-12));
                }
                Actuation::Passive => {
                    if loads.tension(j) != 0.0 {
                        return Err(ModelError::Invalid {
                            field: format!("loads.tensions_n[{j}]"),
                            why: format!(
                                "cable `{}` is passive (a measuring cable): its tension is 0",
                                c.name
                            ),
                        });
                    }
                }
                Actuation::Tension => {}
            }
        }
        if driven.is_empty() {
            return Err(ModelError::Invalid {
                field: "robot.cables".into(),
                why: "no cable has `actuation = \"displacement\"`: nothing to drive from readings"
                    .into(),
            });
        }
        let mut params: Vec<ParamSite> = driven
            .iter()
            .map(|&j| ParamSite::Tension { cable: j })
            .collect();
        params.extend_from_slice(extra);
        let nc = robot.cables().len();
        let routes: Vec<usize> = robot.cables().iter().map(|c| c.route.len()).collect();
        let friction = friction::Friction::new(robot.friction(), driven.iter().map(|&j| routes[j]));
        let ws = Workspace::with_params(robot, loads, settings, &params)?;
        let p = driven.len();
        let np = params.len();
        let mut me = Self {
            joint: joint::JointBufs::new(ws.unknowns(), p, np, nc),
            ws,
            iter: Iterate {
                free: vec![0.0; p],
                t: mech.iter().map(|m| m.pretension_n).collect(),
                theta: vec![0.0; np],
                lengths: vec![0.0; nc],
                mean_factor: vec![1.0; p],
                g: vec![0.0; p],
                taut: vec![true; p],
            },
            friction,
            nested: nested::NestedBufs::new(p, np, nc),
            status: Status {
                report: TendonReport::unsolved(SolveStatus::NonFinite),
                has_solution: false,
            },
            tendons: Tendons {
                free0: vec![0.0; p],
                n_extra: extra.len(),
                x_ref: Vec::new(),
                driven,
                mech,
                columns,
                geo,
            },
            rollback: Rollback {
                enabled: true,
                good: None,
                pending: false,
            },
            budget: budget::Budget::default(),
        };
        me.reference()?;
        // the rollback's copy: allocated once here, refreshed without allocating
        me.rollback.good = Some(Box::new(me.clone()));
        Ok(me)
    }

    /// Solve at the pretensions with zero readings and set `L0`.
    fn reference(&mut self) -> Result<(), ModelError> {
        let (tendons, iter) = (&mut self.tendons, &mut self.iter);
        for (i, m) in tendons.mech.iter().enumerate() {
            iter.theta[i] = m.pretension_n;
        }
        self.ws.set_theta(&iter.theta);
        let rep = self.ws.solve(Start::Cold);
        if !rep.status.is_converged() {
            // the reference is the whole scene at q = 0: the pretensions are one of
            // its inputs, not necessarily the cause (a huge density fails it too)
            return Err(ModelError::Invalid {
                field: "tendon reference solve".into(),
                why: format!(
                    "the robot at its pretensions (robot.tendons.pretension_n) under the scene's loads, the reference that fixes each tendon's free length, did not solve: {:?}, residual {:.3e}; check the pretensions, the loads and the rod's stiffness, mass and geometry",
                    rep.status, rep.residual
                ),
            });
        }
        // every cable's path: the chords through its holes (thesis 3.8.1) or a
        // continuous tendon's integral along the pass (`statics::pass::continuous`)
        self.ws.cable_lengths_into(&mut iter.lengths);
        for (i, &j) in tendons.driven.iter().enumerate() {
            let l = iter.lengths[j];
            tendons.free0[i] = tendons.mech[i].free_length_at_rest(l);
            if tendons.free0[i].is_nan() || tendons.free0[i] <= 0.0 {
                return Err(ModelError::OutOfRange {
                    field: format!("robot.cables[{j}].tendon"),
                    value: tendons.free0[i],
                    why: "the pretension and series spring leave no free length".into(),
                });
            }
        }
        // the reference is the point of zero readings
        iter.free.copy_from_slice(&tendons.free0);
        tendons.x_ref.clear();
        tendons.x_ref.extend_from_slice(self.ws.unknowns_vector());
        self.status.has_solution = true;
        Ok(())
    }
}
