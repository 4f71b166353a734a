//! Why a solve did not converge, said in the scene's terms: the loads' intensity
//! (`intensity.rs`: the bending angle, in rad, each load would cause on its own at
//! the robot's smallest bending stiffness) split by the load that causes it, each
//! named by the scene field a user would change.
//!
//! The intensity is the measure the solver itself decides with (the branch guard's
//! checks above 3, multiple shooting above 20: docs/where-methods-fail.md, "Large loads"). A load of
//! intensity far above a few radians admits looped and inverted equilibria, and a
//! cold solve from the straight rod may not reach the one the robot takes; a failed
//! solve at a low intensity is a numerical matter instead (the integrator or the
//! iteration budget), and the diagnosis says which case it is. Why: a tension of
//! 500 N on the demo scene's cable (below the rod's `EA`, so valid input) ends
//! `max_iterations` after about 100 ms, and the status alone gives a user no reason
//! to act on.

use super::intensity::{intensity_of, intensity_terms, IntensitySource};
use super::{SolveReport, SolveStatus, Workspace};
use crate::error::Num;
use crate::loads::Loads;
use crate::robot::Robot;
use serde::Serialize;
use std::fmt;

/// Intensity above which a failed solve is put down to the loads: the branch
/// guard's threshold (`CERTIFY_INTENSITY`), where equilibria other than the one
/// loaded from rest start to exist.
pub const LOADS_BLAMED_ABOVE: f64 = 3.0;
/// Fraction of the Euler load of the rod between two disks from which a failed solve
/// from readings is put down to the backbone's compression. Measured on the textbook
/// TDCR (`tdcr_two_segment`, 1 mm NiTi rod, disks 10 mm apart, Euler load 291 N) with
/// one tendon pulled and its two antagonists held: 2 mm asks for 0.61 of it (the
/// solve converges with ~60 N in each tendon, as the estimate says), 3 mm for 0.91
/// (`non_finite`), 5 mm for 1.5 (`stalled`).
pub const COMPRESSION_BLAMED_ABOVE: f64 = 0.75;
/// Loads named in a diagnosis at most (the largest first).
const NAMED: usize = 4;

/// One load's share of the intensity.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LoadShare {
    /// The scene field that sets it, e.g. `loads.tensions_n[0]`.
    pub field: String,
    /// Its value as written in the scene, with the unit (a vector as its magnitude).
    pub value: String,
    /// What the term measures.
    pub what: String,
    /// Its bending angle on its own (rad).
    pub intensity: f64,
}

/// Why a solve ended where it did ([`Workspace::diagnose`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Diagnosis {
    /// How the solve ended.
    pub status: SolveStatus,
    /// The solve's residual (scaled, as [`SolveReport::residual`]; for a solve from
    /// readings `TendonReport::residual_m`, in m).
    pub residual: f64,
    /// The solve's tolerance, in the residual's units.
    pub tolerance: f64,
    /// The loads' intensity (rad, summed over the loads).
    pub intensity: f64,
    /// The loads with a share, largest first.
    pub loads: Vec<LoadShare>,
    /// Solves from readings: each tendon pulled in, with the bend its pull asks of
    /// the rod by constant-curvature kinematics (pull over hole radius, rad) as its
    /// `intensity`, largest first; empty otherwise. A pull can ask for a bend no
    /// tension reaches (the tensions the solve reached then say little).
    pub pulls: Vec<LoadShare>,
    /// Solves from readings: the largest axial load that the pulls of one section's
    /// tendons ask of the backbone when they do not cancel (the others held), with
    /// the pretensions, as a fraction (`intensity`) of the Euler load `pi^2 EI/h^2`
    /// of the rod between two disks `h` apart; `None` otherwise.
    pub compression: Option<LoadShare>,
}

impl Workspace {
    /// Why the last solve ended as it did, in terms of the loads that bend the rod
    /// (module docs). Meant for a solve that did not converge; allocates.
    pub fn diagnose(&self) -> Diagnosis {
        diagnose(
            self.robot(),
            self.loads(),
            self.params(),
            self.theta(),
            self.report(),
        )
    }
}

/// [`Workspace::diagnose`] from its parts.
pub fn diagnose(
    robot: &Robot,
    loads: &Loads,
    params: &[super::ParamSite],
    theta: &[f64],
    report: &SolveReport,
) -> Diagnosis {
    let outcome = (report.status, report.residual, report.tolerance);
    diagnose_named(robot, loads, params, theta, &|_| None, outcome)
}

/// Names a cable's share instead of `loads.tensions_n[j]`: `Some((field, value))`
/// (a displacement-driven tendon: its readings column and pull).
pub(crate) type CableNames<'a> = &'a dyn Fn(usize) -> Option<(String, String)>;

/// [`diagnose`] with cables named by `names` and the outcome `(status, residual,
/// tolerance)` of whatever solve ran (a tendon solve's residual is in m).
pub(crate) fn diagnose_named(
    robot: &Robot,
    loads: &Loads,
    params: &[super::ParamSite],
    theta: &[f64],
    names: CableNames<'_>,
    (status, residual, tolerance): (SolveStatus, f64, f64),
) -> Diagnosis {
    let mut shares = Vec::new();
    let g = nalgebra::Vector3::from(loads.gravity_m_s2).norm();
    let spec = robot.spec();
    // the intensity as `load_intensity` sums it (every term, in the same order)
    let mut sum = 0.0;
    let ei = intensity_terms(robot, loads, params, theta, &mut |src, term| {
        sum += term;
        if term > 0.0 || term.is_nan() {
            shares.push((src, term));
        }
    });
    let intensity = intensity_of(sum, ei);
    let mut out: Vec<LoadShare> = shares
        .into_iter()
        .map(|(src, term)| {
            let (field, value, what) = match src {
                IntensitySource::RodWeight { section } => (
                    format!("robot.sections[{section}].density_kg_m3"),
                    format!(
                        "{} kg/m^3",
                        Num(spec.sections[section].material.density_kg_m3)
                    ),
                    format!("the rod's weight at |g| = {} m/s^2", Num(g)),
                ),
                IntensitySource::GuideWeight { section } => (
                    format!("robot.sections[{section}].guides.mass_kg"),
                    format!(
                        "{} kg",
                        Num(spec.sections[section]
                            .guides
                            .as_ref()
                            .map_or(0.0, |d| d.mass_kg))
                    ),
                    "the guide disks' weight".to_string(),
                ),
                IntensitySource::Force { point } => (
                    format!("loads.point[{point}].force_n"),
                    format!(
                        "|F| = {} N",
                        Num(nalgebra::Vector3::from(loads.point[point].force_n).norm())
                    ),
                    "a point force".to_string(),
                ),
                IntensitySource::Mass { point } => (
                    format!("loads.point[{point}].mass_kg"),
                    format!("{} kg", Num(loads.point[point].mass_kg)),
                    "a payload's weight".to_string(),
                ),
                IntensitySource::Torque { point } => (
                    format!("loads.point[{point}].torque_nm"),
                    format!(
                        "|M| = {} N m",
                        Num(nalgebra::Vector3::from(loads.point[point].torque_nm).norm())
                    ),
                    "a point torque".to_string(),
                ),
                IntensitySource::Cables { section, cable } => {
                    let (field, value) = names(cable).unwrap_or_else(|| {
                        (
                            format!("loads.tensions_n[{cable}]"),
                            format!("{} N", Num(loads.tension(cable))),
                        )
                    });
                    (
                        field,
                        value,
                        format!(
                            "the net moment of the cables ending in section {section}, this one \
                         pulling hardest"
                        ),
                    )
                }
                IntensitySource::Param { index } => (
                    format!("load parameter {index}"),
                    format!("{}", Num(theta.get(index).copied().unwrap_or(f64::NAN))),
                    "an estimated load".to_string(),
                ),
            };
            LoadShare {
                field,
                value,
                what,
                intensity: term / ei,
            }
        })
        .collect();
    out.sort_by(|a, b| b.intensity.total_cmp(&a.intensity));
    Diagnosis {
        status,
        residual,
        tolerance,
        intensity,
        loads: out,
        pulls: Vec::new(),
        compression: None,
    }
}

impl Diagnosis {
    /// The loads carry the blame: intensity above [`LOADS_BLAMED_ABOVE`] (or not a
    /// number: loads beyond the range of `f64`).
    pub fn loads_blamed(&self) -> bool {
        self.intensity > LOADS_BLAMED_ABOVE
            || self.intensity.is_nan()
            || self.pull_blamed()
            || self.compression_blamed()
    }

    /// The backbone is compressed to at least [`COMPRESSION_BLAMED_ABOVE`] of its
    /// Euler load between two disks.
    fn compression_blamed(&self) -> bool {
        self.compression
            .as_ref()
            .is_some_and(|c| c.intensity >= COMPRESSION_BLAMED_ABOVE)
    }

    /// A pull asks for a bend above [`LOADS_BLAMED_ABOVE`] rad (the segment curling
    /// back on itself).
    fn pull_blamed(&self) -> bool {
        self.pulls
            .first()
            .is_some_and(|p| p.intensity > LOADS_BLAMED_ABOVE)
    }

    /// The input to reduce first: the largest pull when it is blamed, else the
    /// largest load.
    fn culprit(&self) -> &str {
        let first = if self.compression_blamed() {
            self.compression.as_ref()
        } else if self.pull_blamed() {
            self.pulls.first()
        } else {
            self.loads.first()
        };
        first.map_or("the loads", |s| s.field.as_str())
    }
}

impl fmt::Display for Diagnosis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let status = serde_json::to_value(self.status)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_else(|| format!("{:?}", self.status));
        if self.status.is_converged() {
            write!(f, "converged (residual {:.2e})", self.residual)?;
        } else {
            write!(
                f,
                "not converged ({status}: residual {:.2e} against tolerance {:.2e}); the \
                 shape is not an equilibrium",
                self.residual, self.tolerance
            )?;
        }
        write!(
            f,
            ". Load intensity {:.3} rad (each load's bending angle on its own, summed)",
            self.intensity
        )?;
        shares(f, "; largest:", &self.loads)?;
        shares(f, "; the readings pull in:", &self.pulls)?;
        if let Some(c) = &self.compression {
            write!(
                f,
                "; {} = {} {}: {:.2} of that load",
                c.field, c.value, c.what, c.intensity
            )?;
        }
        if self.status.is_converged() {
            return write!(f, ".");
        }
        if self.compression_blamed() {
            write!(
                f,
                ". The backbone may buckle between disks (compressed to at least \
                 {COMPRESSION_BLAMED_ABOVE} of the Euler load of the rod between two disks) \
                 where tendons pull together: pay their antagonists out with the pull, or \
                 reduce {}",
                self.culprit()
            )
        } else if self.loads_blamed() {
            write!(
                f,
                ". Above {LOADS_BLAMED_ABOVE} rad (a load's intensity, or the bend a pull \
                 asks for) looped or inverted equilibria exist besides the one loaded from \
                 rest, and a cold solve may not reach it: reduce {} (the largest), or reach \
                 it as a ramp of warm solves from a smaller one",
                self.culprit()
            )
        } else {
            write!(
                f,
                ". The loads are mild (intensity, and any pull's bend, at most \
                 {LOADS_BLAMED_ABOVE} rad; any compression by the pulls below \
                 {COMPRESSION_BLAMED_ABOVE} of the Euler load between disks): the cause is \
                 numerical; try more integration steps or the adaptive integrator \
                 (numerics.integrator), a larger numerics.max_iterations, or \
                 numerics.continuation = true"
            )
        }
    }
}

/// `title` and the first [`NAMED`] of `list` as `field = value (what) x rad`, if any.
fn shares(f: &mut fmt::Formatter<'_>, title: &str, list: &[LoadShare]) -> fmt::Result {
    if list.is_empty() {
        return Ok(());
    }
    write!(f, "{title}")?;
    for (k, s) in list.iter().take(NAMED).enumerate() {
        let sep = if k == 0 { " " } else { "; " };
        write!(
            f,
            "{sep}{} = {} ({}) {:.3} rad",
            s.field, s.value, s.what, s.intensity
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::Scene;

    /// The diagnosis's shares add up to the intensity the solver decides with, and
    /// the largest is the load that was made absurd: 500 N on the demo scene's first
    /// cable (a valid value, below the rod's `EA`) does not converge, and the
    /// diagnosis names `loads.tensions_n[0]` first and blames the loads.
    #[test]
    fn an_unreachable_tension_is_named_first() {
        let mut scene = Scene::load("data/scenes/demo_two_section.toml").expect("shipped scene");
        let ws = |scene: &Scene| {
            let robot = scene.build_robot().expect("robot");
            crate::Workspace::new(robot, scene.loads.clone(), scene.numerics.clone())
        };
        let mut ws1 = ws(&scene).expect("workspace");
        ws1.solve(crate::Start::Cold);
        let d = ws1.diagnose();
        assert!(d.status.is_converged(), "{d}");
        let sum: f64 = d.loads.iter().map(|s| s.intensity).sum();
        assert!(
            (sum - d.intensity).abs() <= 1e-12 * d.intensity,
            "{sum} vs {}",
            d.intensity
        );
        scene.loads.tensions_n[0] = 500.0;
        let mut ws = ws(&scene).expect("500 N is below EA: valid");
        let report = ws.solve(crate::Start::Cold);
        assert!(!report.status.is_converged(), "{report:?}");
        let d = ws.diagnose();
        assert_eq!(d.loads[0].field, "loads.tensions_n[0]", "{d}");
        assert!(d.loads_blamed(), "{d}");
        let text = d.to_string();
        for want in ["not converged", "loads.tensions_n[0] = 500 N", "reduce"] {
            assert!(text.contains(want), "{want:?} missing from {text}");
        }
    }
}
