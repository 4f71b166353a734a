//! Scene layer: the schema of a scene file (robot + loads + numerics, and the
//! optional `[estimate]`, `[readings]` and `[calibration]` tables) in one TOML or
//! JSON document, SI units, and the parameter paths into it ([`ParamPath`]).
//!
//! Every table uses `deny_unknown_fields`, so a misspelt key fails loudly with its
//! name and position; numbers are validated when the scene is turned into a
//! [`Robot`], with the field path in the error.
//!
//! This layer only describes problems: it sits below every module that reads a
//! scene (estimate, calibrate, files, validation), and the solvers build themselves
//! from it (`TendonWorkspace::from_scene`, `ReadingsParser::from_scene`).

pub mod calibration;
pub mod estimate;
mod limits;
pub mod param;
pub mod readings;

pub use calibration::{CalibrationSpec, ModelErrorSpec};
pub use estimate::EstimateSpec;
pub use param::{set_params, set_values, ParamError, ParamPath};
pub use readings::ReadingsSpec;

use crate::error::ModelError;
use crate::loads::Loads;
use crate::robot::{Robot, RobotSpec};
use crate::settings::SolverSettings;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// A complete, reproducible forward problem.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Free-text description.
    #[serde(default)]
    pub description: String,
    /// The robot.
    pub robot: RobotSpec,
    /// Loads (default: gravity `[0, 0, -9.81]` only).
    #[serde(default)]
    pub loads: Loads,
    /// Solver settings (defaults documented on [`SolverSettings`]).
    #[serde(default)]
    pub numerics: SolverSettings,
    /// Inverse problem for `estimate` and `track` (optional).
    #[serde(default)]
    pub estimate: Option<EstimateSpec>,
    /// How to read actuator readings of displacement-driven tendons (optional).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub readings: Option<ReadingsSpec>,
    /// Calibration from a recording for `calibrate` (optional): columns, capture
    /// noise, capture frame, marker offset, parameters to fit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<CalibrationSpec>,
}

/// Why a scene could not be read.
#[derive(Debug, Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("cannot read {path}: {cause}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause (part of the message, so not also a `source()`: printers of error
        /// chains would show it twice).
        cause: std::io::Error,
    },
    /// TOML syntax or schema error (the message names the key and line).
    #[error("{path}: {message}")]
    Toml {
        /// File.
        path: PathBuf,
        /// Parser message with line, column and key.
        message: String,
    },
    /// JSON syntax or schema error (the message names the key, line and column).
    #[error("{path}: {message}")]
    Json {
        /// File.
        path: PathBuf,
        /// Parser message.
        message: String,
    },
    /// Parsed, but a value is invalid.
    #[error("{path}: {cause}")]
    Invalid {
        /// File.
        path: PathBuf,
        /// The offending field and value (part of the message, not a `source()`).
        cause: ModelError,
    },
}

impl Scene {
    /// Parse TOML text.
    pub fn from_toml_str(text: &str) -> Result<Self, SceneError> {
        toml::from_str(text).map_err(|e| SceneError::Toml {
            path: "<toml>".into(),
            message: e.to_string(),
        })
    }
    /// Parse JSON text.
    pub fn from_json_str(text: &str) -> Result<Self, SceneError> {
        serde_json::from_str(text).map_err(|e| SceneError::Json {
            path: "<json>".into(),
            message: e.to_string(),
        })
    }
    /// Read a `.toml` or `.json` file (by extension; anything else is tried as TOML).
    pub fn load(path: impl AsRef<Path>) -> Result<Self, SceneError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|cause| SceneError::Io {
            path: path.into(),
            cause,
        })?;
        let json = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        Self::parse_validated(&text, path, json)
    }
    /// Parse TOML (or JSON when `json`) text and validate it, naming `path` in errors
    /// (what [`Scene::load`] does after reading the file).
    pub fn parse_validated(text: &str, path: &Path, json: bool) -> Result<Self, SceneError> {
        let scene = if json {
            Self::from_json_str(text)
        } else {
            Self::from_toml_str(text)
        };
        let scene = scene.map_err(|e| match e {
            SceneError::Toml { message, .. } => SceneError::Toml {
                path: path.into(),
                message,
            },
            SceneError::Json { message, .. } => SceneError::Json {
                path: path.into(),
                message,
            },
            other => other,
        })?;
        scene.validate().map_err(|cause| SceneError::Invalid {
            path: path.into(),
            cause,
        })?;
        Ok(scene)
    }
    /// Validate robot, loads and numerics together.
    pub fn validate(&self) -> Result<(), ModelError> {
        let robot = Robot::new(self.robot.clone())?;
        self.loads.validate(&robot)?;
        if let Some(e) = &self.estimate {
            e.validate(&robot)?;
        }
        if let Some(r) = &self.readings {
            r.validate()?;
        }
        if let Some(c) = &self.calibration {
            c.validate()?;
        }
        self.numerics.validate()
    }
    /// The validated robot.
    pub fn build_robot(&self) -> Result<Robot, ModelError> {
        Robot::new(self.robot.clone())
    }
    /// Serialize to TOML.
    pub fn to_toml_string(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_default()
    }
}
