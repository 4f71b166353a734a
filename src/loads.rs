//! Loads on the robot: gravity, point wrenches and payloads at section ends, and
//! cable tensions. All vectors are in the world frame unless `frame = "body"`.

use crate::error::ModelError;
use crate::robot::Robot;
use serde::{Deserialize, Serialize};

/// Frame a point load's components are expressed in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Frame {
    /// World-fixed direction (dead load).
    #[default]
    World,
    /// Fixed to the backbone's local frame at the load point (follower load).
    Body,
}

/// A force, torque and/or payload mass at the end of a section.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PointLoad {
    /// Section at whose end the load acts (the last section's end is the tip).
    pub section: usize,
    /// Force (N), in `frame`.
    pub force_n: [f64; 3],
    /// Torque (N m), in `frame`.
    pub torque_nm: [f64; 3],
    /// Frame of `force_n` and `torque_nm`. Default `world`.
    pub frame: Frame,
    /// Payload mass (kg), pulled by gravity (always world-fixed), >= 0.
    pub mass_kg: f64,
}

/// All loads of a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Loads {
    /// Gravitational acceleration in the world frame (m/s^2). Default `[0, 0, -9.81]`.
    pub gravity_m_s2: [f64; 3],
    /// Point loads at section ends.
    pub point: Vec<PointLoad>,
    /// Tension of each cable (N), >= 0, indexed like `robot.cables`; missing entries
    /// are 0 (a passive, measuring cable).
    pub tensions_n: Vec<f64>,
}

impl Default for Loads {
    fn default() -> Self {
        Self {
            gravity_m_s2: [0.0, 0.0, -9.81],
            point: Vec::new(),
            tensions_n: Vec::new(),
        }
    }
}

impl Loads {
    /// No gravity, no loads.
    pub fn none() -> Self {
        Self {
            gravity_m_s2: [0.0; 3],
            ..Self::default()
        }
    }
    /// Tension of cable `j` (N).
    pub fn tension(&self, j: usize) -> f64 {
        self.tensions_n.get(j).copied().unwrap_or(0.0)
    }
    /// Check the loads against the robot they act on. Allocation-free when every check
    /// passes (field paths are formatted only for the error), so hot paths (warm
    /// solves, the curvature rungs' ticks) call it on every load update.
    pub fn validate(&self, robot: &Robot) -> Result<(), ModelError> {
        ModelError::finite3("loads.gravity_m_s2", &self.gravity_m_s2)?;
        for (i, p) in self.point.iter().enumerate() {
            // Field names are formatted only when a check fails: this runs on every
            // `set_loads` of a control loop.
            let ok = |v: &[f64; 3]| v.iter().all(|x| x.is_finite());
            if p.section < robot.sections().len()
                && ok(&p.force_n)
                && ok(&p.torque_nm)
                && p.mass_kg.is_finite()
                && p.mass_kg >= 0.0
            {
                continue;
            }
            let f = format!("loads.point[{i}]");
            if p.section >= robot.sections().len() {
                return Err(ModelError::BadIndex {
                    field: format!("{f}.section"),
                    index: p.section,
                    count: robot.sections().len(),
                });
            }
            ModelError::finite3(&format!("{f}.force_n"), &p.force_n)?;
            ModelError::finite3(&format!("{f}.torque_nm"), &p.torque_nm)?;
            ModelError::non_negative(format!("{f}.mass_kg"), p.mass_kg)?;
        }
        if self.tensions_n.len() > robot.cables().len() {
            return Err(ModelError::Invalid {
                field: "loads.tensions_n".into(),
                why: format!(
                    "{} values for {} cables (one per [[robot.cables]], in order)",
                    self.tensions_n.len(),
                    robot.cables().len()
                ),
            });
        }
        if let Some(j) = self
            .tensions_n
            .iter()
            .position(|t| !(t.is_finite() && *t >= 0.0))
        {
            ModelError::non_negative(format!("loads.tensions_n[{j}]"), self.tensions_n[j])?;
        }
        Ok(())
    }
}
