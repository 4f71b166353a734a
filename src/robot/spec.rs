//! Serializable robot description (the `[robot]` table of a scene file), SI units.

use super::routing::{PathSpec, RoutingField};
use super::tendon::{Actuation, FrictionSpec, RoutingSpec, TendonSpec};
use crate::error::ModelError;
use crate::rod::{CrossSection, Material};
use serde::{Deserialize, Serialize};

mod validate;

/// Whole robot: base pose, sections base to tip, cables.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSpec {
    /// Base pose (default: at the origin, backbone along world `+z`).
    #[serde(default)]
    pub base: BaseSpec,
    /// Sections, base to tip (at least one).
    pub sections: Vec<SectionSpec>,
    /// Cables (default none).
    #[serde(default)]
    pub cables: Vec<CableSpec>,
    /// Tendon mechanics shared by every cable (each cable's `tendon` table overrides
    /// it field by field). Default none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tendons: Option<TendonSpec>,
    /// Tendon-on-disk friction (capstan law). Default none (frictionless).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<FrictionSpec>,
    /// Actuator limits of the displacement-driven tendons, in the readings' units
    /// (`[robot.limits]`, [`super::LimitsSpec`]). Default none (unlimited).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limits: Option<super::LimitsSpec>,
}

/// Base pose `r(0)`, `R(0)` (thesis table 2.1) as position plus axis-angle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BaseSpec {
    /// Position of the clamp exit in the world frame (m). Default `[0, 0, 0]`.
    pub position_m: [f64; 3],
    /// Rotation axis in the world frame (any non-zero length). Default `[0, 0, 1]`.
    pub axis: [f64; 3],
    /// Rotation angle about `axis` (degrees). Default 0. A rod clamped horizontally
    /// along world `+x` is `axis = [0, 1, 0]`, `angle_deg = 90`.
    pub angle_deg: f64,
}

impl Default for BaseSpec {
    fn default() -> Self {
        Self {
            position_m: [0.0; 3],
            axis: [0.0, 0.0, 1.0],
            angle_deg: 0.0,
        }
    }
}

/// One section: a length of uniform rod, optionally carrying evenly spaced guide disks.
///
/// In files the material fields sit directly in the section table (see
/// [`SectionFile`]); serde's `flatten` would silently disable `deny_unknown_fields`,
/// so the file form is a separate flat struct converted with `from`/`into`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(from = "SectionFile", into = "SectionFile")]
pub struct SectionSpec {
    /// Unstretched length (m), > 0.
    pub length_m: f64,
    /// Cross-section.
    pub shape: CrossSection,
    /// Material.
    pub material: Material,
    /// Timoshenko shear coefficient `k` in `D = diag(kGA, kGA, EA)`. Default 1
    /// (the thesis's `D1 = D2 = GA`); 6(1+nu)/(7+6nu) for a solid circle.
    pub shear_coefficient: f64,
    /// Precurvature `u*` (1/m) in the local frame. Default zero (straight rod).
    pub precurvature_per_m: [f64; 3],
    /// Guide disks on this section (default none).
    pub guides: Option<GuideSpec>,
}

/// The file form of [`SectionSpec`]: every key at one level, unknown keys rejected.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SectionFile {
    /// Unstretched length (m).
    pub length_m: f64,
    /// Cross-section.
    pub shape: CrossSection,
    /// Young's modulus (Pa).
    pub youngs_modulus_pa: f64,
    /// Poisson's ratio (-).
    pub poisson_ratio: f64,
    /// Density (kg/m^3).
    pub density_kg_m3: f64,
    /// Shear coefficient (default 1).
    #[serde(default = "one")]
    pub shear_coefficient: f64,
    /// Precurvature (1/m, default zero).
    #[serde(default)]
    pub precurvature_per_m: [f64; 3],
    /// Guide disks (default none); `spacing_m` and `first_offset_m` may be `"even"`
    /// (see [`GuideFile`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub guides: Option<GuideFile>,
}

/// The word `"even"` in a guide table (the only word accepted there).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EvenWord {
    /// Evenly spaced to the section's end.
    Even,
}

/// A guide spacing or first offset in a file: metres, or `"even"`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum SpacingValue {
    /// A length (m).
    Metres(f64),
    /// `"even"`: computed from the section length (see [`GuideFile`]).
    Even(EvenWord),
}

/// The file form of [`GuideSpec`]: `spacing_m` and `first_offset_m` are numbers (m)
/// or the word `"even"`, so that disks evenly spaced to the section's end need no
/// rounded decimal (15 disks on 0.1 m: 0.0066666667 overshoots by 5e-10 m).
///
/// With thickness `t`, section length `L` and `n = count` disks, the last disk's
/// face is put on the section's end (its centre at `L - t/2`):
/// * `spacing_m = "even"`, `first_offset_m = a` (m): `spacing = (L - t/2 - a) / (n - 1)`
///   (`n = 1`: spacing unused, 0);
/// * both `"even"`: the first disk one spacing from the base,
///   `first_offset = spacing = (L - t/2) / n`;
/// * `first_offset_m = "even"` with a numeric spacing `d`: `first_offset = L - t/2 - (n - 1) d`.
///
/// Written back (e.g. by `calibrate`) as given: `"even"` stays `"even"` (and is
/// resolved again for the section's length when read).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GuideFile {
    /// Number of disks.
    pub count: usize,
    /// First disk's centre from the section start (m) or `"even"`.
    pub first_offset_m: SpacingValue,
    /// Centre-to-centre spacing (m) or `"even"`.
    pub spacing_m: SpacingValue,
    /// Disk thickness (m).
    pub thickness_m: f64,
    /// Disk outer diameter (m).
    pub diameter_m: f64,
    /// Mass of one disk (kg).
    pub mass_kg: f64,
    /// Cable holes.
    pub holes: HolesSpec,
}

impl GuideFile {
    /// The guide layout on a section of `length_m` (m): the `"even"` values resolved
    /// as documented on [`GuideFile`]. Out-of-range results (e.g. a negative offset)
    /// are left for [`GuideSpec::validate`] to report.
    pub fn resolve(&self, length_m: f64) -> GuideSpec {
        let end = length_m - self.thickness_m / 2.0;
        let n = self.count.max(1) as f64;
        let (first, spacing) = match (self.first_offset_m, self.spacing_m) {
            (SpacingValue::Metres(a), SpacingValue::Metres(d)) => (a, d),
            (SpacingValue::Metres(a), SpacingValue::Even(_)) => {
                (a, if n > 1.0 { (end - a) / (n - 1.0) } else { 0.0 })
            }
            (SpacingValue::Even(_), SpacingValue::Even(_)) => (end / n, end / n),
            (SpacingValue::Even(_), SpacingValue::Metres(d)) => (end - (n - 1.0) * d, d),
        };
        GuideSpec {
            count: self.count,
            first_offset_m: first,
            spacing_m: spacing,
            thickness_m: self.thickness_m,
            diameter_m: self.diameter_m,
            mass_kg: self.mass_kg,
            holes: self.holes.clone(),
            even: EvenLayout {
                first_offset: matches!(self.first_offset_m, SpacingValue::Even(_)),
                spacing: matches!(self.spacing_m, SpacingValue::Even(_)),
            },
        }
    }
}

impl From<GuideSpec> for GuideFile {
    fn from(g: GuideSpec) -> Self {
        let value = |even: bool, m: f64| {
            if even {
                SpacingValue::Even(EvenWord::Even)
            } else {
                SpacingValue::Metres(m)
            }
        };
        Self {
            count: g.count,
            first_offset_m: value(g.even.first_offset, g.first_offset_m),
            spacing_m: value(g.even.spacing, g.spacing_m),
            thickness_m: g.thickness_m,
            diameter_m: g.diameter_m,
            mass_kg: g.mass_kg,
            holes: g.holes,
        }
    }
}

impl From<SectionFile> for SectionSpec {
    fn from(f: SectionFile) -> Self {
        Self {
            length_m: f.length_m,
            shape: f.shape,
            material: Material {
                youngs_modulus_pa: f.youngs_modulus_pa,
                poisson_ratio: f.poisson_ratio,
                density_kg_m3: f.density_kg_m3,
            },
            shear_coefficient: f.shear_coefficient,
            precurvature_per_m: f.precurvature_per_m,
            guides: f.guides.map(|g| g.resolve(f.length_m)),
        }
    }
}

impl From<SectionSpec> for SectionFile {
    fn from(s: SectionSpec) -> Self {
        Self {
            length_m: s.length_m,
            shape: s.shape,
            youngs_modulus_pa: s.material.youngs_modulus_pa,
            poisson_ratio: s.material.poisson_ratio,
            density_kg_m3: s.material.density_kg_m3,
            shear_coefficient: s.shear_coefficient,
            precurvature_per_m: s.precurvature_per_m,
            guides: s.guides.map(GuideFile::from),
        }
    }
}

/// Upper bound on disks per section: the layout is allocated per disk, so an absurd
/// count in a scene file must fail validation rather than exhaust memory.
pub const MAX_GUIDES_PER_SECTION: usize = 10_000;

/// How far (m) a guide disk may reach past its section's ends and still be accepted
/// (it is then placed at the end): 1e-9 m, far below any machining tolerance, and
/// above the rounding of a spacing written to ten decimals times a few dozen disks.
pub const GUIDE_FIT_TOLERANCE_M: f64 = 1e-9;

fn one() -> f64 {
    1.0
}

/// Evenly spaced guide disks (thesis 3.8, figure 3.5).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GuideSpec {
    /// Number of disks, >= 1.
    pub count: usize,
    /// Arc length from the section start to the first disk's centre (m).
    pub first_offset_m: f64,
    /// Centre-to-centre spacing (m); ignored when `count = 1`.
    pub spacing_m: f64,
    /// Disk thickness along the backbone (m).
    pub thickness_m: f64,
    /// Disk outer diameter (m); holes must lie inside it.
    pub diameter_m: f64,
    /// Mass of one disk (kg).
    pub mass_kg: f64,
    /// Cable holes.
    pub holes: HolesSpec,
    /// Which of `first_offset_m` and `spacing_m` the file gave as `"even"` (they
    /// are written back as `"even"`, so a scene whose section length is changed,
    /// e.g. by a calibration, spaces its disks again). Default: neither.
    #[serde(default)]
    pub even: EvenLayout,
}

/// Which guide-layout values were given as `"even"` ([`GuideFile`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvenLayout {
    /// `first_offset_m = "even"`.
    pub first_offset: bool,
    /// `spacing_m = "even"`.
    pub spacing: bool,
}

/// Cable holes on a disk: one radius, several angles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HolesSpec {
    /// Distance of the hole centres from the backbone axis (m).
    pub radius_m: f64,
    /// Hole angles (degrees) from local `+x` towards `+y`. Default `[0, 120, 240]`.
    #[serde(default = "three_holes")]
    pub angles_deg: Vec<f64>,
}

fn three_holes() -> Vec<f64> {
    vec![0.0, 120.0, 240.0]
}

/// A cable: which hole it uses, where it ends, and how it is driven.
///
/// In files `routing` is either a hole table or the string `"continuous"` (then with
/// a `path`, see [`super::routing`]); the file form is [`CableFile`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(from = "CableFile", into = "CableFile")]
pub struct CableSpec {
    /// Optional name used in reports (default `cable<j>`).
    #[serde(default)]
    pub name: Option<String>,
    /// Hole index (into `holes.angles_deg`) used on every disk and the base plate.
    /// Exactly one of `hole` and `routing` is given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hole: Option<usize>,
    /// The cable's own hole (radius, angle, per-section offset) on every disk it
    /// passes and on the base plate, independent of the disks' `holes` list.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub routing: Option<RoutingSpec>,
    /// Section on whose last disk the cable is tied.
    pub end_section: usize,
    /// How the cable is driven. Default `tension` (`loads.tensions_n`).
    #[serde(default)]
    pub actuation: Actuation,
    /// Tendon mechanics, overriding `robot.tendons` field by field.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tendon: Option<TendonSpec>,
    /// Column of a readings file holding this tendon's actuator reading
    /// (displacement-driven tendons). Default: the cable's name.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reading: Option<String>,
    /// Continuous routing (scene `routing = "continuous"`): the tendon runs along
    /// `path` from the base to the end of `end_section`, not through disks.
    pub continuous: bool,
    /// The continuous tendon's path in the cross-section.
    pub path: Option<PathSpec>,
}

/// The file form of [`CableSpec`] (every key at one level, unknown keys rejected).
#[allow(missing_docs)]
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CableFile {
    #[serde(default)]
    pub name: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hole: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub routing: Option<RoutingField>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathSpec>,
    pub end_section: usize,
    #[serde(default)]
    pub actuation: Actuation,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tendon: Option<TendonSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reading: Option<String>,
}

impl From<CableFile> for CableSpec {
    fn from(f: CableFile) -> Self {
        let (continuous, routing) = match f.routing {
            Some(RoutingField::Continuous) => (true, None),
            Some(RoutingField::Holes(h)) => (false, Some(h)),
            None => (false, None),
        };
        Self {
            name: f.name,
            hole: f.hole,
            routing,
            end_section: f.end_section,
            actuation: f.actuation,
            tendon: f.tendon,
            reading: f.reading,
            continuous,
            path: f.path,
        }
    }
}

impl From<CableSpec> for CableFile {
    fn from(c: CableSpec) -> Self {
        let routing = match (c.continuous, c.routing) {
            (true, _) => Some(RoutingField::Continuous),
            (false, r) => r.map(RoutingField::Holes),
        };
        Self {
            name: c.name,
            hole: c.hole,
            routing,
            path: c.path,
            end_section: c.end_section,
            actuation: c.actuation,
            tendon: c.tendon,
            reading: c.reading,
        }
    }
}

impl CableSpec {
    /// A cable through hole index `hole` of every disk, tied at the end of
    /// `end_section`, tension-driven.
    pub fn through_hole(hole: usize, end_section: usize) -> Self {
        Self {
            hole: Some(hole),
            end_section,
            ..Self::default()
        }
    }

    /// The mechanics in effect: this cable's table over the robot-wide one.
    pub fn mechanics(&self, defaults: Option<&TendonSpec>) -> TendonSpec {
        let own = self.tendon.clone().unwrap_or_default();
        match defaults {
            Some(d) => own.or(d),
            None => own,
        }
    }
}
