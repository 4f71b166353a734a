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
//! A tendon on a straight continuous path at offset `d` (`routing = "continuous"`)
//! gives the same moment `T_j (e3 x d)` on every section it spans (the limit of dense
//! disks), and its length is the path's arc length over the arcs,
//! `sum_k L_k |e3 + u_k x d|` (`super::reject_continuous` says why helical and
//! tabulated paths are refused).
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
//!
//! The sweep is generic over [`Real`]: the solver runs it over `f64`, and
//! [`ConstantCurvature::length_sensitivities`] over dual numbers to differentiate the
//! fixed point implicitly (module `sens`), which is what the estimator uses.

use super::anderson::Anderson;
use super::arc::{arc_pose_t, PoseT};
use super::kinematics::TendonKinematics;
use super::sens::{seed_theta, seed_u, Implicit, LoadsT, D6, W};
use super::{add_params, ForwardModel, LadderError, LadderOutput, LadderReport};
use crate::cables::path_length;
use crate::loads::Loads;
use crate::math::Real;
use crate::robot::Robot;
use crate::statics::{ParamSite, Pose, SolveStatus, Start};
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

/// What never changes: the robot and its cable geometry.
#[derive(Clone)]
struct Layout {
    robot: Robot,
    /// `e3 x d_jk`: moment arm (local) of cable `j` on section `k`, `[j][k]`.
    arms: Vec<Vec<Vector3<f64>>>,
    /// Base-plate holes (world).
    base_holes: Vec<Vector3<f64>>,
    /// Offset of each cable on a straight continuous path (`None`: disk-routed).
    straight: Vec<Option<Vector3<f64>>>,
}

/// The state a sweep reads and writes, over `f64` (solver) or dual numbers
/// (sensitivities).
#[derive(Clone, Debug)]
struct Buf<T: Real> {
    u: Vec<Vector3<T>>,
    u_new: Vec<Vector3<T>>,
    /// Start pose of each section; the last entry is the tip.
    starts: Vec<PoseT<T>>,
    ends: Vec<PoseT<T>>,
    guides: Vec<PoseT<T>>,
    hole_pts: Vec<Vec<Vector3<T>>>,
    /// Length of each straight continuous path (zero for disk-routed cables).
    continuous: Vec<T>,
    loads: LoadsT<T>,
}

impl<T: Real> Buf<T> {
    fn new(robot: &Robot) -> Self {
        let ns = robot.sections().len();
        let base = PoseT::constant(&base_pose(robot));
        Self {
            u: robot
                .sections()
                .iter()
                .map(|s| s.precurvature.map(T::cst))
                .collect(),
            u_new: vec![Vector3::zeros(); ns],
            starts: vec![base; ns + 1],
            ends: vec![base; ns],
            guides: vec![base; robot.guides().len()],
            hole_pts: robot
                .cables()
                .iter()
                .map(|c| vec![Vector3::zeros(); c.route.len()])
                .collect(),
            continuous: vec![T::zero(); robot.cables().len()],
            loads: LoadsT::new(robot.cables().len()),
        }
    }
}

impl Layout {
    /// One Gauss-Seidel sweep `u -> u_new` (sections before `k` already updated when
    /// section `k` is computed); returns the largest change times `L`.
    fn sweep<T: Real>(&self, b: &mut Buf<T>) -> f64 {
        let secs = self.robot.sections();
        let ns = secs.len();
        let mut pose = PoseT::constant(&base_pose(&self.robot));
        let g = b.loads.gravity;
        let mut change: f64 = 0.0;
        for k in 0..ns {
            b.starts[k] = pose;
            let rt = pose.rotation.transpose();
            // cable moments, local: T (e3 x d)
            let mut m_loc = Vector3::<T>::zeros();
            for (j, c) in self.robot.cables().iter().enumerate() {
                let t = b.loads.tensions[j];
                if c.end_section >= k && t != T::zero() {
                    m_loc += self.arms[j][k].map(|a| t.scale(a));
                }
            }
            // loads at section ends j >= k, on the current shape (old u for j >= k)
            let mid = arc_pose_t(&pose, &b.u[k], 0.5 * secs[k].length);
            let mut q = pose;
            for (j, sec) in secs.iter().enumerate().skip(k) {
                q = arc_pose_t(&q, &b.u[j], sec.length);
                b.ends[j] = q;
            }
            let mut m_w = Vector3::<T>::zeros();
            for p in b.loads.points.iter().filter(|p| p.section >= k) {
                let e = &b.ends[p.section];
                let (f, tau) = if p.body {
                    (e.rotation * p.force, e.rotation * p.torque)
                } else {
                    (p.force, p.torque)
                };
                let weight = g.map(|x| p.mass.scale(x));
                m_w += tau + (e.position - mid.position).cross(&(f + weight));
            }
            m_loc += rt * m_w;
            let stiff = &secs[k].stiffness.bend_twist;
            let pre = &secs[k].precurvature;
            let u_new = Vector3::from_fn(|i, _| m_loc[i].scale(1.0 / stiff[i]) + T::cst(pre[i]));
            for i in 0..3 {
                change = change.max((u_new[i].re() - b.u[k][i].re()).abs());
            }
            b.u_new[k] = u_new;
            pose = arc_pose_t(&pose, &u_new, secs[k].length);
        }
        b.starts[ns] = pose;
        change * self.robot.length()
    }

    /// Section starts, guide poses and cable hole points from `u` alone.
    fn shape<T: Real>(&self, b: &mut Buf<T>) {
        let secs = self.robot.sections();
        let mut pose = PoseT::constant(&base_pose(&self.robot));
        for (k, sec) in secs.iter().enumerate() {
            b.starts[k] = pose;
            pose = arc_pose_t(&pose, &b.u[k], sec.length);
        }
        b.starts[secs.len()] = pose;
        for (g, guide) in self.robot.guides().iter().enumerate() {
            let k = guide.section;
            b.guides[g] = arc_pose_t(&b.starts[k], &b.u[k], guide.s - secs[k].start);
        }
        for (j, c) in self.robot.cables().iter().enumerate() {
            for (i, &g) in c.route.iter().enumerate() {
                let pose = &b.guides[g];
                let hole = c.hole_local[i].map(T::cst);
                b.hole_pts[j][i] = pose.position + pose.rotation * hole;
            }
        }
        for (j, d) in self.straight.iter().enumerate() {
            if let Some(d) = d {
                let end = self.robot.cables()[j].end_section;
                b.continuous[j] = (0..=end)
                    .map(|k| super::straight_arc_length(&b.u[k], d, secs[k].length))
                    .fold(T::zero(), |a, l| a + l);
            }
        }
    }
}

/// Constant curvature per section (module docs).
#[derive(Clone)]
pub struct ConstantCurvature {
    layout: Layout,
    settings: CcSettings,
    b: Buf<f64>,
    f: Vec<Vector3<f64>>,
    anderson: Anderson,
    lengths: Vec<f64>,
    report: LadderReport,
    /// Sensitivity buffers, built by the first [`ConstantCurvature::length_sensitivities`].
    sens: Option<(Buf<D6>, Implicit)>,
    /// Readings -> arcs, built by the first [`ConstantCurvature::solve_readings`].
    kin: Option<TendonKinematics>,
}

impl ConstantCurvature {
    /// Build for `robot`.
    pub fn new(robot: Robot, settings: CcSettings) -> Result<Self, LadderError> {
        settings.validate()?;
        super::reject_continuous(&robot)?;
        let ns = robot.sections().len();
        let arms = robot
            .cables()
            .iter()
            .map(|c| {
                (0..ns)
                    .map(|k| {
                        if let Some(crate::robot::TendonPath::Straight(d)) = c.path {
                            return Vector3::z().cross(&d);
                        }
                        // the cable's hole on this section's first disk; a section without
                        // disks uses the nearest disk before it (or the base plate)
                        let on = c.route.iter().position(|&g| robot.guides()[g].section == k);
                        let before = c.route.iter().rposition(|&g| robot.guides()[g].section < k);
                        let d = match on.or(before) {
                            Some(i) => c.hole_local[i],
                            None => c.base_hole,
                        };
                        Vector3::z().cross(&d)
                    })
                    .collect()
            })
            .collect();
        let base_holes = robot
            .cables()
            .iter()
            .map(|c| robot.base_position() + robot.base_rotation() * c.base_hole)
            .collect();
        let straight = super::straight_offsets(&robot);
        Ok(Self {
            b: Buf::new(&robot),
            f: vec![Vector3::zeros(); ns],
            anderson: Anderson::new(3, ns),
            lengths: vec![0.0; robot.cables().len()],
            report: LadderReport {
                status: SolveStatus::NonFinite,
                iterations: 0,
                residual: f64::INFINITY,
            },
            sens: None,
            kin: None,
            layout: Layout {
                robot,
                arms,
                base_holes,
                straight,
            },
            settings,
        })
    }

    /// Curvature of each section (1/m, local) from the last solve.
    pub fn curvatures(&self) -> &[Vector3<f64>] {
        &self.b.u
    }

    fn finish(&mut self) {
        self.layout.shape(&mut self.b);
        for (j, l) in self.lengths.iter_mut().enumerate() {
            *l =
                path_length(&self.layout.base_holes[j], &self.b.hole_pts[j]) + self.b.continuous[j];
        }
    }

    /// Displacement actuation: the classic constant-curvature kinematics of the
    /// tendons (module `kinematics`, Webster & Jones 2010): readings (m, one per
    /// displacement-driven tendon, positive = pulled) -> one arc per section in closed
    /// form, no loads. Every pose and cable length follows from the arcs as for
    /// [`ForwardModel::solve`]. An error when no tendon is displacement-driven or a
    /// reading is missing or not finite.
    pub fn solve_readings(&mut self, readings_m: &[f64]) -> Result<LadderReport, LadderError> {
        let mut kin = match self.kin.take() {
            Some(k) => k,
            None => TendonKinematics::new(&self.layout.robot)?,
        };
        let solved = kin.solve(readings_m);
        let kin = self.kin.insert(kin);
        solved?;
        for (k, u) in self.b.u.iter_mut().enumerate() {
            *u = kin.curvature(k);
        }
        self.finish();
        self.report = LadderReport {
            status: SolveStatus::Converged,
            iterations: 0,
            residual: 0.0,
        };
        Ok(self.report)
    }

    /// The tendon kinematics of the last [`ConstantCurvature::solve_readings`]
    /// (arcs, taut flags); `None` before the first.
    pub fn kinematics(&self) -> Option<&TendonKinematics> {
        self.kin.as_ref()
    }

    /// [`ForwardModel::solve`] for `loads` plus `theta_k` at `params[k]` (see
    /// [`super::Differentiable::solve_params`]).
    pub fn solve_params(
        &mut self,
        loads: &Loads,
        params: &[ParamSite],
        theta: &[f64],
        start: Start,
    ) -> Result<LadderReport, LadderError> {
        // allocation-free unless a check fails (`Loads::validate`)
        loads.validate(&self.layout.robot)?;
        self.b.loads.set(loads);
        add_params(&mut self.b.loads, params, theta)?;
        Ok(self.run(start))
    }

    /// The solve proper, on the loads already in `self.b.loads`.
    fn run(&mut self, start: Start) -> LadderReport {
        let g = self.b.loads.gravity;
        let shape_dependent = self.b.loads.points.iter().any(|p| {
            p.force != Vector3::zeros()
                || (p.mass != 0.0 && g != Vector3::zeros())
                || (p.body && p.torque != Vector3::zeros())
        });
        if start == Start::Cold || !self.report.status.is_converged() {
            for (u, s) in self.b.u.iter_mut().zip(self.layout.robot.sections()) {
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
            residual = self.layout.sweep(&mut self.b);
            iterations += 1;
            if !residual.is_finite() {
                status = SolveStatus::NonFinite;
                break;
            }
            if !shape_dependent || residual <= self.settings.tolerance {
                self.b.u.copy_from_slice(&self.b.u_new);
                status = SolveStatus::Converged;
                break;
            }
            if residual > last {
                // the plain fixed point oscillates under heavy forces: damp it
                w = (w * 0.5).max(1.0 / 256.0);
                self.anderson.reset();
            }
            last = residual;
            for (f, (un, u)) in self.f.iter_mut().zip(self.b.u_new.iter().zip(&self.b.u)) {
                *f = un - u;
            }
            self.anderson.step(&mut self.b.u, &self.f, w);
        }
        if status != SolveStatus::Converged {
            // poses below come from the last iterate
            self.layout.sweep(&mut self.b);
            self.b.u.copy_from_slice(&self.b.u_new);
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
        self.report
    }

    /// Exact sensitivities `d l_j / d theta_k` of the cable lengths to load
    /// parameters at the last solve's loads and shape, by implicit differentiation of
    /// the fixed point (module `sens`): row-major `c x p` into `out`, the lengths into
    /// `lengths`. Force and torque sites must be world-frame point loads. Allocates
    /// on the first call only. `false` when the last solve did not converge, a site
    /// is invalid, or `I - Phi_u` is singular.
    pub fn length_sensitivities(
        &mut self,
        params: &[ParamSite],
        out: &mut [f64],
        lengths: &mut [f64],
    ) -> bool {
        let (n, p, c) = (3 * self.b.u.len(), params.len(), self.lengths.len());
        if !self.report.status.is_converged() || out.len() < c * p {
            return false;
        }
        if !matches!(&self.sens, Some((_, imp)) if imp.p == p) {
            self.sens = Some((Buf::new(&self.layout.robot), Implicit::new(n, p, c)));
        }
        let Some((bd, imp)) = &mut self.sens else {
            return false;
        };
        let w = imp.width();
        for c0 in (0..w).step_by(W) {
            seed_u(&self.b.u, &mut bd.u, c0);
            if !seed_theta(&self.b.loads, &mut bd.loads, params, n, c0) {
                return false;
            }
            self.layout.sweep(bd);
            self.layout.shape(bd);
            let (holes, cont) = (&bd.hole_pts, &bd.continuous);
            imp.record_sweep(c0, &bd.u_new, &self.layout.base_holes, holes, cont);
        }
        for (l, v) in lengths.iter_mut().zip(&self.lengths) {
            *l = *v;
        }
        imp.solve(out)
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
        // allocation-free unless a check fails (`Loads::validate`)
        loads.validate(&self.layout.robot)?;
        self.b.loads.set(loads);
        Ok(self.run(start))
    }

    fn tip_position(&self) -> Vector3<f64> {
        self.b.starts[self.b.starts.len() - 1].position
    }

    fn cable_lengths_into(&self, out: &mut [f64]) {
        for (o, l) in out.iter_mut().zip(&self.lengths) {
            *o = *l;
        }
    }

    fn output(&mut self) -> LadderOutput {
        LadderOutput {
            report: self.report,
            section_tips: self.b.starts[1..].iter().map(PoseT::pose).collect(),
            guides: self.b.guides.iter().map(PoseT::pose).collect(),
            cable_lengths: self.lengths.clone(),
        }
    }

    fn robot(&self) -> &Robot {
        &self.layout.robot
    }
}
