//! Table 4.5 redone as a user would: leave one loaded row out, calibrate the scene on
//! the observed data of the other rows (tips of table 4.3 and cable readings of table
//! 4.5, same experiment and masses), estimate the held-out row's tip mass from its
//! cable reading, and check whether its interval covers the hung mass.
//!
//! The calibration is [`crate::calibrate::calibrate`] (no second code path), with a
//! model ([`TableRowModel`]) whose "marker" per row is the vector of observed
//! quantities `(tip x, tip y, k * cable change)`, the capture frame fixed at the
//! identity and the marker offset at zero: the residual is then
//! `((tip - tip_obs) / sigma_tip, (dl - dl_obs) / sigma_reading)` with
//! `k = sigma_tip / sigma_reading` (the scene is planar, so the third coordinate of
//! the tip is free to carry the cable). Noise: the tip was read on a 1 mm grid and the
//! notch on a 1 mm ruler (thesis 4.4.4, 4.7): both uniform over 1 mm,
//! `sigma = 1 mm / sqrt(12)` ([`READING_SIGMA_M`]); the tip sigma is raised to
//! [`TIP_SIGMA_M`] = 1 mm for the clamp and grid parallax the thesis does not quantify.
//!
//! Interval: the estimate's variance is the reading's (the estimator's covariance)
//! plus the calibration's, propagated by the implicit function theorem on
//! `dl(m, p) = dl_obs`: `dm/dp = -(d dl/dp) / (d dl/dm)`, with `d dl/dp` by central
//! differences of the model and the fitted parameters' covariance from the
//! calibration report (`s^2 (J^T W J)^-1`). The interval is `estimate +- 1.96 sd`
//! (95 %, normal), cut at 0 g. A held-out row the fold's model cannot reach (the
//! estimator stalls) gets no coverage verdict.

use super::inverse::{mass_estimator, READING_SIGMA_M};
use super::{FittedFile, ParamPath, Target, ValidationError};
use crate::calibrate::{
    calibrate, CalibrationError, CalibrationModel, CalibrationSettings, CalibrationSetup,
    ColumnMap, FitParam, FrameSetup, LmStatus, Recording, RecordingRow, RigidTransform,
};
use crate::estimate::EstimateStatus;
use crate::files::demo::DataSource;
use crate::files::Scene;
use crate::statics::{Pose, Start, Workspace};
use nalgebra::{Matrix3, Vector3};

/// Tip reading noise used in the calibration (m).
pub const TIP_SIGMA_M: f64 = 1e-3;
/// Two-sided 95 % normal quantile.
pub const Z95: f64 = 1.959_963_984_540_054;

/// Calibrated parameters of every fold: path, lower and upper bound.
pub const LOO_PARAMS: [(&str, f64, f64); 2] = [
    ("robot/sections/*/youngs_modulus_pa", 2.0e10, 1.5e11),
    ("robot/sections/0/guides/holes/radius_m", 2.0e-3, 1.3e-2),
];

/// One held-out row.
#[derive(Clone, Debug, PartialEq)]
pub struct LooRow {
    /// Hung tip mass (kg).
    pub truth_kg: f64,
    /// Observed cable change (m).
    pub observed_change_m: f64,
    /// Estimated tip mass (kg).
    pub estimate_kg: f64,
    /// Standard deviation from the reading alone (kg).
    pub std_reading_kg: f64,
    /// Standard deviation with the calibration's uncertainty (kg).
    pub std_total_kg: f64,
    /// 95 % interval (kg).
    pub interval_kg: (f64, f64),
    /// Does the interval contain the truth? `None` when the estimator did not
    /// converge (a stalled fit has no usable interval).
    pub covered: Option<bool>,
    /// `(estimate - truth) / truth` (%).
    pub error_pct: f64,
    /// Estimator status.
    pub status: EstimateStatus,
    /// Calibration status of the fold.
    pub calibration: LmStatus,
    /// Fitted parameter values of the fold (order of [`LOO_PARAMS`]).
    pub params: Vec<f64>,
    /// Train residual of the fold's calibration, tips and cable, in sigmas RMS.
    pub train_rms_sigma: f64,
}

/// The table rows as a calibration model: row input `mass_kg`, prediction
/// `(tip x, tip y, k * (cable length - length at 0 g))`.
pub struct TableRowModel {
    scene: Scene,
    params: Vec<ParamPath>,
    values: Vec<f64>,
    scale: f64,
    ws: Workspace,
    reference: f64,
}

fn model_err(context: &str) -> impl FnOnce(crate::ModelError) -> CalibrationError + '_ {
    move |source| CalibrationError::Model {
        context: context.into(),
        source,
    }
}

impl TableRowModel {
    /// The model of `scene` (its `loads.point[0]` carries the mass) with `params`;
    /// the cable change is multiplied by `scale`.
    pub fn new(scene: &Scene, params: &[ParamPath], scale: f64) -> Result<Self, CalibrationError> {
        let values = params
            .iter()
            .map(|p| p.value(scene))
            .collect::<Result<Vec<_>, _>>()?;
        let robot = scene.build_robot().map_err(model_err("scene"))?;
        let ws = Workspace::new(robot, scene.loads.clone(), scene.numerics.clone())
            .map_err(model_err("scene"))?;
        let mut m = Self {
            scene: scene.clone(),
            params: params.to_vec(),
            values: Vec::new(),
            scale,
            ws,
            reference: 0.0,
        };
        m.set_params(&values)?;
        Ok(m)
    }

    fn solve_mass(&mut self, mass: f64, line: usize) -> Result<(), CalibrationError> {
        let mut loads = self.ws.loads().clone();
        loads.point[0].mass_kg = mass;
        self.ws.set_loads(&loads).map_err(model_err("loads"))?;
        let mut rep = self.ws.solve(Start::Warm);
        if !rep.status.is_converged() {
            rep = self.ws.solve(Start::Cold);
        }
        if !rep.status.is_converged() {
            return Err(CalibrationError::NotConverged {
                line,
                status: rep.status,
                residual: rep.residual,
            });
        }
        Ok(())
    }

    fn cable_length(&mut self) -> f64 {
        let mut l = [0.0];
        self.ws.cable_lengths_into(&mut l);
        l[0]
    }

    /// The scene at the current values.
    pub fn scene(&self) -> Result<Scene, CalibrationError> {
        Ok(super::set_values(&self.scene, &self.params, &self.values)?)
    }

    /// Cable change (m) at `mass` (kg).
    pub fn change_at(&mut self, mass: f64) -> Result<f64, CalibrationError> {
        self.solve_mass(mass, 0)?;
        Ok(self.cable_length() - self.reference)
    }
}

impl Clone for TableRowModel {
    /// The same model at the same values (the warm state is not copied).
    fn clone(&self) -> Self {
        Self {
            scene: self.scene.clone(),
            params: self.params.clone(),
            values: self.values.clone(),
            scale: self.scale,
            ws: Workspace::new(
                self.ws.robot().clone(),
                self.ws.loads().clone(),
                self.ws.settings().clone(),
            )
            .expect("the workspace's own robot, loads and settings are valid"),
            reference: self.reference,
        }
    }
}

impl CalibrationModel for TableRowModel {
    fn set_params(&mut self, values: &[f64]) -> Result<(), CalibrationError> {
        if values == self.values.as_slice() {
            return Ok(());
        }
        let mut scene = super::set_values(&self.scene, &self.params, values)?;
        scene
            .validate()
            .map_err(model_err(&format!("scene with {values:?}")))?;
        for p in &mut scene.loads.point {
            p.mass_kg = 0.0;
        }
        let robot = scene.build_robot().map_err(model_err("scene"))?;
        self.ws = Workspace::new(robot, scene.loads.clone(), scene.numerics.clone())
            .map_err(model_err("scene"))?;
        self.values = values.to_vec();
        self.solve_mass(0.0, 0)?;
        self.reference = self.cable_length();
        Ok(())
    }

    fn predict(&mut self, row: &RecordingRow) -> Result<Pose, CalibrationError> {
        self.solve_mass(row.inputs[0], row.line)?;
        let tip = self.ws.solution().tip().position;
        let dl = self.cable_length() - self.reference;
        Ok(Pose {
            position: Vector3::new(tip.x, tip.y, self.scale * dl),
            rotation: Matrix3::identity(),
        })
    }
}

/// Leave-one-out over the loaded rows of tables 4.3 (tips) and 4.5 (cable), starting
/// every fold from the scene of table 4.3 with the values fitted to the thesis's
/// predicted columns (`fitted.toml`).
pub fn table_4_5_loo(src: &DataSource) -> Result<Vec<LooRow>, ValidationError> {
    let t45 = src.table("table_4_5.csv")?;
    let t43 = src.table("table_4_3.csv")?;
    let masses = t45.col_si("tip_mass_g")?;
    let deltas = t45.col_si("obs_delta_cm")?;
    let (m43, xs, ys) = (
        t43.col_si("tip_mass_g")?,
        t43.col_si("obs_x_cm")?,
        t43.col_si("obs_y_cm")?,
    );
    if m43 != masses {
        return Err(ValidationError::BadFit(format!(
            "tables 4.3 and 4.5 list different masses ({m43:?} vs {masses:?} kg)"
        )));
    }
    let scene = src.scene("table_4_3.toml")?;
    let mut scene = match FittedFile::load_from(src)?.get("table_4_3.toml", Target::Predicted) {
        Some(r) => r.apply(&scene)?,
        None => scene,
    };
    for p in &mut scene.loads.point {
        p.mass_kg = 0.0;
    }
    let paths: Vec<ParamPath> = LOO_PARAMS
        .iter()
        .map(|(p, _, _)| p.parse())
        .collect::<Result<_, _>>()?;
    let k = TIP_SIGMA_M / READING_SIGMA_M;
    let cal = |e: CalibrationError| ValidationError::BadFit(format!("table 4.5 LOO: {e}"));
    let model = TableRowModel::new(&scene, &paths, k).map_err(cal)?;
    let rows: Vec<RecordingRow> = (0..masses.len())
        .map(|i| RecordingRow {
            line: i + 2,
            t_s: None,
            marker_m: Vector3::new(xs[i], ys[i], k * deltas[i]),
            inputs: vec![masses[i]],
            history: None,
        })
        .collect();
    let settings = CalibrationSettings {
        capture_noise_m: TIP_SIGMA_M,
        threads: 1,
        initial_frame_fit: false,
        ..CalibrationSettings::default()
    };
    let mut out = Vec::new();
    for held in 0..rows.len() {
        if masses[held] <= 0.0 {
            continue; // the 0 g row defines the reference: always in the fit
        }
        let train = Recording {
            file: format!(
                "tables 4.3 + 4.5 without the {:.1} g row",
                masses[held] * 1e3
            ),
            input_names: vec!["mass_0".into()],
            marker_columns: ["tip_x".into(), "tip_y".into(), "cable".into()],
            unit: ColumnMap::default().unit,
            rows: rows
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != held)
                .map(|(_, r)| r.clone())
                .collect(),
        };
        let params: Vec<FitParam> = LOO_PARAMS
            .iter()
            .zip(&paths)
            .map(|((name, lo, hi), p)| {
                let v = p.value(&scene)?;
                Ok(FitParam {
                    name: name.to_string(),
                    initial: v,
                    lower: *lo,
                    upper: *hi,
                    prior: None,
                    scale: v.abs(),
                })
            })
            .collect::<Result<_, ValidationError>>()?;
        let setup = CalibrationSetup {
            model: &model,
            params,
            frame: FrameSetup {
                capture_to_base: RigidTransform::from_vector(&Vector3::zeros(), &Vector3::zeros()),
                marker_offset_m: Vector3::zeros(),
                fit_capture_frame: false,
                fit_marker_offset: false,
            },
            train: &train,
            val: None,
            robot_length_m: 0.39,
        };
        let report = calibrate(&setup, &settings, &mut |_| {}).map_err(cal)?;
        let mut fold = model.clone();
        fold.set_params(&report.scene_values).map_err(cal)?;
        let fitted = fold.scene().map_err(cal)?;
        let mut est = mass_estimator(&fitted)?;
        est.set_theta(&[0.0]);
        let status = est.tick(&[deltas[held]], None);
        let e = est.estimate();
        let (m_hat, sd_read) = (e.values[0], e.std_dev[0]);
        // calibration uncertainty: dm/dp = -(d dl/dp) / (d dl/dm)
        let dl_dm = READING_SIGMA_M / sd_read;
        let np = report.scene_values.len();
        let mut g = vec![0.0; np];
        for (j, gj) in g.iter_mut().enumerate() {
            let h = 1e-4 * report.scene_values[j].abs();
            let mut v = report.scene_values.clone();
            v[j] += h;
            fold.set_params(&v).map_err(cal)?;
            let up = fold.change_at(m_hat).map_err(cal)?;
            v[j] -= 2.0 * h;
            fold.set_params(&v).map_err(cal)?;
            let dn = fold.change_at(m_hat).map_err(cal)?;
            *gj = -(up - dn) / (2.0 * h) / dl_dm;
        }
        let cov = &report.statistics.covariance;
        let mut var_cal = 0.0;
        for a in 0..np {
            for b in 0..np {
                var_cal += g[a] * cov[a * np + b] * g[b];
            }
        }
        let sd = (sd_read * sd_read + var_cal.max(0.0)).sqrt();
        let interval = ((m_hat - Z95 * sd).max(0.0), m_hat + Z95 * sd);
        out.push(LooRow {
            truth_kg: masses[held],
            observed_change_m: deltas[held],
            estimate_kg: m_hat,
            std_reading_kg: sd_read,
            std_total_kg: sd,
            interval_kg: interval,
            covered: (status == EstimateStatus::Converged)
                .then(|| interval.0 <= masses[held] && masses[held] <= interval.1),
            error_pct: (m_hat - masses[held]) / masses[held] * 100.0,
            status,
            calibration: report.status,
            params: report.scene_values.clone(),
            train_rms_sigma: report.rms_sigma,
        });
    }
    Ok(out)
}
