//! What a calibration fits: a model that, for given parameter values, predicts the
//! pose of the body each marker is fixed to, row by row; and its implementation
//! for the forward model driven by cable tensions ([`TensionModel`]).
//!
//! The calibration layer applies the marker offset and the capture-frame
//! transform itself, so a model only predicts poses in the robot base frame.

use super::recording::RecordingRow;
use super::CalibrationError;
use crate::files::Scene;
use crate::loads::Loads;
use crate::scene::{set_values, ParamPath};
use crate::statics::{Pose, SolveStatus, Start, Workspace};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A model to calibrate: given parameter values, predict each row's marker body pose.
///
/// Rows are predicted in sequence, each warm-started from the previous one;
/// [`CalibrationModel::restart`] marks a break in the sequence (a new chunk of rows).
pub trait CalibrationModel: Send {
    /// Rebuild for new parameter values (ordered like the calibration's scene
    /// parameters; e.g. the scene patched through `validation::ParamPath`).
    fn set_params(&mut self, values: &[f64]) -> Result<(), CalibrationError>;

    /// The next [`CalibrationModel::predict`] starts cold (default: nothing to do).
    fn restart(&mut self) {}

    /// A new chain of rows begins: as [`CalibrationModel::restart`], and the model
    /// forgets the history of earlier chains (the friction's direction memory), so a
    /// row's prediction depends only on the rows before it in its own chain; every
    /// evaluation of a chain (the base sweep and each finite-difference sweep) then
    /// sees the same history.
    fn begin_chain(&mut self) {
        self.restart();
    }

    /// Pose (robot base frame, m) of the body the marker is fixed to, for `row`,
    /// warm-started from the previously predicted row.
    fn predict(&mut self, row: &RecordingRow) -> Result<Pose, CalibrationError>;

    /// [`CalibrationModel::predict`] that survives a row whose forward solve does not
    /// converge ([`CalibrationError::NotConverged`]): the model is restarted and the
    /// row solved once more from cold; if that fails too, the row's failure is
    /// returned (`Ok(Err(..))`) and the model is left restarted, so the next row
    /// starts cold, not from the failed state. Other errors (an invalid scene or
    /// reading) are returned as errors.
    fn predict_retrying(
        &mut self,
        row: &RecordingRow,
    ) -> Result<Result<Pose, RowFailure>, CalibrationError> {
        match self.predict(row) {
            Err(CalibrationError::NotConverged { .. }) => {
                self.restart();
                match self.predict(row) {
                    Ok(p) => Ok(Ok(p)),
                    Err(CalibrationError::NotConverged {
                        line,
                        status,
                        residual,
                    }) => {
                        self.restart();
                        Ok(Err(RowFailure {
                            line,
                            status,
                            residual,
                        }))
                    }
                    Err(e) => Err(e),
                }
            }
            Ok(p) => Ok(Ok(p)),
            Err(e) => Err(e),
        }
    }

    /// Poses of `rows` at `values` and their sensitivities to each parameter.
    /// `steps[k]` is a finite-difference step for parameter `k` (its unit). Default:
    /// [`finite_differences`] (central differences, each checked against the forward
    /// difference). A model with exact sensitivities overrides this and leaves
    /// [`Sensitivities::fd_disagreement`] empty. A row whose solve fails (after the
    /// cold retry of [`CalibrationModel::predict_retrying`]) at `values` or at a
    /// perturbed value is listed in [`Sensitivities::failed`]. Must leave the model
    /// at `values`.
    fn sensitivities(
        &mut self,
        values: &[f64],
        steps: &[f64],
        rows: &[RecordingRow],
        out: &mut Sensitivities,
    ) -> Result<(), CalibrationError> {
        finite_differences(self, values, steps, rows, out)
    }

    /// [`CalibrationModel::sensitivities`] that adds each row to `done` when it is
    /// finished (for progress reports from worker threads). Default: all rows at the
    /// end.
    fn sensitivities_counting(
        &mut self,
        values: &[f64],
        steps: &[f64],
        rows: &[RecordingRow],
        out: &mut Sensitivities,
        done: &AtomicUsize,
    ) -> Result<(), CalibrationError> {
        self.sensitivities(values, steps, rows, out)?;
        done.fetch_add(rows.len(), Ordering::Relaxed);
        Ok(())
    }
}

/// Predicted poses of a run of rows and their parameter sensitivities.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sensitivities {
    /// Parameters.
    pub params: usize,
    /// Pose per row.
    pub poses: Vec<Pose>,
    /// `d position / d param`, index `row * params + k` (m per parameter unit).
    pub d_position: Vec<Vector3<f64>>,
    /// Rotation sensitivity as a world-frame angular vector `w` with
    /// `dR/dparam = [w]x R`, index `row * params + k`.
    pub d_rotation: Vec<Vector3<f64>>,
    /// Per parameter: largest |central - forward difference| of the positions over
    /// the largest |central| or |forward difference| (a check of the finite differences; large
    /// values mean noise or a kink). Empty for exact sensitivities.
    pub fd_disagreement: Vec<f64>,
    /// Rows (index into the `rows` given) whose solve failed at the values or at a
    /// perturbed value, with the first failure; their pose and derivatives are zero
    /// and must not be used.
    pub failed: Vec<(usize, RowFailure)>,
}

/// A row whose forward solve did not converge, even from cold.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RowFailure {
    /// Line of the row in its file.
    pub line: usize,
    /// Status of the cold retry.
    pub status: SolveStatus,
    /// Its residual (the model's unit: scaled boundary residual, or m for tendons).
    pub residual: f64,
}

impl Sensitivities {
    pub(super) fn resize(&mut self, rows: usize, params: usize) {
        self.failed.clear();
        self.params = params;
        self.poses.resize(rows, identity_pose());
        self.d_position.resize(rows * params, Vector3::zeros());
        self.d_rotation.resize(rows * params, Vector3::zeros());
    }
}

pub(super) fn identity_pose() -> Pose {
    Pose {
        position: Vector3::zeros(),
        rotation: Matrix3::identity(),
    }
}

/// Predict `rows` in sequence from cold; a row that fails (after the cold retry)
/// gets the identity pose and is added to `failed` (if not yet there).
fn predict_all<M: CalibrationModel + ?Sized>(
    m: &mut M,
    rows: &[RecordingRow],
    out: &mut [Pose],
    failed: &mut Vec<(usize, RowFailure)>,
) -> Result<(), CalibrationError> {
    m.begin_chain();
    for (i, (row, o)) in rows.iter().zip(out.iter_mut()).enumerate() {
        match m.predict_retrying(row)? {
            Ok(p) => *o = p,
            Err(f) => {
                *o = identity_pose();
                if !failed.iter().any(|(j, _)| *j == i) {
                    failed.push((i, f));
                }
            }
        }
    }
    Ok(())
}

/// Central-difference sensitivities with a forward-difference check: for each
/// parameter, the rows are predicted in sequence at `values +- steps[k]`.
pub fn finite_differences<M: CalibrationModel + ?Sized>(
    m: &mut M,
    values: &[f64],
    steps: &[f64],
    rows: &[RecordingRow],
    out: &mut Sensitivities,
) -> Result<(), CalibrationError> {
    let n = values.len();
    out.resize(rows.len(), n);
    out.fd_disagreement = vec![0.0; n];
    m.set_params(values)?;
    let mut failed = Vec::new();
    predict_all(m, rows, &mut out.poses, &mut failed)?;
    let mut plus = vec![identity_pose(); rows.len()];
    let mut minus = vec![identity_pose(); rows.len()];
    let mut x = values.to_vec();
    for k in 0..n {
        let h = steps[k];
        x[k] = values[k] + h;
        m.set_params(&x)?;
        predict_all(m, rows, &mut plus, &mut failed)?;
        x[k] = values[k] - h;
        m.set_params(&x)?;
        predict_all(m, rows, &mut minus, &mut failed)?;
        x[k] = values[k];
        let (mut worst, mut size) = (0.0f64, 0.0f64);
        for i in 0..rows.len() {
            if failed.iter().any(|(j, _)| *j == i) {
                out.d_position[i * n + k] = Vector3::zeros();
                out.d_rotation[i * n + k] = Vector3::zeros();
                continue;
            }
            let central = (plus[i].position - minus[i].position) / (2.0 * h);
            let forward = (plus[i].position - out.poses[i].position) / h;
            worst = worst.max((central - forward).norm());
            size = size.max(central.norm()).max(forward.norm());
            out.d_position[i * n + k] = central;
            let dr = plus[i].rotation * minus[i].rotation.transpose();
            out.d_rotation[i * n + k] = super::frame::rotation_vector(&dr) / (2.0 * h);
        }
        out.fd_disagreement[k] = if size > 0.0 { worst / size } else { 0.0 };
    }
    // a row that failed only at a perturbed value failed after its derivative
    // columns of earlier parameters were written: zero them too
    failed.sort_by_key(|(i, _)| *i);
    for (i, _) in &failed {
        out.poses[*i] = identity_pose();
        for k in 0..n {
            out.d_position[i * n + k] = Vector3::zeros();
            out.d_rotation[i * n + k] = Vector3::zeros();
        }
    }
    out.failed = failed;
    m.set_params(values)?;
    Ok(())
}

/// How an input column drives the tension model.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Slot {
    /// `tension_<cable>` (N).
    Tension(usize),
    /// `force_<k>_<x|y|z>` (N): component of `loads.point[k].force_n`.
    Force(usize, usize),
    /// `mass_<k>` (kg): `loads.point[k].mass_kg`.
    Mass(usize),
}

/// The forward model driven by cable tensions: the scene's loads with each row's
/// `tension_<cable name>` (N; `tension_<index>` for unnamed cables),
/// `force_<k>_<x|y|z>` (N, `loads.point[k]` in its frame) and `mass_<k>` (kg)
/// columns written in, solved warm by a [`Workspace`].
pub struct TensionModel {
    scene: Scene,
    params: Vec<ParamPath>,
    values: Vec<f64>,
    slots: Vec<Slot>,
    marker_s: Option<f64>,
    ws: Workspace,
    loads: Loads,
    cold: bool,
}

impl TensionModel {
    /// A model of `scene` whose `params` are calibrated, reading `input_names`
    /// (a recording's input columns); the marker sits on the body frame at arc
    /// length `marker_s` (m; `None` = the tip).
    pub fn new(
        scene: &Scene,
        params: &[ParamPath],
        input_names: &[String],
        marker_s: Option<f64>,
    ) -> Result<Self, CalibrationError> {
        let robot = scene
            .build_robot()
            .map_err(|source| CalibrationError::Model {
                context: "scene".into(),
                source,
            })?;
        let cables: Vec<String> = robot.cables().iter().map(|c| c.name.clone()).collect();
        let npoint = scene.loads.point.len();
        let mut slots = Vec::new();
        for name in input_names {
            let bad =
                |why: String| CalibrationError::BadInput(format!("input column `{name}`: {why}"));
            let slot = if let Some(c) = name.strip_prefix("tension_") {
                let j = cables
                    .iter()
                    .position(|n| n == c)
                    .or_else(|| c.parse::<usize>().ok().filter(|j| *j < cables.len()))
                    .ok_or_else(|| {
                        bad(format!("no cable `{c}` (cables: {})", cables.join(", ")))
                    })?;
                Slot::Tension(j)
            } else if let Some(rest) = name.strip_prefix("force_") {
                let (k, axis) = rest
                    .split_once('_')
                    .ok_or_else(|| bad("expected force_<point>_<x|y|z>".into()))?;
                let k: usize = k
                    .parse()
                    .map_err(|_| bad(format!("`{k}` is not a point-load index")))?;
                let a = match axis {
                    "x" => 0,
                    "y" => 1,
                    "z" => 2,
                    o => return Err(bad(format!("axis `{o}` is not x, y or z"))),
                };
                if k >= npoint {
                    return Err(bad(format!("the scene has {npoint} point loads")));
                }
                Slot::Force(k, a)
            } else if let Some(k) = name.strip_prefix("mass_") {
                let k: usize = k
                    .parse()
                    .map_err(|_| bad(format!("`{k}` is not a point-load index")))?;
                if k >= npoint {
                    return Err(bad(format!("the scene has {npoint} point loads")));
                }
                Slot::Mass(k)
            } else {
                return Err(bad(
                    "not an input of the tension model (tension_<cable>, force_<k>_<x|y|z>, mass_<k>)"
                        .into(),
                ));
            };
            slots.push(slot);
        }
        if let Some(s) = marker_s {
            if !(0.0..=robot.length()).contains(&s) {
                return Err(CalibrationError::BadInput(format!(
                    "marker arc length {s} m is outside the robot [0, {}] m",
                    robot.length()
                )));
            }
        }
        let values = params
            .iter()
            .map(|p| p.value(scene))
            .collect::<Result<Vec<_>, _>>()?;
        let ws = Workspace::new(robot, scene.loads.clone(), scene.numerics.clone()).map_err(
            |source| CalibrationError::Model {
                context: "scene".into(),
                source,
            },
        )?;
        Ok(Self {
            scene: scene.clone(),
            params: params.to_vec(),
            values,
            slots,
            marker_s,
            loads: scene.loads.clone(),
            ws,
            cold: true,
        })
    }

    /// Current parameter values (initially the scene's).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The scene with the parameters at `values` (validated).
    pub fn scene_with(&self, values: &[f64]) -> Result<Scene, CalibrationError> {
        patched_scene(&self.scene, &self.params, values)
    }

    /// Robot length (m) at the current values.
    pub fn robot_length(&self) -> f64 {
        self.ws.robot().length()
    }

    fn row_loads(&mut self, row: &RecordingRow) {
        for (slot, v) in self.slots.iter().zip(&row.inputs) {
            match *slot {
                Slot::Tension(j) => {
                    if self.loads.tensions_n.len() <= j {
                        self.loads.tensions_n.resize(j + 1, 0.0);
                    }
                    self.loads.tensions_n[j] = *v;
                }
                Slot::Force(k, a) => self.loads.point[k].force_n[a] = *v,
                Slot::Mass(k) => self.loads.point[k].mass_kg = *v,
            }
        }
    }
}

impl Clone for TensionModel {
    /// A fresh model at the same parameter values (the warm state is not copied).
    fn clone(&self) -> Self {
        let mut m = Self {
            scene: self.scene.clone(),
            params: self.params.clone(),
            values: self.values.clone(),
            slots: self.slots.clone(),
            marker_s: self.marker_s,
            ws: Workspace::new(
                self.ws.robot().clone(),
                self.ws.loads().clone(),
                self.ws.settings().clone(),
            )
            .expect("the workspace's own robot, loads and settings are valid"),
            loads: self.loads.clone(),
            cold: true,
        };
        m.cold = true;
        m
    }
}

impl CalibrationModel for TensionModel {
    fn set_params(&mut self, values: &[f64]) -> Result<(), CalibrationError> {
        if values == self.values.as_slice() {
            return Ok(());
        }
        let scene = self.scene_with(values)?;
        let robot = scene
            .build_robot()
            .map_err(|source| CalibrationError::Model {
                context: format!("scene with {values:?}"),
                source,
            })?;
        self.ws = Workspace::new(robot, self.loads.clone(), scene.numerics.clone()).map_err(
            |source| CalibrationError::Model {
                context: format!("scene with {values:?}"),
                source,
            },
        )?;
        // rows' inputs overwrite these; other loads follow the patched scene
        let mut loads = scene.loads.clone();
        loads.tensions_n = self.loads.tensions_n.clone();
        for (k, p) in loads.point.iter_mut().enumerate() {
            for slot in &self.slots {
                match *slot {
                    Slot::Force(j, a) if j == k => p.force_n[a] = self.loads.point[k].force_n[a],
                    Slot::Mass(j) if j == k => p.mass_kg = self.loads.point[k].mass_kg,
                    _ => {}
                }
            }
        }
        self.loads = loads;
        self.values = values.to_vec();
        self.cold = true;
        Ok(())
    }

    fn restart(&mut self) {
        self.cold = true;
    }

    fn predict(&mut self, row: &RecordingRow) -> Result<Pose, CalibrationError> {
        self.row_loads(row);
        self.ws
            .set_loads(&self.loads)
            .map_err(|source| CalibrationError::Model {
                context: format!("line {}: loads", row.line),
                source,
            })?;
        let start = if self.cold { Start::Cold } else { Start::Warm };
        let report = self.ws.solve(start);
        if !report.status.is_converged() {
            self.cold = true;
            return Err(CalibrationError::NotConverged {
                line: row.line,
                status: report.status,
                residual: report.residual,
            });
        }
        self.cold = false;
        Ok(marker_body_pose(&self.ws.solution(), self.marker_s))
    }
}

/// `scene` with `params` at `values`, validated (the scene of a calibration model).
pub(super) fn patched_scene(
    scene: &Scene,
    params: &[ParamPath],
    values: &[f64],
) -> Result<Scene, CalibrationError> {
    let patched = set_values(scene, params, values)?;
    patched
        .validate()
        .map_err(|source| CalibrationError::Model {
            context: format!("scene with {values:?}"),
            source,
        })?;
    Ok(patched)
}

/// Pose of the body the marker sits on: the tip, or the backbone at `marker_s` (m).
pub(super) fn marker_body_pose(sol: &crate::statics::Solution, marker_s: Option<f64>) -> Pose {
    match marker_s {
        None => *sol.tip(),
        Some(s) => pose_at(&sol.samples, s),
    }
}

/// Pose at arc length `s` between the samples (position linear, rotation geodesic).
fn pose_at(samples: &[crate::statics::Sample], s: f64) -> Pose {
    let i = samples
        .iter()
        .rposition(|x| x.s <= s)
        .unwrap_or(0)
        .min(samples.len().saturating_sub(2));
    let (a, b) = (&samples[i], &samples[(i + 1).min(samples.len() - 1)]);
    let f = if b.s > a.s {
        ((s - a.s) / (b.s - a.s)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let rel = super::frame::rotation_vector(&(a.rotation.transpose() * b.rotation));
    Pose {
        position: a.r + (b.r - a.r) * f,
        rotation: a.rotation * crate::math::exp_so3(&(rel * f)),
    }
}
