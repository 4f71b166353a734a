//! Tendon-driven robots in the experiments: sweeps over actuator readings of
//! displacement-driven tendons, every rung through [`ReadingsModel`]
//! ([`Rung::build_readings`]: CC/PCC by the constant-curvature kinematics, rod rungs by
//! the tendon solve [`crate::tendons::TendonWorkspace`]).
//!
//! Readings are generated from arcs: "bend every section by `theta` towards `phi_k`"
//! means the readings the constant-curvature kinematics maps to those arcs
//! ([`TendonKinematics::readings_for`], Webster & Jones 2010: `q_i = sum_k r theta_k
//! cos(phi_k - sigma_ik)`). The mechanics answers them with a smaller bend (the
//! tendons stretch, the rod compresses, gravity acts), which is exactly the model
//! error the pareto rows measure.

use super::pareto::{measure_with, ParetoRow, ParetoScene, ParetoSettings};
use super::stability::{classify, starts_for, Outcome, PointKind, StabilityPoint, StartKind};
use super::sweep::Direction;
use super::track::{track_with, tracking_settings};
use super::{ExperimentError, Progress};
use crate::files::Scene;
use crate::ladder::{self, CcSettings, PccSettings, ReadingsModel, Rung, TendonKinematics};
use crate::loads::Loads;
use crate::robot::Robot;
use crate::settings::{GuideMass, Integrator, RodModel, SolverSettings};
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

/// Bending-plane angle (rad) of section `k` in the generated readings: `k pi / 3`, so
/// that consecutive segments bend out of one plane.
fn phi(k: usize) -> f64 {
    k as f64 * std::f64::consts::FRAC_PI_3
}

/// The readings (reading order) that bend every section by `theta` rad towards
/// `k pi/3` in the constant-curvature kinematics.
pub fn arc_readings(kin: &TendonKinematics, sections: usize, theta: f64) -> Vec<f64> {
    let arcs: Vec<(f64, f64)> = (0..sections).map(|k| (theta, phi(k))).collect();
    kin.readings_for(&arcs)
}

/// The `pareto` readings sweep: every section bent by 0.25, 0.5 and 1 rad, and 0.5 rad
/// with every paid-out tendon paid out 1.5 times as far (slack in every model).
pub fn readings_sweep(robot: &Robot) -> Result<Vec<(String, Vec<f64>)>, ExperimentError> {
    let kin = TendonKinematics::new(robot)?;
    let ns = robot.sections().len();
    let mut out: Vec<(String, Vec<f64>)> = [0.25, 0.5, 1.0]
        .iter()
        .map(|&t| (format!("bend {t} rad"), arc_readings(&kin, ns, t)))
        .collect();
    let slack = arc_readings(&kin, ns, 0.5)
        .into_iter()
        .map(|q| if q < 0.0 { 1.5 * q } else { q })
        .collect();
    out.push(("bend 0.5 rad, paid out x1.5".into(), slack));
    Ok(out)
}

fn measure(
    model: &mut dyn ReadingsModel,
    readings: &[(String, Vec<f64>)],
    nc: usize,
    reps: usize,
) -> Result<super::pareto::Measured, ExperimentError> {
    measure_with(readings.len(), nc, reps, &mut |i, start, len| {
        let rep = model.solve_readings(&readings[i].1, start)?;
        model.cable_lengths_into(len);
        Ok((rep.status.is_converged(), model.tip_position()))
    })
}

/// `pareto` on a robot with displacement-driven tendons: every rung of
/// [`ladder::readings_ladder`] (or `settings.rungs`) on [`readings_sweep`], errors
/// against [`Rung::reference`] driven by the same readings. Estimator ticks and
/// observed errors are not measured (NaN): the estimator's unknowns are loads, not
/// readings.
pub fn pareto_readings(
    name: &str,
    scene: &Scene,
    robot: &Robot,
    settings: &ParetoSettings,
    progress: &mut dyn FnMut(Progress),
) -> Result<ParetoScene, ExperimentError> {
    let readings = readings_sweep(robot)?;
    let nc = robot.cables().len();
    let mut reference = Rung::reference().build_readings(robot, &scene.loads)?;
    let refm = measure(reference.as_mut(), &readings, nc, 1)?;
    let rungs = settings
        .rungs
        .clone()
        .unwrap_or_else(|| ladder::readings_ladder(robot));
    let mut rows = Vec::new();
    for rung in &rungs {
        progress(Progress::Step(format!(
            "{name}: {} (readings)",
            rung.label()
        )));
        let mut model = rung.build_readings(robot, &scene.loads)?;
        let m = measure(model.as_mut(), &readings, nc, settings.reps)?;
        let (ok, tip_err, cable_err) = m.errors(&refm);
        rows.push(ParetoRow {
            scene: name.into(),
            rung: rung.clone(),
            loads_converged: ok,
            loads_total: readings.len(),
            tip_err,
            cable_err,
            cold_s: m.cold_s,
            warm_s: m.warm_s,
            tick_s: f64::NAN,
            est_err: f64::NAN,
            obs_err: f64::NAN,
        });
        progress(Progress::Done);
    }
    Ok(ParetoScene {
        name: name.into(),
        sweep: readings.into_iter().map(|(n, _)| n).collect(),
        rows,
    })
}

/// The settings of the readings map: CC and PCC 8 by the kinematics, Kirchhoff and
/// Cosserat (point guide mass) at RK4 8, RK4 32 and adaptive 1e-8 by the tendon solve.
pub fn readings_settings() -> Vec<Rung> {
    let mut v = vec![
        Rung::ConstantCurvature(CcSettings::default()),
        Rung::PiecewiseConstantCurvature(PccSettings {
            pieces_per_section: 8,
            guide_mass: GuideMass::None,
            ..PccSettings::default()
        }),
    ];
    for model in [RodModel::Kirchhoff, RodModel::Cosserat] {
        for integrator in [
            Integrator::Rk4 {
                steps_per_section: 8,
            },
            Integrator::Rk4 {
                steps_per_section: 32,
            },
            Integrator::Adaptive {
                tol: 1e-8,
                max_steps: 100_000,
            },
        ] {
            v.push(Rung::Rod(SolverSettings {
                rod_model: model,
                guide_mass: GuideMass::Point,
                integrator,
                ..SolverSettings::default()
            }));
        }
    }
    v
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
    for rung in readings_settings() {
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
