//! Non-dimensional load intensity: how far a scene's loads can bend the rod.
//!
//! Each load contributes the bending angle (rad) it would produce on its own at the
//! stiffest-to-bend scale of the robot, `EI_min = min_i min(C_i[0], C_i[1])` (thesis
//! eq. 2.12):
//! - a force `F` at arc length `s`: `|F| s^2 / EI` (the map's `P L^2 / EI` at the tip);
//! - a torque `M` at `s`: `|M| s / EI`;
//! - a weight (payload, guide, rod element) at `s`: `m g_b s^2 / EI`, so the bare rod
//!   contributes `rho A g_b L^3 / (3 EI)`, with `g_b` the part of gravity that can bend
//!   the straight rod: across its base axis, plus along it where it compresses the rod
//!   (weight along the axis of a hanging rod pulls it straight; `bending_gravity`);
//! - the cables ending on one section's last disk at `s_end`, with tensions `T_j` and
//!   holes `d_j` there: `|sum_j T_j (e3 x d_j)| s_end / EI`, the bending angle of the
//!   equivalent constant-curvature arc under their net moment (one cable: the map's
//!   `T r L / EI`). Antagonistic tendons under equal pretension cancel: they compress
//!   the rod between the disks but do not bend it (a tendon-driven robot's
//!   pretension is not a bending load).
//!
//! The intensity is the sum: an upper bound on the scale of the base moment times
//! `L / EI`, hence on the total turning `int |u| ds` of any equilibrium of the
//! clamped-free rod (its internal moment is the moment of the loads distal to `s`).
//! Below a few radians every equilibrium is a mildly bent rod near the one Newton finds
//! from the straight rod; above, looped or inverted equilibria exist too. The solver
//! uses it to decide when a cold Newton's answer needs the branch check
//! (`SolverSettings::branch_guard`).

use super::plan::ParamSite;
use crate::loads::Loads;
use crate::robot::Robot;
use nalgebra::Vector3;

/// Where a term of the intensity comes from (`intensity_terms`): what a diagnosis
/// names, with the scene field a user would change.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum IntensitySource {
    /// The weight of section `k`'s rod (`robot.sections[k].density_kg_m3` under gravity).
    RodWeight { section: usize },
    /// The weight of section `k`'s guide disks (`robot.sections[k].guides.mass_kg`).
    GuideWeight { section: usize },
    /// Point load `i`'s force (`loads.point[i].force_n`).
    Force { point: usize },
    /// Point load `i`'s weight (`loads.point[i].mass_kg`).
    Mass { point: usize },
    /// Point load `i`'s torque (`loads.point[i].torque_nm`).
    Torque { point: usize },
    /// The net moment of the cables ending in section `k`; `cable` is the one with the
    /// largest tension among them (`loads.tensions_n[cable]`).
    Cables { section: usize, cable: usize },
    /// Load parameter `k` of the workspace (an estimator's unknown load).
    Param { index: usize },
}

/// Intensity (dimensionless) of `loads` plus the load parameters `theta` at `params`
/// (a parameter's magnitude is added to its site's, an upper bound).
pub(crate) fn load_intensity(
    robot: &Robot,
    loads: &Loads,
    params: &[ParamSite],
    theta: &[f64],
) -> f64 {
    let mut sum = 0.0;
    let ei = intensity_terms(robot, loads, params, theta, &mut |_, t| sum += t);
    intensity_of(sum, ei)
}

/// The intensity from the sum of [`intensity_terms`]' terms and `EI_min`: infinite
/// when either is not a usable number.
pub(crate) fn intensity_of(sum: f64, ei: f64) -> f64 {
    if ei.is_nan() || ei <= 0.0 || !sum.is_finite() {
        f64::INFINITY
    } else {
        sum / ei
    }
}

/// The part of gravity (m/s^2) that can bend the rod from its straight reference: the
/// component across the base axis `e`, plus the axial component where it compresses
/// the rod (`g . e < 0`: an upright rod carries its weight and can buckle under it).
/// Along `e` (a hanging arm) weight pulls the rod straight: it stiffens rather than
/// bends it, and counting it would call a soft arm hanging under its own weight a
/// large load (a 0.36 m arm of E = 3e5 Pa: 90 rad, which sent its cold solve into a
/// branch-checked continuation that ran out of steps; its equilibrium is a few
/// Newton steps from the straight rod).
fn bending_gravity(robot: &Robot, loads: &Loads) -> f64 {
    let g = Vector3::from(loads.gravity_m_s2);
    let e = robot.base_rotation() * Vector3::z();
    let axial = g.dot(&e);
    (g - e * axial).norm() + (-axial).max(0.0)
}

/// Every term of [`load_intensity`] before the division by `EI_min`, handed to
/// `visit` with its source (terms of zero included, in a fixed order); returns
/// `EI_min` (N m^2). No allocation: [`load_intensity`] runs at every evaluation of a
/// control loop.
pub(crate) fn intensity_terms(
    robot: &Robot,
    loads: &Loads,
    params: &[ParamSite],
    theta: &[f64],
    visit: &mut impl FnMut(IntensitySource, f64),
) -> f64 {
    let ei = robot.min_bending_stiffness();
    let g = bending_gravity(robot, loads);
    let end = |section: usize| robot.sections().get(section).map_or(0.0, |s| s.end());
    // weight of the bare rod, section by section: int rho A g s^2 ds
    for (k, s) in robot.sections().iter().enumerate() {
        let (a, b) = (s.start, s.end());
        let w = s.stiffness.linear_density * g * (b.powi(3) - a.powi(3)) / 3.0;
        visit(IntensitySource::RodWeight { section: k }, w);
    }
    for (k, s) in robot.sections().iter().enumerate() {
        let w: f64 = robot.guides()[s.guides.clone()]
            .iter()
            .map(|d| d.mass * g * d.s * d.s)
            .sum();
        visit(IntensitySource::GuideWeight { section: k }, w);
    }
    for (i, p) in loads.point.iter().enumerate() {
        let s = end(p.section);
        visit(
            IntensitySource::Force { point: i },
            Vector3::from(p.force_n).norm() * s * s,
        );
        visit(IntensitySource::Mass { point: i }, p.mass_kg * g * s * s);
        visit(
            IntensitySource::Torque { point: i },
            Vector3::from(p.torque_nm).norm() * s,
        );
    }
    // cable tension: the scene's plus its parameters'
    let tension = |j: usize| -> f64 {
        let extra: f64 = params
            .iter()
            .zip(theta)
            .filter(|(site, _)| **site == ParamSite::Tension { cable: j })
            .map(|(_, th)| *th)
            .sum();
        (loads.tension(j) + extra).abs()
    };
    for k in 0..robot.sections().len() {
        let mut moment = Vector3::zeros();
        let mut s_end = 0.0;
        let (mut largest, mut t_max) = (None, f64::NEG_INFINITY);
        for (j, c) in robot.cables().iter().enumerate() {
            if c.end_section != k {
                continue;
            }
            // the last hole, or a continuous tendon's offset where it ends
            let Some(d) = c
                .path
                .as_ref()
                .map(|p| p.eval(c.end_s)[0])
                .or(c.hole_local.last().copied())
            else {
                continue;
            };
            s_end = c.end_s;
            let t = tension(j);
            moment += Vector3::z().cross(&d) * t;
            if t > t_max {
                (largest, t_max) = (Some(j), t);
            }
        }
        if let Some(cable) = largest {
            visit(
                IntensitySource::Cables { section: k, cable },
                moment.norm() * s_end,
            );
        }
    }
    for (index, (site, th)) in params.iter().zip(theta).enumerate() {
        let s = |point: usize| loads.point.get(point).map_or(0.0, |p| end(p.section));
        let term = match *site {
            ParamSite::Force { point, .. } => th.abs() * s(point).powi(2),
            ParamSite::Torque { point, .. } => th.abs() * s(point),
            ParamSite::Mass { point } => th.abs() * g * s(point).powi(2),
            ParamSite::Tension { .. } => 0.0,
        };
        visit(IntensitySource::Param { index }, term);
    }
    ei
}
