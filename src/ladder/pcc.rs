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
//! A tendon on a straight continuous path at offset `d` (`routing = "continuous"`)
//! adds, at each midpoint of a piece it spans, its exact free-body term: cut there,
//! the distal part's tendon pulls back along its own tangent `t` at its point
//! `r + R d`, so the local moment gains `d x (-T t)` with `t = unit(e3 + u x d)`
//! (Rucker & Webster 2011's frictionless tendon; `T e3 x d` without torsion, as for a
//! cable through dense disks); nothing is carried along the walk, since the tendon's
//! termination force is internal to rod plus tendon. Its length is
//! `sum h |e3 + u x d|` over the pieces it spans.
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

mod layout;
mod sweep;

use super::anderson::{Anderson, MAX_DEPTH};
use super::arc::PoseT;
use super::kinematics::TendonKinematics;
use super::sens::{seed_theta, seed_u, Implicit, LoadsT, D6, W};
use super::{add_params, ForwardModel, LadderError, LadderOutput, LadderReport};
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
#[derive(Clone)]
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
    /// Offset of each cable on a straight continuous path (`None`: disk-routed).
    straight: Vec<Option<Vector3<f64>>>,
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
    /// Length of each straight continuous path (zero for disk-routed cables).
    continuous: Vec<T>,
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
            continuous: vec![T::zero(); l.robot.cables().len()],
            loads: LoadsT::new(l.robot.cables().len()),
        }
    }
}

/// Piecewise constant curvature (module docs).
#[derive(Clone)]
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
        super::reject_continuous(&robot)?;
        let layout = Layout::new(robot, &settings);
        let np = layout.pieces.len();
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
            *l =
                path_length(&self.layout.base_holes[j], &self.b.hole_pts[j]) + self.b.continuous[j];
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
        // allocation-free unless a check fails (`Loads::validate`)
        loads.validate(&self.layout.robot)?;
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
            *l =
                path_length(&self.layout.base_holes[j], &self.b.hole_pts[j]) + self.b.continuous[j];
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
            let (holes, cont) = (&bd.hole_pts, &bd.continuous);
            imp.record_sweep(c0, &bd.u_new, &self.layout.base_holes, holes, cont);
        }
        for (l, v) in lengths.iter_mut().zip(&self.lengths) {
            *l = *v;
        }
        imp.solve(out)
    }
}

impl ForwardModel for PiecewiseConstantCurvature {
    fn solve(&mut self, loads: &Loads, start: Start) -> Result<LadderReport, LadderError> {
        // allocation-free unless a check fails (`Loads::validate`)
        loads.validate(&self.layout.robot)?;
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
