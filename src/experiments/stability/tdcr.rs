//! Tendon-driven robots in the stability map: the force-and-tension form of a
//! readings scene, and the readings direction of the map (every rung through
//! [`crate::ladder::ReadingsModel`], [`Rung::build_readings`]), with readings generated from arcs
//! ([`arc_readings`]).

use super::{classify, starts_for, Outcome, PointKind, StabilityPoint, StartKind};
use crate::experiments::pareto::tdcr::arc_readings;
use crate::experiments::sweep::Direction;
use crate::experiments::track::{track_with, tracking_settings};
use crate::experiments::{ExperimentError, Progress};
use crate::files::Scene;
use crate::ladder::{Rung, TendonKinematics};
use crate::loads::Loads;
use crate::robot::Robot;
use crate::settings::SolverSettings;
use crate::statics::Start;
use crate::tendons::Actuation;
use nalgebra::Vector3;
use std::cell::RefCell;
use std::time::Instant;

/// The same robot with every displacement-driven tendon tension-driven at its
/// pretension (`loads.tensions_n`), for the force-and-tension maps.
pub fn tension_form(scene: &Scene) -> Result<Scene, ExperimentError> {
    let robot = scene.build_robot()?;
    let mut out = scene.clone();
    let nc = robot.cables().len();
    out.loads
        .tensions_n
        .resize(nc.max(out.loads.tensions_n.len()), 0.0);
    for (j, c) in robot.cables().iter().enumerate() {
        if c.actuation == Actuation::Displacement {
            out.robot.cables[j].actuation = Actuation::Tension;
            out.loads.tensions_n[j] = c.mechanics.map_or(0.0, |m| m.pretension_n);
        }
    }
    Ok(out)
}

/// The settings of the readings map: CC and PCC 8 by the kinematics, Kirchhoff and
/// Cosserat (point guide mass) at RK4 8, RK4 32 and adaptive 1e-8 by the tendon solve.
pub fn readings_settings(robot: &Robot) -> Vec<Rung> {
    crate::ladder::LadderGrid::stability_readings().rungs(robot)
}

/// The readings direction of the stability map: at each magnitude `theta` of
/// [`Direction::Readings`]'s grid, the readings that bend every section by `theta`
/// ([`arc_readings`]); each setting of [`readings_settings`] from each start (rod
/// rungs: `cold` and `warm` without load continuation inside the tendon solve,
/// `continuation` with it), classified against the reference tendon solve
/// ([`tracking_settings`], tracked in steps of 0.05 rad).
pub fn readings_map(
    robot: &Robot,
    loads: &Loads,
    out: &mut Vec<StabilityPoint>,
    progress: &mut dyn FnMut(Progress),
) -> Result<(), ExperimentError> {
    let dir = Direction::Readings;
    let kin = TendonKinematics::new(robot)?;
    let ns = robot.sections().len();
    let l = robot.length();
    let nc = robot.cables().len();
    progress(Progress::Step("readings: reference".into()));
    let reference = RefCell::new(Rung::Rod(tracking_settings()).build_readings(robot, loads)?);
    let refs: Vec<Option<Vector3<f64>>> = track_with(
        dir.grid(),
        dir.reference_step(),
        l,
        &mut |a, start| {
            let mut m = reference.borrow_mut();
            let rep = m.solve_readings(&arc_readings(&kin, ns, a), start)?;
            Ok((rep.status.is_converged(), m.tip_position()))
        },
        &mut || {
            let mut len = vec![0.0; nc];
            reference.borrow().cable_lengths_into(&mut len);
            len
        },
    )?
    .into_iter()
    .map(|p| p.map(|(t, _)| t))
    .collect();
    progress(Progress::Done);
    for rung in readings_settings(robot) {
        progress(Progress::Step(format!("readings: {}", rung.label())));
        for &start in starts_for(&rung) {
            let rung_here = match (&rung, start) {
                (Rung::Rod(s), StartKind::Cold | StartKind::Warm) => Rung::Rod(SolverSettings {
                    continuation: false,
                    ..s.clone()
                }),
                _ => rung.clone(),
            };
            let mut m = rung_here.build_readings(robot, loads)?;
            for (i, &g) in dir.grid().iter().enumerate() {
                let q = arc_readings(&kin, ns, g);
                let st = if start == StartKind::Warm && i > 0 {
                    Start::Warm
                } else {
                    Start::Cold
                };
                let t0 = Instant::now();
                // an invalid reading (a tendon pulled in beyond its length) is a failed
                // point, not the end of the map
                let rep = m.solve_readings(&q, st);
                let time_s = t0.elapsed().as_secs_f64();
                let (status, iterations, residual, converged) = match &rep {
                    Ok(r) => (
                        format!("{:?}", r.status),
                        r.iterations,
                        r.residual,
                        r.status.is_converged(),
                    ),
                    Err(e) => (format!("error: {e}"), 0, f64::NAN, false),
                };
                let tip = m.tip_position();
                let converged = converged && tip.iter().all(|x| x.is_finite());
                let (error, outcome) = classify(converged, tip, refs[i], l);
                out.push(StabilityPoint {
                    kind: PointKind::Forward,
                    method: rung.label(),
                    start,
                    dir,
                    magnitude: g,
                    status: status.replace(',', ";"),
                    iterations,
                    residual,
                    error,
                    outcome: if rep.is_err() {
                        Outcome::Failed
                    } else {
                        outcome
                    },
                    time_s,
                });
            }
        }
        progress(Progress::Done);
    }
    Ok(())
}
