//! The least-squares problem of a calibration: the model's poses of every train
//! row (solved in contiguous chunks over worker threads, rows warm-started in
//! sequence within a chunk), the capture frame and marker offset, whitened by the
//! capture noise, with Gaussian priors (see [`super::calibrate`] for the residual).

use super::fit::{RowWork, RowsProgress};
use super::lm::LeastSquares;
use super::model::{identity_pose, CalibrationModel, RowFailure, Sensitivities};
use super::recording::RecordingRow;
use super::CalibrationError;
use crate::math::exp_so3;
use crate::statics::Pose;
use nalgebra::{DMatrix, Matrix3, Vector3};
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// Index layout of the full parameter vector: scene, rotation vector, translation, offset.
const FRAME: usize = 0;
const TRANS: usize = 3;
const OFFSET: usize = 6;

pub(super) struct Problem<'a, M> {
    pub(super) models: Vec<M>,
    pub(super) chunks: Vec<Range<usize>>,
    pub(super) rows: &'a [RecordingRow],
    pub(super) ns: usize,
    pub(super) full: Vec<f64>,
    pub(super) free: Vec<usize>,
    pub(super) scale: Vec<f64>,
    pub(super) priors: Vec<(usize, f64, f64)>,
    pub(super) noise: f64,
    pub(super) steps: Vec<f64>,
    pub(super) poses: Vec<Pose>,
    pub(super) poses_at: Option<Vec<f64>>,
    pub(super) sens: Sensitivities,
    pub(super) sens_at: Option<Vec<f64>>,
    pub(super) fd_disagreement: Vec<f64>,
    /// Per row: left out of the fit (residual and Jacobian rows zero) because its
    /// solve failed while the set was open (see [`Problem::admit`]).
    pub(super) excluded: Vec<bool>,
    /// The failures that excluded rows, in the order found (row index, failure).
    pub(super) exclusions: Vec<(usize, RowFailure)>,
    /// Once set, a row failing outside the excluded set makes the evaluation an
    /// error (a rejected LM trial) instead of extending the set.
    pub(super) locked: bool,
    /// Told the rows done of each model evaluation while it runs.
    pub(super) report: Option<&'a dyn Fn(RowsProgress)>,
}

/// Work on one chunk of rows with one model, counting the rows it has done.
type ChunkFn<'f, M, T> =
    dyn Fn(&mut M, &[RecordingRow], &AtomicUsize) -> Result<T, CalibrationError> + Sync + 'f;

/// Interval of the rows reports.
const REPORT_EVERY: Duration = Duration::from_millis(100);

fn run_chunks<M: CalibrationModel, T: Send>(
    models: &mut [M],
    chunks: &[Range<usize>],
    rows: &[RecordingRow],
    (work, report): (RowWork, Option<&dyn Fn(RowsProgress)>),
    f: &ChunkFn<'_, M, T>,
) -> Result<Vec<T>, CalibrationError> {
    let done = AtomicUsize::new(0);
    if models.len() == 1 && report.is_none() {
        return Ok(vec![f(&mut models[0], &rows[chunks[0].clone()], &done)?]);
    }
    std::thread::scope(|s| {
        let handles: Vec<_> = models
            .iter_mut()
            .zip(chunks)
            .map(|(m, c)| {
                let (rows, done) = (&rows[c.clone()], &done);
                s.spawn(move || f(m, rows, done))
            })
            .collect();
        if let Some(report) = report {
            // this thread only waits: it reports the workers' count at the start,
            // now and then, and at the end
            let total = rows.len();
            let tell = || {
                let done = done.load(Ordering::Relaxed);
                report(RowsProgress { work, done, total });
            };
            tell();
            let mut last = Instant::now();
            while !handles.iter().all(|h| h.is_finished()) {
                std::thread::sleep(Duration::from_millis(10));
                if last.elapsed() >= REPORT_EVERY {
                    tell();
                    last = Instant::now();
                }
            }
            tell();
        }
        handles
            .into_iter()
            .map(|h| h.join().expect("a calibration worker panicked"))
            .collect()
    })
}

impl<'a, M: CalibrationModel + Clone> Problem<'a, M> {
    /// A problem over `rows` with one model clone per chunk of rows (`threads`), at
    /// the full parameter vector `full` (scene values, then [`super::frame_param_names`]),
    /// unknowns `full[k] / scale[k]`, finite-difference steps `steps` (scene units),
    /// capture noise `noise` (m); nothing free, no priors, the failed-row set open.
    pub(super) fn new(
        model: &M,
        rows: &'a [RecordingRow],
        full: Vec<f64>,
        scale: Vec<f64>,
        steps: Vec<f64>,
        noise: f64,
        threads: usize,
    ) -> Self {
        let chunks = chunks(rows.len(), threads);
        Self {
            models: vec![model.clone(); chunks.len()],
            chunks,
            rows,
            ns: steps.len(),
            full,
            free: Vec::new(),
            scale,
            priors: Vec::new(),
            noise,
            steps,
            poses: Vec::new(),
            poses_at: None,
            sens: Sensitivities::default(),
            sens_at: None,
            fd_disagreement: Vec::new(),
            excluded: vec![false; rows.len()],
            exclusions: Vec::new(),
            locked: false,
            report: None,
        }
    }
}

impl<M: CalibrationModel> Problem<'_, M> {
    pub(super) fn scene_values(&self, full: &[f64]) -> Vec<f64> {
        full[..self.ns].to_vec()
    }
    pub(super) fn frame(&self, full: &[f64]) -> (Matrix3<f64>, Vector3<f64>, Vector3<f64>) {
        let b = self.ns;
        let w = Vector3::new(full[b + FRAME], full[b + FRAME + 1], full[b + FRAME + 2]);
        let t = Vector3::new(full[b + TRANS], full[b + TRANS + 1], full[b + TRANS + 2]);
        let o = Vector3::new(full[b + OFFSET], full[b + OFFSET + 1], full[b + OFFSET + 2]);
        (exp_so3(&w), t, o)
    }
    pub(super) fn expand(&self, z: &[f64]) -> Vec<f64> {
        let mut x = self.full.clone();
        for (i, &k) in self.free.iter().enumerate() {
            x[k] = z[i] * self.scale[k];
        }
        x
    }
    /// Rows whose solve failed at the current evaluation (`failed`: row index and
    /// failure). While the set is open (not `locked`)
    /// they join the excluded rows; once locked, a failure outside the set is
    /// returned as [`CalibrationError::NotConverged`] (the LM rejects that trial, so
    /// that costs are always compared over the same rows).
    fn admit(&mut self, failed: &[(usize, RowFailure)]) -> Result<(), CalibrationError> {
        for &(i, f) in failed {
            if self.excluded[i] {
                continue;
            }
            if self.locked {
                return Err(CalibrationError::NotConverged {
                    line: f.line,
                    status: f.status,
                    residual: f.residual,
                });
            }
            self.excluded[i] = true;
            self.exclusions.push((i, f));
        }
        Ok(())
    }
    /// Whether row `i` is in the fit.
    pub(super) fn included(&self, i: usize) -> bool {
        !self.excluded[i]
    }
    /// Number of rows in the fit.
    pub(super) fn included_count(&self) -> usize {
        self.excluded.iter().filter(|x| !**x).count()
    }
    pub(super) fn ensure_poses(&mut self, values: &[f64]) -> Result<(), CalibrationError> {
        if self.poses_at.as_deref() == Some(values) {
            return Ok(());
        }
        self.poses_at = None;
        let work = (RowWork::Solve, self.report);
        let out = run_chunks(
            &mut self.models,
            &self.chunks,
            self.rows,
            work,
            &|m, rows, done| {
                m.set_params(values)?;
                m.begin_chain();
                rows.iter()
                    .map(|r| {
                        let p = m.predict_retrying(r);
                        done.fetch_add(1, Ordering::Relaxed);
                        p
                    })
                    .collect::<Result<Vec<_>, _>>()
            },
        )?;
        let mut failed = Vec::new();
        self.poses.clear();
        for (i, r) in out.into_iter().flatten().enumerate() {
            match r {
                Ok(p) => self.poses.push(p),
                Err(f) => {
                    self.poses.push(identity_pose());
                    failed.push((i, f));
                }
            }
        }
        self.admit(&failed)?;
        self.poses_at = Some(values.to_vec());
        Ok(())
    }
    pub(super) fn ensure_sens(&mut self, values: &[f64]) -> Result<(), CalibrationError> {
        if self.sens_at.as_deref() == Some(values) {
            return Ok(());
        }
        let steps = self.steps.clone();
        let work = (RowWork::Sensitivities, self.report);
        let out = run_chunks(
            &mut self.models,
            &self.chunks,
            self.rows,
            work,
            &|m, rows, done| {
                let mut s = Sensitivities::default();
                m.sensitivities_counting(values, &steps, rows, &mut s, done)?;
                Ok(s)
            },
        )?;
        let mut all = Sensitivities {
            params: self.ns,
            ..Sensitivities::default()
        };
        let mut dis = vec![0.0f64; 0];
        let mut failed = Vec::new();
        for (c, s) in out.into_iter().enumerate() {
            let first = self.chunks[c].start;
            failed.extend(s.failed.iter().map(|(i, f)| (first + i, *f)));
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
        if let Err(e) = self.admit(&failed) {
            self.poses_at = None;
            self.sens_at = None;
            return Err(e);
        }
        self.poses = all.poses.clone();
        self.poses_at = Some(values.to_vec());
        self.sens = all;
        self.sens_at = Some(values.to_vec());
        self.fd_disagreement = dis;
        Ok(())
    }
    /// Model marker and measured marker in the base frame, per row, at `full`.
    pub(super) fn points(&self, full: &[f64]) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
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
            let r = if self.excluded[i] {
                Vector3::zeros()
            } else {
                (p - m) / self.noise
            };
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
                if self.excluded[i] {
                    continue;
                }
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

pub(super) fn chunks(n: usize, threads: usize) -> Vec<Range<usize>> {
    let t = threads.clamp(1, n.max(1));
    (0..t).map(|i| i * n / t..(i + 1) * n / t).collect()
}

pub(super) fn rms(v: &[Vector3<f64>], w: &[Vector3<f64>]) -> f64 {
    (v.iter()
        .zip(w)
        .map(|(a, b)| (a - b).norm_squared())
        .sum::<f64>()
        / v.len().max(1) as f64)
        .sqrt()
}

pub(super) fn spread(v: &[Vector3<f64>]) -> f64 {
    let c = v.iter().sum::<Vector3<f64>>() / v.len().max(1) as f64;
    rms(v, &vec![c; v.len()])
}
