//! Speed against accuracy of every rung and setting of the model ladder
//! (`cablesense pareto`).
//!
//! On a scene's load sweep ([`super::sweep::pareto_sweep`]), for every rung of
//! [`ladder::full_ladder`]: the largest tip and cable-length error against the
//! reference ([`Rung::reference`]: full Cosserat, accurate guide mass, adaptive tol
//! 1e-12), the median time of a cold solve and of a warm solve (from the previous
//! sweep load), the median time of an estimator tick on that rung and its final
//! estimate error, and on thesis scenes the RMS distance of the tracked points from
//! the observed ones. A scene with displacement-driven tendons is swept over readings
//! instead ([`tdcr::pareto_readings`]).

pub(super) mod tdcr;

use super::sweep::{across, pareto_sweep, with_tip_force};
use super::{median, ExperimentError, Progress};
use crate::estimate::{Axis, EstimateSpec, Estimator, UnknownSpec};
use crate::files::demo::{self, DataRef, DataSource};
use crate::files::Scene;
use crate::ladder::{self, ForwardModel, Rung};
use crate::loads::Loads;
use crate::robot::Robot;
use crate::statics::Start;
use crate::validation::{TableData, ThesisTable, FITTED_FILE};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Settings of the speed-against-accuracy sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ParetoSettings {
    /// Timed repetitions per rung and load; the median is reported (default 7; a
    /// setting whose first solve takes over 5 ms gets at most 3). At least 1.
    pub reps: usize,
    /// Also time estimator ticks on every rung (default true).
    pub estimator: bool,
    /// The rungs to measure (default `None`: [`ladder::full_ladder`] for load sweeps,
    /// [`ladder::readings_ladder`] for readings sweeps).
    pub rungs: Option<Vec<Rung>>,
}

impl Default for ParetoSettings {
    fn default() -> Self {
        Self {
            reps: 7,
            estimator: true,
            rungs: None,
        }
    }
}

impl ParetoSettings {
    /// Check every field.
    pub fn validate(&self) -> Result<(), ExperimentError> {
        if self.reps == 0 {
            return Err(ExperimentError::Setting {
                field: "pareto.reps".into(),
                value: 0.0,
                why: "at least 1".into(),
            });
        }
        if self.rungs.as_ref().is_some_and(|r| r.is_empty()) {
            return Err(ExperimentError::Setting {
                field: "pareto.rungs".into(),
                value: 0.0,
                why: "at least one rung (or none given for the full ladder)".into(),
            });
        }
        Ok(())
    }
}

/// One rung's row of the result. Errors are the largest over the sweep points the
/// reference converged on; `inf` when the rung failed at one of them; NaN where not
/// measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParetoRow {
    /// Scene name (file stem).
    pub scene: String,
    /// The rung and its settings.
    pub rung: Rung,
    /// Sweep points where the rung converged (of those the reference converged on).
    pub loads_converged: usize,
    /// Sweep points.
    pub loads_total: usize,
    /// Tip position error (m).
    pub tip_err: f64,
    /// Cable length error (m).
    pub cable_err: f64,
    /// Median cold solve time (s).
    pub cold_s: f64,
    /// Median warm solve time (s).
    pub warm_s: f64,
    /// Median estimator tick time (s).
    pub tick_s: f64,
    /// Estimate error at the end of the force ramp (N).
    pub est_err: f64,
    /// RMS distance of the tracked points from the thesis's observed ones (m).
    pub obs_err: f64,
}

/// A scene's result: its sweep labels and one row per rung.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParetoScene {
    /// Scene name (file stem).
    pub name: String,
    /// What was swept: load labels, or readings labels for a TDCR.
    pub sweep: Vec<String>,
    /// One row per rung, in ladder order.
    pub rows: Vec<ParetoRow>,
}

/// The shipped scenes `pareto` runs by default: `demo:scenes/*.toml` and
/// `demo:thesis/*.toml` (embedded), without the fitted-parameter file.
pub fn default_scenes() -> Vec<PathBuf> {
    ["scenes", "thesis"]
        .into_iter()
        .flat_map(demo::under)
        .filter(|f| f.path.ends_with(".toml") && !f.path.ends_with(FITTED_FILE))
        .map(|f| PathBuf::from(format!("{}{}", demo::PREFIX, f.path)))
        .collect()
}

/// Tips, lengths and convergence at each sweep point, and the median times.
pub(crate) struct Measured {
    pub tips: Vec<Vector3<f64>>,
    pub lengths: Vec<Vec<f64>>,
    pub converged: Vec<bool>,
    pub cold_s: f64,
    pub warm_s: f64,
}

impl Measured {
    /// Largest tip and cable error of `self` against `reference`, and the number of
    /// points where both converged (errors `inf` where only the reference did).
    pub fn errors(&self, reference: &Measured) -> (usize, f64, f64) {
        let (mut tip_err, mut cable_err, mut ok) = (0.0f64, 0.0f64, 0);
        for i in 0..self.tips.len() {
            if !reference.converged[i] {
                continue;
            }
            if !self.converged[i] {
                tip_err = f64::INFINITY;
                cable_err = f64::INFINITY;
                continue;
            }
            ok += 1;
            tip_err = tip_err.max((self.tips[i] - reference.tips[i]).norm());
            for (x, y) in self.lengths[i].iter().zip(&reference.lengths[i]) {
                cable_err = cable_err.max((x - y).abs());
            }
        }
        (ok, tip_err, cable_err)
    }
}

/// One sweep point's solve: `(point, start, lengths out)` -> (converged, tip).
pub(crate) type PointSolve<'a> =
    dyn FnMut(usize, Start, &mut [f64]) -> Result<(bool, Vector3<f64>), ExperimentError> + 'a;

/// Time `solve(point, start)` over the sweep: one untimed first cold solve (its tip,
/// lengths, status kept), `reps` timed cold solves and `reps` timed warm solves from
/// the previous point's solution (from point 1 for point 0). `solve` returns whether
/// it converged, the tip and fills the lengths.
pub(crate) fn measure_with(
    n: usize,
    nc: usize,
    reps: usize,
    solve: &mut PointSolve<'_>,
) -> Result<Measured, ExperimentError> {
    let mut out = Measured {
        tips: Vec::new(),
        lengths: Vec::new(),
        converged: Vec::new(),
        cold_s: f64::NAN,
        warm_s: f64::NAN,
    };
    let (mut cold, mut warm) = (Vec::new(), Vec::new());
    let mut len = vec![0.0; nc];
    for i in 0..n {
        let t0 = Instant::now();
        let (ok, tip) = solve(i, Start::Cold, &mut len)?;
        let first = t0.elapsed().as_secs_f64();
        out.converged.push(ok);
        out.tips.push(tip);
        out.lengths.push(len.clone());
        // slow settings get fewer repetitions (the median of 3 is still robust)
        let reps = if first > 5e-3 { reps.min(3) } else { reps };
        for _ in 0..reps {
            let t0 = Instant::now();
            solve(i, Start::Cold, &mut len)?;
            cold.push(t0.elapsed().as_secs_f64());
        }
        // warm: from the previous sweep point's solution
        let prev = if i == 0 { 1.min(n - 1) } else { i - 1 };
        for _ in 0..reps {
            solve(prev, Start::Cold, &mut len)?;
            let t0 = Instant::now();
            solve(i, Start::Warm, &mut len)?;
            warm.push(t0.elapsed().as_secs_f64());
        }
    }
    out.cold_s = median(&mut cold);
    out.warm_s = median(&mut warm);
    Ok(out)
}

fn measure(
    model: &mut dyn ForwardModel,
    loads: &[(String, Loads)],
    reps: usize,
) -> Result<Measured, ExperimentError> {
    let nc = model.robot().cables().len();
    measure_with(loads.len(), nc, reps, &mut |i, start, len| {
        let rep = model.solve(&loads[i].1, start)?;
        model.cable_lengths_into(len);
        Ok((rep.status.is_converged(), model.tip_position()))
    })
}

/// Estimator on `rung`: unknown tip force components on the (up to two) world axes
/// most normal to the base tangent; measurements from the reference along a ramp of
/// tip forces up to `P L^2/EI` = 1 (8 samples). The ramp is run `reps` times (once
/// when a tick takes over 5 ms), each from a fresh start at zero. Returns (median
/// tick time in s, final estimate error in N); `(NaN, inf)` when the estimator cannot
/// be built on the rung, `(NaN, NaN)` without cables.
fn estimator_ticks(
    robot: &Robot,
    scene: &Scene,
    rung: &Rung,
    reference: &mut dyn ForwardModel,
    reps: usize,
) -> Result<(f64, f64), ExperimentError> {
    let nc = robot.cables().len();
    let n_unknowns = nc.min(2);
    if n_unknowns == 0 {
        return Ok((f64::NAN, f64::NAN));
    }
    let dir = across(robot, &scene.loads);
    let t = robot.base_rotation() * Vector3::z();
    let mut axes: Vec<usize> = (0..3).collect();
    axes.sort_by(|&a, &b| t[a].abs().total_cmp(&t[b].abs()));
    axes.truncate(n_unknowns);
    let tip = robot.sections().len() - 1;
    let spec = EstimateSpec::new(
        axes.iter()
            .map(|&a| UnknownSpec::force(tip, [Axis::X, Axis::Y, Axis::Z][a]))
            .collect(),
    );
    let Ok(mut est) = Estimator::on_rung(robot.clone(), scene.loads.clone(), rung, spec) else {
        return Ok((f64::NAN, f64::INFINITY));
    };
    // measured changes: reference at the ramp minus reference at the scene loads
    let mut l0 = vec![0.0; nc];
    reference.solve(&scene.loads, Start::Cold)?;
    reference.cable_lengths_into(&mut l0);
    let ei = robot.sections()[0].stiffness.bend_twist.x;
    let mut samples = Vec::new();
    let mut l = vec![0.0; nc];
    for k in 1..=8 {
        let a = k as f64 / 8.0;
        let loads = with_tip_force(robot, &scene.loads, a, dir);
        let rep = reference.solve(&loads, Start::Warm)?;
        if !rep.status.is_converged() {
            reference.solve(&loads, Start::Cold)?;
        }
        reference.cable_lengths_into(&mut l);
        let changes: Vec<f64> = (0..nc).map(|j| l[j] - l0[j]).collect();
        let f = dir * (a * ei / (robot.length() * robot.length()));
        samples.push((changes, f));
    }
    let mut times = Vec::new();
    let mut err = f64::NAN;
    let zero = vec![0.0; axes.len()];
    for r in 0..reps.max(1) {
        est.set_theta(&zero);
        for (changes, f) in &samples {
            let t0 = Instant::now();
            est.tick(changes, None);
            times.push(t0.elapsed().as_secs_f64());
            err = axes
                .iter()
                .zip(est.theta())
                .map(|(&ax, th)| (th - f[ax]).powi(2))
                .sum::<f64>()
                .sqrt();
        }
        if r == 0 && median(&mut times.clone()) > 5e-3 {
            break;
        }
    }
    Ok((median(&mut times), err))
}

/// RMS distance (m) of the rung's tracked points from the thesis's observed points
/// (`inf` when the rung fails on a row).
pub fn observed_error(
    model: &mut dyn ForwardModel,
    data: &TableData,
) -> Result<f64, ExperimentError> {
    let mut sum = 0.0;
    let mut n = 0usize;
    for row in 0..data.rows {
        let loads = data.row_loads(&data.scene, row)?;
        let rep = model.solve(&loads, Start::Warm)?;
        if !rep.status.is_converged() && !model.solve(&loads, Start::Cold)?.status.is_converged() {
            return Ok(f64::INFINITY);
        }
        let out = model.output();
        for (p, obs) in data.spec.points.iter().zip(&data.observed) {
            let q = out.section_tips[p.section].position;
            sum += (q.x - obs[row][0]).powi(2) + (q.y - obs[row][1]).powi(2);
            n += 1;
        }
    }
    Ok(if n > 0 {
        (sum / n as f64).sqrt()
    } else {
        f64::NAN
    })
}

/// The thesis table (with tip points) whose scene is `scene_path`, read from the
/// scene's directory (embedded for `demo:thesis/...`). `Ok(None)` when the scene is
/// not a thesis table's; an error when it is but its table cannot be read.
pub fn thesis_table_for(scene_path: &Path) -> Result<Option<TableData>, ExperimentError> {
    let Some(name) = scene_path.file_name().and_then(|n| n.to_str()) else {
        return Ok(None);
    };
    let Some(t) = ThesisTable::ALL
        .into_iter()
        .find(|t| t.spec().scene == name && !t.spec().points.is_empty())
    else {
        return Ok(None);
    };
    let src = match DataRef::parse(scene_path)? {
        DataRef::Demo(f) if f.path.starts_with("thesis/") => DataSource::THESIS,
        DataRef::Demo(_) => return Ok(None),
        DataRef::Path(p) => DataSource::Dir(
            p.parent()
                .filter(|d| !d.as_os_str().is_empty())
                .unwrap_or(Path::new("."))
                .to_path_buf(),
        ),
    };
    Ok(Some(TableData::load_from(&src, t)?))
}

/// Whether `robot` is driven by readings (any displacement-driven tendon): then
/// [`run_scene`] sweeps readings ([`tdcr::pareto_readings`]).
pub fn is_tdcr(robot: &Robot) -> bool {
    robot
        .cables()
        .iter()
        .any(|c| c.actuation == crate::tendons::Actuation::Displacement)
}

/// The number of rungs [`run_scene`] measures on `robot` (for a progress bar).
pub fn rung_count(robot: &Robot, settings: &ParetoSettings) -> usize {
    match &settings.rungs {
        Some(r) => r.len(),
        None if is_tdcr(robot) => ladder::readings_ladder(robot).len(),
        None => ladder::full_ladder(robot).len(),
    }
}

/// Measure every rung on one scene (named `name`; `table`: its thesis table, for the
/// observed error). Reports a [`Progress::Step`] per rung.
pub fn run_scene(
    name: &str,
    scene: &Scene,
    table: Option<&TableData>,
    settings: &ParetoSettings,
    progress: &mut dyn FnMut(Progress),
) -> Result<ParetoScene, ExperimentError> {
    settings.validate()?;
    let robot = scene.build_robot()?;
    if is_tdcr(&robot) {
        return tdcr::pareto_readings(name, scene, &robot, settings, progress);
    }
    let loads = pareto_sweep(&robot, &scene.loads);
    let mut reference = Rung::reference().build(&robot)?;
    let refm = measure(reference.as_mut(), &loads, 1)?;
    let rungs = settings
        .rungs
        .clone()
        .unwrap_or_else(|| ladder::full_ladder(&robot));
    let mut rows = Vec::new();
    for rung in &rungs {
        progress(Progress::Step(format!("{name}: {}", rung.label())));
        let mut model = rung.build(&robot)?;
        let m = measure(model.as_mut(), &loads, settings.reps)?;
        let (ok, tip_err, cable_err) = m.errors(&refm);
        let (tick_s, est_err) = if settings.estimator {
            estimator_ticks(
                &robot,
                scene,
                rung,
                reference.as_mut(),
                settings.reps.min(3),
            )?
        } else {
            (f64::NAN, f64::NAN)
        };
        let obs_err = match table {
            Some(t) => observed_error(model.as_mut(), t)?,
            None => f64::NAN,
        };
        rows.push(ParetoRow {
            scene: name.into(),
            rung: rung.clone(),
            loads_converged: ok,
            loads_total: loads.len(),
            tip_err,
            cable_err,
            cold_s: m.cold_s,
            warm_s: m.warm_s,
            tick_s,
            est_err,
            obs_err,
        });
        progress(Progress::Done);
    }
    Ok(ParetoScene {
        name: name.into(),
        sweep: loads.into_iter().map(|(n, _)| n).collect(),
        rows,
    })
}
