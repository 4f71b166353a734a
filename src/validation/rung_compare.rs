//! A calibrated Cosserat scene set beside the project's own calibrated
//! constant-curvature (CC) rung on the same train/held-out split: the comparison
//! `cablesense validate` prints for each hardware robot (FTDCR v4 and the
//! one-segment robot of `data/hardware/daru/`).
//!
//! * The Cosserat figures come from the stored calibrated scene (fitted on the
//!   train rows by `cablesense calibrate`), predicting every held-out row.
//! * The CC rung ([`CcModel`]) is fitted here, by the same [`calibrate`], on the
//!   train rows only (every `every`-th row): its [`CcRungSpec`] parameters (readings
//!   scale, lengths, hole angles, each with a documented range), the capture frame
//!   and the marker offset.
//! * Headline errors count every held-out row. A row whose Cosserat solve fails,
//!   even from cold, is scored with the best prediction available, the CC rung's
//!   for that row (carried into the Cosserat scene's base frame through the
//!   capture frame), and counted in [`RungComparison::substituted`]; it is never
//!   dropped.
//!
//! Error metric as [`super::hardware`]: Euclidean tip distance in the robot base
//! frame, raw and with the mean offset over the split removed ([`TipErrors`]).

use crate::calibrate::uncertainty::{coverage_90, lateral_deflection, Coverage};
use crate::calibrate::{
    calibrate, row_order, CalibrationError, CalibrationModel, CalibrationSettings,
    CalibrationSetup, CcModel, FitParam, FrameSetup, ParamSpec, Recording, RigidTransform,
    RowOrder, ServoModel, Split, TipErrors,
};
use crate::files::Scene;
use crate::validation::ParamPath;
use nalgebra::Vector3;
use std::collections::HashMap;
use std::time::Instant;

/// A fitted value beside its documented physical range.
#[derive(Clone, Debug, PartialEq)]
pub struct RangeCheck {
    /// Scene path.
    pub name: String,
    /// Value.
    pub value: f64,
    /// Standard error (`None` when not known, e.g. a stored scene).
    pub std_error: Option<f64>,
    /// Documented lower end of the physical range (the fit's bound).
    pub min: Option<f64>,
    /// Documented upper end.
    pub max: Option<f64>,
}

impl RangeCheck {
    /// Relative distance to a bound below which the value counts as on it (1e-6).
    pub const AT_BOUND: f64 = 1e-6;

    /// Strictly inside the range (not on a bound, where the fit was stopped by it).
    pub fn inside(&self) -> bool {
        let tol = |b: f64| Self::AT_BOUND * b.abs().max(f64::MIN_POSITIVE);
        self.min.is_none_or(|m| self.value > m + tol(m))
            && self.max.is_none_or(|m| self.value < m - tol(m))
    }
}

/// The parameters of a robot's CC rung and how many train rows fit them.
#[derive(Clone, Debug, PartialEq)]
pub struct CcRungSpec {
    /// Scene parameters (with their physical ranges as bounds).
    pub params: Vec<ParamSpec>,
    /// Fit every `every`-th train row (>= 1).
    pub every: usize,
    /// LM iteration limit.
    pub max_iterations: usize,
}

/// The comparison on one robot.
#[derive(Clone, Debug)]
pub struct RungComparison {
    /// Robot name.
    pub robot: String,
    /// Held-out rows.
    pub val_rows: usize,
    /// Held-out rows the Cosserat model solved.
    pub val_solved: usize,
    /// Held-out rows scored with the CC rung's prediction (their Cosserat solve
    /// failed even from cold): file line and solve status.
    pub substituted: Vec<String>,
    /// Cosserat held-out errors over every row (headline).
    pub cosserat: TipErrors,
    /// CC held-out errors over every row.
    pub cc: TipErrors,
    /// CC errors on the rows it was fitted to.
    pub cc_train: TipErrors,
    /// Train rows the CC rung was fitted to.
    pub cc_train_rows: usize,
    /// CC fit status and iterations.
    pub cc_status: String,
    /// Stored Cosserat values beside their ranges (the scene's `[[calibration.params]]`).
    pub cosserat_values: Vec<RangeCheck>,
    /// Fitted CC values beside their ranges.
    pub cc_values: Vec<RangeCheck>,
    /// Robot length of the Cosserat scene (m).
    pub robot_length_m: f64,
    /// Seconds: Cosserat held-out predictions, CC fit and predictions.
    pub seconds: (f64, f64),
    /// Held-out rows inside their 90 % region under the stored calibration's
    /// model-error term (`[calibration.model_error]`, from cross-validation on the
    /// train rows; errors with the split's mean offset removed, as the headline);
    /// `None` when the scene stores no term.
    pub coverage_90: Option<Coverage>,
}

impl RungComparison {
    /// Cosserat over CC held-out RMSE, mean offset removed.
    pub fn ratio(&self) -> f64 {
        self.cosserat.mean_removed.rmse_m / self.cc.mean_removed.rmse_m
    }
    /// Cosserat over CC held-out RMSE, raw.
    pub fn ratio_raw(&self) -> f64 {
        self.cosserat.raw.rmse_m / self.cc.raw.rmse_m
    }
}

fn bad(why: String) -> CalibrationError {
    CalibrationError::BadInput(why)
}

/// The values of `scene`'s `[[calibration.params]]` beside their bounds.
pub fn stored_values(scene: &Scene) -> Result<Vec<RangeCheck>, CalibrationError> {
    let Some(spec) = &scene.calibration else {
        return Ok(Vec::new());
    };
    spec.params
        .iter()
        .map(|p| {
            let path: ParamPath = p.path.parse()?;
            Ok(RangeCheck {
                name: p.path.clone(),
                value: path.value(scene)?,
                std_error: None,
                min: p.min,
                max: p.max,
            })
        })
        .collect()
}

/// Compare the calibrated Cosserat `scene` (its `[calibration]` capture frame and
/// marker offset) with the CC rung fitted on `train` by `cc`, on `val`. Rows are
/// solved in `order` (see [`row_order`]).
pub fn compare_with_cc(
    robot: &str,
    scene: &Scene,
    train: &Recording,
    val: &Recording,
    cc: &CcRungSpec,
    order: RowOrder,
) -> Result<RungComparison, CalibrationError> {
    let spec = scene.calibration.clone().ok_or_else(|| {
        bad(format!(
            "{robot}: the calibrated scene has no [calibration] table"
        ))
    })?;
    if val.rows.is_empty() || train.rows.is_empty() {
        return Err(bad(format!("{robot}: no train or no held-out rows")));
    }
    let frame = RigidTransform::from_spec(&spec.capture_to_base);
    let offset = Vector3::from(spec.marker_offset_m);
    // Cosserat: every held-out row, failures kept as None
    let t0 = Instant::now();
    let mut model = ServoModel::new(scene, &[], &val.input_names, spec.marker_s_m)?;
    let mut cos: Vec<Option<Vector3<f64>>> = vec![None; val.rows.len()];
    let mut failures: HashMap<usize, String> = HashMap::new();
    model.begin_chain();
    for i in row_order(&val.rows, order) {
        let row = &val.rows[i];
        match model.predict_retrying(row)? {
            Ok(pose) => cos[i] = Some(pose.position + pose.rotation * offset),
            Err(f) => {
                failures.insert(
                    i,
                    format!(
                        "line {}: {:?} (residual {:.2e})",
                        f.line, f.status, f.residual
                    ),
                );
            }
        }
    }
    let cos_s = t0.elapsed().as_secs_f64();
    // CC rung: fitted on the train rows only
    let t1 = Instant::now();
    let paths: Vec<ParamPath> = cc
        .params
        .iter()
        .map(|p| p.path.parse())
        .collect::<Result<_, _>>()?;
    let cc_model = CcModel::new(scene, &paths, &train.input_names)?;
    let params: Vec<FitParam> = cc
        .params
        .iter()
        .zip(cc_model.values())
        .map(|(p, v)| FitParam::from_spec(p, *v))
        .collect();
    let fit_rows = train.every(cc.every.max(1));
    let settings = CalibrationSettings {
        max_iterations: cc.max_iterations,
        row_order: order,
        ..CalibrationSettings::from_spec(&spec, 2)
    };
    let setup = CalibrationSetup {
        model: &cc_model,
        params,
        frame: FrameSetup::from_spec(&spec),
        train: &fit_rows,
        val: Some(val),
        robot_length_m: cc_model.robot_length(),
    };
    let rep = calibrate(&setup, &settings, &mut |_| {})?;
    let cc_s = t1.elapsed().as_secs_f64();
    // the CC rung's held-out predictions, by line, in the capture frame
    let cc_frame = rep.capture_to_base;
    let to_capture = |p: &Vector3<f64>| cc_frame.rotation.transpose() * (p - cc_frame.translation);
    let cc_pred: HashMap<usize, Vector3<f64>> = rep
        .rows
        .iter()
        .filter(|r| r.split == Split::Val)
        .map(|r| (r.line, to_capture(&r.model_base_m)))
        .collect();
    let (mut cos_model, mut cos_meas) = (Vec::new(), Vec::new());
    let mut substituted = Vec::new();
    for (i, row) in val.rows.iter().enumerate() {
        let p = match cos[i] {
            Some(p) => p,
            None => {
                let c = cc_pred.get(&row.line).ok_or_else(|| {
                    bad(format!(
                        "{robot}: line {}: neither the Cosserat model nor the CC rung predicted it",
                        row.line
                    ))
                })?;
                substituted.push(failures.remove(&i).unwrap_or_default());
                frame.apply(c)
            }
        };
        cos_model.push(p);
        cos_meas.push(frame.apply(&row.marker_m));
    }
    let ns = cc.params.len();
    let cc_values = cc
        .params
        .iter()
        .zip(rep.params.iter().take(ns))
        .map(|(s, f)| RangeCheck {
            name: s.path.clone(),
            value: f.value,
            std_error: Some(f.std_error),
            min: s.min,
            max: s.max,
        })
        .collect();
    let built = scene
        .build_robot()
        .map_err(|source| CalibrationError::Model {
            context: format!("{robot}: calibrated scene"),
            source,
        })?;
    let robot_length_m = built.length();
    let coverage_90 = spec.model_error.as_ref().map(|term| {
        let n = cos_model.len().max(1) as f64;
        let mean = cos_model
            .iter()
            .zip(&cos_meas)
            .fold(Vector3::zeros(), |m, (p, q)| m + (p - q))
            / n;
        let axis = built.base_rotation() * Vector3::z();
        let rows: Vec<(f64, Vector3<f64>)> = cos_model
            .iter()
            .zip(&cos_meas)
            .map(|(p, q)| {
                let d = lateral_deflection(p, built.base_position(), &axis);
                (d, p - q - mean)
            })
            .collect();
        coverage_90(term, &rows)
    });
    Ok(RungComparison {
        coverage_90,
        robot: robot.into(),
        val_rows: val.rows.len(),
        val_solved: cos.iter().filter(|p| p.is_some()).count(),
        substituted,
        cosserat: TipErrors::of(&cos_model, &cos_meas),
        cc: rep.val.unwrap_or_default(),
        cc_train: rep.train,
        cc_train_rows: fit_rows.rows.len(),
        cc_status: format!("{:?} after {} LM iterations", rep.status, rep.iterations),
        cosserat_values: stored_values(scene)?,
        cc_values,
        robot_length_m,
        seconds: (cos_s, cc_s),
    })
}

/// The stored calibrated scene of the one-segment robot (`data/hardware/daru/`),
/// written by `cablesense calibrate data/scenes/daru.toml` on its train rows.
pub const DARU_SCENE: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/data/calibration/daru_calibrated.toml"
));
/// The one-segment robot's recording (30,250 rows, no header).
pub const DARU_DATA: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/data/hardware/daru/Dataset-Actions-Positions.txt"
));
/// Its train rows: the first 80 % in file order (rows 0..24,200); the last 20 %
/// (24,200..30,250) are held out.
pub const DARU_TRAIN_ROWS: usize = 24_200;

fn ranged(path: &str, min: f64, max: f64) -> ParamSpec {
    ParamSpec {
        min: Some(min),
        max: Some(max),
        ..ParamSpec::new(path)
    }
}

/// The one-segment robot's CC rung: the readings scale (m per command unit; for
/// CC the same as the tendon offset: 0.05-0.2 mm a unit against the nominal 0.1 mm),
/// the length (0.07-0.16 m, as the Cosserat scene) and the hole angles of cables
/// l2 and l3 (within 30 degrees of 120-degree spacing; l1's angle is absorbed by
/// the capture frame). Every 10th train row (2,420 rows).
pub fn daru_cc_spec() -> CcRungSpec {
    CcRungSpec {
        params: vec![
            ranged("readings/scale_m", 5e-5, 2e-4),
            ranged("robot/sections/0/length_m", 0.07, 0.16),
            ranged("robot/cables/1/routing/angle_deg", 210.0, 270.0),
            ranged("robot/cables/2/routing/angle_deg", 90.0, 150.0),
        ],
        every: 10,
        max_iterations: 30,
    }
}

/// FTDCR v4's CC rung: the readings scale (servo mm to m: 0.5-2x the nominal
/// 0.001) and the three section lengths (within 30 % of the upstream geometry's
/// 60, 62.5 and 64 mm). Every train row (1,620 rows).
pub fn ftdcr_cc_spec() -> CcRungSpec {
    CcRungSpec {
        params: vec![
            ranged("readings/scale_m", 5e-4, 2e-3),
            ranged("robot/sections/0/length_m", 0.042, 0.078),
            ranged("robot/sections/1/length_m", 0.04375, 0.08125),
            ranged("robot/sections/2/length_m", 0.0448, 0.0832),
        ],
        every: 1,
        max_iterations: 30,
    }
}

fn parse_scene(file: &str, text: &str) -> Result<Scene, CalibrationError> {
    Scene::parse_validated(text, std::path::Path::new(file), false).map_err(|e| {
        CalibrationError::Io {
            path: file.into(),
            why: e.to_string(),
        }
    })
}

/// The one-segment robot's comparison on the embedded files: fit rows 0..24,200,
/// held out 24,200..30,250, rows chained by [`RowOrder::Auto`] (no time column:
/// nearest neighbour in readings).
pub fn shipped_daru_comparison() -> Result<RungComparison, CalibrationError> {
    let file = "data/calibration/daru_calibrated.toml";
    let scene = parse_scene(file, DARU_SCENE)?;
    let map = super::column_map(&scene)?;
    let all = Recording::parse_str(
        "data/hardware/daru/Dataset-Actions-Positions.txt",
        DARU_DATA,
        &map,
    )?;
    let (train, val) = all.split_rows(0..DARU_TRAIN_ROWS);
    compare_with_cc(
        "one-segment robot (daru)",
        &scene,
        &train,
        &val,
        &daru_cc_spec(),
        RowOrder::Auto,
    )
}

/// FTDCR v4's comparison on the embedded files (train.csv fit, val.csv held out,
/// rows in time order).
pub fn shipped_ftdcr_comparison() -> Result<RungComparison, CalibrationError> {
    let file = "data/calibration/ftdcr_v4_calibrated.toml";
    let scene = parse_scene(file, super::CALIBRATED_SCENE)?;
    let map = super::column_map(&scene)?;
    let train = Recording::parse_str("data/hardware/ftdcr_v4/train.csv", super::TRAIN_CSV, &map)?;
    let val = Recording::parse_str("data/hardware/ftdcr_v4/val.csv", super::VAL_CSV, &map)?;
    compare_with_cc(
        "FTDCR v4",
        &scene,
        &train,
        &val,
        &ftdcr_cc_spec(),
        RowOrder::Auto,
    )
}
