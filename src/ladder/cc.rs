//! Rung (a): constant curvature per section.
//!
//! Each section `k` is one arc ([`arc_pose`]) whose local curvature vector is
//! `u_k = C_k^-1 m_k + u*_k` (thesis eq. 2.12 inverted, `C = diag(EI, EI, GJ)`), with the
//! section's bending/twisting moment `m_k` in its local frame:
//!
//! * cable `j` with tension `T_j > 0` ending at or beyond section `k`, through the hole
//!   `d_jk` (local, in the disk plane) of the section's disks: `T_j (e3 x d_jk)`. This is
//!   the moment about the backbone of a cable running parallel to it (Webster & Jones
//!   2010, section 4.1; thesis 3.8.1 routing in the limit of dense disks). The cable's
//!   axial force is carried by the rod and bends nothing in this limit;
//! * torques at the ends of sections `j >= k`: world torques resolved in the section's
//!   start frame `R_k^T tau`, body torques `R_k^T R_end,j tau`;
//! * point forces and payload weights at the ends of sections `j >= k`, by their moment
//!   about the section's arc midpoint `(p_j - r_mid,k) x F_j` (the mean of the linearly
//!   varying moment over a straight section). This is an extension of the classical
//!   CC model; forces make `m_k` depend on the shape, found by a fixed point.
//!
//! Ignored: gravity on the rod and on the disks, the cable's chord geometry between
//! disks, shear and extension. Exact (to round-off) only for bending torques without
//! gravity or forces: then `m(s)` is constant in the body frame and the Cosserat
//! solution is this arc. Without point forces and body torques the result is closed
//! form (one sweep base to tip); otherwise Gauss-Seidel sweeps (base to tip, each
//! section computed with the sections before it already updated) are the fixed-point
//! map, accelerated by Anderson mixing (depth 3, mixing parameter `w` = 1, halved
//! whenever the change grows), until the curvatures change by less than
//! `tolerance / L`.

use super::anderson::Anderson;
use super::arc::arc_pose;
use super::{check_loads, ForwardModel, LadderError, LadderOutput, LadderReport};
use crate::cables::path_length;
use crate::loads::{Frame, Loads};
use crate::robot::Robot;
use crate::statics::{Pose, SolveStatus, Start};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Settings of the constant-curvature rung.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CcSettings {
    /// Sweeps of the fixed point when point forces or body torques make the moments
    /// shape-dependent (default 100).
    pub max_iterations: usize,
    /// Stop when the largest curvature change of a sweep times the rod length is below
    /// this (dimensionless, default 1e-13).
    pub tolerance: f64,
}

impl Default for CcSettings {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            tolerance: 1e-13,
        }
    }
}

impl CcSettings {
    /// Check every field.
    pub fn validate(&self) -> Result<(), LadderError> {
        if self.max_iterations == 0 {
            return Err(LadderError::Setting {
                field: "cc.max_iterations".into(),
                value: 0.0,
                why: "at least 1".into(),
            });
        }
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(LadderError::Setting {
                field: "cc.tolerance".into(),
                value: self.tolerance,
                why: "finite and > 0".into(),
            });
        }
        Ok(())
    }
}

/// A resolved point load: section, force/torque as given, frame, payload weight.
#[derive(Clone, Copy, Debug)]
struct Point {
    section: usize,
    force: Vector3<f64>,
    torque: Vector3<f64>,
    body: bool,
    weight: Vector3<f64>,
}

/// Constant curvature per section (module docs).
pub struct ConstantCurvature {
    robot: Robot,
    settings: CcSettings,
    /// Local hole vector of cable `j` on section `k`'s disks, `[j][k]`.
    holes: Vec<Vec<Vector3<f64>>>,
    /// Base-plate holes (world).
    base_holes: Vec<Vector3<f64>>,
    u: Vec<Vector3<f64>>,
    u_new: Vec<Vector3<f64>>,
    f: Vec<Vector3<f64>>,
    anderson: Anderson,
    tensions: Vec<f64>,
    /// Start pose of each section; the last entry is the tip.
    starts: Vec<Pose>,
    guides: Vec<Pose>,
    hole_pts: Vec<Vec<Vector3<f64>>>,
    lengths: Vec<f64>,
    points: Vec<Point>,
    ends: Vec<Pose>,
    report: LadderReport,
}

impl ConstantCurvature {
    /// Build for `robot`.
    pub fn new(robot: Robot, settings: CcSettings) -> Result<Self, LadderError> {
        settings.validate()?;
        let ns = robot.sections().len();
        let holes = robot
            .cables()
            .iter()
            .map(|c| {
                (0..ns)
                    .map(|k| {
                        // the cable's hole on this section's first disk; a section without
                        // disks uses the nearest disk before it (or the base plate)
                        let on = c.route.iter().find(|&&g| robot.guides()[g].section == k);
                        let before = c
                            .route
                            .iter()
                            .rev()
                            .find(|&&g| robot.guides()[g].section < k);
                        match on.or(before) {
                            Some(&g) => robot.guides()[g].holes[c.hole],
                            None => c.base_hole,
                        }
                    })
                    .collect()
            })
            .collect();
        let base_holes = robot
            .cables()
            .iter()
            .map(|c| robot.base_position() + robot.base_rotation() * c.base_hole)
            .collect();
        let hole_pts = robot
            .cables()
            .iter()
            .map(|c| vec![Vector3::zeros(); c.route.len()])
            .collect();
        let base = base_pose(&robot);
        Ok(Self {
            u: robot.sections().iter().map(|s| s.precurvature).collect(),
            u_new: vec![Vector3::zeros(); ns],
            f: vec![Vector3::zeros(); ns],
            anderson: Anderson::new(3, ns),
            tensions: vec![0.0; robot.cables().len()],
            starts: vec![base; ns + 1],
            ends: vec![base; ns],
            guides: vec![base; robot.guides().len()],
            lengths: vec![0.0; robot.cables().len()],
            hole_pts,
            holes,
            base_holes,
            points: Vec::new(),
            report: LadderReport {
                status: SolveStatus::NonFinite,
                iterations: 0,
                residual: f64::INFINITY,
            },
            robot,
            settings,
        })
    }

    /// Curvature of each section (1/m, local) from the last solve.
    pub fn curvatures(&self) -> &[Vector3<f64>] {
        &self.u
    }

    /// One Gauss-Seidel sweep `u -> u_new` (sections before `k` already updated when
    /// section `k` is computed); returns the largest change times `L`.
    fn sweep(&mut self) -> f64 {
        let secs = self.robot.sections();
        let ns = secs.len();
        let mut pose = base_pose(&self.robot);
        let mut change: f64 = 0.0;
        for k in 0..ns {
            self.starts[k] = pose;
            let rt = pose.rotation.transpose();
            // cable moments, local: T (e3 x d)
            let mut m_loc = Vector3::zeros();
            for (j, c) in self.robot.cables().iter().enumerate() {
                let t = self.tensions.get(j).copied().unwrap_or(0.0);
                if t > 0.0 && c.end_section >= k {
                    m_loc += Vector3::z().cross(&self.holes[j][k]) * t;
                }
            }
            // loads at section ends j >= k, on the current shape (old u for j >= k)
            let mid = arc_pose(&pose, &self.u[k], 0.5 * secs[k].length);
            let mut q = pose;
            for (j, sec) in secs.iter().enumerate().skip(k) {
                q = arc_pose(&q, &self.u[j], sec.length);
                self.ends[j] = q;
            }
            let mut m_w = Vector3::zeros();
            for p in self.points.iter().filter(|p| p.section >= k) {
                let e = &self.ends[p.section];
                let (f, tau) = if p.body {
                    (e.rotation * p.force, e.rotation * p.torque)
                } else {
                    (p.force, p.torque)
                };
                m_w += tau + (e.position - mid.position).cross(&(f + p.weight));
            }
            m_loc += rt * m_w;
            let stiff = &secs[k].stiffness.bend_twist;
            let u_new = m_loc.component_div(stiff) + secs[k].precurvature;
            change = change.max((u_new - self.u[k]).amax());
            self.u_new[k] = u_new;
            pose = arc_pose(&pose, &u_new, secs[k].length);
        }
        self.starts[ns] = pose;
        change * self.robot.length()
    }

    fn finish(&mut self) {
        let secs = self.robot.sections();
        for (g, guide) in self.robot.guides().iter().enumerate() {
            let k = guide.section;
            self.guides[g] = arc_pose(&self.starts[k], &self.u[k], guide.s - secs[k].start);
        }
        for (j, c) in self.robot.cables().iter().enumerate() {
            for (i, &g) in c.route.iter().enumerate() {
                let pose = &self.guides[g];
                self.hole_pts[j][i] =
                    pose.position + pose.rotation * self.robot.guides()[g].holes[c.hole];
            }
            self.lengths[j] = path_length(&self.base_holes[j], &self.hole_pts[j]);
        }
    }
}

fn base_pose(robot: &Robot) -> Pose {
    Pose {
        position: *robot.base_position(),
        rotation: *robot.base_rotation(),
    }
}

impl ForwardModel for ConstantCurvature {
    fn solve(&mut self, loads: &Loads, start: Start) -> Result<LadderReport, LadderError> {
        check_loads(&self.robot, loads)?;
        let g = Vector3::from(loads.gravity_m_s2);
        for (j, t) in self.tensions.iter_mut().enumerate() {
            *t = loads.tension(j);
        }
        self.points.clear();
        self.points.extend(loads.point.iter().map(|p| Point {
            section: p.section,
            force: Vector3::from(p.force_n),
            torque: Vector3::from(p.torque_nm),
            body: p.frame == Frame::Body,
            weight: g * p.mass_kg,
        }));
        let shape_dependent = self.points.iter().any(|p| {
            p.force != Vector3::zeros()
                || p.weight != Vector3::zeros()
                || (p.body && p.torque != Vector3::zeros())
        });
        if start == Start::Cold || !self.report.status.is_converged() {
            for (u, s) in self.u.iter_mut().zip(self.robot.sections()) {
                *u = s.precurvature;
            }
        }
        let mut status = SolveStatus::MaxIterations;
        let mut iterations = 0;
        let mut residual = f64::INFINITY;
        let mut w: f64 = 1.0;
        let mut last = f64::INFINITY;
        self.anderson.reset();
        while iterations < self.settings.max_iterations {
            residual = self.sweep();
            iterations += 1;
            if !residual.is_finite() {
                status = SolveStatus::NonFinite;
                break;
            }
            if !shape_dependent || residual <= self.settings.tolerance {
                self.u.copy_from_slice(&self.u_new);
                status = SolveStatus::Converged;
                break;
            }
            if residual > last {
                // the plain fixed point oscillates under heavy forces: damp it
                w = (w * 0.5).max(1.0 / 256.0);
                self.anderson.reset();
            }
            last = residual;
            for (f, (un, u)) in self.f.iter_mut().zip(self.u_new.iter().zip(&self.u)) {
                *f = un - u;
            }
            self.anderson.step(&mut self.u, &self.f, w);
        }
        if status != SolveStatus::Converged {
            // poses below come from the last iterate
            self.sweep();
            self.u.copy_from_slice(&self.u_new);
        }
        if !shape_dependent {
            residual = 0.0;
        }
        self.finish();
        self.report = LadderReport {
            status,
            iterations,
            residual,
        };
        Ok(self.report)
    }

    fn tip_position(&self) -> Vector3<f64> {
        self.starts[self.starts.len() - 1].position
    }

    fn cable_lengths_into(&self, out: &mut [f64]) {
        for (o, l) in out.iter_mut().zip(&self.lengths) {
            *o = *l;
        }
    }

    fn output(&mut self) -> LadderOutput {
        LadderOutput {
            report: self.report,
            section_tips: self.starts[1..].to_vec(),
            guides: self.guides.clone(),
            cable_lengths: self.lengths.clone(),
        }
    }

    fn robot(&self) -> &Robot {
        &self.robot
    }
}
