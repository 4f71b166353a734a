//! [`calibrate_scene`]: the calibration job from a scene and its recordings, in one
//! call (the steps `cablesense calibrate SCENE --data FILE` takes): the scene's model
//! of the recording's inputs ([`SceneModel`]), the fitted parameters at their scene
//! values, the capture frame and LM settings from the scene's `[calibration]` table,
//! [`calibrate`], and the scene with the fitted values written in
//! ([`calibrated_scene`]).

use super::fit::{CalibrationReport, CalibrationSettings, FitParam, FrameSetup, Progress};
use super::readings_model::{SceneModel, ServoModel};
use super::recording::Recording;
use super::report::calibrated_scene;
use super::run::{calibrate, CalibrationSetup};
use super::CalibrationError;
use crate::scene::{CalibrationSpec, ParamPath, Scene};

/// The calibration spec of `scene`: its `[calibration]` table (the defaults without
/// one), with the inputs of a tendon-driven scene defaulting to its servo reading
/// columns when the table lists none.
pub fn scene_spec(scene: &Scene) -> CalibrationSpec {
    let mut spec = scene.calibration.clone().unwrap_or_default();
    if spec.inputs.is_empty() {
        spec.inputs = ServoModel::reading_columns(scene);
    }
    spec
}

/// A calibrated scene and the report of its fit.
#[derive(Clone, Debug)]
pub struct SceneCalibration {
    /// The fit: parameters, errors on train and val, status.
    pub report: CalibrationReport,
    /// The scene with the fitted parameters, capture frame and marker offset written
    /// in (its `[calibration]` table updated).
    pub scene: Scene,
}

/// Calibrate `scene`'s parameters listed in `spec` (usually the scene's own
/// `[calibration]` table, after any overrides) on the `train` rows, reporting the
/// errors on `val` (held out: it chooses nothing). `threads` worker threads evaluate
/// the rows; `observer` sees every LM trial ([`calibrate`]).
///
/// An error when `spec` is invalid, a parameter path names no scene value, the
/// recording lacks the model's inputs, or the fit cannot start.
pub fn calibrate_scene(
    scene: &Scene,
    spec: &CalibrationSpec,
    train: &Recording,
    val: Option<&Recording>,
    threads: usize,
    observer: &mut dyn FnMut(&Progress),
) -> Result<SceneCalibration, CalibrationError> {
    spec.validate().map_err(|source| CalibrationError::Model {
        context: "[calibration]".into(),
        source,
    })?;
    let paths: Vec<ParamPath> = spec
        .params
        .iter()
        .map(|p| p.path.parse())
        .collect::<Result<_, _>>()?;
    let model = SceneModel::new(scene, &paths, &train.input_names, spec.marker_s_m)?;
    let setup = CalibrationSetup {
        model: &model,
        params: FitParam::all_from_spec(spec, model.values()),
        frame: FrameSetup::from_spec(spec),
        train,
        val,
        robot_length_m: model.robot_length(),
    };
    let settings = CalibrationSettings::from_spec(spec, threads);
    let report = calibrate(&setup, &settings, observer)?;
    let scene = calibrated_scene(scene, spec, &report, &paths)?;
    Ok(SceneCalibration { report, scene })
}
