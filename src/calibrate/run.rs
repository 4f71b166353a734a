//! [`calibrate`]: the stages of a calibration (model at the start values, a
//! closed-form capture frame with a unit check, LM on the frame alone, LM on
//! everything) and the report.

use super::fit::{
    CalibrationReport, CalibrationSettings, FailedRow, FitParam, FittedParam, FrameSetup, Progress,
    RowResult, RowsProgress, Split, Stage,
};
use super::frame::{kabsch, RigidTransform};
use super::lm::{levenberg_marquardt, Bounds, Huber, LmIteration, LmSettings, LmStatus};
use super::model::CalibrationModel;
use super::order::row_order;
use super::problem::{rms, spread, Problem};
use super::recording::{Recording, RecordingRow};
use super::stats::{parameter_statistics, TipErrors};
use super::CalibrationError;
use nalgebra::Vector3;
use std::cell::{Cell, RefCell};

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
/// train rows; report errors on train and val. `observer` sees every LM trial
/// and, about every 0.1 s, the rows done of the model evaluation in progress
/// ([`Progress::rows`]).
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
    if let Some(k) = settings.huber_sigma {
        crate::scene::calibration::check_huber_sigma("huber_sigma", k)
            .map_err(|e| CalibrationError::BadInput(e.to_string()))?;
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
        // a start outside the bounds is this parameter's error (clamping it to a
        // bound, e.g. a modulus of 2 Pa, failed later in a model check that named
        // another field). Within 1e-9 of a bound (relative) is on it: a value that a
        // calibration fitted onto its bound comes back from `x / scale * scale` an ulp
        // or two outside (3e10 Pa written as 29999999999.999996), and is clamped below.
        let near = |b: f64| (p.initial - b).abs() <= 1e-9 * b.abs().max(p.scale);
        let inside = p.lower <= p.initial && p.initial <= p.upper;
        if !(inside || near(p.lower) || near(p.upper)) {
            return bad(format!(
                "parameter {}: start value {} (the scene's) is outside its bounds [{}, {}]; widen the bounds or start inside them",
                p.name, p.initial, p.lower, p.upper
            ));
        }
    }
    let ns = params.len();
    // the row chain (see `chain_order`); results are reported in file order
    let chained: Vec<RecordingRow> = row_order(&train.rows, settings.row_order)
        .into_iter()
        .map(|i| train.rows[i].clone())
        .collect();
    let rows = &chained[..];
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
    // each row measures three coordinates: fewer than the values to fit (those
    // without a prior) cannot determine them (and a single row has no spread for
    // the unit check below to judge)
    let unknown = params.iter().filter(|p| p.prior.is_none()).count() + frame_free.len();
    let needed = unknown.div_ceil(3).max(2);
    if rows.len() < needed {
        return bad(format!(
            "{}: {} training row(s) give {} coordinates for {unknown} values to fit (parameters, capture frame, marker offset): at least {} rows are needed",
            train.file,
            rows.len(),
            3 * rows.len(),
            needed
        ));
    }
    let priors: Vec<(usize, f64, f64)> = params
        .iter()
        .enumerate()
        .filter_map(|(k, p)| p.prior.map(|(m, s)| (k, m, s)))
        .collect();
    let steps = params.iter().map(|p| settings.fd_step * p.scale).collect();
    // the observer is called by the LM's callbacks and, between them, while the
    // model's rows are evaluated (the last LM report is repeated with the rows)
    let observer = RefCell::new(observer);
    let last = Cell::new(Progress {
        stage: Stage::Start,
        lm: LmIteration {
            iteration: 0,
            cost: f64::NAN,
            damping: f64::NAN,
            accepted: true,
        },
        max_iterations: 0,
        rows: None,
    });
    let tell = |p: Progress| {
        last.set(p);
        (observer.borrow_mut())(&p);
    };
    let tell_rows = |r: RowsProgress| {
        let p = Progress {
            rows: Some(r),
            ..last.get()
        };
        (observer.borrow_mut())(&p);
    };
    let mut pb = Problem::new(
        model,
        rows,
        full.clone(),
        scale.clone(),
        steps,
        settings.capture_noise_m,
        settings.threads,
    );
    pb.report = Some(&tell_rows);
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
    // (rows that fail here, even from cold, are left out: see `Problem::admit`)
    pb.ensure_poses(&full[..ns])?;
    let keep: Vec<usize> = (0..rows.len()).filter(|&i| pb.included(i)).collect();
    let (model_pts, _) = pb.points(&full);
    let model_pts: Vec<Vector3<f64>> = keep.iter().map(|&i| model_pts[i]).collect();
    let meas_capture: Vec<Vector3<f64>> = keep.iter().map(|&i| rows[i].marker_m).collect();
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
        let model_pts: Vec<Vector3<f64>> = keep.iter().map(|&i| model_pts[i]).collect();
        let meas_base: Vec<Vector3<f64>> = keep.iter().map(|&i| meas_base[i]).collect();
        let rms_sigma = rms(&model_pts, &meas_base) / 3f64.sqrt() / settings.capture_noise_m;
        let (spread_meas, spread_model) = (spread(&meas_capture), spread(&model_pts));
        let ratio = spread_meas / spread_model.max(f64::MIN_POSITIVE);
        // a path that does not move (one row, or rows of one pose) says nothing
        // about the unit: no verdict then
        let judged = spread_meas > 0.0 && spread_model > 0.0;
        if judged && rms_sigma > settings.unit_check_sigma && !(0.01..=100.0).contains(&ratio) {
            let worst = model_pts
                .iter()
                .zip(&meas_base)
                .enumerate()
                .max_by(|a, b| {
                    (a.1 .0 - a.1 .1)
                        .norm()
                        .total_cmp(&(b.1 .0 - b.1 .1).norm())
                })
                .map(|(i, _)| rows[keep[i]].line)
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
            tell(Progress {
                stage: Stage::Frame,
                lm: *it,
                max_iterations: 50,
                rows: None,
            })
        })?;
        full = pb.expand(&res.z);
        pb.full = full.clone();
    }
    let frame_start = full.clone();
    // (the sensitivities at the start belong to the full stage's first point)
    let before = last.get();
    last.set(Progress {
        stage: Stage::Full,
        lm: LmIteration {
            iteration: 0,
            ..before.lm
        },
        max_iterations: settings.max_iterations,
        ..before
    });
    // the sensitivities at the start: rows failing in a perturbed solve are left out
    // too; then the set is closed (a trial point where another row fails is rejected)
    if ns > 0 {
        pb.ensure_sens(&full[..ns])?;
    }
    pb.locked = true;
    let failed_limit = (settings.max_failed_fraction * rows.len() as f64).floor() as usize;
    let too_many = pb.exclusions.len() > failed_limit;
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
        // too many failed rows: no step, only the report at the start values
        max_iterations: if too_many { 0 } else { settings.max_iterations },
        tolerance: settings.tolerance,
        huber,
        ..LmSettings::default()
    };
    let res = levenberg_marquardt(&mut pb, &z0, &bounds, &lm, &mut |it| {
        tell(Progress {
            stage: Stage::Full,
            lm: *it,
            max_iterations: settings.max_iterations,
            rows: None,
        })
    })?;
    let status = if too_many {
        LmStatus::TooManyFailedRows
    } else {
        res.status
    };
    if status == LmStatus::Stalled {
        warnings.push(format!(
            "the fit stalled after {} accepted steps, away from a minimum: {}; the values are \
             the last accepted point, not a fit (try other start values or bounds, or fewer \
             parameters)",
            res.iterations,
            res.last_rejection
                .as_deref()
                .unwrap_or("no trial was rejected")
        ));
    }
    full = pb.expand(&res.z);
    pb.full = full.clone();
    pb.ensure_poses(&full[..ns])?;
    let keep: Vec<usize> = (0..rows.len()).filter(|&i| pb.included(i)).collect();
    let mut failed_rows: Vec<FailedRow> = pb
        .exclusions
        .iter()
        .map(|(_, f)| FailedRow::new(Split::Train, f))
        .collect();
    failed_rows.sort_by_key(|f| f.line);
    if !failed_rows.is_empty() {
        warnings.push(format!(
            "{} of {} train rows left out: their solve failed even from cold ({}){}",
            failed_rows.len(),
            rows.len(),
            FailedRow::list(&failed_rows, 8),
            if too_many {
                format!(
                    "; more than {} % of the rows: not fitted (status too_many_failed_rows)",
                    settings.max_failed_fraction * 100.0
                )
            } else {
                String::new()
            }
        ));
    }
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
    let statistics =
        parameter_statistics(&jw, wssr, 3 * pb.included_count(), &free_names, &free_scale);
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
    let (model_all, meas_all) = pb.points(&full);
    let model_pts: Vec<Vector3<f64>> = keep.iter().map(|&i| model_all[i]).collect();
    let meas_base: Vec<Vector3<f64>> = keep.iter().map(|&i| meas_all[i]).collect();
    let rms_sigma = rms(&model_pts, &meas_base) / 3f64.sqrt() / settings.capture_noise_m;
    if rms_sigma > settings.unit_check_sigma {
        warnings.push(format!(
            "train residual is {rms_sigma:.1} capture-noise sigmas RMS ({:.3} mm): model error, a wrong \
             capture_noise_m, or a wrong unit of the marker columns",
            rms_sigma * settings.capture_noise_m * 1e3
        ));
    }
    let mut out_rows: Vec<RowResult> = keep
        .iter()
        .map(|&i| RowResult {
            split: Split::Train,
            line: rows[i].line,
            t_s: rows[i].t_s,
            measured_capture_m: rows[i].marker_m,
            measured_base_m: meas_all[i],
            model_base_m: model_all[i],
            weight: res.weights[3 * i],
            inputs: rows[i].inputs.clone(),
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
            m.begin_chain();
            let (mut a, mut b) = (Vec::new(), Vec::new());
            let val_rows: Vec<&RecordingRow> = row_order(&v.rows, settings.row_order)
                .into_iter()
                .map(|i| &v.rows[i])
                .collect();
            for row in val_rows {
                match m.predict_retrying(row)? {
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
                    Err(f) => failed_rows.push(FailedRow::new(Split::Val, &f)),
                }
            }
            let val_failed = failed_rows.iter().filter(|f| f.split == Split::Val);
            if val_failed.clone().next().is_some() {
                let list: Vec<FailedRow> = val_failed.cloned().collect();
                warnings.push(format!(
                    "{} of {} val rows not predicted: their solve failed even from cold ({})",
                    list.len(),
                    v.rows.len(),
                    FailedRow::list(&list, 8)
                ));
            }
            Some(TipErrors::of(&a, &b))
        }
    };
    // file order (lines are unique within a split's file), whatever the chain
    out_rows.sort_by_key(|r| (r.split != Split::Train, r.line));
    Ok(CalibrationReport {
        status,
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
        failed_rows,
    })
}
