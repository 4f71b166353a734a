//! Robot layer: sections, guide disks, cables and the base pose, validated once.
//!
//! Conventions (also in `docs/conventions.md`): every section's backbone runs along its local
//! `+z` axis (thesis 2.5: the rod "extends along the z axis"); guide disks lie in the
//! local `xy` plane (thesis 3.8.1 says "yz", which cannot be perpendicular to a rod
//! along z: a typo); hole angles are measured in that plane from local `+x` towards
//! `+y`; cable `j` runs from the base plate (`s = 0`) through every guide of the
//! sections it spans to the last guide of its `end_section`.

mod friction;
mod limits;
mod routing;
mod spec;
mod tendon;

pub use friction::{capstan_factors, FrictionLaw};
pub use limits::{ActuatorLimits, LimitsSpec};
pub use routing::{PathPoint, PathSpec, RoutingField, TendonPath};
pub use spec::{
    BaseSpec, CableFile, CableSpec, EvenLayout, EvenWord, GuideFile, GuideSpec, HolesSpec,
    RobotSpec, SectionFile, SectionSpec, SpacingValue, GUIDE_FIT_TOLERANCE_M,
    MAX_GUIDES_PER_SECTION,
};
pub use tendon::{Actuation, FrictionSpec, RoutingSpec, TendonMechanics, TendonSpec};

use crate::error::ModelError;
use crate::math::exp_so3;
use crate::rod::Stiffness;
use nalgebra::{Matrix3, Vector3};

/// One guide disk of the validated robot.
#[derive(Clone, Debug, PartialEq)]
pub struct Guide {
    /// Section the disk sits on.
    pub section: usize,
    /// Index within its section (0 = nearest the base).
    pub index: usize,
    /// Arc length of the disk centre from the robot base (m).
    pub s: f64,
    /// Disk thickness along the backbone (m).
    pub thickness: f64,
    /// Disk mass (kg).
    pub mass: f64,
    /// Hole centres in the disk's local frame (m), `z = 0`.
    pub holes: Vec<Vector3<f64>>,
}

/// One section of the validated robot.
#[derive(Clone, Debug, PartialEq)]
pub struct Section {
    /// Arc length where the section starts (m).
    pub start: f64,
    /// Section length (m).
    pub length: f64,
    /// Stiffnesses and bare-rod linear density.
    pub stiffness: Stiffness,
    /// Precurvature `u*` in the local frame (1/m).
    pub precurvature: Vector3<f64>,
    /// Global indices of this section's guides, base to tip.
    pub guides: std::ops::Range<usize>,
}

impl Section {
    /// Arc length where the section ends (m).
    pub fn end(&self) -> f64 {
        self.start + self.length
    }
}

/// One cable of the validated robot.
#[derive(Clone, Debug, PartialEq)]
pub struct Cable {
    /// Optional name.
    pub name: String,
    /// Hole index used on every disk and on the base plate (`None` for a cable with
    /// its own routing).
    pub hole: Option<usize>,
    /// The cable's hole on each route disk, in that disk's local frame (m).
    pub hole_local: Vec<Vector3<f64>>,
    /// How the cable is driven.
    pub actuation: Actuation,
    /// Resolved tendon mechanics (`None` when no stiffness is given anywhere).
    pub mechanics: Option<TendonMechanics>,
    /// Readings column of a displacement-driven tendon.
    pub reading: String,
    /// Section on whose last guide the cable ends.
    pub end_section: usize,
    /// Global guide indices the cable passes, base to termination.
    pub route: Vec<usize>,
    /// Hole position on the base plate, in the base frame (m).
    pub base_hole: Vector3<f64>,
    /// Continuous routing: the tendon's path `r(s)` along the rod (`route` and
    /// `hole_local` are then empty). `None` for a disk-routed cable.
    pub path: Option<TendonPath>,
    /// Arc length where the cable ends (m): its termination disk, or the end of
    /// `end_section` for a continuous tendon.
    pub end_s: f64,
}

/// A validated robot: an invalid one cannot be constructed.
#[derive(Clone, Debug, PartialEq)]
pub struct Robot {
    spec: RobotSpec,
    sections: Vec<Section>,
    guides: Vec<Guide>,
    cables: Vec<Cable>,
    base_rotation: Matrix3<f64>,
    base_position: Vector3<f64>,
}

impl Robot {
    /// Validate a description and derive the arc-length layout.
    pub fn new(spec: RobotSpec) -> Result<Self, ModelError> {
        spec.validate()?;
        let mut sections = Vec::with_capacity(spec.sections.len());
        let mut guides = Vec::new();
        let mut start = 0.0;
        for (k, sec) in spec.sections.iter().enumerate() {
            let g0 = guides.len();
            if let Some(g) = &sec.guides {
                let holes: Vec<Vector3<f64>> = g
                    .holes
                    .angles_deg
                    .iter()
                    .map(|a| {
                        let t = a.to_radians();
                        Vector3::new(g.holes.radius_m * t.cos(), g.holes.radius_m * t.sin(), 0.0)
                    })
                    .collect();
                for i in 0..g.count {
                    guides.push(Guide {
                        section: k,
                        index: i,
                        // a disk within GUIDE_FIT_TOLERANCE_M past the section's end
                        // (a rounded spacing) sits at the end
                        s: start
                            + (g.first_offset_m + i as f64 * g.spacing_m)
                                .max(0.0)
                                .min(sec.length_m),
                        thickness: g.thickness_m,
                        mass: g.mass_kg,
                        holes: holes.clone(),
                    });
                }
            }
            sections.push(Section {
                start,
                length: sec.length_m,
                stiffness: Stiffness::new(&sec.material, &sec.shape, sec.shear_coefficient),
                precurvature: Vector3::from(sec.precurvature_per_m),
                guides: g0..guides.len(),
            });
            start += sec.length_m;
        }
        let mut cables = Vec::with_capacity(spec.cables.len());
        for (j, c) in spec.cables.iter().enumerate() {
            if c.continuous {
                cables.push(Self::continuous_cable(&spec, &sections, c, j)?);
                continue;
            }
            let route: Vec<usize> = (0..guides.len())
                .filter(|&g| guides[g].section <= c.end_section)
                .collect();
            let field = format!("robot.cables[{j}]");
            let last = *route.last().ok_or_else(|| ModelError::Invalid {
                field: format!("{field}.end_section"),
                why: format!(
                    "no guide disk on sections 0..={}: a cable needs at least one",
                    c.end_section
                ),
            })?;
            if guides[last].section != c.end_section {
                return Err(ModelError::Invalid {
                    field: format!("{field}.end_section"),
                    why: format!("section {} has no guide disk to end on", c.end_section),
                });
            }
            let hole_local = Self::route_holes(&spec, &guides, c, &route, &field)?;
            let base_hole = hole_local[0];
            let name = c.name.clone().unwrap_or_else(|| format!("cable{j}"));
            cables.push(Cable {
                reading: c.reading.clone().unwrap_or_else(|| name.clone()),
                name,
                hole: c.hole,
                hole_local,
                actuation: c.actuation,
                mechanics: TendonMechanics::resolve(&c.mechanics(spec.tendons.as_ref())),
                end_section: c.end_section,
                end_s: guides[last].s,
                route,
                base_hole,
                path: None,
            });
        }
        Self::check_unique_names(&cables)?;
        let mut axis = Vector3::from(spec.base.axis);
        if !axis.norm_squared().is_normal() {
            // |axis|^2 overflows (1e200) or underflows (1e-170): scale it first, or
            // `normalize` would give a zero or NaN axis (the base silently unrotated)
            axis /= axis.amax();
        }
        let base_rotation = exp_so3(&(axis.normalize() * spec.base.angle_deg.to_radians()));
        Ok(Self {
            base_position: Vector3::from(spec.base.position_m),
            spec,
            sections,
            guides,
            cables,
            base_rotation,
        })
    }

    /// Cable names (given or defaulted) are unique, and so are the readings columns
    /// of the displacement-driven tendons: readings, load-cell (`tension_<cable>`),
    /// length (`length_<cable>`) and encoder columns are found by these names, so a
    /// second cable of the same name would never get its column.
    fn check_unique_names(cables: &[Cable]) -> Result<(), ModelError> {
        let driven = |c: &Cable| c.actuation == Actuation::Displacement;
        for (j, c) in cables.iter().enumerate() {
            if let Some(i) = cables[..j].iter().position(|d| d.name == c.name) {
                return Err(ModelError::Invalid {
                    field: format!("robot.cables[{j}].name"),
                    why: format!(
                        "`{}` is also the name of robot.cables[{i}]: cable names must be unique (columns of readings, load cells and encoders are found by them)",
                        c.name
                    ),
                });
            }
            if !driven(c) {
                continue;
            }
            if let Some(i) = cables[..j]
                .iter()
                .position(|d| driven(d) && d.reading == c.reading)
            {
                return Err(ModelError::Invalid {
                    field: format!("robot.cables[{j}].reading"),
                    why: format!(
                        "column `{}` is also the reading of robot.cables[{i}]: each displacement-driven tendon needs its own readings column",
                        c.reading
                    ),
                });
            }
        }
        Ok(())
    }

    /// A continuously routed tendon from the base to the end of its `end_section`;
    /// its path must stay on the disks of the sections it crosses.
    fn continuous_cable(
        spec: &RobotSpec,
        sections: &[Section],
        c: &spec::CableSpec,
        j: usize,
    ) -> Result<Cable, ModelError> {
        // A displacement-driven continuous tendon is solved like a disk-routed one
        // (`crate::tendons`: its length is the pass's integral `int |p_i'| ds`, RW
        // 2011 section III, and its derivatives come from the dual sweep), except for
        // capstan friction: `robot::friction` is a per-hole wrap angle, and a tendon
        // sliding along a continuous sheath has friction distributed along its path
        // (tension varying with `s`, which the RW 2011 equations here do not model).
        let law = FrictionLaw::of(spec.friction.as_ref());
        if c.actuation == Actuation::Displacement && !law.is_frictionless() {
            let mu = law.mu();
            return Err(ModelError::Invalid {
                field: "robot.friction".into(),
                why: format!(
                    "robot.cables[{j}] is continuously routed and displacement-driven: capstan friction (mu = {mu}) is a per-disk wrap-angle model and does not apply to a continuous path (friction along it is not modelled); remove [robot.friction] or set mu = 0"
                ),
            });
        }
        let field = format!("robot.cables[{j}].path");
        let end_s = sections[c.end_section].end();
        let max_radius = spec.sections[..=c.end_section]
            .iter()
            .filter_map(|s| s.guides.as_ref().map(|g| g.diameter_m / 2.0))
            .fold(f64::INFINITY, f64::min);
        let path = c
            .path
            .as_ref()
            .ok_or_else(|| ModelError::Invalid {
                field: field.clone(),
                why: "missing".into(),
            })?
            .build(&field, end_s, max_radius)?;
        if path.max_radius(end_s) > max_radius {
            return Err(ModelError::OutOfRange {
                field,
                value: path.max_radius(end_s),
                why: format!("the spline leaves the disks it passes (radius {max_radius} m)"),
            });
        }
        let name = c.name.clone().unwrap_or_else(|| format!("cable{j}"));
        Ok(Cable {
            reading: c.reading.clone().unwrap_or_else(|| name.clone()),
            name,
            hole: None,
            hole_local: Vec::new(),
            actuation: c.actuation,
            mechanics: TendonMechanics::resolve(&c.mechanics(spec.tendons.as_ref())),
            end_section: c.end_section,
            route: Vec::new(),
            base_hole: path.eval(0.0)[0],
            path: Some(path),
            end_s,
        })
    }

    /// A cable's hole on every disk of its route (local frames), from its hole index
    /// or its own routing; errors name the field and the disk.
    fn route_holes(
        spec: &RobotSpec,
        guides: &[Guide],
        c: &spec::CableSpec,
        route: &[usize],
        field: &str,
    ) -> Result<Vec<Vector3<f64>>, ModelError> {
        let mut out = Vec::with_capacity(route.len());
        for &g in route {
            let guide = &guides[g];
            match (&c.hole, &c.routing) {
                (Some(h), _) => {
                    let p = guide.holes.get(*h).ok_or_else(|| ModelError::BadIndex {
                        field: format!(
                            "{field}.hole (on guide {} of section {})",
                            guide.index, guide.section
                        ),
                        index: *h,
                        count: guide.holes.len(),
                    })?;
                    out.push(*p);
                }
                (None, Some(r)) => {
                    let d = spec.sections[guide.section]
                        .guides
                        .as_ref()
                        .map_or(f64::INFINITY, |gs| gs.diameter_m);
                    if r.radius_m > d / 2.0 {
                        return Err(ModelError::OutOfRange {
                            field: format!("{field}.routing.radius_m"),
                            value: r.radius_m,
                            why: format!(
                                "the hole lies outside disk {} of section {} (radius {} m)",
                                guide.index,
                                guide.section,
                                d / 2.0
                            ),
                        });
                    }
                    let a = r.angle_rad(guide.section);
                    out.push(Vector3::new(
                        r.radius_m * a.cos(),
                        r.radius_m * a.sin(),
                        0.0,
                    ));
                }
                (None, None) => {
                    return Err(ModelError::Invalid {
                        field: field.into(),
                        why: "no hole and no routing".into(),
                    })
                }
            }
        }
        Ok(out)
    }

    /// Smallest bending stiffness `min_i min(C_i[0], C_i[1])` over the sections
    /// (N m^2; thesis eq. 2.12): the scale of the load intensity and the residual floor.
    pub fn min_bending_stiffness(&self) -> f64 {
        self.sections
            .iter()
            .map(|s| s.stiffness.bend_twist.x.min(s.stiffness.bend_twist.y))
            .fold(f64::INFINITY, f64::min)
    }

    /// The tendons' friction law (`[robot.friction]`; frictionless when absent).
    pub fn friction(&self) -> FrictionLaw {
        FrictionLaw::of(self.spec.friction.as_ref())
    }

    /// The description this robot was built from.
    pub fn spec(&self) -> &RobotSpec {
        &self.spec
    }
    /// Sections, base to tip.
    pub fn sections(&self) -> &[Section] {
        &self.sections
    }
    /// All guide disks, base to tip.
    pub fn guides(&self) -> &[Guide] {
        &self.guides
    }
    /// Cables.
    pub fn cables(&self) -> &[Cable] {
        &self.cables
    }
    /// Total backbone length (m).
    pub fn length(&self) -> f64 {
        self.sections.last().map_or(0.0, |s| s.end())
    }
    /// Base orientation `R(0)` in the world frame.
    pub fn base_rotation(&self) -> &Matrix3<f64> {
        &self.base_rotation
    }
    /// Base position `r(0)` in the world frame (m).
    pub fn base_position(&self) -> &Vector3<f64> {
        &self.base_position
    }
    /// Section containing arc length `s` (the last one for `s` at a boundary past the end).
    pub fn section_at(&self, s: f64) -> usize {
        self.sections
            .iter()
            .position(|sec| s < sec.end())
            .unwrap_or(self.sections.len() - 1)
    }
    /// A copy with the base moved to `position` and rotated to `rotation`.
    pub fn with_base(&self, rotation: Matrix3<f64>, position: Vector3<f64>) -> Self {
        let mut r = self.clone();
        let w = nalgebra::Rotation3::from_matrix_unchecked(rotation).scaled_axis();
        let angle = w.norm();
        r.spec.base.axis = if angle > 0.0 {
            (w / angle).into()
        } else {
            [0.0, 0.0, 1.0]
        };
        r.spec.base.angle_deg = angle.to_degrees();
        r.spec.base.position_m = position.into();
        r.base_rotation = rotation;
        r.base_position = position;
        r
    }
}
