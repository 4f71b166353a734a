//! The calibration itself: scene parameters (through a [`CalibrationModel`]) plus
//! the capture-frame transform and the marker offset, fitted to a recording.
//!
//! Residual of row `i` (robot base frame, whitened by the capture noise `sigma`):
//! `r_i = (P_i + Q_i o - (R(w) m_i + t)) / sigma`, with `P_i, Q_i` the predicted pose
//! of the marker's body, `o` the marker offset in that body's frame, `m_i` the
//! measured marker in the capture frame and `x_base = R(w) x_capture + t` the capture
//! frame (`w` a rotation vector). Gaussian priors add `(x_k - mean_k) / sigma_k`.
//!
//! Stages: (1) the model at the initial parameters; a closed-form Kabsch fit of the
//! capture frame onto the predicted marker points, with a unit check (the spread of
//! the measured points against the predicted ones, when the residual is far above
//! the capture noise); (2) Levenberg-Marquardt on the frame and offset alone (cheap:
//! no model solves); (3) Levenberg-Marquardt on everything. Rows are split into
//! contiguous chunks over `threads` workers (one model clone each, rows warm-started
//! in sequence within a chunk).

use super::frame::{kabsch, RigidTransform};
use super::lm::{
    levenberg_marquardt, Bounds, Huber, LeastSquares, LmIteration, LmSettings, LmStatus,
};
use super::model::{CalibrationModel, Sensitivities};
use super::recording::{Recording, RecordingRow};
use super::spec::{CalibrationSpec, ParamSpec};
use super::stats::{parameter_statistics, ParamStatistics, TipErrors};
use super::CalibrationError;
use crate::math::exp_so3;
use crate::statics::Pose;
use nalgebra::{DMatrix, Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// One scene parameter of a calibration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitParam {
    /// Name (the scene path).
    pub name: String,
    /// Starting value.
    pub initial: f64,
    /// Lower bound (`-inf` for none).
    pub lower: f64,
    /// Upper bound (`+inf` for none).
    pub upper: f64,
    /// Gaussian prior `(mean, sigma)`.
    pub prior: Option<(f64, f64)>,
    /// Typical size: unknowns are `x / scale`, finite-difference steps `fd_step * scale`.
    pub scale: f64,
}

impl FitParam {
    /// From a `[[calibration.params]]` entry and the scene's current value.
    pub fn from_spec(spec: &ParamSpec, initial: f64) -> Self {
        Self {
            name: spec.path.clone(),
            initial,
            lower: spec.min.unwrap_or(f64::NEG_INFINITY),
            upper: spec.max.unwrap_or(f64::INFINITY),
            prior: spec.prior_mean.zip(spec.prior_sigma),
            scale: spec
                .scale
                .unwrap_or(if initial != 0.0 { initial.abs() } else { 1.0 }),
        }
    }

    /// Every `[[calibration.params]]` entry of `spec` with its current value
    /// (`values`, in the same order: e.g. `SceneModel::values`).
    pub fn all_from_spec(spec: &CalibrationSpec, values: &[f64]) -> Vec<Self> {
        spec.params
            .iter()
            .zip(values)
            .map(|(p, v)| Self::from_spec(p, *v))
            .collect()
    }
}

impl FrameSetup {
    /// The capture frame and marker offset of a scene's `[calibration]` table.
    pub fn from_spec(spec: &CalibrationSpec) -> Self {
        Self {
            capture_to_base: RigidTransform::from_vector(
                &Vector3::from(spec.capture_to_base.rotation_vector),
                &Vector3::from(spec.capture_to_base.translation_m),
            ),
            marker_offset_m: Vector3::from(spec.marker_offset_m),
            fit_capture_frame: spec.fit_capture_frame,
            fit_marker_offset: spec.fit_marker_offset,
        }
    }
}

impl CalibrationSettings {
    /// The settings a scene's `[calibration]` table gives, on `threads` workers
    /// (at least 1); the rest at their defaults.
    pub fn from_spec(spec: &CalibrationSpec, threads: usize) -> Self {
        Self {
            capture_noise_m: spec.capture_noise_m,
            huber_sigma: spec.huber_sigma,
            max_iterations: spec.max_iterations,
            threads: threads.max(1),
            ..Self::default()
        }
    }
}

/// The non-scene parameters: capture frame and marker offset, starting values and
/// whether each is fitted.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameSetup {
    /// Capture frame to robot base (`x_base = R x_capture + t`).
    pub capture_to_base: RigidTransform,
    /// Marker position in its body's local frame (m).
    pub marker_offset_m: Vector3<f64>,
    /// Fit the capture frame (6 parameters).
    pub fit_capture_frame: bool,
    /// Fit the marker offset (3 parameters).
    pub fit_marker_offset: bool,
}

/// Settings of [`calibrate`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CalibrationSettings {
    /// Capture noise, std per coordinate (m), > 0 (default 5e-4).
    pub capture_noise_m: f64,
    /// Huber threshold in noise sigmas per marker point; `None` (default) = least squares.
    pub huber_sigma: Option<f64>,
    /// LM iterations of the full fit (default 30).
    pub max_iterations: usize,
    /// LM tolerance (relative cost decrease / step; default 1e-9).
    pub tolerance: f64,
    /// Finite-difference step relative to each parameter's scale (default 1e-5).
    pub fd_step: f64,
    /// Worker threads over row chunks (default 2).
    pub threads: usize,
    /// Start by fitting the capture frame in closed form (Kabsch) (default true).
    pub initial_frame_fit: bool,
    /// Residual RMS (noise sigmas per coordinate) above which the fit is suspicious:
    /// at the start, with a 100x spread mismatch, a unit error; at the end, a warning
    /// (default 20).
    pub unit_check_sigma: f64,
    /// Relative central/forward-difference disagreement above which a parameter's
    /// finite-difference Jacobian is flagged (default 1e-3).
    pub fd_check_limit: f64,
}

impl Default for CalibrationSettings {
    fn default() -> Self {
        Self {
            capture_noise_m: 5e-4,
            huber_sigma: None,
            max_iterations: 30,
            tolerance: 1e-9,
            fd_step: 1e-5,
            threads: 2,
            initial_frame_fit: true,
            unit_check_sigma: 20.0,
            fd_check_limit: 1e-3,
        }
    }
}

/// Which stage a progress report belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Frame and offset only.
    Frame,
    /// All parameters.
    Full,
}

/// Progress of [`calibrate`] (one per LM trial).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Stage.
    pub stage: Stage,
    /// The LM's report.
    pub lm: LmIteration,
    /// Iteration limit of this stage.
    pub max_iterations: usize,
}

/// A fitted parameter (scene or non-scene).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FittedParam {
    /// Name: the scene path, `capture_to_base/rotation_vector/<i>` (rad),
    /// `capture_to_base/translation_m/<i>` (m) or `marker_offset_m/<i>` (m).
    pub name: String,
    /// Starting value (after the closed-form frame fit for the frame).
    pub initial: f64,
    /// Fitted value.
    pub value: f64,
    /// Standard error; NaN when the data do not determine it (see
    /// [`ParamStatistics::unidentifiable`]).
    pub std_error: f64,
    /// Whether the value ended on a bound (its standard error then means little).
    pub at_bound: bool,
}

/// Data split of a row.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Split {
    /// Fitted.
    Train,
    /// Held out.
    Val,
}

/// One row's outcome.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RowResult {
    /// Split.
    pub split: Split,
    /// Line in its file.
    pub line: usize,
    /// Time (s), if recorded.
    pub t_s: Option<f64>,
    /// Measured marker, capture frame (m).
    pub measured_capture_m: Vector3<f64>,
    /// Measured marker, robot base frame (m).
    pub measured_base_m: Vector3<f64>,
    /// Model marker, robot base frame (m).
    pub model_base_m: Vector3<f64>,
    /// IRLS weight of the row in the fit (1 without Huber; val rows 1).
    pub weight: f64,
    /// Input values, ordered like [`CalibrationReport::input_names`].
    pub inputs: Vec<f64>,
}

impl RowResult {
    /// Model minus measured (m, base frame).
    pub fn error_m(&self) -> Vector3<f64> {
        self.model_base_m - self.measured_base_m
    }
}

/// Everything a calibration found.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CalibrationReport {
    /// How the full LM ended.
    pub status: LmStatus,
    /// Accepted LM steps (full stage).
    pub iterations: usize,
    /// Scene parameter values, ordered like the [`FitParam`]s.
    pub scene_values: Vec<f64>,
    /// Every fitted parameter (scene first, then frame and offset when fitted).
    pub params: Vec<FittedParam>,
    /// Fitted capture frame.
    pub capture_to_base: RigidTransform,
    /// Fitted marker offset (m).
    pub marker_offset_m: Vector3<f64>,
    /// Covariance, correlation, identifiability of the fitted parameters.
    pub statistics: ParamStatistics,
    /// Train tip errors.
    pub train: TipErrors,
    /// Validation tip errors (when a validation recording was given).
    pub val: Option<TipErrors>,
    /// Robot length (m), for errors in % of length.
    pub robot_length_m: f64,
    /// Train RMS residual per coordinate in capture-noise sigmas.
    pub rms_sigma: f64,
    /// Per scene parameter: central/forward difference disagreement (see
    /// [`Sensitivities::fd_disagreement`]; empty for exact sensitivities).
    pub fd_disagreement: Vec<f64>,
    /// Things to look at (flagged Jacobian columns, large residuals, skipped rows).
    pub warnings: Vec<String>,
    /// Names of the input columns.
    pub input_names: Vec<String>,
    /// Per row: measured and model marker.
    pub rows: Vec<RowResult>,
}

/// Index layout of the full parameter vector: scene, rotation vector, translation, offset.
const FRAME: usize = 0;
const TRANS: usize = 3;
const OFFSET: usize = 6;

struct Problem<'a, M> {
    models: Vec<M>,
    chunks: Vec<Range<usize>>,
    rows: &'a [RecordingRow],
    ns: usize,
    full: Vec<f64>,
    free: Vec<usize>,
    scale: Vec<f64>,
    priors: Vec<(usize, f64, f64)>,
    noise: f64,
    steps: Vec<f64>,
    poses: Vec<Pose>,
    poses_at: Option<Vec<f64>>,
    sens: Sensitivities,
    sens_at: Option<Vec<f64>>,
    fd_disagreement: Vec<f64>,
}

/// Work on one chunk of rows with one model.
type ChunkFn<'f, M, T> = dyn Fn(&mut M, &[RecordingRow]) -> Result<T, CalibrationError> + Sync + 'f;

fn run_chunks<M: CalibrationModel, T: Send>(
    models: &mut [M],
    chunks: &[Range<usize>],
    rows: &[RecordingRow],
    f: &ChunkFn<'_, M, T>,
) -> Result<Vec<T>, CalibrationError> {
    if models.len() == 1 {
        return Ok(vec![f(&mut models[0], &rows[chunks[0].clone()])?]);
    }
    std::thread::scope(|s| {
        let handles: Vec<_> = models
            .iter_mut()
            .zip(chunks)
            .map(|(m, c)| {
                let rows = &rows[c.clone()];
                s.spawn(move || f(m, rows))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("a calibration worker panicked"))
            .collect()
    })
}

impl<M: CalibrationModel> Problem<'_, M> {
    fn scene_values(&self, full: &[f64]) -> Vec<f64> {
        full[..self.ns].to_vec()
    }
    fn frame(&self, full: &[f64]) -> (Matrix3<f64>, Vector3<f64>, Vector3<f64>) {
        let b = self.ns;
        let w = Vector3::new(full[b + FRAME], full[b + FRAME + 1], full[b + FRAME + 2]);
        let t = Vector3::new(full[b + TRANS], full[b + TRANS + 1], full[b + TRANS + 2]);
        let o = Vector3::new(full[b + OFFSET], full[b + OFFSET + 1], full[b + OFFSET + 2]);
        (exp_so3(&w), t, o)
    }
    fn expand(&self, z: &[f64]) -> Vec<f64> {
        let mut x = self.full.clone();
        for (i, &k) in self.free.iter().enumerate() {
            x[k] = z[i] * self.scale[k];
        }
        x
    }
    fn ensure_poses(&mut self, values: &[f64]) -> Result<(), CalibrationError> {
        if self.poses_at.as_deref() == Some(values) {
            return Ok(());
        }
        self.poses_at = None;
        let out = run_chunks(&mut self.models, &self.chunks, self.rows, &|m, rows| {
            m.set_params(values)?;
            m.restart();
            rows.iter()
                .map(|r| m.predict(r))
                .collect::<Result<Vec<_>, _>>()
        })?;
        self.poses = out.into_iter().flatten().collect();
        self.poses_at = Some(values.to_vec());
        Ok(())
    }
    fn ensure_sens(&mut self, values: &[f64]) -> Result<(), CalibrationError> {
        if self.sens_at.as_deref() == Some(values) {
            return Ok(());
        }
        let steps = self.steps.clone();
        let out = run_chunks(&mut self.models, &self.chunks, self.rows, &|m, rows| {
            let mut s = Sensitivities::default();
            m.sensitivities(values, &steps, rows, &mut s)?;
            Ok(s)
        })?;
        let mut all = Sensitivities {
            params: self.ns,
            ..Sensitivities::default()
        };
        let mut dis = vec![0.0f64; 0];
        for s in out {
            all.poses.extend(s.poses);
            all.d_position.extend(s.d_position);
            all.d_rotation.extend(s.d_rotation);
            if dis.len() < s.fd_disagreement.len() {
                dis.resize(s.fd_disagreement.len(), 0.0);
            }
            for (d, x) in dis.iter_mut().zip(&s.fd_disagreement) {
                *d = d.max(*x);
            }
        }
        self.poses = all.poses.clone();
        self.poses_at = Some(values.to_vec());
        self.sens = all;
        self.sens_at = Some(values.to_vec());
        self.fd_disagreement = dis;
        Ok(())
    }
    /// Model marker and measured marker in the base frame, per row, at `full`.
    fn points(&self, full: &[f64]) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
        let (r, t, o) = self.frame(full);
        let model = self
            .poses
            .iter()
            .map(|p| p.position + p.rotation * o)
            .collect();
        let meas = self.rows.iter().map(|row| r * row.marker_m + t).collect();
        (model, meas)
    }
}

impl<M: CalibrationModel> LeastSquares for Problem<'_, M> {
    type Error = CalibrationError;
    fn unknowns(&self) -> usize {
        self.free.len()
    }
    fn residual_count(&self) -> usize {
        3 * self.rows.len() + self.priors.len()
    }
    fn residuals(&mut self, z: &[f64], out: &mut [f64]) -> Result<(), CalibrationError> {
        let x = self.expand(z);
        self.ensure_poses(&self.scene_values(&x))?;
        let (model, meas) = self.points(&x);
        for (i, (p, m)) in model.iter().zip(&meas).enumerate() {
            let r = (p - m) / self.noise;
            out[3 * i..3 * i + 3].copy_from_slice(r.as_slice());
        }
        let base = 3 * self.rows.len();
        for (j, &(k, mean, sigma)) in self.priors.iter().enumerate() {
            out[base + j] = (x[k] - mean) / sigma;
        }
        Ok(())
    }
    fn jacobian(
        &mut self,
        z: &[f64],
        _r: &[f64],
        jac: &mut DMatrix<f64>,
    ) -> Result<(), CalibrationError> {
        let x = self.expand(z);
        let scene = self.scene_values(&x);
        if self.free.iter().any(|&k| k < self.ns) {
            self.ensure_sens(&scene)?;
        } else {
            self.ensure_poses(&scene)?;
        }
        let (rot, _t, o) = self.frame(&x);
        let b = self.ns;
        let w = Vector3::new(x[b], x[b + 1], x[b + 2]);
        let hw = 1e-7;
        let drot: Vec<Matrix3<f64>> = (0..3)
            .map(|j| {
                let mut e = Vector3::zeros();
                e[j] = hw;
                (exp_so3(&(w + e)) - exp_so3(&(w - e))) / (2.0 * hw)
            })
            .collect();
        let _ = rot;
        jac.fill(0.0);
        for (c, &k) in self.free.iter().enumerate() {
            let sk = self.scale[k] / self.noise;
            for (i, row) in self.rows.iter().enumerate() {
                let pose = &self.poses[i];
                let col: Vector3<f64> = if k < self.ns {
                    let dp = self.sens.d_position[i * self.ns + k];
                    let dw = self.sens.d_rotation[i * self.ns + k];
                    dp + dw.cross(&(pose.rotation * o))
                } else {
                    let j = k - self.ns;
                    match j {
                        0..=2 => -(drot[j] * row.marker_m),
                        3..=5 => {
                            let mut e = Vector3::zeros();
                            e[j - 3] = -1.0;
                            e
                        }
                        _ => pose.rotation.column(j - 6).into_owned(),
                    }
                };
                for a in 0..3 {
                    jac[(3 * i + a, c)] = col[a] * sk;
                }
            }
            for (jp, &(kp, _, sigma)) in self.priors.iter().enumerate() {
                if kp == k {
                    jac[(3 * self.rows.len() + jp, c)] = self.scale[k] / sigma;
                }
            }
        }
        Ok(())
    }
}

fn chunks(n: usize, threads: usize) -> Vec<Range<usize>> {
    let t = threads.clamp(1, n.max(1));
    (0..t).map(|i| i * n / t..(i + 1) * n / t).collect()
}

fn rms(v: &[Vector3<f64>], w: &[Vector3<f64>]) -> f64 {
    (v.iter()
        .zip(w)
        .map(|(a, b)| (a - b).norm_squared())
        .sum::<f64>()
        / v.len().max(1) as f64)
        .sqrt()
}

fn spread(v: &[Vector3<f64>]) -> f64 {
    let c = v.iter().sum::<Vector3<f64>>() / v.len().max(1) as f64;
    rms(v, &vec![c; v.len()])
}

/// Names of the non-scene parameters, in layout order.
pub fn frame_param_names() -> Vec<String> {
    let mut n = Vec::new();
    for i in 0..3 {
        n.push(format!("capture_to_base/rotation_vector/{i}"));
    }
    for i in 0..3 {
        n.push(format!("capture_to_base/translation_m/{i}"));
    }
    for i in 0..3 {
        n.push(format!("marker_offset_m/{i}"));
    }
    n
}

/// What to calibrate on which data.
pub struct CalibrationSetup<'a, M> {
    /// The model (cloned once per worker thread; not modified).
    pub model: &'a M,
    /// Its scene parameters, ordered as [`CalibrationModel::set_params`] takes them.
    pub params: Vec<FitParam>,
    /// Capture frame and marker offset.
    pub frame: FrameSetup,
    /// Rows to fit.
    pub train: &'a Recording,
    /// Held-out rows (only predicted).
    pub val: Option<&'a Recording>,
    /// Robot length (m): errors in % of length, scale of the frame unknowns.
    pub robot_length_m: f64,
}

/// Calibrate the setup's scene parameters, capture frame and marker offset on its
/// train rows; report errors on train and val. `observer` sees every LM trial.
pub fn calibrate<M: CalibrationModel + Clone>(
    setup: &CalibrationSetup<'_, M>,
    settings: &CalibrationSettings,
    observer: &mut dyn FnMut(&Progress),
) -> Result<CalibrationReport, CalibrationError> {
    let CalibrationSetup {
        model,
        params,
        frame,
        train,
        val,
        robot_length_m,
    } = setup;
    let (model, train, val, robot_length_m) = (*model, *train, *val, *robot_length_m);
    let bad = |s: String| Err(CalibrationError::BadInput(s));
    if settings.capture_noise_m.is_nan() || settings.capture_noise_m <= 0.0 {
        return bad(format!(
            "capture noise must be > 0, got {}",
            settings.capture_noise_m
        ));
    }
    if train.rows.is_empty() {
        return bad(format!("{}: no rows to fit", train.file));
    }
    for p in params {
        if !(p.scale > 0.0 && p.scale.is_finite() && p.initial.is_finite()) {
            return bad(format!(
                "parameter {}: scale {} / initial {}",
                p.name, p.scale, p.initial
            ));
        }
    }
    let ns = params.len();
    let rows = &train.rows[..];
    let ch = chunks(rows.len(), settings.threads);
    let models = vec![model.clone(); ch.len()];
    let mut full: Vec<f64> = params
        .iter()
        .map(|p| p.initial.clamp(p.lower, p.upper))
        .collect();
    full.extend(frame.capture_to_base.rotation_vector().iter());
    full.extend(frame.capture_to_base.translation.iter());
    full.extend(frame.marker_offset_m.iter());
    let mut scale: Vec<f64> = params.iter().map(|p| p.scale).collect();
    scale.extend([1.0; 3]);
    scale.extend([robot_length_m; 6]);
    let mut names: Vec<String> = params.iter().map(|p| p.name.clone()).collect();
    names.extend(frame_param_names());
    let mut frame_free = Vec::new();
    if frame.fit_capture_frame {
        frame_free.extend(ns..ns + 6);
    }
    if frame.fit_marker_offset {
        frame_free.extend(ns + 6..ns + 9);
    }
    let priors: Vec<(usize, f64, f64)> = params
        .iter()
        .enumerate()
        .filter_map(|(k, p)| p.prior.map(|(m, s)| (k, m, s)))
        .collect();
    let mut pb = Problem {
        models,
        chunks: ch,
        rows,
        ns,
        full: full.clone(),
        free: Vec::new(),
        scale: scale.clone(),
        priors: Vec::new(),
        noise: settings.capture_noise_m,
        steps: params.iter().map(|p| settings.fd_step * p.scale).collect(),
        poses: Vec::new(),
        poses_at: None,
        sens: Sensitivities::default(),
        sens_at: None,
        fd_disagreement: Vec::new(),
    };
    let mut warnings = Vec::new();
    for (i, p) in params.iter().enumerate() {
        if params[..i].iter().any(|q| q.name == p.name) {
            warnings.push(format!(
                "parameter {} is given twice: the model sees one value, so the data cannot \
                 separate the two (expect a null direction below)",
                p.name
            ));
        }
    }
    // stage 1: model at the initial values, closed-form frame, unit check
    pb.ensure_poses(&full[..ns])?;
    let (model_pts, _) = pb.points(&full);
    let meas_capture: Vec<Vector3<f64>> = rows.iter().map(|r| r.marker_m).collect();
    if frame.fit_capture_frame && settings.initial_frame_fit {
        match kabsch(&meas_capture, &model_pts) {
            Some(t) => {
                let w = t.rotation_vector();
                full[ns..ns + 3].copy_from_slice(w.as_slice());
                full[ns + 3..ns + 6].copy_from_slice(t.translation.as_slice());
            }
            None => warnings.push(
                "closed-form frame fit skipped: the measured points are collinear or fewer than 3"
                    .into(),
            ),
        }
    }
    pb.full = full.clone();
    {
        let (model_pts, meas_base) = pb.points(&full);
        let rms_sigma = rms(&model_pts, &meas_base) / 3f64.sqrt() / settings.capture_noise_m;
        let ratio = spread(&meas_capture) / spread(&model_pts).max(f64::MIN_POSITIVE);
        if rms_sigma > settings.unit_check_sigma && !(0.01..=100.0).contains(&ratio) {
            let worst = model_pts
                .iter()
                .zip(&meas_base)
                .enumerate()
                .max_by(|a, b| {
                    (a.1 .0 - a.1 .1)
                        .norm()
                        .total_cmp(&(b.1 .0 - b.1 .1).norm())
                })
                .map(|(i, _)| rows[i].line)
                .unwrap_or(0);
            return Err(CalibrationError::UnitMismatch {
                file: train.file.clone(),
                line: worst,
                columns: train.marker_columns.join(","),
                unit: train.unit.name().into(),
                spread_ratio: ratio,
                rms_sigma,
                noise_m: settings.capture_noise_m,
            });
        }
    }
    let huber = settings.huber_sigma.map(|k| Huber {
        threshold: k,
        group: 3,
        rows: 3 * rows.len(),
    });
    // stage 2: frame and offset alone (no model solves)
    if !frame_free.is_empty() {
        pb.free = frame_free.clone();
        let z0: Vec<f64> = pb.free.iter().map(|&k| full[k] / scale[k]).collect();
        let lm = LmSettings {
            max_iterations: 50,
            tolerance: settings.tolerance,
            huber,
            ..LmSettings::default()
        };
        let res = levenberg_marquardt(&mut pb, &z0, &Bounds::none(z0.len()), &lm, &mut |it| {
            observer(&Progress {
                stage: Stage::Frame,
                lm: *it,
                max_iterations: 50,
            })
        })?;
        full = pb.expand(&res.z);
        pb.full = full.clone();
    }
    let frame_start = full.clone();
    // stage 3: everything
    pb.free = (0..ns).chain(frame_free.iter().copied()).collect();
    pb.priors = priors;
    let z0: Vec<f64> = pb.free.iter().map(|&k| full[k] / scale[k]).collect();
    let bounds = Bounds {
        lower: pb
            .free
            .iter()
            .map(|&k| {
                if k < ns {
                    params[k].lower / scale[k]
                } else {
                    f64::NEG_INFINITY
                }
            })
            .collect(),
        upper: pb
            .free
            .iter()
            .map(|&k| {
                if k < ns {
                    params[k].upper / scale[k]
                } else {
                    f64::INFINITY
                }
            })
            .collect(),
    };
    let lm = LmSettings {
        max_iterations: settings.max_iterations,
        tolerance: settings.tolerance,
        huber,
        ..LmSettings::default()
    };
    let res = levenberg_marquardt(&mut pb, &z0, &bounds, &lm, &mut |it| {
        observer(&Progress {
            stage: Stage::Full,
            lm: *it,
            max_iterations: settings.max_iterations,
        })
    })?;
    full = pb.expand(&res.z);
    pb.full = full.clone();
    pb.ensure_poses(&full[..ns])?;
    // statistics from the weighted Jacobian at the solution
    let mut jw = res.jacobian.clone();
    let mut wssr = 0.0;
    for i in 0..jw.nrows() {
        let w = res.weights[i];
        jw.row_mut(i).scale_mut(w.sqrt());
        wssr += w * res.residuals[i] * res.residuals[i];
    }
    let free_names: Vec<String> = pb.free.iter().map(|&k| names[k].clone()).collect();
    let free_scale: Vec<f64> = pb.free.iter().map(|&k| scale[k]).collect();
    let statistics = parameter_statistics(&jw, wssr, 3 * rows.len(), &free_names, &free_scale);
    let fitted: Vec<FittedParam> = pb
        .free
        .iter()
        .enumerate()
        .map(|(i, &k)| {
            let at_bound = k < ns && (full[k] <= params[k].lower || full[k] >= params[k].upper);
            FittedParam {
                name: names[k].clone(),
                initial: if k < ns {
                    params[k].initial
                } else {
                    frame_start[k]
                },
                value: full[k],
                std_error: statistics.std_errors[i],
                at_bound,
            }
        })
        .collect();
    for u in &statistics.unidentifiable {
        warnings.push(format!("not identifiable: {u}"));
    }
    for (k, d) in pb.fd_disagreement.iter().enumerate() {
        if *d > settings.fd_check_limit {
            warnings.push(format!(
                "finite-difference Jacobian of {} doubtful: central and forward differences differ by {:.1e} (relative); \
                 check the solver tolerance or the step",
                names[k], d
            ));
        }
    }
    let (r, t, o) = pb.frame(&full);
    let (model_pts, meas_base) = pb.points(&full);
    let rms_sigma = rms(&model_pts, &meas_base) / 3f64.sqrt() / settings.capture_noise_m;
    if rms_sigma > settings.unit_check_sigma {
        warnings.push(format!(
            "train residual is {rms_sigma:.1} capture-noise sigmas RMS ({:.3} mm): model error, a wrong \
             capture_noise_m, or a wrong unit of the marker columns",
            rms_sigma * settings.capture_noise_m * 1e3
        ));
    }
    let mut out_rows: Vec<RowResult> = rows
        .iter()
        .enumerate()
        .map(|(i, row)| RowResult {
            split: Split::Train,
            line: row.line,
            t_s: row.t_s,
            measured_capture_m: row.marker_m,
            measured_base_m: meas_base[i],
            model_base_m: model_pts[i],
            weight: res.weights[3 * i],
            inputs: row.inputs.clone(),
        })
        .collect();
    let train_err = TipErrors::of(&model_pts, &meas_base);
    let val_err = match val {
        None => None,
        Some(v) => {
            if v.input_names != train.input_names {
                return bad(format!(
                    "{} has input columns [{}], {} has [{}]",
                    v.file,
                    v.input_names.join(", "),
                    train.file,
                    train.input_names.join(", ")
                ));
            }
            let mut m = model.clone();
            m.set_params(&full[..ns])?;
            m.restart();
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for row in &v.rows {
                match m.predict(row) {
                    Ok(p) => {
                        let mp = p.position + p.rotation * o;
                        let mb = r * row.marker_m + t;
                        a.push(mp);
                        b.push(mb);
                        out_rows.push(RowResult {
                            split: Split::Val,
                            line: row.line,
                            t_s: row.t_s,
                            measured_capture_m: row.marker_m,
                            measured_base_m: mb,
                            model_base_m: mp,
                            weight: 1.0,
                            inputs: row.inputs.clone(),
                        });
                    }
                    Err(e) => {
                        warnings.push(format!("{} line {}: skipped ({e})", v.file, row.line));
                        m.restart();
                    }
                }
            }
            Some(TipErrors::of(&a, &b))
        }
    };
    Ok(CalibrationReport {
        status: res.status,
        iterations: res.iterations,
        scene_values: full[..ns].to_vec(),
        params: fitted,
        capture_to_base: RigidTransform {
            rotation: r,
            translation: t,
        },
        marker_offset_m: o,
        statistics,
        train: train_err,
        val: val_err,
        robot_length_m,
        rms_sigma,
        fd_disagreement: pb.fd_disagreement.clone(),
        warnings,
        input_names: train.input_names.clone(),
        rows: out_rows,
    })
}
