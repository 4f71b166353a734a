//! The calibration itself: scene parameters (through a
//! [`CalibrationModel`](super::CalibrationModel)) plus
//! the capture-frame transform and the marker offset, fitted to a recording.
//!
//! Residual of row `i` (robot base frame, whitened by the capture noise `sigma`):
//! `r_i = (P_i + Q_i o - (R(w) m_i + t)) / sigma`, with `P_i, Q_i` the predicted pose
//! of the marker's body, `o` the marker offset in that body's frame, `m_i` the
//! measured marker in the capture frame and `x_base = R(w) x_capture + t` the capture
//! frame (`w` a rotation vector). Gaussian priors add `(x_k - mean_k) / sigma_k`.
//!
//! Stages: (1) the model at the initial parameters; a closed-form Kabsch fit of the
//! capture frame onto the predicted marker points, with a unit check (the spread of
//! the measured points against the predicted ones, when the residual is far above
//! the capture noise); (2) Levenberg-Marquardt on the frame and offset alone (cheap:
//! no model solves); (3) Levenberg-Marquardt on everything. Rows are split into
//! contiguous chunks over `threads` workers (one model clone each, rows warm-started
//! in sequence within a chunk).

use super::frame::RigidTransform;
use super::lm::{LmIteration, LmStatus};
use super::model::RowFailure;
use super::stats::{ParamStatistics, TipErrors};
use crate::scene::calibration::{CalibrationSpec, ParamSpec};
use crate::statics::SolveStatus;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// One scene parameter of a calibration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitParam {
    /// Name (the scene path).
    pub name: String,
    /// Starting value.
    pub initial: f64,
    /// Lower bound (`-inf` for none).
    pub lower: f64,
    /// Upper bound (`+inf` for none).
    pub upper: f64,
    /// Gaussian prior `(mean, sigma)`.
    pub prior: Option<(f64, f64)>,
    /// Typical size: unknowns are `x / scale`, finite-difference steps `fd_step * scale`.
    pub scale: f64,
}

impl FitParam {
    /// From a `[[calibration.params]]` entry and the scene's current value.
    pub fn from_spec(spec: &ParamSpec, initial: f64) -> Self {
        Self {
            name: spec.path.clone(),
            initial,
            lower: spec.min.unwrap_or(f64::NEG_INFINITY),
            upper: spec.max.unwrap_or(f64::INFINITY),
            prior: spec.prior_mean.zip(spec.prior_sigma),
            scale: spec
                .scale
                .unwrap_or(if initial != 0.0 { initial.abs() } else { 1.0 }),
        }
    }

    /// Every `[[calibration.params]]` entry of `spec` with its current value
    /// (`values`, in the same order: e.g. `SceneModel::values`).
    pub fn all_from_spec(spec: &CalibrationSpec, values: &[f64]) -> Vec<Self> {
        spec.params
            .iter()
            .zip(values)
            .map(|(p, v)| Self::from_spec(p, *v))
            .collect()
    }
}

impl FrameSetup {
    /// The capture frame and marker offset of a scene's `[calibration]` table.
    pub fn from_spec(spec: &CalibrationSpec) -> Self {
        Self {
            capture_to_base: RigidTransform::from_spec(&spec.capture_to_base),
            marker_offset_m: Vector3::from(spec.marker_offset_m),
            fit_capture_frame: spec.fit_capture_frame,
            fit_marker_offset: spec.fit_marker_offset,
        }
    }
}

impl CalibrationSettings {
    /// The settings a scene's `[calibration]` table gives, on `threads` workers
    /// (at least 1); the rest at their defaults.
    pub fn from_spec(spec: &CalibrationSpec, threads: usize) -> Self {
        Self {
            capture_noise_m: spec.capture_noise_m,
            huber_sigma: spec.huber_sigma,
            max_iterations: spec.max_iterations,
            threads: threads.max(1),
            ..Self::default()
        }
    }
}

/// The non-scene parameters: capture frame and marker offset, starting values and
/// whether each is fitted.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameSetup {
    /// Capture frame to robot base (`x_base = R x_capture + t`).
    pub capture_to_base: RigidTransform,
    /// Marker position in its body's local frame (m).
    pub marker_offset_m: Vector3<f64>,
    /// Fit the capture frame (6 parameters).
    pub fit_capture_frame: bool,
    /// Fit the marker offset (3 parameters).
    pub fit_marker_offset: bool,
}

/// Settings of [`calibrate`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CalibrationSettings {
    /// Capture noise, std per coordinate (m), > 0 (default 5e-4).
    pub capture_noise_m: f64,
    /// Huber threshold in noise sigmas per marker point; `None` (default) = least squares.
    pub huber_sigma: Option<f64>,
    /// LM iterations of the full fit (default 30).
    pub max_iterations: usize,
    /// LM tolerance (relative cost decrease / step; default 1e-9).
    pub tolerance: f64,
    /// Finite-difference step relative to each parameter's scale (default 1e-5).
    pub fd_step: f64,
    /// Worker threads over row chunks (default 2).
    pub threads: usize,
    /// Start by fitting the capture frame in closed form (Kabsch) (default true).
    pub initial_frame_fit: bool,
    /// Residual RMS (noise sigmas per coordinate) above which the fit is suspicious:
    /// at the start, with a 100x spread mismatch, a unit error; at the end, a warning
    /// (default 20).
    pub unit_check_sigma: f64,
    /// Relative central/forward-difference disagreement above which a parameter's
    /// finite-difference Jacobian is flagged (default 1e-3).
    pub fd_check_limit: f64,
    /// Largest fraction of the train rows that may be left out because their
    /// forward solve fails (default 0.05). A row whose solve does not converge at
    /// the start values, or in a finite-difference solve there, even when
    /// re-solved from cold ([`super::CalibrationModel::predict_retrying`]), gets a
    /// zero residual (weight zero) for the whole fit and is listed in
    /// [`CalibrationReport::failed_rows`]; after that, a trial point at which any
    /// other row fails is rejected, so every cost is compared over the same rows.
    /// With more failed rows than this fraction (of the train rows, rounded down)
    /// no step is taken and the status is [`LmStatus::TooManyFailedRows`].
    pub max_failed_fraction: f64,
    /// Order in which the rows are solved, each warm-started from the one before
    /// (default [`RowOrder::Auto`]: the result does not depend on the order of
    /// the file's rows).
    pub row_order: RowOrder,
}

/// The order of a calibration's row chain (see [`super::row_order`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RowOrder {
    /// Time order when every row has a time stamp (a time series: play and
    /// friction carry history from one row to the next), else
    /// [`RowOrder::Nearest`]. Either way the same chain whatever the order of the
    /// rows in the file.
    #[default]
    Auto,
    /// A nearest-neighbour chain in readings space from the row nearest to zero
    /// readings, ties broken by the rows' values ([`super::chain_order`]).
    Nearest,
    /// File order (a raster's line ends are long jumps for a warm start).
    File,
}

impl Default for CalibrationSettings {
    fn default() -> Self {
        Self {
            capture_noise_m: 5e-4,
            huber_sigma: None,
            max_iterations: 30,
            tolerance: 1e-9,
            fd_step: 1e-5,
            threads: 2,
            initial_frame_fit: true,
            unit_check_sigma: 20.0,
            fd_check_limit: 1e-3,
            max_failed_fraction: 0.05,
            row_order: RowOrder::Auto,
        }
    }
}

/// Which stage a progress report belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// The model at the start values, before the LM stages (`lm` is not yet
    /// meaningful: iteration 0, cost NaN).
    Start,
    /// Frame and offset only.
    Frame,
    /// All parameters.
    Full,
}

/// What the rows of a model evaluation are being put through.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowWork {
    /// Forward solves (the poses at a trial point).
    Solve,
    /// Sensitivities to the scene parameters (the Jacobian at an accepted point).
    Sensitivities,
}

/// Rows of the model evaluation in progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RowsProgress {
    /// What is done to them.
    pub work: RowWork,
    /// Rows done so far (over all worker threads).
    pub done: usize,
    /// Rows in all.
    pub total: usize,
}

/// Progress of [`calibrate`]: one report per LM trial (`rows: None`), and reports
/// of the rows of each model evaluation while it runs (about every 0.1 s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Stage.
    pub stage: Stage,
    /// The LM's report (the last one of this stage for a rows report).
    pub lm: LmIteration,
    /// Iteration limit of this stage.
    pub max_iterations: usize,
    /// The model evaluation in progress; `None` for an LM trial's report.
    pub rows: Option<RowsProgress>,
}

/// A fitted parameter (scene or non-scene).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FittedParam {
    /// Name: the scene path, `capture_to_base/rotation_vector/<i>` (rad),
    /// `capture_to_base/translation_m/<i>` (m) or `marker_offset_m/<i>` (m).
    pub name: String,
    /// Starting value (after the closed-form frame fit for the frame).
    pub initial: f64,
    /// Fitted value.
    pub value: f64,
    /// Standard error; NaN when the data do not determine it (see
    /// [`ParamStatistics::unidentifiable`]).
    pub std_error: f64,
    /// Whether the value ended on a bound (its standard error then means little).
    pub at_bound: bool,
}

/// Data split of a row.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Split {
    /// Fitted.
    Train,
    /// Held out.
    Val,
}

/// One row's outcome.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RowResult {
    /// Split.
    pub split: Split,
    /// Line in its file.
    pub line: usize,
    /// Time (s), if recorded.
    pub t_s: Option<f64>,
    /// Measured marker, capture frame (m).
    pub measured_capture_m: Vector3<f64>,
    /// Measured marker, robot base frame (m).
    pub measured_base_m: Vector3<f64>,
    /// Model marker, robot base frame (m).
    pub model_base_m: Vector3<f64>,
    /// IRLS weight of the row in the fit (1 without Huber; val rows 1).
    pub weight: f64,
    /// Input values, ordered like [`CalibrationReport::input_names`].
    pub inputs: Vec<f64>,
}

impl RowResult {
    /// Model minus measured (m, base frame).
    pub fn error_m(&self) -> Vector3<f64> {
        self.model_base_m - self.measured_base_m
    }
}

/// Everything a calibration found.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CalibrationReport {
    /// How the full LM ended.
    pub status: LmStatus,
    /// Accepted LM steps (full stage).
    pub iterations: usize,
    /// Scene parameter values, ordered like the [`FitParam`]s.
    pub scene_values: Vec<f64>,
    /// Every fitted parameter (scene first, then frame and offset when fitted).
    pub params: Vec<FittedParam>,
    /// Fitted capture frame.
    pub capture_to_base: RigidTransform,
    /// Fitted marker offset (m).
    pub marker_offset_m: Vector3<f64>,
    /// Covariance, correlation, identifiability of the fitted parameters.
    pub statistics: ParamStatistics,
    /// Train tip errors.
    pub train: TipErrors,
    /// Validation tip errors (when a validation recording was given).
    pub val: Option<TipErrors>,
    /// Robot length (m), for errors in % of length.
    pub robot_length_m: f64,
    /// Train RMS residual per coordinate in capture-noise sigmas.
    pub rms_sigma: f64,
    /// Per scene parameter: central/forward difference disagreement (see
    /// [`Sensitivities::fd_disagreement`]; empty for exact sensitivities).
    pub fd_disagreement: Vec<f64>,
    /// Things to look at (flagged Jacobian columns, large residuals, skipped rows).
    pub warnings: Vec<String>,
    /// Names of the input columns.
    pub input_names: Vec<String>,
    /// Per row: measured and model marker (failed rows are not here).
    pub rows: Vec<RowResult>,
    /// Rows whose solve failed even from cold: train rows left out of the fit
    /// ([`CalibrationSettings::max_failed_fraction`]) and val rows not predicted, in
    /// line order per split.
    #[serde(default)]
    pub failed_rows: Vec<FailedRow>,
}

/// A row left out because its forward solve failed even from cold.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FailedRow {
    /// Split.
    pub split: Split,
    /// Line in its file.
    pub line: usize,
    /// Status of the cold retry.
    pub status: SolveStatus,
    /// Its residual (the model's measure: scaled boundary residual, or m for
    /// tendons).
    pub residual: f64,
}

impl FailedRow {
    /// From a model's failure.
    pub fn new(split: Split, f: &RowFailure) -> Self {
        Self {
            split,
            line: f.line,
            status: f.status,
            residual: f.residual,
        }
    }
    /// `line N (status)` of the first `max` rows, `...` for the rest.
    pub fn list(rows: &[FailedRow], max: usize) -> String {
        let mut parts: Vec<String> = rows
            .iter()
            .take(max)
            .map(|f| format!("line {} ({})", f.line, f.status_name()))
            .collect();
        if rows.len() > max {
            parts.push(format!("... {} more", rows.len() - max));
        }
        parts.join(", ")
    }
    /// The status as in JSON (`max_iterations`, `stalled`, ...).
    pub fn status_name(&self) -> String {
        serde_json::to_value(self.status)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_else(|| format!("{:?}", self.status))
    }
}
