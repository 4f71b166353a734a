//! Solving the sampled readings in warm chains, in parallel (module docs of
//! [`super`]).

use super::fold::fold_test;
use super::retry::{ok, solve_status, tip_and_marker, Outcome, RetryPass};
use super::sequence::{nearest_neighbour_order, nth_prime, radical_inverse};
use super::{SampleStatus, WorkspaceCloud, WorkspaceSettings};
use crate::error::ModelError;
use crate::robot::ActuatorLimits;
use crate::settings::TendonSettings;
use crate::statics::{SolveStatus, Start};
use crate::tendons::TendonWorkspace;
use nalgebra::Vector3;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Solve one sample's readings `q`, warm from the chain's last converged readings
/// `from` (updated on success): directly; else, when `settings.max_substeps > 0`,
/// by continuation along the segment from `from` to `q` (a step that fails is
/// halved, one that converges is doubled, at most `max_substeps` solves); else,
/// with `settings.cold_retry`, cold without a budget (`cold`: the workspace's
/// settings for it). `buf` is scratch of `q`'s length. Returns the status, the
/// status of the last solve and the rod passes spent.
fn solve_sample(
    ws: &mut TendonWorkspace,
    q: &[f64],
    from: &mut [f64],
    buf: &mut [f64],
    settings: &WorkspaceSettings,
    cold: &Option<(TendonSettings, TendonSettings)>,
) -> (SampleStatus, Option<SolveStatus>, u32) {
    let mut work = 0u32;
    let mut stop = solve_status(ws, q, Start::Warm, &mut work);
    if ok(stop) {
        from.copy_from_slice(q);
        return (SampleStatus::Converged, stop, work);
    }
    // (a failed solve is rolled back: the warm state is `from`'s again)
    let (mut t, mut h) = (0.0f64, 0.5f64);
    for _ in 0..settings.max_substeps {
        let tn = (t + h).min(1.0);
        for ((b, a), z) in buf.iter_mut().zip(from.iter()).zip(q) {
            *b = a + tn * (z - a);
        }
        // (a converged step short of `q` is not the sample's stop)
        let step = solve_status(ws, buf, Start::Warm, &mut work);
        if !ok(step) {
            stop = step;
        }
        if ok(step) {
            t = tn;
            if t >= 1.0 {
                from.copy_from_slice(q);
                return (SampleStatus::ConvergedStepped, step, work);
            }
            h *= 2.0;
        } else {
            h *= 0.5;
        }
    }
    if t > 0.0 {
        // the chain moved part of the way: that point is converged
        for ((b, a), z) in buf.iter_mut().zip(from.iter()).zip(q) {
            *b = a + t * (z - a);
        }
        from.copy_from_slice(buf);
    }
    if let Some((unbudgeted, budgeted)) = cold {
        // (settings valid: checked when the chain's workspace was set up)
        let solved = ws.set_tendon_settings(*unbudgeted).is_ok() && {
            stop = solve_status(ws, q, Start::Cold, &mut work);
            ok(stop)
        };
        if solved {
            from.copy_from_slice(q);
        }
        let _ = ws.set_tendon_settings(*budgeted);
        if solved {
            return (SampleStatus::ConvergedCold, stop, work);
        }
    }
    (SampleStatus::Failed, stop, work)
}

/// What every chain shares: the workspace it copies, the settings of the
/// sampling, of the in-chain cold retry and of the retry pass, and the progress.
struct Shared<'a> {
    base: &'a TendonWorkspace,
    settings: &'a WorkspaceSettings,
    cold: Option<(TendonSettings, TendonSettings)>,
    retry_settings: TendonSettings,
    p: usize,
    zero_unit: &'a [f64],
    done: &'a AtomicUsize,
    progress: &'a (dyn Fn(usize) + Sync),
}

impl Shared<'_> {
    fn tick(&self) {
        (self.progress)(self.done.fetch_add(1, Ordering::Relaxed) + 1);
    }

    /// One chain over the chunk's unit points and readings (chunk-local, `p` per
    /// sample): the first pass in nearest-neighbour order from reading 0, then the
    /// retry pass over its failed samples in the same order. Per chunk-local
    /// sample, its outcome.
    fn chain(&self, unit: &[f64], readings: &[f64]) -> Vec<Outcome> {
        let (p, settings) = (self.p, self.settings);
        let n = unit.len() / p;
        let retries = settings.retries();
        // a fresh copy per chunk: the result does not depend on the threads
        let mut ws = self.base.clone();
        let order = nearest_neighbour_order(unit, p, self.zero_unit);
        let mut out = vec![Outcome::failed(None, 0); n];
        let mut states: Vec<Option<TendonWorkspace>> = vec![None; if retries { n } else { 0 }];
        // each chain starts from reading 0 (a known converged state)
        let mut from = vec![0.0; p];
        let mut buf = vec![0.0; p];
        let mut w0 = 0u32;
        let start_ok = ok(solve_status(&mut ws, &from, Start::Warm, &mut w0))
            || ok(solve_status(&mut ws, &from, Start::Cold, &mut w0));
        for &j in &order {
            let q = &readings[j * p..(j + 1) * p];
            let (status, stop, work) = if start_ok {
                solve_sample(&mut ws, q, &mut from, &mut buf, settings, &self.cold)
            } else {
                (SampleStatus::Failed, None, 0)
            };
            let o = &mut out[j];
            o.status = status;
            o.stop = stop;
            o.work = work;
            if start_ok {
                o.residual_m = ws.report().residual_m;
            }
            if settings.fold_test && start_ok && !status.is_solved() {
                // from the chain's last converged readings (`ws`'s warm state once
                // the failed solve is rolled back), on a copy of `ws`
                let t = fold_test(&ws, &from, q, &self.retry_settings);
                o.fold = Some(t.class);
                o.fold_passes = t.passes;
            }
            if status.is_solved() {
                (o.tip, o.marker) = tip_and_marker(&mut ws, settings.marker_offset_m);
                if retries {
                    states[j] = Some(ws.clone().without_rollback());
                }
            }
            if !(retries && start_ok) || status.is_solved() {
                self.tick();
            }
        }
        if retries && start_ok {
            let mut pass = RetryPass {
                unit,
                readings,
                p,
                states,
                base: self.base,
                retry_settings: self.retry_settings,
                settings,
            };
            for &j in &order {
                if !out[j].status.is_solved() {
                    pass.retry(j, &mut out[j]);
                    self.tick();
                }
            }
        }
        out
    }
}

/// Sample the reachable workspace of `tw` over the box of `limits` (every driven
/// tendon bounded) by `settings.samples` Halton points, chained and solved in
/// parallel (module docs). `progress` is called with the number of samples done
/// after each one (from any thread). Errors: limits that are missing (unbounded),
/// of the wrong length, unordered or excluding 0, and settings out of range.
/// Samples that do not solve are counted in the cloud ([`SampleStatus::Failed`]),
/// not an error.
pub fn sample_workspace(
    tw: &TendonWorkspace,
    limits: &ActuatorLimits,
    settings: &WorkspaceSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<WorkspaceCloud, ModelError> {
    settings.validate()?;
    let columns = tw.columns().to_vec();
    limits.validate(&columns)?;
    let p = columns.len();
    if p == 0 {
        return Err(ModelError::Invalid {
            field: "robot.cables".into(),
            why: "no displacement-driven tendon: there are no readings to sample".into(),
        });
    }
    if let Some(i) = (0..p).find(|&i| !(limits.min_m[i].is_finite() && limits.max_m[i].is_finite()))
    {
        return Err(ModelError::Invalid {
            field: format!("robot.limits ({})", columns[i]),
            why: "the workspace samples the actuator box: every driven tendon needs finite \
                  limits (give [robot.limits] default, sections or tendons)"
                .into(),
        });
    }
    let mut base = tw.clone();
    let mut unbudgeted = *base.tendon_settings();
    unbudgeted.max_shooting_solves = unbudgeted
        .max_shooting_solves
        .min(settings.max_shooting_solves);
    unbudgeted.max_passes = None;
    unbudgeted.time_budget_s = None;
    let mut ts = unbudgeted;
    ts.max_passes = settings.max_passes;
    unbudgeted.validate()?;
    base.set_tendon_settings(ts)?;
    let cold = settings.cold_retry.then_some((unbudgeted, ts));
    let mut retry_settings = ts;
    if settings.retry_passes.is_some() {
        retry_settings.max_passes = settings.retry_passes;
    }
    retry_settings.validate()?;
    let n = settings.samples;
    // unit-cube Halton points k = 1..=n (k = 0 is the corner q_min)
    let mut unit = Vec::with_capacity(n * p);
    let bases: Vec<u64> = (0..p).map(nth_prime).collect();
    for k in 1..=n as u64 {
        unit.extend(bases.iter().map(|&b| radical_inverse(k, b)));
    }
    let mut readings_m = vec![0.0; n * p];
    for (k, u) in unit.chunks(p).enumerate() {
        for i in 0..p {
            readings_m[k * p + i] = limits.min_m[i] + u[i] * (limits.max_m[i] - limits.min_m[i]);
        }
    }
    // reading 0 in the unit cube: where each chain starts (the workspace's reference)
    let zero_unit: Vec<f64> = (0..p)
        .map(|i| {
            let w = limits.max_m[i] - limits.min_m[i];
            if w > 0.0 {
                -limits.min_m[i] / w
            } else {
                0.0
            }
        })
        .collect();
    let chunks: Vec<std::ops::Range<usize>> = (0..n)
        .step_by(settings.chunk_samples)
        .map(|s| s..(s + settings.chunk_samples).min(n))
        .collect();
    let threads = match settings.threads {
        0 => std::thread::available_parallelism().map_or(1, |t| t.get()),
        t => t,
    }
    .min(chunks.len())
    .max(1);
    let next_chunk = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let shared = Shared {
        base: &base,
        settings,
        cold,
        retry_settings,
        p,
        zero_unit: &zero_unit,
        done: &done,
        progress,
    };
    let results: Mutex<Vec<(usize, Outcome)>> = Mutex::new(Vec::with_capacity(n));
    let first_error: Mutex<Option<ModelError>> = Mutex::new(None);
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let c = next_chunk.fetch_add(1, Ordering::Relaxed);
                let Some(range) = chunks.get(c) else { break };
                let (a, b) = (range.start * p, range.end * p);
                let out = shared.chain(&unit[a..b], &readings_m[a..b]);
                match results.lock() {
                    Ok(mut r) => r.extend(
                        out.into_iter()
                            .enumerate()
                            .map(|(j, o)| (range.start + j, o)),
                    ),
                    Err(_) => {
                        if let Ok(mut e) = first_error.lock() {
                            e.get_or_insert(ModelError::Invalid {
                                field: "workspace".into(),
                                why: "a sampling thread failed".into(),
                            });
                        }
                    }
                }
            });
        }
    });
    if let Some(e) = first_error.into_inner().ok().flatten() {
        return Err(e);
    }
    let results = results.into_inner().map_err(|_| ModelError::Invalid {
        field: "workspace".into(),
        why: "a sampling thread failed".into(),
    })?;
    let mut tips_m = vec![Vector3::repeat(f64::NAN); n];
    let mut markers_m = vec![Vector3::repeat(f64::NAN); n];
    let mut status = vec![SampleStatus::Failed; n];
    let mut stop = vec![None; n];
    let mut passes = vec![0u32; n];
    let mut retry_check_m = vec![f64::NAN; n];
    let mut residual_m = vec![f64::NAN; n];
    let mut fold = vec![None; n];
    let mut fold_passes = vec![0u32; n];
    for (k, o) in results {
        // (a sample the retry pass solved keeps no verdict)
        fold[k] = o.fold.filter(|_| !o.status.is_solved());
        fold_passes[k] = o.fold_passes;
        tips_m[k] = o.tip;
        markers_m[k] = o.marker;
        status[k] = o.status;
        stop[k] = o.stop;
        passes[k] = o.work;
        retry_check_m[k] = o.check_m;
        residual_m[k] = o.residual_m;
    }
    if settings.marker_offset_m.is_none() {
        markers_m.clear();
    }
    Ok(WorkspaceCloud {
        columns,
        readings_m,
        tips_m,
        markers_m,
        status,
        stop,
        passes,
        residual_m,
        retry_check_m,
        fold,
        fold_passes,
    })
}
