//! The scene's optional `[calibration]` table: how a recording's columns map to the
//! model, the capture noise, the non-scene parameters (capture frame, marker
//! offset) and the scene parameters to fit. Every table rejects unknown keys.
//!
//! ```toml
//! [calibration]
//! marker_columns = ["tip_x", "tip_y", "tip_z"]  # marker position columns (default)
//! unit = "mm"                                   # "m" (default) or "mm": unit of the marker columns
//! time_column = "t_s"                           # s; optional, default "t_s" when present
//! inputs = ["tension_a", "tension_b"]           # input columns; default: every tension_*, force_*, mass_* column
//! # marker_s_m = 0.1                            # arc length of the body the marker sits on (m); absent = tip
//! marker_offset_m = [0.0, 0.0, 0.008]           # marker in that body's local frame (m); fitted
//! capture_noise_m = 5e-4                        # capture noise std per coordinate (m), > 0
//! fit_capture_frame = true                      # fit the 6 capture-frame parameters
//! fit_marker_offset = true                      # fit the 3 marker-offset parameters
//! # huber_sigma = 3.0                           # Huber threshold in noise sigmas, >= 1e-3 (absent: plain least squares)
//! max_iterations = 30
//! capture_to_base = { rotation_vector = [0, 0, 0], translation_m = [0, 0, 0] }  # x_base = R x_capture + t
//!
//! [[calibration.params]]
//! path = "robot/sections/*/youngs_modulus_pa"   # a `ParamPath` into the scene
//! min = 1e9                                     # bounds in the parameter's unit (optional)
//! max = 2e11
//! # prior_mean = 50e9, prior_sigma = 10e9        # optional Gaussian prior
//! # scale = 1e10                                # optional: typical size (default |initial value|)
//! ```

use crate::error::ModelError;
use serde::{Deserialize, Serialize};

/// Unit of the marker position columns of a recording.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LengthUnit {
    /// Metres (default).
    #[default]
    M,
    /// Millimetres.
    Mm,
}

impl LengthUnit {
    /// Metres per unit.
    pub fn to_m(self) -> f64 {
        match self {
            Self::M => 1.0,
            Self::Mm => 1e-3,
        }
    }
    /// Name as written in files (`m`, `mm`).
    pub fn name(self) -> &'static str {
        match self {
            Self::M => "m",
            Self::Mm => "mm",
        }
    }
}

impl std::str::FromStr for LengthUnit {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "m" => Ok(Self::M),
            "mm" => Ok(Self::Mm),
            o => Err(format!("unknown length unit `{o}` (m | mm)")),
        }
    }
}

/// A rigid transform given as rotation vector (axis times angle, rad) and translation (m):
/// `x_base = R x_capture + t`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TransformSpec {
    /// Rotation vector (rad), default zero.
    pub rotation_vector: [f64; 3],
    /// Translation (m), default zero.
    pub translation_m: [f64; 3],
}

/// One scene parameter to fit.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ParamSpec {
    /// Path into the scene (`validation::ParamPath`), e.g. `robot/sections/*/youngs_modulus_pa`.
    pub path: String,
    /// Lower bound, in the parameter's unit (optional).
    pub min: Option<f64>,
    /// Upper bound, in the parameter's unit (optional).
    pub max: Option<f64>,
    /// Mean of a Gaussian prior, in the parameter's unit (needs `prior_sigma`).
    pub prior_mean: Option<f64>,
    /// Standard deviation of the Gaussian prior (> 0).
    pub prior_sigma: Option<f64>,
    /// Typical size used to scale the unknown and its finite-difference step
    /// (default: |initial value|, or 1 when that is 0).
    pub scale: Option<f64>,
}

impl ParamSpec {
    /// A parameter with no bounds and no prior.
    pub fn new(path: impl Into<String>) -> Self {
        Self {
            path: path.into(),
            ..Self::default()
        }
    }
    /// Check bounds, prior and scale.
    pub fn validate(&self, field: &str) -> Result<(), ModelError> {
        for (name, v) in [
            ("min", self.min),
            ("max", self.max),
            ("prior_mean", self.prior_mean),
        ] {
            if let Some(v) = v {
                ModelError::finite(format!("{field}.{name}"), v)?;
            }
        }
        if let (Some(lo), Some(hi)) = (self.min, self.max) {
            if lo >= hi {
                return Err(ModelError::OutOfRange {
                    field: format!("{field}.max"),
                    value: hi,
                    why: format!("must exceed min = {lo}"),
                });
            }
        }
        if let Some(s) = self.prior_sigma {
            ModelError::positive(format!("{field}.prior_sigma"), s)?;
        }
        if self.prior_sigma.is_some() != self.prior_mean.is_some() {
            return Err(ModelError::Invalid {
                field: format!("{field}.prior_mean"),
                why: "a prior needs both prior_mean and prior_sigma".into(),
            });
        }
        if let Some(s) = self.scale {
            ModelError::positive(format!("{field}.scale"), s)?;
        }
        Ok(())
    }
}

/// The scene's `[calibration]` table (see the module docs for an example).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CalibrationSpec {
    /// Marker position columns x, y, z (default `tip_x`, `tip_y`, `tip_z`).
    pub marker_columns: [String; 3],
    /// Unit of the marker columns (default `m`).
    pub unit: LengthUnit,
    /// Time column (s). Default: `t_s` when the recording has it.
    pub time_column: Option<String>,
    /// Input columns; empty (default) = every column named `tension_*`, `force_*` or `mass_*`.
    pub inputs: Vec<String>,
    /// Names of the columns of a CSV recording without a header line, in file order
    /// (then the first line is data); empty (default) = the first line is the header.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub header: Vec<String>,
    /// Arc length (m) of the body frame the marker is fixed to; `None` (default) = the tip.
    pub marker_s_m: Option<f64>,
    /// Marker position in that body's local frame (m); default zero. Fitted when
    /// `fit_marker_offset`.
    pub marker_offset_m: [f64; 3],
    /// Capture noise, standard deviation per coordinate (m), default 5e-4.
    pub capture_noise_m: f64,
    /// Fit the capture-frame transform (default true).
    pub fit_capture_frame: bool,
    /// Fit the marker offset (default true).
    pub fit_marker_offset: bool,
    /// Huber threshold in noise sigmas (per marker point); `None` = least squares.
    /// Finite and at least [`MIN_HUBER_SIGMA`] (1e-3): below it nearly every point
    /// is past the threshold, the loss is `k` times an L1 loss (the same estimate at
    /// any smaller `k`) and only its gradient shrinks with `k`, down to the LM's
    /// absolute stopping floor, so a tiny `k` (or a subnormal one) would report
    /// "converged" at the start.
    pub huber_sigma: Option<f64>,
    /// Levenberg-Marquardt iteration limit (default 30).
    pub max_iterations: usize,
    /// Capture frame to robot base, `x_base = R x_capture + t` (starting value; fitted
    /// when `fit_capture_frame`).
    pub capture_to_base: TransformSpec,
    /// Scene parameters to fit.
    pub params: Vec<ParamSpec>,
    /// The model-error term of a predicted tip's covariance, estimated by
    /// cross-validation on the training rows (`cablesense crossval`); absent: none
    /// estimated.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model_error: Option<ModelErrorSpec>,
}

/// Model error of a predicted tip: an isotropic 3-D Gaussian whose standard
/// deviation per coordinate grows with the predicted tip's lateral deflection `d`
/// (its distance from the base axis, m): `sigma(d)^2 = sigma_m^2 + (per_deflection
/// d)^2`. Fitted by maximum likelihood to held-out cross-validation residuals
/// (`calibrate::uncertainty`).
///
/// ```toml
/// [calibration.model_error]
/// sigma_m = 1.2e-3          # per coordinate at zero deflection (m), >= 0
/// per_deflection = 0.04     # growth per metre of deflection (dimensionless), >= 0
/// rows = 1620               # held-out rows it was fitted to (information)
/// source = "crossval: 4 groups by pattern family"   # how (information)
/// ```
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelErrorSpec {
    /// Standard deviation per coordinate at zero deflection (m).
    pub sigma_m: f64,
    /// Growth of the standard deviation per metre of lateral deflection.
    pub per_deflection: f64,
    /// Held-out rows the term was fitted to.
    #[serde(default)]
    pub rows: usize,
    /// How it was estimated.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub source: String,
}

impl ModelErrorSpec {
    /// Variance per coordinate (m^2) at lateral deflection `d` (m).
    pub fn variance(&self, d: f64) -> f64 {
        self.sigma_m * self.sigma_m + (self.per_deflection * d).powi(2)
    }

    /// Check the numbers (field paths start with `calibration.model_error.`).
    pub fn validate(&self) -> Result<(), ModelError> {
        ModelError::non_negative("calibration.model_error.sigma_m", self.sigma_m)?;
        ModelError::non_negative(
            "calibration.model_error.per_deflection",
            self.per_deflection,
        )?;
        if self.sigma_m == 0.0 && self.per_deflection == 0.0 {
            return Err(ModelError::Invalid {
                field: "calibration.model_error".into(),
                why: "sigma_m and per_deflection are both 0: a model without error has no region"
                    .into(),
            });
        }
        Ok(())
    }
}

impl Default for CalibrationSpec {
    fn default() -> Self {
        Self {
            marker_columns: ["tip_x".into(), "tip_y".into(), "tip_z".into()],
            unit: LengthUnit::M,
            time_column: None,
            inputs: Vec::new(),
            header: Vec::new(),
            marker_s_m: None,
            marker_offset_m: [0.0; 3],
            capture_noise_m: 5e-4,
            fit_capture_frame: true,
            fit_marker_offset: true,
            huber_sigma: None,
            max_iterations: 30,
            capture_to_base: TransformSpec::default(),
            params: Vec::new(),
            model_error: None,
        }
    }
}

/// Smallest Huber threshold (noise sigmas) accepted: see
/// [`CalibrationSpec::huber_sigma`].
pub const MIN_HUBER_SIGMA: f64 = 1e-3;

/// A Huber threshold `k` (noise sigmas): finite and at least [`MIN_HUBER_SIGMA`].
pub(crate) fn check_huber_sigma(field: &str, k: f64) -> Result<f64, ModelError> {
    ModelError::positive(field, k)?;
    if k < MIN_HUBER_SIGMA {
        return Err(ModelError::OutOfRange {
            field: field.into(),
            value: k,
            why: format!(
                "a Huber threshold below {MIN_HUBER_SIGMA} noise sigmas makes every point an outlier \
                 and only scales the loss down toward the fit's stopping floor (omit it for least squares)"
            ),
        });
    }
    Ok(k)
}

impl CalibrationSpec {
    /// Check every number (field paths start with `calibration.`).
    pub fn validate(&self) -> Result<(), ModelError> {
        ModelError::positive("calibration.capture_noise_m", self.capture_noise_m)?;
        if let Some(m) = &self.model_error {
            m.validate()?;
        }
        ModelError::finite3("calibration.marker_offset_m", &self.marker_offset_m)?;
        ModelError::finite3(
            "calibration.capture_to_base.rotation_vector",
            &self.capture_to_base.rotation_vector,
        )?;
        ModelError::finite3(
            "calibration.capture_to_base.translation_m",
            &self.capture_to_base.translation_m,
        )?;
        if let Some(s) = self.marker_s_m {
            ModelError::non_negative("calibration.marker_s_m", s)?;
        }
        if let Some(h) = self.huber_sigma {
            check_huber_sigma("calibration.huber_sigma", h)?;
        }
        for (i, c) in self.marker_columns.iter().enumerate() {
            if c.trim().is_empty() {
                return Err(ModelError::Invalid {
                    field: format!("calibration.marker_columns[{i}]"),
                    why: "empty column name".into(),
                });
            }
            if let Some(j) = self.marker_columns[..i].iter().position(|d| d == c) {
                // one column read as two coordinates: the fit would run on nonsense
                return Err(ModelError::Invalid {
                    field: format!("calibration.marker_columns[{i}]"),
                    why: format!(
                        "`{c}` is also calibration.marker_columns[{j}]: x, y and z need three columns"
                    ),
                });
            }
        }
        for (i, p) in self.params.iter().enumerate() {
            p.validate(&format!("calibration.params[{i}]"))?;
        }
        Ok(())
    }
}
