//! Loads on the robot: gravity, point wrenches and payloads at section ends, and
//! cable tensions. All vectors are in the world frame unless `frame = "body"`.

use crate::error::ModelError;
use crate::robot::Robot;
use nalgebra::Vector3;
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
        self.check_tensions(robot)?;
        self.check_point_forces(robot)?;
        self.check_weight(robot)
    }

    /// A point force must stay below the axial stiffness `EA` of every section
    /// between the base and the section it acts on (each carries it): a force of `EA`
    /// along the axis is an axial strain of magnitude 1 (pressed to zero length, or
    /// stretched to twice its length), as for the tensions and the weight: a force of
    /// this size, if accepted, ends in a non-convergence status without a reason.
    /// Allocation-free when it passes.
    fn check_point_forces(&self, robot: &Robot) -> Result<(), ModelError> {
        let sections = robot.sections();
        for (i, p) in self.point.iter().enumerate() {
            // |F| without overflowing for components near the range of f64
            let v = Vector3::from(p.force_n);
            let big = v.amax();
            let f = if big > 0.0 {
                big * (v / big).norm()
            } else {
                0.0
            };
            let Some((k, sec)) = sections
                .iter()
                .enumerate()
                .take(p.section + 1)
                .min_by(|a, b| {
                    a.1.stiffness
                        .shear_stretch
                        .z
                        .total_cmp(&b.1.stiffness.shear_stretch.z)
                })
            else {
                continue;
            };
            let ea = sec.stiffness.shear_stretch.z;
            if f < ea {
                continue;
            }
            return Err(ea_error(
                format!("loads.point[{i}].force_n"),
                f,
                format!("its magnitude, carried by section {k}, reaches"),
                ea,
                "along the axis an axial strain of magnitude 1 or beyond (the rod pressed to \
                 zero length, or stretched to twice its length)",
            ));
        }
        Ok(())
    }

    /// The cable tensions each section carries (every cable that ends in it or beyond
    /// pulls its disks towards the base plate, so the backbone between them carries the
    /// tension as axial compression) must stay below the section's axial stiffness `EA`,
    /// as the weight must (`check_weight`): a sum of `EA` is an axial strain of
    /// -1. Before, a tension of 1e6 N on a 1.56 mm rod (`EA` 1.2e5 N) ended `Stalled`
    /// with an infinite residual and no reason. Names the largest such tension.
    /// Allocation-free when it passes.
    fn check_tensions(&self, robot: &Robot) -> Result<(), ModelError> {
        let cables = robot.cables();
        for (i, sec) in robot.sections().iter().enumerate() {
            let through = || {
                self.tensions_n
                    .iter()
                    .enumerate()
                    .filter(move |(j, _)| cables[*j].end_section >= i)
            };
            let sum: f64 = through().map(|(_, t)| t).sum();
            let ea = sec.stiffness.shear_stretch.z;
            if sum < ea {
                continue;
            }
            let (j, t) = through().fold(
                (0, f64::NEG_INFINITY),
                |m, (j, t)| if *t > m.1 { (j, *t) } else { m },
            );
            let what = format!(
                "the cable tensions section {i} carries ({} N in all) reach",
                crate::error::Num(sum)
            );
            return Err(beyond_ea(format!("loads.tensions_n[{j}]"), t, what, ea));
        }
        Ok(())
    }

    /// The weight each section carries (rod, guide disks and point masses from its
    /// base to the tip, times |g|) must stay below the section's axial stiffness
    /// `EA`: a weight of `EA` along the axis is an axial strain of -1 (a rod pressed
    /// to zero length, beyond it inverted), which no Cosserat equilibrium of a real
    /// rod has, yet the shooting solve can still meet its boundary conditions there
    /// and report `Converged`. The error names the heaviest contribution (a section's
    /// `density_kg_m3`, a section's `guides.mass_kg` or a `loads.point[i].mass_kg`).
    /// Allocation-free when it passes.
    fn check_weight(&self, robot: &Robot) -> Result<(), ModelError> {
        let [gx, gy, gz] = self.gravity_m_s2;
        let g = (gx * gx + gy * gy + gz * gz).sqrt();
        if g == 0.0 {
            return Ok(());
        }
        let sections = robot.sections();
        let guide_mass = |k: usize| -> f64 {
            robot.guides()[sections[k].guides.clone()]
                .iter()
                .map(|d| d.mass)
                .sum()
        };
        let point_mass = |k: usize| -> f64 {
            self.point
                .iter()
                .filter(|p| p.section == k)
                .map(|p| p.mass_kg)
                .sum()
        };
        let rod_mass = |k: usize| sections[k].stiffness.linear_density * sections[k].length;
        let mut distal = 0.0;
        for i in (0..sections.len()).rev() {
            distal += rod_mass(i) + guide_mass(i) + point_mass(i);
            let (weight, ea) = (g * distal, sections[i].stiffness.shear_stretch.z);
            if weight < ea {
                continue;
            }
            // the heaviest single contribution from section i to the tip
            let mut field = String::new();
            let (mut value, mut heaviest) = (0.0, -1.0);
            for k in i..sections.len() {
                if rod_mass(k) > heaviest {
                    heaviest = rod_mass(k);
                    field = format!("robot.sections[{k}].density_kg_m3");
                    value = robot.spec().sections[k].material.density_kg_m3;
                }
                if guide_mass(k) > heaviest {
                    heaviest = guide_mass(k);
                    field = format!("robot.sections[{k}].guides.mass_kg");
                    value = robot.spec().sections[k]
                        .guides
                        .as_ref()
                        .map_or(0.0, |d| d.mass_kg);
                }
                for (p, load) in self.point.iter().enumerate() {
                    if load.section == k && load.mass_kg > heaviest {
                        heaviest = load.mass_kg;
                        field = format!("loads.point[{p}].mass_kg");
                        value = load.mass_kg;
                    }
                }
            }
            let what = format!(
                "the weight section {i} carries from its base to the tip ({} N at |g| = {} m/s^2) \
                 reaches",
                crate::error::Num(weight),
                crate::error::Num(g)
            );
            return Err(beyond_ea(field, value, what, ea));
        }
        Ok(())
    }
}

/// `field = value` is out of range because `what` (an axial load, ending in "reach" or
/// "reaches") a section's axial stiffness `ea`: an axial strain of -1 or beyond.
fn beyond_ea(field: String, value: f64, what: String, ea: f64) -> ModelError {
    ea_error(
        field,
        value,
        what,
        ea,
        "an axial strain of -1 or beyond (the rod pressed to zero length or inverted)",
    )
}

/// `field = value` refused: `what` the axial stiffness `ea`, which is `strain`.
fn ea_error(field: String, value: f64, what: String, ea: f64, strain: &str) -> ModelError {
    ModelError::OutOfRange {
        field,
        value,
        why: format!(
            "{what} its axial stiffness EA = {} N: {strain}, not a physical state",
            crate::error::Num(ea)
        ),
    }
}
