//! Calibration of a robot model from a recording: scene parameters (by path,
//! [`crate::scene::param::ParamPath`]) together with the capture-frame transform and
//! the marker offset, fitted to measured marker positions.
//!
//! Workflow:
//! 1. A scene with a `[calibration]` table ([`CalibrationSpec`]: columns, unit,
//!    capture noise, parameters with bounds and priors).
//! 2. [`Recording::load`] reads the train (and validation) rows (CSV or JSON lines).
//! 3. A [`CalibrationModel`] predicts each row's marker body pose: [`TensionModel`]
//!    for the forward model driven by `tension_<cable>` columns; other models (e.g.
//!    displacement-driven tendons) implement the same trait.
//! 4. [`calibrate`]: closed-form capture frame ([`kabsch`]), then bounded, optionally
//!    robust Levenberg-Marquardt ([`levenberg_marquardt`]) over all rows, with
//!    finite-difference sensitivities checked against forward differences unless the
//!    model supplies its own ([`CalibrationModel::sensitivities`]).
//! 5. [`CalibrationReport`]: fitted values with standard errors, correlation,
//!    unidentifiable directions ([`Unidentifiable`]), train/val tip errors raw and with
//!    the mean offset removed ([`TipErrors`]); [`write_report_svg`],
//!    [`write_residuals_csv`] and [`calibrated_scene`] write it out.
//!
//! Units: SI (m, N, kg, rad); a recording's mm columns are converted on reading.

mod cc_model;
pub mod conditioning;
mod crossval;
mod fit;
mod frame;
mod identify;
mod identify_assign;
mod jacobian;
mod lm;
mod model;
mod order;
mod problem;
mod readings_model;
mod recording;
mod report;
mod run;
mod scene_job;
mod stats;
pub mod uncertainty;

pub use crate::scene::calibration::{
    CalibrationSpec, LengthUnit, ModelErrorSpec, ParamSpec, TransformSpec, MIN_HUBER_SIGMA,
};
pub use cc_model::CcModel;
pub use conditioning::{Conditioning, InputTimeline, ReadingsHistory, MAX_GAP_S};
pub use crossval::{cross_validate, parse_families, row_labels, CrossValidation, Folds, HeldOut};
pub use fit::{
    CalibrationReport, CalibrationSettings, FailedRow, FitParam, FittedParam, FrameSetup, Progress,
    RowOrder, RowResult, RowWork, RowsProgress, Split, Stage,
};
pub use frame::{kabsch, rotation_vector, umeyama, RigidTransform};
pub use identify::{
    linear_response, scene_segments, servo_rows, IdentifyError, IdentifySettings, LinearResponse,
    Pattern, PullRecording, PullRow, SceneSegment, ServoRows,
};
pub use identify_assign::{
    identify, identify_file, identify_recording, IdentifyResult, SegmentProposal, ServoEvidence,
    SwapMargin,
};
pub use jacobian::residuals_and_jacobian;
pub use lm::{
    central_differences, gradient_cosine, levenberg_marquardt, Bounds, Huber, LeastSquares,
    LmIteration, LmResult, LmSettings, LmStatus, STATIONARY_COSINE,
};
pub use model::{finite_differences, CalibrationModel, RowFailure, Sensitivities, TensionModel};
pub use order::{chain_order, row_order};
pub use readings_model::{SceneModel, ServoModel};
pub use recording::{
    is_default_input, parse_row_range, ColumnMap, Recording, RecordingRow, RowHistory,
};
pub use report::{calibrated_scene, write_report_svg, write_residuals_csv, SvgOptions};
pub use run::{calibrate, frame_param_names, CalibrationSetup};
pub use scene_job::{calibrate_scene, scene_spec, SceneCalibration};
pub use stats::{
    parameter_statistics, percentile, ErrorStats, ParamStatistics, TipErrors, Unidentifiable,
    CORRELATION_LIMIT, NULL_DIRECTION_LIMIT,
};

use crate::error::ModelError;
use crate::scene::ParamError;
use crate::statics::SolveStatus;
use thiserror::Error;

/// Why a calibration could not run. Non-convergence of the fit itself is a status
/// ([`LmStatus`]); a row the model cannot solve at the starting point is an error.
#[derive(Debug, Error)]
pub enum CalibrationError {
    /// A cell of a recording is bad (non-numeric, NaN, empty, missing).
    #[error("{file}:{line}: column `{column}`: {why}")]
    Recording {
        /// File.
        file: String,
        /// Line (1-based).
        line: usize,
        /// Column name.
        column: String,
        /// What is wrong.
        why: String,
    },
    /// A column the mapping needs is not in the header.
    #[error("{file}:{line}: no column `{column}` in the header (columns: {available})")]
    MissingColumn {
        /// File.
        file: String,
        /// Header line.
        line: usize,
        /// Missing column.
        column: String,
        /// Columns present.
        available: String,
    },
    /// The measured marker path is about 1000x larger (or smaller) than the model's and
    /// the residual is far above the capture noise: the columns' unit is wrong.
    #[error(
        "{file}:{line}: columns `{columns}` read as {unit}: the measured path spreads {spread_ratio:.3e} times the model's \
         and the best rigid fit leaves {rms_sigma:.3e} capture-noise sigmas ({} m) RMS; \
         the unit is wrong (mm read as m?) (line: the worst row)",
        crate::error::Num(*.noise_m)
    )]
    UnitMismatch {
        /// File.
        file: String,
        /// Line of the worst row.
        line: usize,
        /// Marker columns.
        columns: String,
        /// Unit they were read in.
        unit: String,
        /// Spread of the measured points over the model's.
        spread_ratio: f64,
        /// RMS residual per coordinate in noise sigmas.
        rms_sigma: f64,
        /// Stated capture noise (m).
        noise_m: f64,
    },
    /// A file could not be read or written.
    #[error("{path}: {why}")]
    Io {
        /// Path.
        path: String,
        /// Cause.
        why: String,
    },
    /// A parameter path is malformed or does not name a number in the scene.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// The scene is invalid with some parameter values or loads.
    #[error("{context}: {source}")]
    Model {
        /// What was being built.
        context: String,
        /// The invalid field.
        source: ModelError,
    },
    /// The model could not predict a row.
    #[error("line {line}: forward solve ended with {status:?} (residual {residual:.2e})")]
    NotConverged {
        /// Line of the row.
        line: usize,
        /// Solver status.
        status: SolveStatus,
        /// Scaled residual.
        residual: f64,
    },
    /// Inconsistent calibration input (parameters, columns, settings).
    #[error("calibration: {0}")]
    BadInput(String),
}
