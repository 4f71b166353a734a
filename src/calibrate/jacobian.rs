//! The calibration's residuals and their Jacobian at a chosen parameter vector, as
//! [`super::calibrate`]'s Levenberg-Marquardt sees them (without priors): for
//! inspecting a model's sensitivities, and for checking them against
//! finite differences (`tests/calibrate_sensitivities.rs`).
//!
//! Layout of `x` and of the Jacobian's columns: the setup's scene parameters (their
//! units), then [`super::frame_param_names`]: the capture frame's rotation vector
//! (rad) and translation (m), the marker offset (m). Residual rows: `3 i + a` is
//! coordinate `a` of row `i`, `(P_i + Q_i o - (R(w) m_i + t)) / sigma` (see
//! [`super::calibrate`]). Scene columns come from the model's
//! [`CalibrationModel::sensitivities`] (central differences unless the model has
//! exact ones) combined with the offset, `dP + w x (Q o)`; frame and offset columns
//! are analytic.

use super::lm::LeastSquares;
use super::model::CalibrationModel;
use super::problem::Problem;
use super::run::CalibrationSetup;
use super::{CalibrationError, CalibrationSettings};
use nalgebra::DMatrix;

/// The residuals (`3 x rows`, whitened by the capture noise) at `x`, and with
/// `jacobian` their derivatives `dr/dx` (`3 rows x (scene + 9)`, per unit of each
/// `x`). The setup's train rows are solved in sequence (warm) in
/// `settings.threads` chunks; finite-difference steps are `settings.fd_step` times
/// each parameter's scale. A row whose solve fails is an error here (naming it).
pub fn residuals_and_jacobian<M: CalibrationModel + Clone>(
    setup: &CalibrationSetup<'_, M>,
    settings: &CalibrationSettings,
    x: &[f64],
    jacobian: bool,
) -> Result<(Vec<f64>, Option<DMatrix<f64>>), CalibrationError> {
    let ns = setup.params.len();
    if x.len() != ns + 9 {
        return Err(CalibrationError::BadInput(format!(
            "{} values for {ns} scene parameters + 9 frame and offset parameters",
            x.len()
        )));
    }
    let steps = setup
        .params
        .iter()
        .map(|p| settings.fd_step * p.scale)
        .collect();
    let mut pb = Problem::new(
        setup.model,
        &setup.train.rows,
        x.to_vec(),
        vec![1.0; ns + 9],
        steps,
        settings.capture_noise_m,
        settings.threads,
    );
    // every row must solve: a failure is an error, not a left-out row
    pb.locked = true;
    pb.free = (0..ns + 9).collect();
    let mut r = vec![0.0; pb.residual_count()];
    pb.residuals(x, &mut r)?;
    if !jacobian {
        return Ok((r, None));
    }
    let mut jac = DMatrix::zeros(r.len(), ns + 9);
    pb.jacobian(x, &r, &mut jac)?;
    Ok((r, Some(jac)))
}
