//! Errors for invalid input. Non-convergence is not an error: see [`crate::SolveStatus`].

use thiserror::Error;

/// Everything that can be wrong with a robot, its loads or the solver settings.
///
/// Each variant names the offending field (a dotted path such as
/// `sections[1].guides.spacing_m`) and the value that was rejected.
// Field names (`field`, `value`, `section`, ...) are self-describing; the variant
// docs say what each case means.
#[allow(missing_docs)]
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ModelError {
    /// A number is NaN or infinite.
    #[error("{field} must be finite, got {value}")]
    NonFinite { field: String, value: f64 },
    /// A number must be strictly positive (lengths, moduli, diameters, tolerances).
    #[error("{field} must be > 0, got {value}")]
    NonPositive { field: String, value: f64 },
    /// A number must be >= 0 (masses, tensions, offsets).
    #[error("{field} must be >= 0, got {value}")]
    Negative { field: String, value: f64 },
    /// A number is outside its physical range.
    #[error("{field} = {value} is out of range: {why}")]
    OutOfRange {
        field: String,
        value: f64,
        why: String,
    },
    /// A guide disk (centre +- half thickness) does not fit inside its section.
    #[error(
        "guide {guide} of section {section} spans s = [{start:.6}, {end:.6}] m, outside the section [0, {length:.6}] m"
    )]
    GuideOutsideSection {
        section: usize,
        guide: usize,
        start: f64,
        end: f64,
        length: f64,
    },
    /// Two guide disks of one section overlap.
    #[error("guides {guide} and {next} of section {section} overlap (spacing {spacing} m < thickness {thickness} m)")]
    GuidesOverlap {
        section: usize,
        guide: usize,
        next: usize,
        spacing: f64,
        thickness: f64,
    },
    /// A reference to a section, cable, hole or load that does not exist.
    #[error("{field} = {index} refers to nothing: only {count} exist")]
    BadIndex {
        field: String,
        index: usize,
        count: usize,
    },
    /// A structural problem that is not a single number.
    #[error("{field}: {why}")]
    Invalid { field: String, why: String },
}

impl ModelError {
    /// Check that `value` is finite.
    pub fn finite(field: impl Into<String>, value: f64) -> Result<f64, Self> {
        if value.is_finite() {
            Ok(value)
        } else {
            Err(Self::NonFinite {
                field: field.into(),
                value,
            })
        }
    }
    /// Check that `value` is finite and > 0.
    pub fn positive(field: impl Into<String>, value: f64) -> Result<f64, Self> {
        // The field name is converted only on the error path (validation runs on every
        // `set_loads` of a control loop).
        if value > 0.0 && value.is_finite() {
            return Ok(value);
        }
        let field = field.into();
        Self::finite(field.clone(), value)?;
        Err(Self::NonPositive { field, value })
    }
    /// Check that `value` is finite and >= 0.
    pub fn non_negative(field: impl Into<String>, value: f64) -> Result<f64, Self> {
        if value >= 0.0 && value.is_finite() {
            return Ok(value);
        }
        let field = field.into();
        Self::finite(field.clone(), value)?;
        Err(Self::Negative { field, value })
    }
    /// Check that every component of a vector is finite.
    pub fn finite3(field: &str, v: &[f64; 3]) -> Result<(), Self> {
        match v.iter().position(|x| !x.is_finite()) {
            None => Ok(()),
            Some(i) => Self::finite(format!("{field}[{i}]"), v[i]).map(|_| ()),
        }
    }
}
