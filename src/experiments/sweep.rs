//! Which loads the experiments sweep: the `pareto` load sweep of a scene and the
//! `stability` load directions with their non-dimensional magnitudes.
//!
//! Magnitudes are non-dimensional so that one grid fits every robot: a tip force `P`
//! as `P L^2 / EI` (the bending angle it causes on a cantilever, to first order) and a
//! cable tension `T` as `T r L / EI` (the bending angle of the constant-curvature arc
//! it would cause, `theta = kappa L` with `kappa = T r / EI`, Webster & Jones 2010
//! section 4.1). `EI` is section 0's, `L` the robot's length.

use crate::ladder;
use crate::loads::{Frame, Loads, PointLoad};
use crate::robot::Robot;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Unit vector across the rod at the base: along gravity's component normal to the
/// base tangent, else the base's local x.
pub fn across(robot: &Robot, loads: &Loads) -> Vector3<f64> {
    let t = robot.base_rotation() * Vector3::z();
    let g = Vector3::from(loads.gravity_m_s2);
    let gn = g - t * t.dot(&g);
    if gn.norm() > 1e-9 * g.norm().max(1.0) && gn.norm() > 0.0 {
        gn.normalize()
    } else {
        robot.base_rotation() * Vector3::x()
    }
}

/// `loads` plus a world-frame tip force of non-dimensional magnitude `P L^2 / EI`
/// along `dir` (added to an existing world-frame tip load if there is one).
pub fn with_tip_force(robot: &Robot, loads: &Loads, nondim: f64, dir: Vector3<f64>) -> Loads {
    let l = robot.length();
    let ei = robot.sections()[0].stiffness.bend_twist.x;
    let f = dir * (nondim * ei / (l * l));
    let mut out = loads.clone();
    let tip = robot.sections().len() - 1;
    match out
        .point
        .iter_mut()
        .find(|p| p.section == tip && p.frame == Frame::World)
    {
        Some(p) => {
            for i in 0..3 {
                p.force_n[i] += f[i];
            }
        }
        None => out.point.push(PointLoad {
            section: tip,
            force_n: f.into(),
            ..Default::default()
        }),
    }
    out
}

/// The `pareto` load sweep of a scene: its point loads and tensions scaled by 0.5, 1,
/// 1.5 (gravity unchanged), and its loads plus a tip force of `P L^2/EI` = 1 and 3
/// across the rod ([`across`]). Each entry is (label, loads).
pub fn pareto_sweep(robot: &Robot, loads: &Loads) -> Vec<(String, Loads)> {
    let dir = across(robot, loads);
    let mut v: Vec<(String, Loads)> = [0.5, 1.0, 1.5]
        .iter()
        .map(|&f| (format!("x{f}"), ladder::scale_loads(loads, f)))
        .collect();
    for a in [1.0, 3.0] {
        v.push((
            format!("+tip PL2/EI={a}"),
            with_tip_force(robot, loads, a, dir),
        ));
    }
    v
}

/// Load direction of a `stability` sweep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    /// World tip force along gravity's component across the rod.
    Down,
    /// The opposite.
    Up,
    /// World tip force across the rod, normal to gravity.
    Lateral,
    /// World tip force against the base tangent (compression).
    Axial,
    /// Body-frame (follower) tip force along the tip's local x axis.
    Follower,
    /// Tension of cable 0, `T r L / EI`.
    Tension,
    /// Readings of displacement-driven tendons that the constant-curvature kinematics
    /// maps to every section bent by `theta` rad (module [`super::tdcr`]).
    Readings,
}

/// The load directions of the force-and-tension map, in map order.
pub const DIRECTIONS: [Direction; 6] = [
    Direction::Down,
    Direction::Up,
    Direction::Lateral,
    Direction::Axial,
    Direction::Follower,
    Direction::Tension,
];

impl Direction {
    /// Long name (chart titles).
    pub fn name(self) -> &'static str {
        match self {
            Self::Down => "down (along gravity)",
            Self::Up => "up (against gravity)",
            Self::Lateral => "lateral",
            Self::Axial => "axial compression",
            Self::Tension => "cable tension TrL/EI",
            Self::Follower => "follower (body-frame x)",
            Self::Readings => "tendon readings (CC bend, rad)",
        }
    }

    /// Short name (CSV, tables).
    pub fn short(self) -> &'static str {
        match self {
            Self::Down => "down",
            Self::Up => "up",
            Self::Lateral => "lateral",
            Self::Axial => "axial",
            Self::Tension => "tension",
            Self::Follower => "follower",
            Self::Readings => "readings",
        }
    }

    /// Magnitudes of the map (non-dimensional; rad for readings).
    pub fn grid(self) -> &'static [f64] {
        match self {
            Self::Tension => &[
                0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 7.5, 8.0, 8.5,
            ],
            Self::Readings => &[
                0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0,
            ],
            _ => &[
                0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 7.5, 10.0, 15.0, 20.0, 30.0, 40.0, 50.0, 100.0,
                200.0, 500.0, 1000.0,
            ],
        }
    }

    /// Continuation step of the reference tracked along this direction.
    pub fn reference_step(self) -> f64 {
        match self {
            Self::Tension => 0.02,
            Self::Follower | Self::Readings => 0.05,
            _ => 0.1,
        }
    }
}

/// The loads at `magnitude` along a force or tension direction (`base` plus the tip
/// force or with cable 0's tension set). [`Direction::Readings`] changes no load:
/// `base` is returned.
pub fn loads_at(robot: &Robot, base: &Loads, dir: Direction, magnitude: f64) -> Loads {
    let l = robot.length();
    let ei = robot.sections()[0].stiffness.bend_twist.x;
    let mut out = base.clone();
    match dir {
        Direction::Readings => return out,
        Direction::Tension => {
            let Some(c) = robot.cables().first() else {
                return out;
            };
            let r = c.base_hole.norm().max(1e-6);
            if out.tensions_n.is_empty() {
                out.tensions_n.push(0.0);
            }
            out.tensions_n[0] = magnitude * ei / (r * l);
            return out;
        }
        Direction::Follower => {
            out.point.push(PointLoad {
                section: robot.sections().len() - 1,
                force_n: [magnitude * ei / (l * l), 0.0, 0.0],
                frame: Frame::Body,
                ..Default::default()
            });
            return out;
        }
        _ => {}
    }
    let t = robot.base_rotation() * Vector3::z();
    let down = across(robot, base);
    let d = match dir {
        Direction::Down => down,
        Direction::Up => -down,
        Direction::Lateral => t.cross(&down).normalize(),
        _ => -t,
    };
    let f = d * (magnitude * ei / (l * l));
    out.point.push(PointLoad {
        section: robot.sections().len() - 1,
        force_n: f.into(),
        ..Default::default()
    });
    out
}
