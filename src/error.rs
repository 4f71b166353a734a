//! Errors for invalid input. Non-convergence is not an error: see [`crate::SolveStatus`].

use thiserror::Error;

/// A user-given number in an error message, readable at any magnitude: the plain
/// shortest form (`0.015`, `-5`, `60000000000`, `-0.000000001`) for magnitudes in
/// [1e-9, 1e16), zero and the non-finite values; scientific
/// (`1e300`, `-2.5e-12`) beyond, where the plain form would print up to hundreds of
/// digits (`1e300` as `{}` is 301 of them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Num(pub f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if !a.is_finite() || a == 0.0 || (1e-9..1e16).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// Six decimals (a length in m to the micrometre) when that is readable, else
/// [`Num`]'s scientific form: `{:.6}` of 1e300 is 308 characters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fixed6(pub f64);

impl std::fmt::Display for Fixed6 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0.is_finite() && self.0.abs() >= 1e16 {
            write!(f, "{}", Num(self.0))
        } else {
            write!(f, "{:.6}", self.0)
        }
    }
}

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
    #[error("{field} must be finite, got {}", Num(*.value))]
    NonFinite { field: String, value: f64 },
    /// A number must be strictly positive (lengths, moduli, diameters, tolerances).
    #[error("{field} must be > 0, got {}", Num(*.value))]
    NonPositive { field: String, value: f64 },
    /// A number must be >= 0 (masses, tensions, offsets).
    #[error("{field} must be >= 0, got {}", Num(*.value))]
    Negative { field: String, value: f64 },
    /// A number is outside its physical range.
    #[error("{field} = {} is out of range: {why}", Num(*.value))]
    OutOfRange {
        field: String,
        value: f64,
        why: String,
    },
    /// A guide disk (centre +- half thickness) does not fit inside its section.
    #[error(
        "guide {guide} of section {section} spans s = [{}, {}] m, outside the section [0, {}] m \
         by {} m (more than the {} m tolerance; `spacing_m = \"even\"` spaces the disks to \
         the section's end without a rounded spacing)",
        Num(*.start),
        Num(*.end),
        Num(*.length),
        Num((-*.start).max(*.end - *.length)),
        Num(*.tolerance)
    )]
    GuideOutsideSection {
        section: usize,
        guide: usize,
        start: f64,
        end: f64,
        length: f64,
        /// The overshoot accepted (m), `crate::robot::GUIDE_FIT_TOLERANCE_M`.
        tolerance: f64,
    },
    /// Two guide disks of one section overlap.
    #[error("guides {guide} and {next} of section {section} overlap (spacing {} m < thickness {} m)", Num(*.spacing), Num(*.thickness))]
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

#[cfg(test)]
mod tests {
    use super::{Fixed6, ModelError, Num};

    #[test]
    fn extreme_numbers_print_in_scientific_form() {
        assert_eq!(Num(1e300).to_string(), "1e300");
        assert_eq!(Num(-1e-300).to_string(), "-1e-300");
        assert_eq!(Num(2.5e16).to_string(), "2.5e16");
        assert_eq!(Num(-2.5e-12).to_string(), "-2.5e-12");
        assert_eq!(Fixed6(1e300).to_string(), "1e300");
        let e = ModelError::positive("robot.sections[0].length_m", -1e300).unwrap_err();
        assert_eq!(
            e.to_string(),
            "robot.sections[0].length_m must be > 0, got -1e300"
        );
    }

    #[test]
    fn moderate_numbers_keep_their_plain_form() {
        assert_eq!(Num(-0.1).to_string(), "-0.1");
        assert_eq!(Num(60e9).to_string(), "60000000000");
        assert_eq!(Num(-1e-9).to_string(), "-0.000000001");
        assert_eq!(Num(9.5e15).to_string(), "9500000000000000");
        assert_eq!(Num(0.0).to_string(), "0");
        assert_eq!(Num(f64::NAN).to_string(), "NaN");
        assert_eq!(Num(f64::NEG_INFINITY).to_string(), "-inf");
        assert_eq!(Fixed6(0.2).to_string(), "0.200000");
    }
}
