//! Fitted parameter values (`data/thesis/fitted.toml`): per scene file and target,
//! an ordered list of `(path, value)` overrides plus a log of the fits that
//! produced them. Written by `cablesense calibrate --write`, read by
//! `cablesense validate` and the table tests.

use super::fit::{FitReport, Target};
use super::ValidationError;
use crate::files::demo::DataSource;
use crate::files::Scene;
use crate::scene::param::{set_params, ParamPath};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The whole file.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedFile {
    /// Keyed by scene file name (`table_4_1.toml`).
    #[serde(default)]
    pub scenes: BTreeMap<String, SceneFits>,
}

/// The fits of one scene.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFits {
    /// Fitted to the thesis's predicted columns (used by `validate` and the tests).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predicted: Option<FitRecord>,
    /// Fitted to the observed columns.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub observed: Option<FitRecord>,
}

/// Parameter overrides for one scene and target, applied in order.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitRecord {
    /// Values, applied in order.
    #[serde(default)]
    pub params: Vec<ParamValue>,
    /// The fits that produced them (the latest per table/parameter set).
    #[serde(default)]
    pub runs: Vec<FitRun>,
}

/// One fitted value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParamValue {
    /// Parameter path.
    pub path: String,
    /// Value (SI).
    pub value: f64,
}

/// Log entry of one fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitRun {
    /// Tables fitted to.
    pub tables: Vec<String>,
    /// Parameters fitted.
    pub params: Vec<String>,
    /// Method (`levenberg_marquardt`, `gauss_newton`).
    pub method: String,
    /// Number of residuals.
    pub residuals: usize,
    /// RMS residual (m).
    pub rms_m: f64,
    /// Largest |residual| (m).
    pub max_abs_m: f64,
    /// Formal standard errors, parameter units (NaN written as -1: unknown).
    pub std_errors: Vec<f64>,
}

/// Name of the fitted values file in a data directory.
pub const FITTED_FILE: &str = "fitted.toml";

impl FittedFile {
    /// Parse TOML text.
    pub fn parse(text: &str) -> Result<Self, ValidationError> {
        toml::from_str(text).map_err(|e| ValidationError::Fitted(e.to_string()))
    }

    /// Read a file; a missing file is an empty set of fits.
    pub fn load(path: &Path) -> Result<Self, ValidationError> {
        match std::fs::read_to_string(path) {
            Ok(text) => Self::parse(&text)
                .map_err(|e| ValidationError::Fitted(format!("{}: {e}", path.display()))),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Self::default()),
            Err(e) => Err(ValidationError::Fitted(format!("{}: {e}", path.display()))),
        }
    }

    /// `fitted.toml` of a data directory on disk or embedded; missing is empty.
    pub fn load_from(src: &DataSource) -> Result<Self, ValidationError> {
        match src.optional_text(FITTED_FILE)? {
            Some((text, path)) => {
                Self::parse(&text).map_err(|e| ValidationError::Fitted(format!("{path}: {e}")))
            }
            None => Ok(Self::default()),
        }
    }

    /// TOML text with a header comment.
    pub fn to_toml_string(&self) -> String {
        let body = toml::to_string_pretty(self).unwrap_or_default();
        format!(
            "# Fitted scene parameters for the thesis tables (data/thesis/README.md, \"Parameter choices\").\n\
             # Written by `cablesense calibrate --write`; read by `cablesense validate` and tests/thesis_tables.rs.\n\
             # scenes.<scene file>.<target>.params are applied in order on top of the scene file.\n\n{body}"
        )
    }

    /// The record of `scene` (file name) for `target`.
    pub fn get(&self, scene: &str, target: Target) -> Option<&FitRecord> {
        let s = self.scenes.get(scene)?;
        match target {
            Target::Predicted => s.predicted.as_ref(),
            Target::Observed => s.observed.as_ref(),
        }
    }

    /// Merge a fit into the record of `scene` for `target`: set (or append) each
    /// fitted value, and replace the log entry with the same tables and parameters.
    pub fn record(&mut self, scene: &str, target: Target, tables: &[String], report: &FitReport) {
        let fits = self.scenes.entry(scene.to_string()).or_default();
        let rec = match target {
            Target::Predicted => fits.predicted.get_or_insert_with(Default::default),
            Target::Observed => fits.observed.get_or_insert_with(Default::default),
        };
        for (path, value) in report.params.iter().zip(&report.values) {
            match rec.params.iter_mut().find(|p| &p.path == path) {
                Some(p) => p.value = *value,
                None => rec.params.push(ParamValue {
                    path: path.clone(),
                    value: *value,
                }),
            }
        }
        let run = FitRun {
            tables: tables.to_vec(),
            params: report.params.clone(),
            method: match report.method {
                super::FitMethod::LevenbergMarquardt => "levenberg_marquardt".into(),
                super::FitMethod::GaussNewton => "gauss_newton".into(),
            },
            residuals: report.residuals.len(),
            rms_m: report.rms_m,
            max_abs_m: report.max_abs_m,
            std_errors: report
                .std_errors
                .iter()
                .map(|s| if s.is_finite() { *s } else { -1.0 })
                .collect(),
        };
        match rec
            .runs
            .iter_mut()
            .find(|r| r.tables == run.tables && r.params == run.params)
        {
            Some(r) => *r = run,
            None => rec.runs.push(run),
        }
    }
}

impl FitRecord {
    /// `scene` with this record's values written in order.
    pub fn apply(&self, scene: &Scene) -> Result<Scene, ValidationError> {
        let pairs = self
            .params
            .iter()
            .map(|p| Ok((p.path.parse::<ParamPath>()?, p.value)))
            .collect::<Result<Vec<_>, ValidationError>>()?;
        Ok(set_params(scene, &pairs)?)
    }

    /// The fitted value of `path`, if recorded.
    pub fn value(&self, path: &str) -> Option<f64> {
        self.params.iter().find(|p| p.path == path).map(|p| p.value)
    }
}
