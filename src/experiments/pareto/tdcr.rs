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

use super::{measure_with, Measured, ParetoRow, ParetoScene, ParetoSettings};
use crate::experiments::{ExperimentError, Progress};
use crate::files::Scene;
use crate::ladder::{self, ReadingsModel, Rung, TendonKinematics};
use crate::robot::Robot;

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
) -> Result<Measured, ExperimentError> {
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
