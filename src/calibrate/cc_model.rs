//! The calibration model of the cheapest rung of the ladder: constant curvature
//! (CC) per section driven by the servo readings through the tendon kinematics of
//! [`crate::ladder::ConstantCurvature::solve_readings`] (Webster & Jones 2010,
//! section 4.1: each section one arc whose bend follows from the taut tendons'
//! shortening, no loads, no stiffness). It is the baseline the Cosserat model is
//! set beside on the hardware benchmarks (`cablesense validate`), fitted with the
//! same [`super::calibrate`] on the same train rows.
//!
//! Its parameters are scene paths like any calibration's: typically the readings
//! scale (`readings/scale_m`, which for CC is the same as the tendons' offset from
//! the axis), the section lengths (`robot/sections/K/length_m`: the guide disks
//! keep their place as a fraction of the section) and the cables' hole angles
//! (`robot/cables/J/routing/angle_deg`); the capture frame and the marker offset are
//! fitted by the calibration itself. The scene's `[readings]` conditioning (time
//! offset, backlash) is applied as for [`super::ServoModel`].

use super::conditioning::{Conditioning, InputTimeline};
use super::model::{patched_scene, CalibrationModel};
use super::readings_model::{conditioned_into, ServoModel};
use super::recording::RecordingRow;
use super::CalibrationError;
use crate::files::Scene;
use crate::ladder::{CcSettings, ConstantCurvature, ForwardModel};
use crate::scene::param::ParamPath;
use crate::statics::Pose;
use std::sync::Arc;

/// Readings -> constant-curvature arcs -> tip pose.
pub struct CcModel {
    scene: Scene,
    params: Vec<ParamPath>,
    values: Vec<f64>,
    /// Per driven tendon: its column's index in a row's inputs.
    columns: Vec<usize>,
    scale: f64,
    cc: ConstantCurvature,
    q: Vec<f64>,
    cond: Conditioning,
    conditioned: Option<(Arc<InputTimeline>, Vec<f64>)>,
}

fn model_err(context: String) -> impl FnOnce(crate::ModelError) -> CalibrationError {
    move |source| CalibrationError::Model { context, source }
}

fn ladder_err(context: String) -> impl FnOnce(crate::ladder::LadderError) -> CalibrationError {
    move |e| CalibrationError::BadInput(format!("{context}: {e}"))
}

/// `scene` patched with `values` at `params`; every section's guide disks scaled
/// with its length (a fitted length keeps the disks inside the section; a layout
/// given as `"even"` is spaced again by the patch itself).
fn cc_scene(
    scene: &Scene,
    params: &[ParamPath],
    values: &[f64],
) -> Result<Scene, CalibrationError> {
    let mut patched = crate::scene::param::set_values(scene, params, values)?;
    for (new, old) in patched.robot.sections.iter_mut().zip(&scene.robot.sections) {
        if let Some(g) = new.guides.as_mut() {
            // "even" layouts were spaced again for the new length when patched
            if !g.even.first_offset
                && !g.even.spacing
                && old.length_m > 0.0
                && new.length_m.is_finite()
                && new.length_m > 0.0
            {
                let f = new.length_m / old.length_m;
                g.first_offset_m *= f;
                g.spacing_m *= f;
                g.thickness_m *= f.min(1.0);
            }
        }
    }
    patched_scene(&patched, &[], &[])
}

impl CcModel {
    /// A CC model of `scene` (with displacement-driven tendons) calibrating `params`;
    /// every driven tendon's reading column must be among `input_names`.
    pub fn new(
        scene: &Scene,
        params: &[ParamPath],
        input_names: &[String],
    ) -> Result<Self, CalibrationError> {
        let reading_columns = ServoModel::reading_columns(scene);
        if reading_columns.is_empty() {
            return Err(CalibrationError::BadInput(
                "the CC rung needs displacement-driven tendons (their readings)".into(),
            ));
        }
        let columns = super::readings_model::reading_positions(&reading_columns, input_names)?;
        let values = params
            .iter()
            .map(|p| p.value(scene))
            .collect::<Result<Vec<_>, _>>()?;
        let cc = Self::build(scene)?;
        Ok(Self {
            scene: scene.clone(),
            params: params.to_vec(),
            values,
            q: vec![0.0; columns.len()],
            columns,
            scale: scene.readings.as_ref().map_or(1.0, |r| r.scale_m),
            cc,
            cond: Conditioning::from_spec(scene.readings.as_ref()),
            conditioned: None,
        })
    }

    fn build(scene: &Scene) -> Result<ConstantCurvature, CalibrationError> {
        let robot = scene
            .build_robot()
            .map_err(model_err("CC rung: scene".into()))?;
        ConstantCurvature::new(robot, CcSettings::default()).map_err(ladder_err("CC rung".into()))
    }

    /// Current parameter values.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Robot length (m) at the current values.
    pub fn robot_length(&self) -> f64 {
        self.cc.robot().length()
    }

    /// The scene at the current values (guides scaled with the lengths).
    pub fn scene(&self) -> Result<Scene, CalibrationError> {
        cc_scene(&self.scene, &self.params, &self.values)
    }
}

impl Clone for CcModel {
    fn clone(&self) -> Self {
        let scene = cc_scene(&self.scene, &self.params, &self.values)
            .expect("values this model already accepted");
        Self {
            scene: self.scene.clone(),
            params: self.params.clone(),
            values: self.values.clone(),
            columns: self.columns.clone(),
            scale: scene.readings.as_ref().map_or(1.0, |r| r.scale_m),
            cc: Self::build(&scene).expect("values this model already accepted"),
            q: self.q.clone(),
            cond: Conditioning::from_spec(scene.readings.as_ref()),
            conditioned: None,
        }
    }
}

impl CalibrationModel for CcModel {
    fn set_params(&mut self, values: &[f64]) -> Result<(), CalibrationError> {
        if values == self.values.as_slice() {
            return Ok(());
        }
        let scene = cc_scene(&self.scene, &self.params, values)?;
        self.cc = Self::build(&scene)?;
        self.scale = scene.readings.as_ref().map_or(1.0, |r| r.scale_m);
        self.cond = Conditioning::from_spec(scene.readings.as_ref());
        self.conditioned = None;
        self.values = values.to_vec();
        Ok(())
    }

    fn predict(&mut self, row: &RecordingRow) -> Result<Pose, CalibrationError> {
        conditioned_into(
            &self.cond,
            &mut self.conditioned,
            &self.columns,
            self.scale,
            row,
            &mut self.q,
        )?;
        self.cc
            .solve_readings(&self.q)
            .map_err(ladder_err(format!("line {}: CC rung", row.line)))?;
        let out = self.cc.output();
        out.tip().cloned().ok_or_else(|| {
            CalibrationError::BadInput(format!("line {}: CC rung: no tip pose", row.line))
        })
    }
}
