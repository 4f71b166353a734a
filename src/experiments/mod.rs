//! Experiments users call from code, the CLI and the bindings: speed against accuracy
//! of every rung of the model ladder ([`pareto`], `cablesense pareto`) and where each
//! method stops converging ([`stability`], `cablesense stability`), both also on
//! tendon-driven robots driven by actuator readings ([`tdcr`]).
//!
//! Each experiment takes a plain settings struct and returns serializable result
//! rows; [`write`] turns them into the CSV files the CLI writes. Charts and progress
//! bars belong to the binary: the library reports progress through a callback
//! ([`Progress`]).
//!
//! Layout: [`sweep`] (which loads and readings are swept), [`pareto`], [`stability`]
//! (forward map) with [`track`] (the reference branch) and the estimation map in
//! `stability_estimate`, [`tdcr`] (readings sweeps), [`write`] (CSV).

pub mod pareto;
pub mod stability;
pub mod sweep;
pub mod track;
pub mod write;

/// Tendon-driven robots in the experiments: sweeps over actuator readings of
/// displacement-driven tendons (the readings rows of the pareto table and the
/// readings direction of the stability map).
pub mod tdcr {
    pub use super::pareto::tdcr::{arc_readings, pareto_readings, readings_sweep};
    pub use super::stability::tdcr::{readings_map, readings_settings, tension_form};
}

use crate::error::ModelError;
use crate::estimate::EstimateError;
use crate::files::demo::DataError;
use crate::files::SceneError;
use crate::ladder::LadderError;
use crate::validation::ValidationError;
use thiserror::Error;

/// Why an experiment could not run. Non-convergence of a model is a result (a row
/// or map point with its status), never an error.
#[derive(Debug, Error)]
pub enum ExperimentError {
    /// A rung could not be built or was given invalid loads.
    #[error(transparent)]
    Ladder(#[from] LadderError),
    /// Invalid robot, loads or readings.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The estimator could not be built.
    #[error(transparent)]
    Estimate(#[from] EstimateError),
    /// A thesis table (observed points) could not be read.
    #[error(transparent)]
    Validation(#[from] ValidationError),
    /// A scene file could not be read.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A data file or directory could not be found or read.
    #[error(transparent)]
    Data(#[from] DataError),
    /// A setting is out of range.
    #[error("{field} = {} is out of range: {why}", crate::error::Num(*.value))]
    Setting {
        /// Field path, e.g. `pareto.reps`.
        field: String,
        /// Rejected value.
        value: f64,
        /// What is allowed.
        why: String,
    },
    /// Writing a result file failed.
    #[error("writing {what}: {source}")]
    Io {
        /// What was being written.
        what: String,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// What a long experiment reports while it runs (to draw a progress bar).
#[derive(Clone, Debug, PartialEq)]
pub enum Progress {
    /// Starting one unit of work (a rung, a direction's reference, ...), with a label.
    Step(String),
    /// One unit of work finished.
    Done,
    /// A status line for the user (e.g. a slow point, a finished scene).
    Note(String),
}

/// Median of `v` (sorted in place); NaN when empty.
pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Indices on the Pareto front of `(time, error)` points: no other point is both
/// faster and at least as accurate. Points with a non-finite coordinate are never on it.
pub fn front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut best = f64::INFINITY;
    let mut out = Vec::new();
    for i in idx {
        if points[i].1 < best {
            best = points[i].1;
            out.push(i);
        }
    }
    out
}
