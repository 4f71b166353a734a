//! The scene's actuator limits in metres: `[robot.limits]` (readings' units,
//! [`crate::robot::LimitsSpec`]) scaled by `[readings] scale_m` (1 without a
//! `[readings]` table, as for the readings themselves).

use super::Scene;
use crate::error::ModelError;
use crate::robot::{Actuation, ActuatorLimits};

impl Scene {
    /// Metres per unit of the tendons' readings columns (`[readings] scale_m`, 1
    /// without the table).
    pub fn readings_scale_m(&self) -> f64 {
        self.readings.as_ref().map_or(1.0, |r| r.scale_m)
    }

    /// The actuator limits of the displacement-driven tendons (m, in cable order:
    /// `TendonWorkspace::driven`), unbounded without `[robot.limits]`; checked (a
    /// bad range is an error naming its field).
    pub fn actuator_limits(&self) -> Result<ActuatorLimits, ModelError> {
        let p = self
            .robot
            .cables
            .iter()
            .filter(|c| c.actuation == Actuation::Displacement)
            .count();
        match &self.robot.limits {
            None => Ok(ActuatorLimits::unbounded(p)),
            Some(l) => {
                l.validate(&self.robot)?;
                Ok(ActuatorLimits::from_ranges(
                    &l.ranges(&self.robot),
                    self.readings_scale_m(),
                ))
            }
        }
    }
}
