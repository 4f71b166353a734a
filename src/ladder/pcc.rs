//! Rung (b): piecewise constant curvature, solved by a damped fixed point on the shape.
//!
//! Pieces: the rod is cut at section ends, guide-disk centres (and disk edges for the
//! accurate guide-mass model) and then evenly, so that no piece is longer than
//! `L_k / pieces_per_section` of its section `k`. Each piece is an arc ([`arc_pose`]).
//!
//! One sweep, exactly:
//! 1. pose every piece boundary, midpoint and three-quarter point from the current
//!    curvatures (base to tip), and every cable hole `p = r + R d` (thesis 3.8.1);
//! 2. walk tip to base carrying the internal force and moment `(n, m)` (what the distal
//!    part exerts, thesis 2.7): at a boundary add its loads (point loads at section
//!    ends, thesis 3.5: `n- = n+ + F`, `m- = m+ + tau`; point guide masses; the cable
//!    pulls on each disk along both chords, `T (unit(prev - p) + unit(next - p))` applied
//!    at the hole `p`, as in the full model), then cross the piece: `n` gains the
//!    piece's weight `f h` (`f = rho_eff A g`), `m` is carried by the moment-transport
//!    law `m(a) = m(b) + (r(b) - r(a)) x n(b) + (c - r(a)) x f h` (thesis eq. 2.11
//!    integrated, `c` the Simpson centroid of the piece's arc);
//! 3. each piece's new curvature is that of the internal moment at its **midpoint**
//!    (not its start: the midpoint makes the discretisation error O(h^2)),
//!    `u = C^-1 R_mid^T m_mid + u*` (thesis eq. 2.12 inverted), with `m_mid` from the same
//!    transport law applied to the distal half of the piece;
//! 4. update `u` by Anderson mixing of the last `anderson_depth` sweeps with mixing
//!    parameter `w` (plain relaxation `u <- u + w (u_new - u)` when the depth is 0);
//!    `w` starts at 1 and is halved (down to 1/256), and the history dropped, whenever
//!    the largest change grows from one sweep to the next (the plain map oscillates and
//!    diverges for heavy loads).
//!
//! Converged when `max |u_new - u| L < tolerance`. A cold start under a load that
//! bends the straight rod by more than 2 rad in its first sweep ramps the loads
//! (gravity, point loads, tensions together) up in steps of about 2 rad of bending,
//! each step warm-started from the last and solved only to 1e-4 (load continuation). Gravity on rod and disks, point
//! loads, body-frame loads and cable chords are all modelled; shear and extension are
//! not (a Kirchhoff rod discretised by the midpoint rule).
//!
//! Steps 1-3 are generic over [`Real`]: the solver runs them over `f64`, and
//! [`PiecewiseConstantCurvature::length_sensitivities`] over dual numbers to
//! differentiate the converged fixed point implicitly (module `sens`).

use super::anderson::{Anderson, MAX_DEPTH};
use super::arc::{arc_pose_t, PoseT};
use super::kinematics::TendonKinematics;
use super::sens::{seed_theta, seed_u, unit_t, Implicit, LoadsT, D6, W};
use super::{add_params, check_loads, ForwardModel, LadderError, LadderOutput, LadderReport};
use crate::cables::path_length;
use crate::loads::Loads;
use crate::math::Real;
use crate::robot::Robot;
use crate::settings::GuideMass;
use crate::statics::{ParamSite, Pose, SolveStatus, Start};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Settings of the piecewise-constant-curvature rung.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PccSettings {
    /// Minimum number of pieces per section; pieces also break at every disk
    /// (default 8).
    pub pieces_per_section: usize,
    /// Guide-mass model, as for the rod rungs (default `average`).
    pub guide_mass: GuideMass,
    /// Anderson acceleration depth (0 = plain damped fixed point; default 3,
    /// at most 5).
    pub anderson_depth: usize,
    /// Sweep limit (default 2000).
    pub max_iterations: usize,
    /// Convergence: largest curvature change of a sweep times the rod length
    /// (dimensionless, default 1e-12).
    pub tolerance: f64,
}

impl Default for PccSettings {
    fn default() -> Self {
        Self {
            pieces_per_section: 8,
            guide_mass: GuideMass::Average,
            anderson_depth: 3,
            max_iterations: 2000,
            tolerance: 1e-12,
        }
    }
}

impl PccSettings {
    /// Check every field.
    pub fn validate(&self) -> Result<(), LadderError> {
        let bad = |field: &str, value: f64, why: &str| LadderError::Setting {
            field: format!("pcc.{field}"),
            value,
            why: why.into(),
        };
        if self.pieces_per_section == 0 {
            return Err(bad("pieces_per_section", 0.0, "at least 1"));
        }
        if self.max_iterations == 0 {
            return Err(bad("max_iterations", 0.0, "at least 1"));
        }
        if self.anderson_depth > MAX_DEPTH {
            return Err(bad(
                "anderson_depth",
                self.anderson_depth as f64,
                "at most 5",
            ));
        }
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(bad("tolerance", self.tolerance, "finite and > 0"));
        }
        Ok(())
    }
}

/// Cold starts whose first sweep bends the rod by more than this (rad) ramp the loads
/// up in steps of about this bending angle (load continuation): the fixed point from
/// the straight rod can otherwise land on an unstable equilibrium (a heavy tip mass
/// curling the rod up over its clamp).
const CONTINUATION_ANGLE: f64 = 2.0;
/// Most continuation steps.
const MAX_CONTINUATION: usize = 32;

/// Something that acts at a piece boundary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mark {
    Guide(usize),
    SectionEnd(usize),
}

#[derive(Clone, Copy, Debug)]
struct Piece {
    h: f64,
    section: usize,
    /// Linear density incl. distributed guide mass (kg/m).
    lambda: f64,
}

/// What never changes: the robot, its pieces and where loads act.
struct Layout {
    robot: Robot,
    guide_mass: GuideMass,
    pieces: Vec<Piece>,
    /// Marks at boundary `i` (boundary 0 is the base): `marks[mark_at[i]..mark_at[i+1]]`.
    marks: Vec<Mark>,
    mark_at: Vec<usize>,
    /// Boundary index of each guide.
    guide_boundary: Vec<usize>,
    /// `(cable, route position)` of each guide.
    guide_cables: Vec<Vec<(usize, usize)>>,
    base_holes: Vec<Vector3<f64>>,
    section_ends: Vec<usize>,
}

/// The state a sweep reads and writes, over `f64` (solver) or dual numbers
/// (sensitivities).
#[derive(Clone, Debug)]
struct Buf<T: Real> {
    u: Vec<Vector3<T>>,
    u_new: Vec<Vector3<T>>,
    bound: Vec<PoseT<T>>,
    mid: Vec<PoseT<T>>,
    quarter: Vec<Vector3<T>>,
    hole_pts: Vec<Vec<Vector3<T>>>,
    loads: LoadsT<T>,
}

impl<T: Real> Buf<T> {
    fn new(l: &Layout) -> Self {
        let np = l.pieces.len();
        let base = PoseT::constant(&Pose {
            position: *l.robot.base_position(),
            rotation: *l.robot.base_rotation(),
        });
        Self {
            u: l.pieces
                .iter()
                .map(|p| l.robot.sections()[p.section].precurvature.map(T::cst))
                .collect(),
            u_new: vec![Vector3::zeros(); np],
            bound: vec![base; np + 1],
            mid: vec![base; np],
            quarter: vec![Vector3::zeros(); np],
            hole_pts: l
                .robot
                .cables()
                .iter()
                .map(|c| vec![Vector3::zeros(); c.route.len()])
                .collect(),
            loads: LoadsT::new(l.robot.cables().len()),
        }
    }
}

/// Piecewise constant curvature (module docs).
pub struct PiecewiseConstantCurvature {
    layout: Layout,
    settings: PccSettings,
    b: Buf<f64>,
    f: Vec<Vector3<f64>>,
    anderson: Anderson,
    lengths: Vec<f64>,
    report: LadderReport,
    /// Sensitivity buffers, built by the first
    /// [`PiecewiseConstantCurvature::length_sensitivities`].
    sens: Option<(Buf<D6>, Implicit)>,
    /// Readings -> arcs, built by the first
    /// [`PiecewiseConstantCurvature::solve_readings`].
    kin: Option<TendonKinematics>,
}

impl PiecewiseConstantCurvature {
    /// Build the pieces for `robot`.
    pub fn new(robot: Robot, settings: PccSettings) -> Result<Self, LadderError> {
        settings.validate()?;
        let length = robot.length();
        let tol = 1e-12 * length;
        let mut cuts: Vec<(f64, Option<Mark>)> = Vec::new();
        for (k, sec) in robot.sections().iter().enumerate() {
            cuts.push((sec.end(), Some(Mark::SectionEnd(k))));
        }
        for (g, guide) in robot.guides().iter().enumerate() {
            cuts.push((guide.s, Some(Mark::Guide(g))));
            if settings.guide_mass == GuideMass::Accurate && guide.thickness > 0.0 {
                cuts.push((guide.s - guide.thickness / 2.0, None));
                cuts.push((guide.s + guide.thickness / 2.0, None));
            }
        }
        cuts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut pieces = Vec::new();
        let mut guide_boundary = vec![0; robot.guides().len()];
        let mut section_ends = vec![0; robot.sections().len()];
        let mut s0 = 0.0;
        let mut i = 0;
        // marks at s = 0 (a disk at the clamp) sit on boundary 0
        while i < cuts.len() && cuts[i].0 <= tol {
            i += 1;
        }
        while i < cuts.len() {
            let s1 = cuts[i].0.min(length);
            let j0 = i;
            while i < cuts.len() && cuts[i].0 - s1 <= tol {
                i += 1;
            }
            let k = robot.section_at(0.5 * (s0 + s1));
            let sec = &robot.sections()[k];
            let n = ((settings.pieces_per_section as f64) * (s1 - s0) / sec.length)
                .ceil()
                .max(1.0) as usize;
            let mid = 0.5 * (s0 + s1);
            let mut lambda = sec.stiffness.linear_density;
            let gs = &robot.guides()[sec.guides.clone()];
            match settings.guide_mass {
                GuideMass::Average => lambda += gs.iter().map(|g| g.mass).sum::<f64>() / sec.length,
                GuideMass::Accurate => {
                    for g in gs {
                        if g.thickness > 0.0 && (mid - g.s).abs() < g.thickness / 2.0 {
                            lambda += g.mass / g.thickness;
                        }
                    }
                }
                GuideMass::None | GuideMass::Point => {}
            }
            for _ in 0..n {
                pieces.push(Piece {
                    h: (s1 - s0) / n as f64,
                    section: k,
                    lambda,
                });
            }
            // the interval's marks sit on its last boundary
            for c in &cuts[j0..i] {
                match c.1 {
                    Some(Mark::Guide(g)) => guide_boundary[g] = pieces.len(),
                    Some(Mark::SectionEnd(k)) => section_ends[k] = pieces.len(),
                    None => {}
                }
            }
            s0 = s1;
        }
        // marks of boundary b are `ordered[at[b]..at[b + 1]]` (a counting sort)
        let nb = pieces.len() + 1;
        let mut at = vec![0usize; nb + 1];
        for &b in guide_boundary.iter().chain(&section_ends) {
            at[b + 1] += 1;
        }
        for b in 0..nb {
            at[b + 1] += at[b];
        }
        let mut fill = at.clone();
        let mut ordered = vec![Mark::SectionEnd(0); at[nb]];
        for (g, &b) in guide_boundary.iter().enumerate() {
            ordered[fill[b]] = Mark::Guide(g);
            fill[b] += 1;
        }
        for (k, &b) in section_ends.iter().enumerate() {
            ordered[fill[b]] = Mark::SectionEnd(k);
            fill[b] += 1;
        }
        let mut guide_cables = vec![Vec::new(); robot.guides().len()];
        for (j, c) in robot.cables().iter().enumerate() {
            for (k, &g) in c.route.iter().enumerate() {
                guide_cables[g].push((j, k));
            }
        }
        let np = pieces.len();
        let layout = Layout {
            base_holes: robot
                .cables()
                .iter()
                .map(|c| robot.base_position() + robot.base_rotation() * c.base_hole)
                .collect(),
            guide_mass: settings.guide_mass,
            pieces,
            marks: ordered,
            mark_at: at,
            guide_boundary,
            guide_cables,
            section_ends,
            robot,
        };
        Ok(Self {
            b: Buf::new(&layout),
            f: vec![Vector3::zeros(); np],
            anderson: Anderson::new(settings.anderson_depth, np),
            lengths: vec![0.0; layout.robot.cables().len()],
            report: LadderReport {
                status: SolveStatus::NonFinite,
                iterations: 0,
                residual: f64::INFINITY,
            },
            sens: None,
            kin: None,
            layout,
            settings,
        })
    }

    /// Damped, Anderson-accelerated fixed point at load scale `lam` from the current
    /// curvatures, at most `budget` sweeps (counted into `iterations`).
    fn iterate(
        &mut self,
        lam: f64,
        budget: usize,
        tol: f64,
        iterations: &mut usize,
    ) -> (SolveStatus, f64) {
        self.anderson.reset();
        let mut w: f64 = 1.0;
        let mut last = f64::INFINITY;
        let mut residual = f64::INFINITY;
        for _ in 0..budget {
            self.layout.kinematics(&mut self.b);
            residual = self.layout.moments(&mut self.b, lam);
            *iterations += 1;
            if !residual.is_finite() {
                return (SolveStatus::NonFinite, residual);
            }
            if residual <= tol {
                return (SolveStatus::Converged, residual);
            }
            if residual > last {
                w = (w * 0.5).max(1.0 / 256.0);
                self.anderson.reset();
            }
            last = residual;
            for (f, (un, u)) in self.f.iter_mut().zip(self.b.u_new.iter().zip(&self.b.u)) {
                *f = un - u;
            }
            if self.settings.anderson_depth > 0 {
                self.anderson.step(&mut self.b.u, &self.f, w);
            } else {
                for (u, f) in self.b.u.iter_mut().zip(&self.f) {
                    *u += f * w;
                }
            }
        }
        (SolveStatus::MaxIterations, residual)
    }

    /// Number of pieces.
    pub fn pieces(&self) -> usize {
        self.layout.pieces.len()
    }

    fn reset(&mut self) {
        for (u, p) in self.b.u.iter_mut().zip(&self.layout.pieces) {
            *u = self.layout.robot.sections()[p.section].precurvature;
        }
    }

    /// Displacement actuation by the constant-curvature kinematics per section
    /// (module `kinematics`; the proximal sections' path change of a distal tendon is
    /// subtracted from its reading): every piece of section `k` takes section `k`'s
    /// arc. Pure kinematics has nothing to say below a section, so the shape equals
    /// [`ConstantCurvature::solve_readings`](super::ConstantCurvature::solve_readings)'s;
    /// the pieces only resample it. Errors as there.
    pub fn solve_readings(&mut self, readings_m: &[f64]) -> Result<LadderReport, LadderError> {
        let mut kin = match self.kin.take() {
            Some(k) => k,
            None => TendonKinematics::new(&self.layout.robot)?,
        };
        let solved = kin.solve(readings_m);
        let kin = self.kin.insert(kin);
        solved?;
        for (u, p) in self.b.u.iter_mut().zip(&self.layout.pieces) {
            *u = kin.curvature(p.section);
        }
        self.layout.kinematics(&mut self.b);
        for (j, l) in self.lengths.iter_mut().enumerate() {
            *l = path_length(&self.layout.base_holes[j], &self.b.hole_pts[j]);
        }
        self.report = LadderReport {
            status: SolveStatus::Converged,
            iterations: 0,
            residual: 0.0,
        };
        Ok(self.report)
    }

    /// The tendon kinematics of the last
    /// [`PiecewiseConstantCurvature::solve_readings`]; `None` before the first.
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
        check_loads(&self.layout.robot, loads)?;
        self.b.loads.set(loads);
        add_params(&mut self.b.loads, params, theta)?;
        Ok(self.run(start))
    }

    /// The solve proper, on the loads already in `self.b.loads`.
    fn run(&mut self, start: Start) -> LadderReport {
        let cold = start == Start::Cold || !self.report.status.is_converged();
        let mut iterations = 0;
        let (mut status, mut residual) = (SolveStatus::MaxIterations, f64::INFINITY);
        let mut steps = 1;
        if cold {
            // the first sweep from the straight rod measures the load: its largest
            // bending angle per unit length times L
            self.reset();
            self.layout.kinematics(&mut self.b);
            let theta0 = self.layout.moments(&mut self.b, 1.0);
            self.reset();
            if theta0.is_finite() && theta0 > CONTINUATION_ANGLE {
                steps = ((theta0 / CONTINUATION_ANGLE).ceil() as usize).min(MAX_CONTINUATION);
            }
        }
        for k in 1..=steps {
            let lam = k as f64 / steps as f64;
            let budget =
                self.settings.max_iterations - iterations.min(self.settings.max_iterations);
            let tol = if k == steps {
                self.settings.tolerance
            } else {
                self.settings.tolerance.max(1e-4)
            };
            (status, residual) = self.iterate(lam, budget, tol, &mut iterations);
            if !status.is_converged() {
                break;
            }
        }
        if status == SolveStatus::NonFinite {
            self.reset();
        }
        self.layout.kinematics(&mut self.b);
        for (j, l) in self.lengths.iter_mut().enumerate() {
            *l = path_length(&self.layout.base_holes[j], &self.b.hole_pts[j]);
        }
        self.report = LadderReport {
            status,
            iterations,
            residual,
        };
        self.report
    }

    /// Exact sensitivities `d l_j / d theta_k` of the cable lengths to load
    /// parameters at the last solve's loads and shape, by implicit differentiation of
    /// the fixed point `u = Phi(u, theta)` of steps 1-3 (module `sens`): row-major
    /// `c x p` into `out`, the lengths into `lengths`. Force and torque sites must be
    /// world-frame point loads. Costs `ceil((3 pieces + p) / 6)` dual sweeps and one
    /// LU of size `3 pieces`; allocates on the first call only. `false` when the last
    /// solve did not converge, a site is invalid, or `I - Phi_u` is singular.
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
            self.sens = Some((Buf::new(&self.layout), Implicit::new(n, p, c)));
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
            self.layout.kinematics(bd);
            self.layout.moments(bd, 1.0);
            imp.record_sweep(c0, &bd.u_new, &self.layout.base_holes, &bd.hole_pts);
        }
        for (l, v) in lengths.iter_mut().zip(&self.lengths) {
            *l = *v;
        }
        imp.solve(out)
    }
}

impl Layout {
    /// Step 1 of a sweep: poses and holes from `b.u`.
    fn kinematics<T: Real>(&self, b: &mut Buf<T>) {
        for (i, p) in self.pieces.iter().enumerate() {
            let s = b.bound[i];
            b.mid[i] = arc_pose_t(&s, &b.u[i], 0.5 * p.h);
            b.quarter[i] = arc_pose_t(&s, &b.u[i], 0.75 * p.h).position;
            b.bound[i + 1] = arc_pose_t(&s, &b.u[i], p.h);
        }
        for (j, c) in self.robot.cables().iter().enumerate() {
            for (k, &g) in c.route.iter().enumerate() {
                let pose = &b.bound[self.guide_boundary[g]];
                let hole = c.hole_local[k].map(T::cst);
                b.hole_pts[j][k] = pose.position + pose.rotation * hole;
            }
        }
    }

    /// Steps 2-3: new curvatures into `b.u_new` at load scale `lam`; returns the
    /// largest change times `L`.
    fn moments<T: Real>(&self, b: &mut Buf<T>, lam: f64) -> f64 {
        let g = b.loads.gravity * lam;
        let gt = g.map(T::cst);
        let secs = self.robot.sections();
        let mut n = Vector3::<T>::zeros();
        let mut m = Vector3::<T>::zeros();
        let mut change: f64 = 0.0;
        for i in (0..self.pieces.len()).rev() {
            let bi = i + 1;
            let rb = b.bound[bi].position;
            // loads at boundary bi (distal end of piece i); m is about rb
            for mark in &self.marks[self.mark_at[bi]..self.mark_at[bi + 1]] {
                match *mark {
                    Mark::SectionEnd(k) => {
                        for p in b.loads.points.iter().filter(|p| p.section == k) {
                            let rot = &b.bound[bi].rotation;
                            let (f, t) = if p.body {
                                (rot * p.force, rot * p.torque)
                            } else {
                                (p.force, p.torque)
                            };
                            n += f.map(|x| x.scale(lam)) + gt * p.mass;
                            m += t.map(|x| x.scale(lam));
                        }
                    }
                    Mark::Guide(gi) => {
                        if self.guide_mass == GuideMass::Point {
                            n += (g * self.robot.guides()[gi].mass).map(T::cst);
                        }
                        for &(j, k) in &self.guide_cables[gi] {
                            let t = b.loads.tensions[j].scale(lam);
                            if t == T::zero() {
                                continue;
                            }
                            let pts = &b.hole_pts[j];
                            let p = pts[k];
                            let prev = if k == 0 {
                                self.base_holes[j].map(T::cst)
                            } else {
                                pts[k - 1]
                            };
                            let mut f = unit_t(prev - p) * t;
                            if k + 1 < pts.len() {
                                f += unit_t(pts[k + 1] - p) * t;
                            }
                            n += f;
                            m += (p - rb).cross(&f);
                        }
                    }
                }
            }
            let piece = self.pieces[i];
            let w = (g * (piece.lambda * piece.h)).map(T::cst);
            let ra = b.bound[i].position;
            let rm = b.mid[i].position;
            // midpoint moment: transport from rb plus the distal half's weight
            let c_half = (rm + b.quarter[i].map(|x| x.scale(4.0)) + rb).map(|x| x.scale(1.0 / 6.0));
            let m_mid = m + (rb - rm).cross(&n) + (c_half - rm).cross(&w.map(|x| x.scale(0.5)));
            let sec = &secs[piece.section];
            let ml = b.mid[i].rotation.transpose() * m_mid;
            let stiff = &sec.stiffness.bend_twist;
            let pre = &sec.precurvature;
            let u = Vector3::from_fn(|a, _| ml[a].scale(1.0 / stiff[a]) + T::cst(pre[a]));
            for a in 0..3 {
                change = change.max((u[a].re() - b.u[i][a].re()).abs());
            }
            b.u_new[i] = u;
            // transport (n, m) to the piece's start
            let c = (ra + rm.map(|x| x.scale(4.0)) + rb).map(|x| x.scale(1.0 / 6.0));
            m += (rb - ra).cross(&n) + (c - ra).cross(&w);
            n += w;
        }
        change * self.robot.length()
    }
}

impl ForwardModel for PiecewiseConstantCurvature {
    fn solve(&mut self, loads: &Loads, start: Start) -> Result<LadderReport, LadderError> {
        check_loads(&self.layout.robot, loads)?;
        self.b.loads.set(loads);
        Ok(self.run(start))
    }

    fn tip_position(&self) -> Vector3<f64> {
        self.b.bound[self.b.bound.len() - 1].position
    }

    fn cable_lengths_into(&self, out: &mut [f64]) {
        for (o, l) in out.iter_mut().zip(&self.lengths) {
            *o = *l;
        }
    }

    fn output(&mut self) -> LadderOutput {
        let l = &self.layout;
        LadderOutput {
            report: self.report,
            section_tips: l
                .section_ends
                .iter()
                .map(|&b| self.b.bound[b].pose())
                .collect(),
            guides: l
                .guide_boundary
                .iter()
                .map(|&b| self.b.bound[b].pose())
                .collect(),
            cable_lengths: self.lengths.clone(),
        }
    }

    fn robot(&self) -> &Robot {
        &self.layout.robot
    }
}
