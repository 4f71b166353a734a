//! What the estimator needs from its forward model, and the models that provide it.
//!
//! [`EstimationModel`] is the small interface the nested LM/GN/constrained/argmin code
//! of [`super::Estimator`] runs on: set the load parameters `theta`, solve (warm or
//! cold), read the cable lengths, get the exact length sensitivities `dl/dtheta`, and
//! the tip and section poses. Implemented by
//! * the shooting [`Workspace`] (rod rungs: Kirchhoff and Cosserat), sensitivities by
//!   implicit differentiation of the shooting problem
//!   ([`Workspace::length_sensitivities`]);
//! * [`RungModel`] over a [`Differentiable`] curvature rung (constant curvature,
//!   piecewise constant curvature), sensitivities by implicit differentiation of the
//!   rung's fixed point.
//!
//! The estimator is generic over the model ([`super::Estimator<M>`], default the
//! workspace) so that the hot loop has no dynamic dispatch; [`DynModel`] is the
//! run-time choice the command line uses.

use super::EstimateError;
use crate::error::ModelError;
use crate::ladder::{CurvatureModel, Differentiable, LadderError, Rung, RungJob};
use crate::loads::{Frame, Loads, PointLoad};
use crate::robot::Robot;
use crate::scene::estimate::{Axis, EstimateSpec, UnknownKind};
use crate::settings::SolverSettings;
use crate::statics::{ParamSite, Pose, SolveReport, SolveStatus, Start, Workspace};
use nalgebra::Vector3;

/// The forward model under an estimator (module docs).
///
/// The method names and signatures follow [`Workspace`]'s, which implements the trait
/// by forwarding. Hot methods (`set_theta`, `solve` warm, `cable_lengths_into`,
/// `length_sensitivities`) must not allocate after warm-up for the estimator tick
/// to be allocation-free.
pub trait EstimationModel: CloneModel {
    /// The robot.
    fn robot(&self) -> &Robot;
    /// The load parameters `theta` are added at (one per unknown).
    fn params(&self) -> &[ParamSite];
    /// Set `theta` (units per [`ParamSite`]).
    fn set_theta(&mut self, theta: &[f64]);
    /// Solve at the current `theta`; the status says whether the shape is usable.
    fn solve(&mut self, start: Start) -> SolveReport;
    /// Cable lengths of the last solve (m), indexed like `robot.cables`.
    fn cable_lengths_into(&self, out: &mut [f64]);
    /// Exact `dl/dtheta` at the last solve, row-major `c x p`, and the lengths;
    /// `false` when they do not exist there.
    fn length_sensitivities(&mut self, out: &mut [f64], lengths: &mut [f64]) -> bool;
    /// Tip position of the last solve (m).
    fn tip_position(&self) -> Vector3<f64>;
    /// Pose of each section's end of the last solve (allocates).
    fn section_tips(&mut self) -> Vec<Pose>;
    /// The shooting workspace, when this model is one.
    fn workspace_mut(&mut self) -> Option<&mut Workspace> {
        None
    }
    /// Measurement channels: what [`EstimationModel::cable_lengths_into`] and
    /// [`EstimationModel::length_sensitivities`] fill. Default: one per cable, its
    /// path length. A tendon model appends one per load cell
    /// ([`super::TendonModel`]).
    fn channels(&self) -> usize {
        self.robot().cables().len()
    }
    /// Whether channel `j` is an absolute tendon tension (N, reference 0, default
    /// noise [`super::EstimateSpec::load_cell_sigma_n`]) rather than a path length
    /// (m, measured as a change from the reference lengths). Default: never.
    fn is_tension_channel(&self, j: usize) -> bool {
        let _ = j;
        false
    }
    /// Whether channel `j`'s residual is left out at the last solve, given its
    /// measurement and noise (a slack tendon whose load cell agrees: no residual,
    /// [`super::TendonModel`]). Default: never.
    fn drops_residual(&self, j: usize, measured: f64, sigma: f64) -> bool {
        let _ = (j, measured, sigma);
        false
    }
}

impl EstimationModel for Workspace {
    fn robot(&self) -> &Robot {
        Workspace::robot(self)
    }
    fn params(&self) -> &[ParamSite] {
        Workspace::params(self)
    }
    fn set_theta(&mut self, theta: &[f64]) {
        Workspace::set_theta(self, theta)
    }
    fn solve(&mut self, start: Start) -> SolveReport {
        Workspace::solve(self, start)
    }
    fn cable_lengths_into(&self, out: &mut [f64]) {
        Workspace::cable_lengths_into(self, out)
    }
    fn length_sensitivities(&mut self, out: &mut [f64], lengths: &mut [f64]) -> bool {
        Workspace::length_sensitivities(self, out, lengths)
    }
    fn tip_position(&self) -> Vector3<f64> {
        Workspace::tip_position(self)
    }
    fn section_tips(&mut self) -> Vec<Pose> {
        self.solution().section_tips
    }
    fn workspace_mut(&mut self) -> Option<&mut Workspace> {
        Some(self)
    }
}

/// A model chosen at run time (`--model` on the command line).
pub type DynModel = Box<dyn EstimationModel>;

/// Cloning behind a `Box<dyn EstimationModel>`: a stream keeps a copy of its last good
/// estimator (with the model's whole warm state) to fall back to after a bad row.
/// Implemented for every `Clone` model.
pub trait CloneModel {
    /// A boxed copy of this model.
    fn clone_model(&self) -> DynModel;
}

impl<M: EstimationModel + Clone + 'static> CloneModel for M {
    fn clone_model(&self) -> DynModel {
        Box::new(self.clone())
    }
}

impl Clone for DynModel {
    fn clone(&self) -> Self {
        (**self).clone_model()
    }
}

impl EstimationModel for DynModel {
    fn robot(&self) -> &Robot {
        (**self).robot()
    }
    fn params(&self) -> &[ParamSite] {
        (**self).params()
    }
    fn set_theta(&mut self, theta: &[f64]) {
        (**self).set_theta(theta)
    }
    fn solve(&mut self, start: Start) -> SolveReport {
        (**self).solve(start)
    }
    fn cable_lengths_into(&self, out: &mut [f64]) {
        (**self).cable_lengths_into(out)
    }
    fn length_sensitivities(&mut self, out: &mut [f64], lengths: &mut [f64]) -> bool {
        (**self).length_sensitivities(out, lengths)
    }
    fn tip_position(&self) -> Vector3<f64> {
        (**self).tip_position()
    }
    fn section_tips(&mut self) -> Vec<Pose> {
        (**self).section_tips()
    }
    fn workspace_mut(&mut self) -> Option<&mut Workspace> {
        (**self).workspace_mut()
    }
    fn channels(&self) -> usize {
        (**self).channels()
    }
    fn is_tension_channel(&self, j: usize) -> bool {
        (**self).is_tension_channel(j)
    }
    fn drops_residual(&self, j: usize, measured: f64, sigma: f64) -> bool {
        (**self).drops_residual(j, measured, sigma)
    }
}

/// A curvature rung with load parameters: the scene's loads plus `theta` at the
/// parameter sites, solved by the rung (warm starts from its previous shape).
///
/// The rung adds `theta` to its resolved loads itself
/// ([`Differentiable::solve_params`], no allocation), without sign checks, as the
/// workspace does. Force and torque parameters are world-frame, as for the
/// workspace: a site on a body-frame point load gets its own world-frame point load
/// at the same section end.
#[derive(Clone)]
pub struct RungModel<F: Differentiable> {
    rung: F,
    base: Loads,
    theta: Vec<f64>,
    /// The caller's sites (what [`EstimationModel::params`] returns).
    params: Vec<ParamSite>,
    /// The same sites on `loads` (body-frame point loads redirected).
    sites: Vec<ParamSite>,
    report: SolveReport,
}

impl<F: Differentiable> RungModel<F> {
    /// `rung` under `loads` with parameters at `params` (validated: indices in range).
    pub fn new(rung: F, loads: Loads, params: &[ParamSite]) -> Result<Self, ModelError> {
        let robot = rung.robot();
        loads.validate(robot)?;
        let mut base = loads;
        let mut redirected: Vec<Option<usize>> = vec![None; base.point.len()];
        let mut sites = Vec::with_capacity(params.len());
        for (k, site) in params.iter().enumerate() {
            let field = || format!("estimate parameter {k}");
            let site = match *site {
                ParamSite::Tension { cable } => {
                    if cable >= robot.cables().len() {
                        return Err(ModelError::BadIndex {
                            field: field(),
                            index: cable,
                            count: robot.cables().len(),
                        });
                    }
                    *site
                }
                ParamSite::Force { point, axis } | ParamSite::Torque { point, axis } => {
                    if point >= redirected.len() {
                        return Err(ModelError::BadIndex {
                            field: field(),
                            index: point,
                            count: redirected.len(),
                        });
                    }
                    if axis > 2 {
                        return Err(ModelError::BadIndex {
                            field: format!("{} axis", field()),
                            index: axis,
                            count: 3,
                        });
                    }
                    let at = if base.point[point].frame == Frame::Body {
                        *redirected[point].get_or_insert_with(|| {
                            base.point.push(PointLoad {
                                section: base.point[point].section,
                                ..Default::default()
                            });
                            base.point.len() - 1
                        })
                    } else {
                        point
                    };
                    match site {
                        ParamSite::Force { .. } => ParamSite::Force { point: at, axis },
                        _ => ParamSite::Torque { point: at, axis },
                    }
                }
                ParamSite::Mass { point } => {
                    if point >= redirected.len() {
                        return Err(ModelError::BadIndex {
                            field: field(),
                            index: point,
                            count: redirected.len(),
                        });
                    }
                    *site
                }
            };
            sites.push(site);
        }
        Ok(Self {
            rung,
            theta: vec![0.0; params.len()],
            base,
            params: params.to_vec(),
            sites,
            report: SolveReport {
                status: SolveStatus::NonFinite,
                iterations: 0,
                residual: f64::INFINITY,
                // the curvature rungs report no tolerance of the rod's residual
                tolerance: f64::NAN,
                rhs_evals: 0,
                jacobian_evals: 0,
                continuation_steps: 0,
                unknowns: 0,
            },
        })
    }

    /// The rung.
    pub fn rung(&self) -> &F {
        &self.rung
    }

    /// The known loads `theta` adds to.
    pub fn loads(&self) -> &Loads {
        &self.base
    }
}

impl<F: Differentiable + Clone + 'static> EstimationModel for RungModel<F> {
    fn robot(&self) -> &Robot {
        self.rung.robot()
    }
    fn params(&self) -> &[ParamSite] {
        &self.params
    }
    fn set_theta(&mut self, theta: &[f64]) {
        for (t, v) in self.theta.iter_mut().zip(theta) {
            *t = *v;
        }
    }
    fn solve(&mut self, start: Start) -> SolveReport {
        let mut run = |start| {
            match self
                .rung
                .solve_params(&self.base, &self.sites, &self.theta, start)
            {
                Ok(r) => (r.status, r.iterations, r.residual),
                // sites are checked in `new`: not reached, but never a panic
                Err(_) => (SolveStatus::NonFinite, 0, f64::INFINITY),
            }
        };
        let (mut status, mut iterations, mut residual) = run(start);
        if start == Start::Warm && !status.is_converged() {
            // a long trial step can leave the fixed point's basin from the previous
            // shape: the cold start ramps the loads up (load continuation)
            let (s, i, r) = run(Start::Cold);
            (status, iterations, residual) = (s, iterations + i, r);
        }
        self.report = SolveReport {
            status,
            iterations,
            residual,
            ..self.report
        };
        self.report
    }
    fn cable_lengths_into(&self, out: &mut [f64]) {
        self.rung.cable_lengths_into(out)
    }
    fn length_sensitivities(&mut self, out: &mut [f64], lengths: &mut [f64]) -> bool {
        self.report.jacobian_evals += 1;
        self.rung.length_sensitivities(&self.sites, out, lengths)
    }
    fn tip_position(&self) -> Vector3<f64> {
        self.rung.tip_position()
    }
    fn section_tips(&mut self) -> Vec<Pose> {
        self.rung.output().section_tips
    }
}

/// The scene's loads with a point load at every section an unknown acts on (created
/// when absent) and the parameter site of each unknown.
pub(crate) fn sites(spec: &EstimateSpec, loads: Loads) -> (Loads, Vec<ParamSite>) {
    let mut loads = loads;
    let mut params = Vec::with_capacity(spec.unknowns.len());
    for u in &spec.unknowns {
        let site = match u.kind {
            UnknownKind::Tension => ParamSite::Tension {
                cable: u.cable.unwrap_or(0),
            },
            kind => {
                let section = u.section.unwrap_or(0);
                let point = match loads.point.iter().position(|p| p.section == section) {
                    Some(i) => i,
                    None => {
                        loads.point.push(PointLoad {
                            section,
                            ..Default::default()
                        });
                        loads.point.len() - 1
                    }
                };
                let axis = match u.axis {
                    Some(Axis::X) | None => 0,
                    Some(Axis::Y) => 1,
                    Some(Axis::Z) => 2,
                };
                match kind {
                    UnknownKind::Force => ParamSite::Force { point, axis },
                    UnknownKind::Torque => ParamSite::Torque { point, axis },
                    _ => ParamSite::Mass { point },
                }
            }
        };
        params.push(site);
    }
    (loads, params)
}

/// The forward model of `rung` for the unknowns of `spec` (validated).
pub(super) fn build(
    robot: Robot,
    loads: Loads,
    rung: &Rung,
    spec: &EstimateSpec,
) -> Result<DynModel, EstimateError> {
    spec.validate(&robot)?;
    loads.validate(&robot)?;
    let (loads, params) = sites(spec, loads);
    let job = Estimation {
        loads,
        params: &params,
    };
    rung.build_for(robot, job).map_err(from_ladder)
}

/// The estimator's job on a rung ([`Rung::build_for`]): a curvature rung under
/// [`RungModel`], a rod rung the shooting [`Workspace`] with the load parameters.
struct Estimation<'a> {
    loads: Loads,
    params: &'a [ParamSite],
}

impl RungJob for Estimation<'_> {
    type Output = DynModel;
    fn curvature<F: CurvatureModel>(self, model: F) -> Result<DynModel, LadderError> {
        Ok(Box::new(RungModel::new(model, self.loads, self.params)?))
    }
    fn rod(self, robot: Robot, settings: &SolverSettings) -> Result<DynModel, LadderError> {
        Ok(Box::new(Workspace::with_params(
            robot,
            self.loads,
            settings.clone(),
            self.params,
        )?))
    }
}

/// A rung's build error as the estimator's (the model errors unchanged, a rung
/// setting out of range as one).
fn from_ladder(e: LadderError) -> EstimateError {
    match e {
        LadderError::Model(m) => m.into(),
        LadderError::Setting { field, value, why } => {
            ModelError::OutOfRange { field, value, why }.into()
        }
        LadderError::NoCandidate(why) => ModelError::Invalid {
            field: "estimate model".into(),
            why,
        }
        .into(),
        e @ LadderError::Label { .. } => ModelError::Invalid {
            field: "estimate model".into(),
            why: e.to_string(),
        }
        .into(),
    }
}
