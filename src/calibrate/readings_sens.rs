//! Sensitivities of [`ServoModel`]'s poses to the calibration parameters by the
//! implicit function theorem, from the converged state each row's prediction left
//! (no row is solved again).
//!
//! A converged row is a zero of the joint residual of the tendon solve
//! (`crate::tendons`, joint path): `F(z; p) = [r(x, T; p); G(x, T; q, p)] = 0` in
//! `z = [x; T]`, the scaled shooting unknowns and the driven tendons' tensions, with
//! `r` the scaled boundary residual and, per taut tendon,
//! `G_i = c_i(L_f,i) T_i + L_f,i - l_i(x, T)` (`L_f,i = L0_i - q_i`, `c_i` the
//! compliance: `crate::tendons::TendonMechanics`); a slack tendon keeps `T_i = 0`.
//! With the active set held (each tendon clearly taut or slack),
//!
//! ```text
//! F_z dz/dp_k = -dF/dp_k            (implicit function theorem)
//! dP/dp_k = d/dh P(z + h dz/dp_k; p + h e_k) at h = 0
//! ```
//!
//! `F_z` is exact, from one dual sweep (`Workspace::joint_jacobians`): the same
//! generalized Jacobian as the joint Newton's. `dF/dp_k` is a central difference of
//! `F` at the fixed converged `z` (one `f64` pass per side: the workspace of the
//! perturbed scene evaluated at `z`, or only `G` with the perturbed readings for a
//! `readings/...` parameter, whose conditioning changes `q` and nothing else); the
//! pose's total derivative is a central difference along the tangent
//! `(dz/dp_k, e_k)`, two more passes (`Workspace::solution` at the two points). Per
//! row and parameter that is 4 passes (2 for a readings parameter), and one sweep
//! per row, against the two full solves of a central difference of the poses
//! ([`super::super::finite_differences`], each a warm solve of 5-9 Newton
//! iterations). Step `h` is the finite-difference step the
//! calibration gives (`fd_step` times the parameter's scale); the differences are of
//! smooth functions at fixed `z` (truncation `h^2`), not of converged solves, so the
//! solver tolerance does not enter them.
//!
//! The conditioning of the readings (time offset, backlash) has no derivative here:
//! `dq/dp` is the central difference of the conditioned readings, checked against
//! the forward difference as the pose differences were
//! ([`Sensitivities::fd_disagreement`]: the backlash's play switches within a step).
//!
//! Fallback to [`super::super::finite_differences`]: with capstan friction (the
//! row's pose depends on the direction memory of the chain, not on `z` alone), or
//! when a row's sweep or `F_z` fails (singular).

use super::{conditioned_into, model_err, ServoModel};
use crate::calibrate::conditioning::{Conditioning, InputTimeline};
use crate::calibrate::frame::rotation_vector;
use crate::calibrate::model::{
    finite_differences, identity_pose, marker_body_pose, patched_scene, CalibrationModel,
    Sensitivities,
};
use crate::calibrate::recording::RecordingRow;
use crate::calibrate::CalibrationError;
use crate::math::DenseLu;
use crate::statics::Pose;
use crate::tendons::ift::assemble_joint_jacobian;
use crate::tendons::{TendonMechanics, TendonWorkspace};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// The fallback's differences are of converged solves, whose noise is the solve's
/// tolerance (a tendon mismatch of `TendonSettings::tolerance_m`, ~1e-7 m in the
/// shipped scenes), not rounding: with the calibration's step (`fd_step`, 1e-5 of
/// the scale) a tip that moves ~10 mm per unit relative change moves ~1e-7 m, the
/// size of that noise, and the central and forward differences disagreed by
/// 50-110 % on FTDCR v4 with friction. A central difference's error is
/// `h^2 f'''/6 + noise/h`; relative noise ~1e-5 puts its minimum near `h ~ 3e-2`;
/// 100 times the step (1e-3 of the scale) keeps the noise term near 1 % and the
/// step far inside the parameters' ranges.
const SOLVE_STEP_FACTOR: f64 = 100.0;

/// A converged row: its conditioned readings (m), shooting unknowns, tensions (N),
/// taut flags and marker body pose.
#[derive(Clone, Debug)]
pub(super) struct RowState {
    q: Vec<f64>,
    x: Vec<f64>,
    t: Vec<f64>,
    taut: Vec<bool>,
    pose: Pose,
}

impl RowState {
    /// The state `ws` converged to for readings `q`.
    pub(super) fn of(ws: &TendonWorkspace, q: &[f64], pose: Pose) -> Self {
        Self {
            q: q.to_vec(),
            x: ws.workspace().unknowns_vector().to_vec(),
            t: ws.tensions().to_vec(),
            taut: ws.taut().to_vec(),
            pose,
        }
    }
}

/// One side (`p +- h e_k`) of a parameter's difference.
struct Side {
    /// The perturbed scene's tendon workspace, its tendons' mechanics and rest free
    /// lengths; `None` for a readings parameter (the base workspace's, which it
    /// leaves unchanged).
    ws: Option<(TendonWorkspace, Vec<TendonMechanics>, Vec<f64>)>,
    cond: Conditioning,
    cache: Option<(Arc<InputTimeline>, Vec<f64>)>,
    /// Conditioned readings of the current row (m).
    q: Vec<f64>,
}

/// Mechanics and rest free lengths of a tendon workspace's driven tendons.
fn mechanics(ws: &TendonWorkspace) -> (Vec<TendonMechanics>, Vec<f64>) {
    let cables = ws.workspace().robot().cables();
    let mech = ws
        .driven()
        .iter()
        .map(|&j| {
            cables[j]
                .mechanics
                .expect("a driven tendon has mechanics (checked by TendonWorkspace)")
        })
        .collect();
    (mech, ws.rest_free_lengths().to_vec())
}

/// Tendon rows `G_i` of the joint residual at tensions `t`, path lengths `l` (all
/// cables), readings `q` (m); 0 for a slack tendon (its row is `T_i = 0`).
fn tendon_residual(
    ws: &TendonWorkspace,
    mech: &[TendonMechanics],
    free0: &[f64],
    st: &RowState,
    q: &[f64],
    l: &[f64],
    g: &mut [f64],
) {
    for (i, &j) in ws.driven().iter().enumerate() {
        g[i] = if st.taut[i] {
            let free = free0[i] - (q[i] - mech[i].zero_offset_m);
            mech[i].covered(free, st.t[i], 1.0) - l[j]
        } else {
            0.0
        };
    }
}

impl ServoModel {
    /// [`CalibrationModel::sensitivities`] by the implicit function theorem (module
    /// docs), with [`finite_differences`] as the fallback.
    pub(super) fn exact_sensitivities(
        &mut self,
        values: &[f64],
        steps: &[f64],
        rows: &[RecordingRow],
        out: &mut Sensitivities,
        done: Option<&AtomicUsize>,
    ) -> Result<(), CalibrationError> {
        let count_all = |done: Option<&AtomicUsize>, k: usize| {
            if let Some(d) = done {
                d.fetch_add(k, Ordering::Relaxed);
            }
        };
        let solve_steps: Vec<f64> = steps.iter().map(|h| h * SOLVE_STEP_FACTOR).collect();
        if !self.ws.workspace().robot().friction().is_frictionless() {
            finite_differences(self, values, &solve_steps, rows, out)?;
            count_all(done, rows.len());
            return Ok(());
        }
        self.set_params(values)?;
        let n = values.len();
        out.resize(rows.len(), n);
        out.fd_disagreement = vec![0.0; n];
        // every row's converged state at `values` (solved again, in sequence, only
        // when one is missing or belongs to other readings)
        let mut q_rows = Vec::with_capacity(rows.len());
        for row in rows {
            self.conditioned_readings(row)?;
            q_rows.push(self.q.clone());
        }
        let missing = rows
            .iter()
            .zip(&q_rows)
            .any(|(r, q)| self.states.get(&r.line).is_none_or(|s| &s.q != q));
        let mut failed = Vec::new();
        if missing {
            self.begin_chain();
            for (i, row) in rows.iter().enumerate() {
                if let Err(f) = self.predict_retrying(row)? {
                    failed.push((i, f));
                }
            }
        }
        let mut counted = 0;
        if !self.exact_rows(values, steps, rows, &failed, out, (done, &mut counted))? {
            // (the fallback redoes the rows counted so far)
            if let Some(d) = done {
                d.fetch_sub(counted, Ordering::Relaxed);
            }
            self.restart();
            finite_differences(self, values, &solve_steps, rows, out)?;
            count_all(done, rows.len());
            return Ok(());
        }
        for (i, _) in &failed {
            out.poses[*i] = identity_pose();
        }
        out.failed = failed;
        // the base workspace was moved to other points: the next row starts cold
        self.restart();
        Ok(())
    }

    /// The exact sensitivities of every row not in `failed` into `out`; `false` when
    /// a row's sweep or `F_z` failed (the caller falls back).
    fn exact_rows(
        &mut self,
        values: &[f64],
        steps: &[f64],
        rows: &[RecordingRow],
        failed: &[(usize, super::super::RowFailure)],
        out: &mut Sensitivities,
        (done, counted): (Option<&AtomicUsize>, &mut usize),
    ) -> Result<bool, CalibrationError> {
        let n = values.len();
        // the two sides of each parameter
        let mut sides: Vec<[Side; 2]> = Vec::with_capacity(n);
        let mut x = values.to_vec();
        for k in 0..n {
            let readings_only = self.params[k].as_str().starts_with("readings/");
            let mut side = |v: f64| -> Result<Side, CalibrationError> {
                x[k] = v;
                let scene = patched_scene(&self.scene, &self.params, &x)?;
                let ws = if readings_only {
                    None
                } else {
                    let mut ws = scene
                        .tendon_workspace()
                        .map(TendonWorkspace::without_rollback)
                        .map_err(model_err(format!("scene with {x:?}")))?;
                    ws.workspace_mut().set_local_tolerance(0.0);
                    let (mech, free0) = mechanics(&ws);
                    Some((ws, mech, free0))
                };
                Ok(Side {
                    ws,
                    cond: Conditioning::from_spec(scene.readings.as_ref()),
                    cache: None,
                    q: vec![0.0; self.columns.len()],
                })
            };
            let plus = side(values[k] + steps[k])?;
            let minus = side(values[k] - steps[k])?;
            x[k] = values[k];
            sides.push([plus, minus]);
        }
        let ws = self.ws.workspace();
        let nx = ws.unknowns();
        let p = self.ws.driven().len();
        let nc = ws.robot().cables().len();
        let w = nx + ws.params().len();
        let m = nx + p;
        let (mech, free0) = mechanics(&self.ws);
        let mut jac_s = vec![0.0; nx * w];
        let mut jac_m = vec![0.0; nc * w];
        let mut lu = DenseLu::new(m);
        let (mut l0, mut l1) = (vec![0.0; nc], vec![0.0; nc]);
        let mut g = vec![0.0; p];
        let mut dz = vec![0.0; m];
        let (mut xs, mut ts) = (vec![0.0; nx], vec![0.0; p]);
        let mut worst = vec![(0.0f64, 0.0f64); n];
        self.ws.workspace_mut().set_local_tolerance(0.0);
        for (i, row) in rows.iter().enumerate() {
            if let Some(d) = done {
                d.fetch_add(1, Ordering::Relaxed);
                *counted += 1;
            }
            if failed.iter().any(|(j, _)| *j == i) {
                continue;
            }
            self.conditioned_readings(row)?;
            let st = self.states.get(&row.line).expect("every row solved above");
            let (st, q0) = (st.clone(), self.q.clone());
            // F_z at the converged point (one pass to settle it, then the sweep)
            let base = self.ws.workspace_mut();
            base.set_theta(&st.t);
            if !base.adopt_unknowns(&st.x, true).is_finite()
                || !base.joint_jacobians(&st.x, &mut jac_s, &mut jac_m)
            {
                return Ok(false);
            }
            base.cable_lengths_into(&mut l0);
            assemble_joint_jacobian(
                nx,
                w,
                &jac_s,
                &jac_m,
                self.ws.driven(),
                &mech,
                |ti| free0[ti] - (q0[ti] - mech[ti].zero_offset_m),
                &st.t,
                &st.taut,
                lu.matrix_mut(),
            );
            if !matches!(lu.factor(), Some(rc) if rc > 1e-14) {
                return Ok(false);
            }
            out.poses[i] = st.pose;
            for (k, sd) in sides.iter_mut().enumerate() {
                let h = steps[k];
                dz.fill(0.0);
                for (s, side) in sd.iter_mut().enumerate() {
                    let sign = if s == 0 { 1.0 } else { -1.0 };
                    conditioned_into(
                        &side.cond,
                        &mut side.cache,
                        &self.columns,
                        self.scale,
                        row,
                        &mut side.q,
                    )?;
                    // dF/dp_k: F at the converged z with the side's scene and readings
                    match side.ws.as_mut() {
                        Some((sw, mech_s, free_s)) => {
                            let wsp = sw.workspace_mut();
                            wsp.set_theta(&st.t);
                            if !wsp.adopt_unknowns(&st.x, true).is_finite() {
                                return Ok(false);
                            }
                            for (d, r) in dz[..nx].iter_mut().zip(wsp.residual_vector()) {
                                *d += sign * r;
                            }
                            wsp.cable_lengths_into(&mut l1);
                            tendon_residual(sw, mech_s, free_s, &st, &side.q, &l1, &mut g);
                        }
                        None => tendon_residual(&self.ws, &mech, &free0, &st, &side.q, &l0, &mut g),
                    }
                    for (d, gi) in dz[nx..].iter_mut().zip(&g) {
                        *d += sign * gi;
                    }
                }
                // dz/dp_k = -F_z^-1 dF/dp_k (dz holds 2h dF/dp_k)
                for d in dz.iter_mut() {
                    *d /= -2.0 * h;
                }
                lu.solve_in_place(&mut dz);
                for (ti, taut) in st.taut.iter().enumerate() {
                    if !taut {
                        dz[nx + ti] = 0.0;
                    }
                }
                // the pose along the tangent (z + h dz, p + h e_k), both sides
                let mut poses = [identity_pose(); 2];
                for (s, side) in sd.iter_mut().enumerate() {
                    let sign = if s == 0 { 1.0 } else { -1.0 };
                    for (v, (a, d)) in xs.iter_mut().zip(st.x.iter().zip(&dz[..nx])) {
                        *v = a + sign * h * d;
                    }
                    for (v, (a, d)) in ts.iter_mut().zip(st.t.iter().zip(&dz[nx..])) {
                        *v = a + sign * h * d;
                    }
                    let sw = match side.ws.as_mut() {
                        Some((sw, _, _)) => sw,
                        None => &mut self.ws,
                    }
                    .workspace_mut();
                    sw.set_theta(&ts);
                    // (no pass here: `solution` runs its own at the adopted point)
                    sw.adopt_unknowns(&xs, false);
                    let sol = sw.solution();
                    if !sol.tip().position.iter().all(|v| v.is_finite()) {
                        return Ok(false);
                    }
                    poses[s] = marker_body_pose(&sol, self.marker_s);
                }
                out.d_position[i * n + k] = (poses[0].position - poses[1].position) / (2.0 * h);
                out.d_rotation[i * n + k] =
                    rotation_vector(&(poses[0].rotation * poses[1].rotation.transpose()))
                        / (2.0 * h);
                // check of the readings' differences: central against forward
                let (wk, sk) = &mut worst[k];
                for ((qp, qm), q) in sd[0].q.iter().zip(&sd[1].q).zip(&q0) {
                    let central = (qp - qm) / (2.0 * h);
                    let forward = (qp - q) / h;
                    *wk = wk.max((central - forward).abs());
                    *sk = sk.max(central.abs()).max(forward.abs());
                }
            }
        }
        for (d, (wk, sk)) in out.fd_disagreement.iter_mut().zip(worst) {
            *d = if sk > 0.0 { wk / sk } else { 0.0 };
        }
        Ok(true)
    }
}
