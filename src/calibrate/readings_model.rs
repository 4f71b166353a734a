//! The calibration model of a tendon-driven robot: each row's servo readings drive
//! the displacement-driven tendons ([`crate::tendons::TendonWorkspace`]), solved warm
//! row after row (so friction's direction memory follows the recording), and the
//! pose of the body the marker sits on is predicted. [`SceneModel`] chooses it or
//! [`TensionModel`] from the scene.
//!
//! The scene's `[readings]` conditioning (time offset, backlash: see
//! [`super::conditioning`]) is applied to the whole recording a row came from
//! ([`super::RowHistory`]), so `readings/time_offset_s` and `readings/backlash_m`
//! are calibration parameters like any scene value (sensitivities by the checked
//! chained through the exact sensitivities of the tendon solve, see the `sens`
//! submodule).

use super::conditioning::{Conditioning, InputTimeline};
use super::model::{
    marker_body_pose, patched_scene, CalibrationModel, Sensitivities, TensionModel,
};
use super::recording::RecordingRow;
use super::CalibrationError;
use crate::files::Scene;
use crate::scene::ParamPath;
use crate::statics::{Pose, Start};
use crate::tendons::{Actuation, TendonWorkspace};
use std::collections::HashMap;
use std::sync::atomic::AtomicUsize;
use std::sync::Arc;

// Exact (implicit-function) sensitivities of the rows' poses to the parameters.
#[path = "readings_sens.rs"]
mod sens;
use sens::RowState;

/// Servo readings -> tendon tensions and shape -> marker body pose.
pub struct ServoModel {
    scene: Scene,
    params: Vec<ParamPath>,
    values: Vec<f64>,
    /// Per driven tendon: its column's index in a row's inputs.
    columns: Vec<usize>,
    /// Metres per unit of the reading columns (`[readings] scale_m`).
    scale: f64,
    marker_s: Option<f64>,
    ws: TendonWorkspace,
    q: Vec<f64>,
    cold: bool,
    /// The scene's `[readings]` conditioning at the current values.
    cond: Conditioning,
    /// Conditioned readings (m) of every row of the last timeline used, row-major.
    conditioned: Option<(Arc<InputTimeline>, Vec<f64>)>,
    /// Converged state of every row predicted at the current values, by line (the
    /// sensitivities start from them instead of solving the rows again).
    states: HashMap<usize, RowState>,
}

/// The readings (m) of `row` conditioned by `cond` into `q`; `cache` keeps the
/// conditioned readings of the whole timeline of the last row's recording.
pub(super) fn conditioned_into(
    cond: &Conditioning,
    cache: &mut Option<(Arc<InputTimeline>, Vec<f64>)>,
    columns: &[usize],
    scale: f64,
    row: &RecordingRow,
    q: &mut [f64],
) -> Result<(), CalibrationError> {
    if cond.is_identity() {
        for (q, &c) in q.iter_mut().zip(columns) {
            *q = row.inputs[c] * scale;
        }
        return Ok(());
    }
    let h = row.history.as_ref().ok_or_else(|| {
        CalibrationError::BadInput(format!(
            "line {}: the scene's readings conditioning ({cond:?}) needs the row's recording \
             (a row read by `Recording::load`, not built by hand)",
            row.line
        ))
    })?;
    let stale = !matches!(cache, Some((t, _)) if Arc::ptr_eq(t, &h.timeline));
    if stale {
        let all = h
            .timeline
            .conditioned(cond, columns, scale)
            .map_err(model_err(format!("line {}: readings", row.line)))?;
        *cache = Some((h.timeline.clone(), all));
    }
    let (_, all) = cache.as_ref().expect("set above");
    let m = columns.len();
    q.copy_from_slice(&all[h.index * m..(h.index + 1) * m]);
    Ok(())
}

fn model_err(context: String) -> impl FnOnce(crate::ModelError) -> CalibrationError {
    move |source| CalibrationError::Model { context, source }
}

impl ServoModel {
    /// A model of `scene` (with displacement-driven tendons) calibrating `params`;
    /// every driven tendon's reading column must be among `input_names`.
    pub fn new(
        scene: &Scene,
        params: &[ParamPath],
        input_names: &[String],
        marker_s: Option<f64>,
    ) -> Result<Self, CalibrationError> {
        let ws = scene
            .tendon_workspace()
            .map(TendonWorkspace::without_rollback)
            .map_err(model_err("scene".into()))?;
        if let Some(s) = marker_s {
            let length = ws.workspace().robot().length();
            if !(0.0..=length).contains(&s) {
                return Err(CalibrationError::BadInput(format!(
                    "marker arc length {s} m is outside the robot [0, {length}] m"
                )));
            }
        }
        let columns = reading_positions(ws.columns(), input_names)?;
        let values = params
            .iter()
            .map(|p| p.value(scene))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            scene: scene.clone(),
            params: params.to_vec(),
            values,
            q: vec![0.0; columns.len()],
            columns,
            scale: scene.readings.as_ref().map_or(1.0, |r| r.scale_m),
            marker_s,
            ws,
            cold: true,
            cond: Conditioning::from_spec(scene.readings.as_ref()),
            conditioned: None,
            states: HashMap::new(),
        })
    }

    /// The conditioned readings (m) of `row` into `self.q`.
    fn conditioned_readings(&mut self, row: &RecordingRow) -> Result<(), CalibrationError> {
        conditioned_into(
            &self.cond,
            &mut self.conditioned,
            &self.columns,
            self.scale,
            row,
            &mut self.q,
        )
    }

    /// The reading columns of a scene's displacement-driven tendons (the default
    /// inputs of a calibration), in cable order.
    pub fn reading_columns(scene: &Scene) -> Vec<String> {
        scene
            .robot
            .cables
            .iter()
            .enumerate()
            .filter(|(_, c)| c.actuation == Actuation::Displacement)
            .map(|(j, c)| {
                c.reading
                    .clone()
                    .or_else(|| c.name.clone())
                    .unwrap_or_else(|| format!("cable{j}"))
            })
            .collect()
    }
}

impl Clone for ServoModel {
    /// A fresh model at the same parameter values (the warm state is not copied).
    fn clone(&self) -> Self {
        let mut m = Self {
            scene: self.scene.clone(),
            params: self.params.clone(),
            values: Vec::new(),
            columns: self.columns.clone(),
            scale: self.scale,
            marker_s: self.marker_s,
            ws: self
                .scene
                .tendon_workspace()
                .map(TendonWorkspace::without_rollback)
                .expect("the scene this model was built from is valid"),
            q: self.q.clone(),
            cold: true,
            cond: self.cond,
            conditioned: None,
            states: HashMap::new(),
        };
        m.set_params(&self.values)
            .expect("values this model already accepted");
        m
    }
}

impl CalibrationModel for ServoModel {
    fn set_params(&mut self, values: &[f64]) -> Result<(), CalibrationError> {
        if values == self.values.as_slice() {
            return Ok(());
        }
        let scene = patched_scene(&self.scene, &self.params, values)?;
        self.ws = scene
            .tendon_workspace()
            .map(TendonWorkspace::without_rollback)
            .map_err(model_err(format!("scene with {values:?}")))?;
        self.values = values.to_vec();
        self.cold = true;
        self.cond = Conditioning::from_spec(scene.readings.as_ref());
        self.conditioned = None;
        self.states.clear();
        Ok(())
    }

    fn restart(&mut self) {
        self.cold = true;
    }

    fn begin_chain(&mut self) {
        self.cold = true;
        self.ws.forget_direction_memory();
    }

    fn predict(&mut self, row: &RecordingRow) -> Result<Pose, CalibrationError> {
        self.conditioned_readings(row)?;
        let start = if self.cold { Start::Cold } else { Start::Warm };
        let rep = self
            .ws
            .solve_readings_from(&self.q, start)
            .map_err(model_err(format!("line {}: readings", row.line)))?;
        if !rep.status.is_converged() {
            self.cold = true;
            return Err(CalibrationError::NotConverged {
                line: row.line,
                status: rep.status,
                residual: rep.residual_m,
            });
        }
        self.cold = false;
        let pose = marker_body_pose(&self.ws.workspace_mut().solution(), self.marker_s);
        self.states
            .insert(row.line, RowState::of(&self.ws, &self.q, pose));
        Ok(pose)
    }

    fn sensitivities(
        &mut self,
        values: &[f64],
        steps: &[f64],
        rows: &[RecordingRow],
        out: &mut Sensitivities,
    ) -> Result<(), CalibrationError> {
        self.exact_sensitivities(values, steps, rows, out, None)
    }

    fn sensitivities_counting(
        &mut self,
        values: &[f64],
        steps: &[f64],
        rows: &[RecordingRow],
        out: &mut Sensitivities,
        done: &AtomicUsize,
    ) -> Result<(), CalibrationError> {
        self.exact_sensitivities(values, steps, rows, out, Some(done))
    }
}

/// The calibration model a scene calls for: [`ServoModel`] when it has
/// displacement-driven tendons, else [`TensionModel`].
#[derive(Clone)]
pub enum SceneModel {
    /// Tension-driven (rows hold `tension_*`, `force_*`, `mass_*`).
    Tension(Box<TensionModel>),
    /// Servo readings of displacement-driven tendons.
    Readings(Box<ServoModel>),
}

impl SceneModel {
    /// Choose and build the model of `scene`.
    pub fn new(
        scene: &Scene,
        params: &[ParamPath],
        input_names: &[String],
        marker_s: Option<f64>,
    ) -> Result<Self, CalibrationError> {
        Ok(if ServoModel::reading_columns(scene).is_empty() {
            Self::Tension(Box::new(TensionModel::new(
                scene,
                params,
                input_names,
                marker_s,
            )?))
        } else {
            Self::Readings(Box::new(ServoModel::new(
                scene,
                params,
                input_names,
                marker_s,
            )?))
        })
    }

    /// Current parameter values (initially the scene's).
    pub fn values(&self) -> &[f64] {
        match self {
            Self::Tension(m) => m.values(),
            Self::Readings(m) => &m.values,
        }
    }

    /// Robot length (m).
    pub fn robot_length(&self) -> f64 {
        match self {
            Self::Tension(m) => m.robot_length(),
            Self::Readings(m) => m.ws.workspace().robot().length(),
        }
    }
}

impl CalibrationModel for SceneModel {
    fn set_params(&mut self, values: &[f64]) -> Result<(), CalibrationError> {
        match self {
            Self::Tension(m) => m.set_params(values),
            Self::Readings(m) => m.set_params(values),
        }
    }
    fn restart(&mut self) {
        match self {
            Self::Tension(m) => m.restart(),
            Self::Readings(m) => m.restart(),
        }
    }
    fn begin_chain(&mut self) {
        match self {
            Self::Tension(m) => m.begin_chain(),
            Self::Readings(m) => m.begin_chain(),
        }
    }
    fn predict(&mut self, row: &RecordingRow) -> Result<Pose, CalibrationError> {
        match self {
            Self::Tension(m) => m.predict(row),
            Self::Readings(m) => m.predict(row),
        }
    }
    fn sensitivities(
        &mut self,
        values: &[f64],
        steps: &[f64],
        rows: &[RecordingRow],
        out: &mut Sensitivities,
    ) -> Result<(), CalibrationError> {
        match self {
            Self::Tension(m) => m.sensitivities(values, steps, rows, out),
            Self::Readings(m) => m.sensitivities(values, steps, rows, out),
        }
    }
    fn sensitivities_counting(
        &mut self,
        values: &[f64],
        steps: &[f64],
        rows: &[RecordingRow],
        out: &mut Sensitivities,
        done: &AtomicUsize,
    ) -> Result<(), CalibrationError> {
        match self {
            Self::Tension(m) => m.sensitivities_counting(values, steps, rows, out, done),
            Self::Readings(m) => m.sensitivities_counting(values, steps, rows, out, done),
        }
    }
}

/// Where each displacement-driven tendon's reading column is among a recording's
/// inputs; a missing one is an error naming it and the inputs there are.
pub(super) fn reading_positions<S: AsRef<str>>(
    columns: &[S],
    input_names: &[String],
) -> Result<Vec<usize>, CalibrationError> {
    columns
        .iter()
        .map(|c| {
            let c = c.as_ref();
            input_names.iter().position(|n| n == c).ok_or_else(|| {
                CalibrationError::BadInput(format!(
                    "no input column `{c}` for a displacement-driven tendon (inputs: {})",
                    input_names.join(", ")
                ))
            })
        })
        .collect()
}
