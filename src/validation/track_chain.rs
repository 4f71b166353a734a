//! Estimation on the hardware from servo readings alone, as `cablesense track`
//! runs it: the scene's readings parser (`[readings]` table) reads each row, a
//! [`TrackChain`] solves it warm-started from the previous row, and a row that
//! does not converge is not the next row's warm start (the workspace is rolled back
//! to its state after the last converged row first). [`track_errors`] sets the chain's tips
//! (capture frame and marker offset from the scene's `[calibration]` table) against
//! the measured ones: the same val error as the calibrated solve of
//! [`super::hardware_benchmark`] when both chains converge every row on the same
//! branch (they differ only in what follows a failed row: a cold restart there, the
//! rolled-back last good row here).
//!
//! The scene's readings conditioning (`[readings] time_offset_s`, `backlash_m`:
//! [`crate::calibrate::conditioning`]) is applied by the chain from a small
//! per-stream state ([`ReadingsHistory`]): it follows every row whose readings were
//! valid (converged or not, as the servos moved either way), and a row whose
//! readings are rejected leaves it as it was. A negative time offset (readings
//! from the future) is clamped to the newest row in a stream, so `track` and the
//! offline calibration agree for offsets >= 0.

use crate::calibrate::{
    CalibrationError, CalibrationSpec, Conditioning, ReadingsHistory, RigidTransform, TipErrors,
};
use crate::error::ModelError;
use crate::files::Scene;
use crate::tendons::{TendonReport, TendonWorkspace};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// The warm-started chain of `track` on a tendon-driven scene.
pub struct TrackChain {
    /// The workspace, its rollback on: a row that does not converge is not the next
    /// row's warm start ([`TendonWorkspace::set_rollback`]).
    ws: TendonWorkspace,
    /// Time offset and backlash state of the stream.
    history: ReadingsHistory,
    /// Its state before the row being stepped (restored when the row is rejected).
    saved: ReadingsHistory,
    /// Name of the time column, for errors.
    time_column: String,
}

/// One row of a [`TrackChain`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChainStep {
    /// The solve of this row.
    pub report: TendonReport,
    /// The row did not converge: the next row starts from the state before it (the
    /// last converged row's, or the reference's), not from this row's state.
    pub fallback: bool,
}

impl TrackChain {
    /// A chain on `ws` (warm from its reference solve), readings unconditioned; the
    /// workspace's rollback is turned on.
    pub fn new(mut ws: TendonWorkspace) -> Self {
        ws.set_rollback(true);
        let history = ReadingsHistory::new(Conditioning::default());
        Self {
            ws,
            saved: history.clone(),
            history,
            time_column: "t_s".into(),
        }
    }
    /// The chain of `scene` on `ws`: with the scene's `[readings]` conditioning.
    pub fn for_scene(scene: &Scene, ws: TendonWorkspace) -> Self {
        let mut chain = Self::new(ws);
        chain.history = ReadingsHistory::new(Conditioning::from_spec(scene.readings.as_ref()));
        chain.saved = chain.history.clone();
        chain.time_column = scene
            .readings
            .as_ref()
            .map_or_else(|| "t_s".into(), |r| r.time_column.clone());
        chain
    }
    /// The workspace (the state of the last row solved).
    pub fn workspace(&self) -> &TendonWorkspace {
        &self.ws
    }
    /// The workspace, mutable (e.g. to read a full solution).
    pub fn workspace_mut(&mut self) -> &mut TendonWorkspace {
        &mut self.ws
    }
    /// Solve one row (readings in m, in the workspace's tendon order), warm-started
    /// from the previous row, or, when the previous row did not converge, from the
    /// workspace rolled back to its whole state after the last converged row (the
    /// library's rollback, [`TendonWorkspace::set_rollback`]), so rows after a failed
    /// one are bit-identical to a stream without it. Invalid
    /// readings are an error and leave the chain as it was.
    pub fn step(&mut self, readings_m: &[f64]) -> Result<ChainStep, ModelError> {
        self.step_at(None, readings_m)
    }

    /// [`TrackChain::step`] of a row stamped `t_s` (s; needed with a time offset):
    /// the readings are conditioned first (time offset, backlash). A rejected row
    /// (an error) leaves the conditioning state as it was too.
    pub fn step_at(
        &mut self,
        t_s: Option<f64>,
        readings_m: &[f64],
    ) -> Result<ChainStep, ModelError> {
        self.saved.clone_from(&self.history);
        let q = match self.history.push(t_s, readings_m, &self.time_column) {
            Ok(q) => q.to_vec(),
            Err(e) => {
                self.history.clone_from(&self.saved);
                return Err(e);
            }
        };
        let step = self.solve(&q);
        if step.is_err() {
            self.history.clone_from(&self.saved);
        }
        step
    }

    fn solve(&mut self, readings_m: &[f64]) -> Result<ChainStep, ModelError> {
        let report = self.ws.solve_readings(readings_m)?;
        let fallback = self.ws.rollback_pending();
        Ok(ChainStep { report, fallback })
    }
}

/// The tip errors of a [`TrackChain`] over a recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrackErrors {
    /// Errors over the rows with a measured tip (all rows are solved; rows that did
    /// not converge count with the tip they returned).
    pub errors: TipErrors,
    /// Rows solved.
    pub rows: usize,
    /// Rows that did not converge (fallback rows).
    pub not_converged: usize,
    /// Rows the parser rejected (line, why).
    pub bad_rows: Vec<(usize, String)>,
    /// Model tip per solved row with a measured tip (m, base frame, marker
    /// offset applied), in row order.
    pub model_m: Vec<Vector3<f64>>,
    /// Mean wall time of a row's solve (s).
    pub mean_row_s: f64,
}

/// Run the `track` chain of `scene` (tendon-driven, with `[readings]` mapping the
/// measured tip and `[calibration]` giving the capture frame and marker offset)
/// over the recording `text` (`file` names it in errors).
pub fn track_errors(
    scene: &Scene,
    file: &str,
    text: &str,
) -> Result<TrackErrors, CalibrationError> {
    let spec: CalibrationSpec = scene.calibration.clone().ok_or_else(|| {
        CalibrationError::BadInput(format!(
            "{file}: the scene has no [calibration] table (capture frame, marker offset)"
        ))
    })?;
    let frame = RigidTransform::from_spec(&spec.capture_to_base);
    let offset = Vector3::from(spec.marker_offset_m);
    let ws = scene
        .tendon_workspace()
        .map_err(|source| CalibrationError::Model {
            context: "calibrated scene".into(),
            source,
        })?;
    let mut parser = scene.readings_parser(&ws);
    let mut chain = TrackChain::for_scene(scene, ws);
    let (mut model, mut measured) = (Vec::new(), Vec::new());
    let (mut rows, mut not_converged, mut bad_rows, mut time) = (0, 0, Vec::new(), 0.0);
    for (i, line) in text.lines().enumerate() {
        let row = match parser.line(i + 1, line) {
            Ok(None) => continue,
            Ok(Some(r)) => r,
            Err(e) => {
                bad_rows.push((e.line, e.why));
                continue;
            }
        };
        let t0 = std::time::Instant::now();
        let step =
            chain
                .step_at(row.t_s, &row.readings_m)
                .map_err(|source| CalibrationError::Model {
                    context: format!("{file} line {}: readings", row.line),
                    source,
                })?;
        time += t0.elapsed().as_secs_f64();
        rows += 1;
        not_converged += usize::from(!step.report.status.is_converged());
        if let Some(tip) = row.measured_tip_m {
            let pose = *chain.workspace_mut().workspace_mut().solution().tip();
            model.push(pose.position + pose.rotation * offset);
            measured.push(frame.apply(&Vector3::from(tip)));
        }
    }
    Ok(TrackErrors {
        errors: TipErrors::of(&model, &measured),
        rows,
        not_converged,
        bad_rows,
        model_m: model,
        mean_row_s: time / rows.max(1) as f64,
    })
}
