//! Validation of a robot description: every field checked, errors naming the
//! field path and the value.

use super::*;

/// Largest `|robot.base.angle_deg|` (deg): one full turn either way; a larger value
/// is a unit slip (radians read as degrees, or a value in another unit).
pub const MAX_ANGLE_DEG: f64 = 360.0;

/// Largest `|precurvature_per_m| * length_m` of a section (rad): two full turns
/// (4 pi). A continuum robot's precurved section bends through at most about one
/// turn; far beyond it the rod integration needs ever more steps and the failure
/// was diagnosed as numerical.
pub const MAX_PRECURVATURE_RAD: f64 = 4.0 * std::f64::consts::PI;

impl RobotSpec {
    /// Check every field; errors name the field path and the value.
    pub fn validate(&self) -> Result<(), ModelError> {
        ModelError::finite3("robot.base.position_m", &self.base.position_m)?;
        ModelError::finite3("robot.base.axis", &self.base.axis)?;
        ModelError::finite("robot.base.angle_deg", self.base.angle_deg)?;
        if self.base.angle_deg.abs() > MAX_ANGLE_DEG {
            return Err(ModelError::OutOfRange {
                field: "robot.base.angle_deg".into(),
                value: self.base.angle_deg,
                why: format!("a rotation angle is within [-{MAX_ANGLE_DEG}, {MAX_ANGLE_DEG}] deg"),
            });
        }
        if self.base.axis.iter().all(|x| *x == 0.0) {
            return Err(ModelError::Invalid {
                field: "robot.base.axis".into(),
                why: "must be non-zero".into(),
            });
        }
        if self.sections.is_empty() {
            return Err(ModelError::Invalid {
                field: "robot.sections".into(),
                why: "at least one section is needed".into(),
            });
        }
        for (k, s) in self.sections.iter().enumerate() {
            let f = format!("robot.sections[{k}]");
            ModelError::positive(format!("{f}.length_m"), s.length_m)?;
            s.shape.validate(&format!("{f}.shape"))?;
            s.material.validate(&f)?;
            ModelError::positive(format!("{f}.shear_coefficient"), s.shear_coefficient)?;
            ModelError::finite3(&format!("{f}.precurvature_per_m"), &s.precurvature_per_m)?;
            let u = s.precurvature_per_m;
            let turns = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt() * s.length_m;
            if turns > MAX_PRECURVATURE_RAD {
                return Err(ModelError::OutOfRange {
                    field: format!("{f}.precurvature_per_m"),
                    value: turns,
                    why: format!(
                        "|precurvature| x length_m (rad) must be at most {MAX_PRECURVATURE_RAD:.3} (two full turns of the section); |u| = {} 1/m over {} m",
                        turns / s.length_m,
                        s.length_m
                    ),
                });
            }
            if let Some(g) = &s.guides {
                g.validate(k, s.length_m)?;
            }
        }
        if let Some(t) = &self.tendons {
            t.validate("robot.tendons")?;
        }
        if let Some(f) = &self.friction {
            f.validate()?;
        }
        for (j, c) in self.cables.iter().enumerate() {
            let f = format!("robot.cables[{j}]");
            if c.end_section >= self.sections.len() {
                return Err(ModelError::BadIndex {
                    field: format!("{f}.end_section"),
                    index: c.end_section,
                    count: self.sections.len(),
                });
            }
            if c.continuous || c.path.is_some() {
                super::super::routing::validate_cable(c, &f)?;
            } else {
                match (&c.hole, &c.routing) {
                (Some(_), Some(_)) => {
                    return Err(ModelError::Invalid {
                        field: f,
                        why: "give either `hole` (an index into the disks' holes) or `routing` (the cable's own hole), not both".into(),
                    })
                }
                (None, None) => {
                    return Err(ModelError::Invalid {
                        field: f,
                        why: "a cable needs `hole` (an index into the disks' holes) or `routing = { radius_m, angle_deg }`".into(),
                    })
                }
                (None, Some(r)) => r.validate(&format!("{f}.routing"))?,
                (Some(_), None) => {}
            }
            }
            if let Some(t) = &c.tendon {
                t.validate(&format!("{f}.tendon"))?;
            }
            let merged = c.mechanics(self.tendons.as_ref());
            if merged.series_quadratic_m_per_n2.is_some_and(|b| b < 0.0)
                && merged.series_stiffness_n_per_m.is_none()
            {
                return Err(ModelError::Invalid {
                    field: format!("{f}.tendon.series_quadratic_m_per_n2"),
                    why: "a negative second-order term (a toe region) needs the linear series spring series_stiffness_n_per_m (N/m), here or in [robot.tendons]: without one the extension would fall as the tension grows".into(),
                });
            }
            if c.actuation == Actuation::Displacement && merged.stiffness_n.is_none() {
                return Err(ModelError::Invalid {
                    field: format!("{f}.tendon.stiffness_n"),
                    why: "a displacement-driven tendon needs its axial stiffness EA_t (N; `inf` for an inextensible tendon), here or in [robot.tendons]".into(),
                });
            }
        }
        if let Some(l) = &self.limits {
            l.validate(self)?;
        }
        Ok(())
    }
}

impl GuideSpec {
    fn validate(&self, section: usize, length: f64) -> Result<(), ModelError> {
        let f = format!("robot.sections[{section}].guides");
        if self.count > MAX_GUIDES_PER_SECTION {
            return Err(ModelError::OutOfRange {
                field: format!("{f}.count"),
                value: self.count as f64,
                why: format!("at most {MAX_GUIDES_PER_SECTION} disks per section"),
            });
        }
        if self.count == 0 {
            return Err(ModelError::OutOfRange {
                field: format!("{f}.count"),
                value: 0.0,
                why: "omit `guides` for a section without disks".into(),
            });
        }
        ModelError::non_negative(format!("{f}.first_offset_m"), self.first_offset_m)?;
        ModelError::non_negative(format!("{f}.thickness_m"), self.thickness_m)?;
        ModelError::positive(format!("{f}.diameter_m"), self.diameter_m)?;
        ModelError::non_negative(format!("{f}.mass_kg"), self.mass_kg)?;
        ModelError::non_negative(format!("{f}.holes.radius_m"), self.holes.radius_m)?;
        if self.count > 1 {
            ModelError::positive(format!("{f}.spacing_m"), self.spacing_m)?;
            if self.spacing_m < self.thickness_m {
                return Err(ModelError::GuidesOverlap {
                    section,
                    guide: 0,
                    next: 1,
                    spacing: self.spacing_m,
                    thickness: self.thickness_m,
                });
            }
        } else {
            ModelError::finite(format!("{f}.spacing_m"), self.spacing_m)?;
        }
        if self.holes.radius_m > self.diameter_m / 2.0 {
            return Err(ModelError::OutOfRange {
                field: format!("{f}.holes.radius_m"),
                value: self.holes.radius_m,
                why: format!(
                    "holes must lie on the disk (radius <= diameter_m / 2 = {})",
                    crate::error::Num(self.diameter_m / 2.0)
                ),
            });
        }
        if self.holes.angles_deg.is_empty() {
            return Err(ModelError::Invalid {
                field: format!("{f}.holes.angles_deg"),
                why: "at least one hole".into(),
            });
        }
        for (i, a) in self.holes.angles_deg.iter().enumerate() {
            ModelError::finite(format!("{f}.holes.angles_deg[{i}]"), *a)?;
        }
        let half = self.thickness_m / 2.0;
        for i in 0..self.count {
            let c = self.first_offset_m + i as f64 * self.spacing_m;
            if c - half < -GUIDE_FIT_TOLERANCE_M || c + half > length + GUIDE_FIT_TOLERANCE_M {
                return Err(ModelError::GuideOutsideSection {
                    section,
                    guide: i,
                    start: c - half,
                    end: c + half,
                    length,
                    tolerance: GUIDE_FIT_TOLERANCE_M,
                });
            }
        }
        Ok(())
    }
}
