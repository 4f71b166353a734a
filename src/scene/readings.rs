//! The `[readings]` table of a scene: units, time column, measured tip, and the
//! conditioning (time offset, backlash) of a readings file. The parser that reads
//! such a file is `files::readings`.

use serde::{Deserialize, Serialize};

/// The `[readings]` table of a scene: how to read a readings file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReadingsSpec {
    /// Metres per unit of the tendon columns (default 1: metres; 0.001 for mm).
    pub scale_m: f64,
    /// Time column (s). Default `t_s`.
    pub time_column: String,
    /// Three columns with a measured tip position, shown beside the model's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measured_tip: Option<[String; 3]>,
    /// Metres per unit of `measured_tip` (default 1).
    pub measured_scale_m: f64,
    /// Metres per unit of the `length_<cable>` columns (measuring cables' length
    /// changes, > 0). Default: none, i.e. the same unit as the tendon columns
    /// (`scale_m`); set it when the encoders log in another unit than the servos.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub length_scale_m: Option<f64>,
    /// Time offset between the servo log and the measured tip (s, default 0): the
    /// row stamped `t` is solved with the readings linearly interpolated at
    /// `t - time_offset_s` (> 0: the capture lags the log), inside blocks of rows
    /// at most 3 s apart, clamped at a block's ends; needs the time column. See
    /// `calibrate::conditioning`. Calibration path `readings/time_offset_s`. At most
    /// [`MAX_TIME_OFFSET_S`] (10 s) in magnitude.
    pub time_offset_s: f64,
    /// Backlash between each servo and its tendon (m, >= 0, default 0): the tendon
    /// follows the (time-shifted) reading with a play of this width (loading and
    /// unloading differ by it). See `calibrate::conditioning`. Calibration path
    /// `readings/backlash_m`.
    pub backlash_m: f64,
}

/// Largest magnitude (s) of `[readings] time_offset_s`: a latency between a servo
/// log and a capture (0.053 s calibrated on the FTDCR v4). Readings are interpolated
/// at `t - offset` inside blocks of rows at most 3 s apart, clamped at a block's
/// ends, so an offset far beyond that gap only clamps every row to its block's first
/// (or last) reading, and a stream keeps every row back to `t - offset`; 10 s leaves
/// room for an unsynchronised clock and refuses a value in ms read as s (53 for
/// 0.053) as well as an absurd one (1e300, where `t - offset == -offset`).
pub const MAX_TIME_OFFSET_S: f64 = 10.0;

impl Default for ReadingsSpec {
    fn default() -> Self {
        Self {
            scale_m: 1.0,
            time_column: "t_s".into(),
            measured_tip: None,
            measured_scale_m: 1.0,
            length_scale_m: None,
            time_offset_s: 0.0,
            backlash_m: 0.0,
        }
    }
}

impl ReadingsSpec {
    /// Check the numbers.
    pub fn validate(&self) -> Result<(), crate::ModelError> {
        crate::ModelError::positive("readings.scale_m", self.scale_m)?;
        crate::ModelError::positive("readings.measured_scale_m", self.measured_scale_m)?;
        if let Some(l) = self.length_scale_m {
            crate::ModelError::positive("readings.length_scale_m", l)?;
        }
        crate::ModelError::finite("readings.time_offset_s", self.time_offset_s)?;
        if self.time_offset_s.abs() > MAX_TIME_OFFSET_S {
            return Err(crate::ModelError::OutOfRange {
                field: "readings.time_offset_s".into(),
                value: self.time_offset_s,
                why: format!(
                    "a latency between the servo log and the capture is at most {MAX_TIME_OFFSET_S} s \
                     in magnitude (a larger one clamps every row to a block's first or last reading, \
                     freezing the tip; is it in ms?)"
                ),
            });
        }
        crate::ModelError::non_negative("readings.backlash_m", self.backlash_m)?;
        Ok(())
    }

    /// Metres per unit of the `length_<cable>` columns: `length_scale_m`, else
    /// `scale_m`.
    pub fn length_scale(&self) -> f64 {
        self.length_scale_m.unwrap_or(self.scale_m)
    }
}
