//! Actuator limits of the displacement-driven tendons (`[robot.limits]` of a scene):
//! the range of readings each servo can command, in the readings' units (the scene's
//! `[readings] scale_m` converts them to metres, as it does the readings themselves).
//!
//! ```toml
//! [robot.limits]
//! default = [-10.0, 10.0]               # every driven tendon (optional)
//! sections = [[-10.5, 5.5], [-10.5, 9.0]] # per segment: tendons ending on section k (optional)
//! tendons = { servo_4_mm = [-8.0, 5.0] } # per tendon, by its readings column (optional)
//! ```
//!
//! A tendon takes the most specific entry: its own (`tendons`), else its segment's
//! (`sections`, indexed by the tendon's `end_section`), else `default`, else no limit
//! (unbounded: only the tendon's free length bounds a pull). Each range must be
//! finite, `min <= max`, and contain 0: reading 0 is the reference of the tendon
//! model (the pretension is set there) and where a cold inverse solve starts.
//! Used by inverse kinematics (`crate::command`) and the reachable workspace.

use super::spec::RobotSpec;
use super::tendon::Actuation;
use crate::error::ModelError;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The `[robot.limits]` table: `[min, max]` readings in the readings' units.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LimitsSpec {
    /// Range of every driven tendon without a more specific entry.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub default: Option<[f64; 2]>,
    /// Range per segment, one entry per section (`robot.sections`), applied to the
    /// tendons that end on that section.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sections: Option<Vec<[f64; 2]>>,
    /// Range per tendon, keyed by its readings column (`robot.cables[j].reading`,
    /// default the cable's name).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub tendons: BTreeMap<String, [f64; 2]>,
}

/// Check one `[min, max]` range (finite, ordered, containing 0).
fn check_range(field: &str, r: &[f64; 2]) -> Result<(), ModelError> {
    ModelError::finite(format!("{field}[0]"), r[0])?;
    ModelError::finite(format!("{field}[1]"), r[1])?;
    if r[0] > r[1] {
        return Err(ModelError::OutOfRange {
            field: field.into(),
            value: r[0],
            why: format!("min {} is above max {}", r[0], r[1]),
        });
    }
    if r[0] > 0.0 || r[1] < 0.0 {
        return Err(ModelError::OutOfRange {
            field: field.into(),
            value: if r[0] > 0.0 { r[0] } else { r[1] },
            why: format!(
                "the range [{}, {}] excludes reading 0, the reference of the tendon model \
                 (pretension) and the start of a cold inverse solve",
                r[0], r[1]
            ),
        });
    }
    Ok(())
}

/// The readings column of cable `j` as the robot resolves it (its `reading`, else its
/// name, else `cable<j>`).
fn column_of(spec: &RobotSpec, j: usize) -> String {
    let c = &spec.cables[j];
    c.reading
        .clone()
        .or_else(|| c.name.clone())
        .unwrap_or_else(|| format!("cable{j}"))
}

impl LimitsSpec {
    /// Check every range and name (errors name the field: `robot.limits.tendons.<column>`,
    /// `robot.limits.sections[k]`, `robot.limits.default`).
    pub fn validate(&self, spec: &RobotSpec) -> Result<(), ModelError> {
        if let Some(d) = &self.default {
            check_range("robot.limits.default", d)?;
        }
        if let Some(s) = &self.sections {
            if s.len() != spec.sections.len() {
                return Err(ModelError::Invalid {
                    field: "robot.limits.sections".into(),
                    why: format!(
                        "{} ranges for {} sections: give one [min, max] per section",
                        s.len(),
                        spec.sections.len()
                    ),
                });
            }
            for (k, r) in s.iter().enumerate() {
                check_range(&format!("robot.limits.sections[{k}]"), r)?;
            }
        }
        let driven: Vec<String> = (0..spec.cables.len())
            .filter(|&j| spec.cables[j].actuation == Actuation::Displacement)
            .map(|j| column_of(spec, j))
            .collect();
        for (name, r) in &self.tendons {
            let field = format!("robot.limits.tendons.{name}");
            if !driven.iter().any(|c| c == name) {
                return Err(ModelError::Invalid {
                    field,
                    why: format!(
                        "no displacement-driven tendon reads column `{name}` (driven tendons' columns: {})",
                        if driven.is_empty() { "none".to_string() } else { driven.join(", ") }
                    ),
                });
            }
            check_range(&field, r)?;
        }
        Ok(())
    }

    /// `[min, max]` (readings' units) of each displacement-driven tendon, in cable
    /// order (the order of `TendonWorkspace::driven`); `[-inf, inf]` without an entry.
    pub fn ranges(&self, spec: &RobotSpec) -> Vec<[f64; 2]> {
        (0..spec.cables.len())
            .filter(|&j| spec.cables[j].actuation == Actuation::Displacement)
            .map(|j| {
                let col = column_of(spec, j);
                self.tendons
                    .get(&col)
                    .copied()
                    .or_else(|| {
                        self.sections
                            .as_ref()
                            .and_then(|s| s.get(spec.cables[j].end_section).copied())
                    })
                    .or(self.default)
                    .unwrap_or([f64::NEG_INFINITY, f64::INFINITY])
            })
            .collect()
    }
}

/// Resolved actuator limits of the driven tendons (m), in `TendonWorkspace::driven`
/// order: what inverse kinematics and the workspace sampler use.
#[derive(Clone, Debug, PartialEq)]
pub struct ActuatorLimits {
    /// Lower bound of each reading (m; `-inf` when unlimited).
    pub min_m: Vec<f64>,
    /// Upper bound of each reading (m; `inf` when unlimited).
    pub max_m: Vec<f64>,
}

impl ActuatorLimits {
    /// No limit on any of `p` tendons.
    pub fn unbounded(p: usize) -> Self {
        Self {
            min_m: vec![f64::NEG_INFINITY; p],
            max_m: vec![f64::INFINITY; p],
        }
    }

    /// From `[min, max]` ranges in readings' units and the metres per unit.
    pub fn from_ranges(ranges: &[[f64; 2]], scale_m: f64) -> Self {
        Self {
            min_m: ranges.iter().map(|r| r[0] * scale_m).collect(),
            max_m: ranges.iter().map(|r| r[1] * scale_m).collect(),
        }
    }

    /// Number of tendons.
    pub fn len(&self) -> usize {
        self.min_m.len()
    }

    /// Whether there is no tendon.
    pub fn is_empty(&self) -> bool {
        self.min_m.is_empty()
    }

    /// Every tendon has a finite range.
    pub fn is_bounded(&self) -> bool {
        self.min_m.iter().chain(&self.max_m).all(|v| v.is_finite())
    }

    /// Check that the limits are finite-or-infinite, ordered and contain 0 (limits
    /// built by hand; a scene's are checked when it is read). `columns` names the
    /// tendons in errors.
    pub fn validate(&self, columns: &[String]) -> Result<(), ModelError> {
        if self.max_m.len() != self.min_m.len() || self.min_m.len() != columns.len() {
            return Err(ModelError::Invalid {
                field: "limits".into(),
                why: format!(
                    "{} lower and {} upper bounds for {} driven tendons",
                    self.min_m.len(),
                    self.max_m.len(),
                    columns.len()
                ),
            });
        }
        for (i, c) in columns.iter().enumerate() {
            let (lo, hi) = (self.min_m[i], self.max_m[i]);
            let field = format!("limits.{c}");
            if lo.is_nan() || hi.is_nan() {
                return Err(ModelError::NonFinite {
                    field,
                    value: f64::NAN,
                });
            }
            if lo > hi {
                return Err(ModelError::OutOfRange {
                    field,
                    value: lo,
                    why: format!("min {lo} m is above max {hi} m"),
                });
            }
            if lo > 0.0 || hi < 0.0 {
                return Err(ModelError::OutOfRange {
                    field,
                    value: if lo > 0.0 { lo } else { hi },
                    why: format!(
                        "the range [{lo}, {hi}] m excludes reading 0, the reference of the tendon \
                         model (pretension) and the start of a cold inverse solve"
                    ),
                });
            }
        }
        Ok(())
    }
}
