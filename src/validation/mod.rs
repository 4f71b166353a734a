//! Validation layer: the thesis experiments (tables 4.1-4.5) as scenes, the
//! comparison of our predictions with the thesis's observed and predicted columns,
//! and least-squares calibration of named scene parameters.
//!
//! Workflow:
//! 1. [`ThesisTable`] names a table; [`TableData::load`] reads its CSV and scene
//!    from `data/thesis/` (the scenes bundle geometry, loads template and numerics).
//! 2. [`FittedFile`] holds fitted parameter values (`data/thesis/fitted.toml`),
//!    applied on top of a scene with [`FitRecord::apply`].
//! 3. [`compare`] solves every row and lines up observed, thesis-predicted and our
//!    tip positions and cable lengths, with the thesis's error metric.
//! 4. [`FitProblem`] + [`fit`] adjust named parameters ([`ParamPath`], e.g.
//!    `robot/sections/*/youngs_modulus_pa`) to the observed or predicted columns.
//!
//! Units: SI everywhere in this module (the CSVs' cm and g are converted by
//! [`crate::files::thesis::Table::col_si`]). Printing in cm is the binary's job.

mod compare;
mod fit;
mod fitted;
mod hardware;
mod inverse;
mod inverse_loo;
mod rung_compare;
mod tables;
mod track_chain;

pub use crate::scene::param::{set_params, set_values, ParamError, ParamPath};
pub use compare::{
    compare, simulate, Comparison, LengthRow, LengthSummary, PointRow, PointSummary, RowComparison,
};
pub use fit::{fit, FitMethod, FitProblem, FitReport, FitSettings, FitStatus, Target};
pub use fitted::{FitRecord, FitRun, FittedFile, ParamValue, SceneFits, FITTED_FILE};
pub use hardware::{
    column_map, hardware_benchmark, parse_summary, shipped_hardware_benchmark, HardwareBenchmark,
    HardwareSettings, PublishedFigures, StoredSummary, CALIBRATED_SCENE, PUBLISHED, SUMMARY_JSON,
    TRAIN_CSV, VAL_CSV,
};
pub use inverse::{table_4_5_inverse, table_4_5_inverse_from, InverseRow, READING_SIGMA_M};
pub use inverse_loo::{table_4_5_loo, LooRow, TableRowModel, LOO_PARAMS, TIP_SIGMA_M, Z95};
pub use rung_compare::{
    compare_with_cc, daru_cc_spec, ftdcr_cc_spec, shipped_daru_comparison,
    shipped_ftdcr_comparison, stored_values, CcRungSpec, RangeCheck, RungComparison, DARU_DATA,
    DARU_SCENE, DARU_TRAIN_ROWS,
};
pub use tables::{LengthSpec, PointSpec, RowLoad, TableData, TableSpec, ThesisTable};
pub use track_chain::{track_errors, ChainStep, TrackChain, TrackErrors};

use crate::error::ModelError;
use crate::files::thesis::TableError;
use crate::files::SceneError;
use thiserror::Error;

/// Why a validation or calibration step could not run.
///
/// Non-convergence of a forward solve during a comparison is reported in the
/// [`Comparison`] (status per row), not as an error; during a fit it is an error
/// only at the starting point (a later trial point that fails is rejected).
#[derive(Debug, Error)]
pub enum ValidationError {
    /// A table file could not be read or lacks a column.
    #[error(transparent)]
    Table(#[from] TableError),
    /// A scene file could not be read.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A shipped-style data file could not be found or read.
    #[error(transparent)]
    Data(#[from] crate::files::demo::DataError),
    /// The scene (after setting parameters or row loads) is invalid.
    #[error("{context}: {cause}")]
    Model {
        /// What was being built.
        context: String,
        /// The invalid field (part of the message, so not also a `source()`).
        cause: ModelError,
    },
    /// Unknown table name.
    #[error("unknown table `{0}` (known: 4.1, 4.2, 4.3, 4.3m, 4.4, 4.5, 4.5acc)")]
    UnknownTable(String),
    /// A parameter path is malformed or does not lead to a number in the scene.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// The scene lacks a point load a row needs to set.
    #[error("table {table}: the scene needs loads.point[{point}] ({why})")]
    MissingPointLoad {
        /// Table.
        table: String,
        /// Index into `loads.point`.
        point: usize,
        /// Purpose of that load.
        why: String,
    },
    /// A forward solve did not converge where a result is required.
    #[error(
        "table {table}, row {row}: forward solve ended with {status:?} (residual {residual:.2e})"
    )]
    NotConverged {
        /// Table.
        table: String,
        /// Row index (0-based).
        row: usize,
        /// Solver status.
        status: crate::SolveStatus,
        /// Scaled residual.
        residual: f64,
    },
    /// The requested fit is not meaningful (no parameters, no residuals, a copied column...).
    #[error("fit: {0}")]
    BadFit(String),
    /// The fitted-values file is malformed.
    #[error("fitted values: {0}")]
    Fitted(String),
}
