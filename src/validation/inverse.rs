//! Table 4.5 as an inverse experiment: from the observed cable deflections
//! (0.5 ... 1.0 cm) estimate the tip masses (17.2 ... 83.2 g) with the estimator on
//! the average-mass scene of table 4.3, with the values fitted to the thesis's
//! predicted columns (E, hole radius, first-disk offset; `fitted.toml`).
//!
//! Nothing here is tuned to the inverse result: the scene and fitted values are the
//! forward ones. Encoder noise: the thesis read the notch on a 1 mm ruler, so the
//! reading error is modelled as uniform over 1 mm, sigma = 1 mm / sqrt(12).

use super::{FittedFile, Target, ValidationError};
use crate::estimate::{EstimateSpec, EstimateStatus, Estimator, Fit, UnknownKind, UnknownSpec};
use crate::files::demo::DataSource;
use std::path::Path;

/// One row of the inverse experiment.
#[derive(Clone, Debug, PartialEq)]
pub struct InverseRow {
    /// Tip mass the thesis hung (kg).
    pub truth_kg: f64,
    /// Observed cable deflection (m).
    pub observed_change_m: f64,
    /// Estimated tip mass (kg).
    pub estimate_kg: f64,
    /// Its standard deviation from the reading noise (kg).
    pub std_kg: f64,
    /// Estimator status.
    pub status: EstimateStatus,
    /// Fit quality: one cable for one unknown has no redundancy, so `untestable`
    /// unless the mass bound stops the fit short of the data (then `poor`).
    pub fit: Fit,
    /// RMS of the residual in reading-noise sigmas (-).
    pub rms_sigma: f64,
    /// The model's deflection at the true mass (m), for comparison.
    pub model_change_m: f64,
}

/// Ruler reading noise: uniform over 1 mm.
pub const READING_SIGMA_M: f64 = 1e-3 / 3.464_101_615_137_754_6;

/// Run the experiment on `dir` (`data/thesis`). Rows with zero mass are skipped
/// (they define the reference).
pub fn table_4_5_inverse(dir: &Path) -> Result<Vec<InverseRow>, ValidationError> {
    table_4_5_inverse_from(&DataSource::Dir(dir.to_path_buf()))
}

/// [`table_4_5_inverse`] on a directory on disk or the embedded `data/thesis`.
pub fn table_4_5_inverse_from(src: &DataSource) -> Result<Vec<InverseRow>, ValidationError> {
    let table = src.table("table_4_5.csv")?;
    let masses = table.col_si("tip_mass_g")?;
    let deltas = table.col_si("obs_delta_cm")?;
    let scene = src.scene("table_4_3.toml")?;
    let fitted = FittedFile::load_from(src)?;
    let mut scene = match fitted.get("table_4_3.toml", Target::Predicted) {
        Some(r) => r.apply(&scene)?,
        None => scene,
    };
    // the reference is the unloaded rod (the thesis zeroed the notch at 0 g)
    for p in &mut scene.loads.point {
        p.mass_kg = 0.0;
    }
    let mut est = mass_estimator(&scene)?;
    let mut rows = Vec::new();
    for (m, d) in masses.iter().zip(&deltas) {
        if *m <= 0.0 {
            continue;
        }
        // the model's own deflection at the true mass (a plain forward solve)
        let reference = est.reference_lengths()[0];
        let ws = est.workspace();
        ws.set_theta(&[*m]);
        let rep = ws.solve(crate::Start::Warm);
        let mut len = [0.0];
        ws.cable_lengths_into(&mut len);
        let model_change = if rep.status.is_converged() {
            len[0] - reference
        } else {
            f64::NAN
        };
        est.set_theta(&[0.0]);
        let status = est.tick(&[*d], None);
        let e = est.estimate();
        rows.push(InverseRow {
            truth_kg: *m,
            observed_change_m: *d,
            estimate_kg: e.values[0],
            std_kg: e.std_dev[0],
            status,
            fit: e.fit,
            rms_sigma: e.rms_sigma,
            model_change_m: model_change,
        });
    }
    Ok(rows)
}

/// The estimator of the tip mass (`loads.point[0]`, >= 0) from the one cable's
/// reading, reading noise [`READING_SIGMA_M`]; the reference is `scene`'s loads
/// (set the mass to 0 first: the thesis zeroed the notch at 0 g).
pub(super) fn mass_estimator(scene: &crate::files::Scene) -> Result<Estimator, ValidationError> {
    let model = |context: &str, e: crate::ModelError| ValidationError::Model {
        context: context.into(),
        cause: e,
    };
    let robot = scene
        .build_robot()
        .map_err(|e| model("table 4.5 robot", e))?;
    let mut spec = EstimateSpec::new(vec![UnknownSpec {
        kind: UnknownKind::Mass,
        section: Some(0),
        axis: None,
        cable: None,
        name: Some("tip_mass".into()),
        min: Some(0.0),
        max: None,
        prior_mean: None,
        prior_sigma: None,
        reference: 0.0,
        initial: 0.0,
    }]);
    spec.noise_m = READING_SIGMA_M;
    spec.max_iterations = 50;
    Estimator::new(robot, scene.loads.clone(), scene.numerics.clone(), spec).map_err(|e| match e {
        crate::estimate::EstimateError::Model(m) => model("table 4.5 estimator", m),
        crate::estimate::EstimateError::Reference(st) => ValidationError::NotConverged {
            table: "4.5".into(),
            row: 0,
            status: st,
            residual: f64::NAN,
        },
    })
}
