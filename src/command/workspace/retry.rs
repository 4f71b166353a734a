//! The retry pass: a chain's samples whose first solve failed, solved again from
//! other starts once the whole chain has run (module docs of [`super`],
//! "Retries"), and the check of what a retry found against a cold solve.

use super::sequence::nearest_solved;
use super::{SampleStatus, WorkspaceSettings};
use crate::settings::TendonSettings;
use crate::statics::{SolveStatus, Start};
use crate::tendons::TendonWorkspace;
use nalgebra::Vector3;

/// One solve of `q` from `start`: its status (`None`: readings rejected), its rod
/// passes added to `work`. A budgeted solve whose joint paths handed back before
/// its passes ran out ends `BudgetExhausted` (the nested fallback, not run under a
/// budget, was all that was left: `SolveStatus::BudgetExhausted`); that is a stall
/// of those paths, not the budget, and is returned as `Stalled`.
pub(super) fn solve_status(
    ws: &mut TendonWorkspace,
    q: &[f64],
    start: Start,
    work: &mut u32,
) -> Option<SolveStatus> {
    match ws.solve_readings_from(q, start) {
        Ok(r) => {
            *work = work.saturating_add(u32::try_from(r.forward_solves).unwrap_or(u32::MAX));
            let to_spare = ws
                .tendon_settings()
                .max_passes
                .is_some_and(|m| r.forward_solves < m);
            Some(match r.status {
                SolveStatus::BudgetExhausted if to_spare => SolveStatus::Stalled,
                s => s,
            })
        }
        Err(_) => None,
    }
}

/// Whether a solve's status is a converged equilibrium.
pub(super) fn ok(s: Option<SolveStatus>) -> bool {
    s.is_some_and(SolveStatus::is_converged)
}

/// A sample of a chain: its chunk-local index, and where its solves ended.
#[derive(Clone, Copy, Debug)]
pub(super) struct Outcome {
    pub(super) status: SampleStatus,
    /// The status of the sample's last solve (`None`: readings rejected).
    pub(super) stop: Option<SolveStatus>,
    /// Rod passes of all its solves.
    pub(super) work: u32,
    /// Tip and marker point (m; NaN when not solved).
    pub(super) tip: Vector3<f64>,
    pub(super) marker: Vector3<f64>,
    /// For a sample solved by a retry (with [`WorkspaceSettings::check_retries`]):
    /// distance to the tip of a cold solve at the same readings (m; NaN when not
    /// checked or when the cold solve did not converge).
    pub(super) check_m: f64,
    /// `max_i |G_i|` of the last solve (m; [`crate::tendons::TendonReport::residual_m`]).
    pub(super) residual_m: f64,
    /// The fold test's verdict on a failed first pass, and its rod passes.
    pub(super) fold: Option<super::FoldClass>,
    pub(super) fold_passes: u32,
}

impl Outcome {
    pub(super) fn failed(stop: Option<SolveStatus>, work: u32) -> Self {
        let nan = Vector3::repeat(f64::NAN);
        Self {
            status: SampleStatus::Failed,
            stop,
            work,
            tip: nan,
            marker: nan,
            check_m: f64::NAN,
            residual_m: f64::NAN,
            fold: None,
            fold_passes: 0,
        }
    }
}

/// The tip and the marker point (`offset` in the tip frame) of `ws`'s last solve.
pub(super) fn tip_and_marker(
    ws: &mut TendonWorkspace,
    offset: Option<Vector3<f64>>,
) -> (Vector3<f64>, Vector3<f64>) {
    let tip = ws.tip_position();
    let marker = match offset {
        Some(o) => {
            let pose = *ws.workspace_mut().solution().tip();
            pose.position + pose.rotation * o
        }
        None => Vector3::repeat(f64::NAN),
    };
    (tip, marker)
}

/// What the retry pass works with: the chain's unit-cube points and readings
/// (chunk-local, `p` per sample), a converged state per solved sample, the
/// reference workspace for cold solves and the retries' tendon settings.
pub(super) struct RetryPass<'a> {
    pub(super) unit: &'a [f64],
    pub(super) readings: &'a [f64],
    pub(super) p: usize,
    pub(super) states: Vec<Option<TendonWorkspace>>,
    pub(super) base: &'a TendonWorkspace,
    pub(super) retry_settings: TendonSettings,
    pub(super) settings: &'a WorkspaceSettings,
}

impl RetryPass<'_> {
    /// A solved sample's state with the retries' settings and the rollback as asked.
    fn start_from(&self, c: usize, rollback: bool) -> Option<TendonWorkspace> {
        let mut w = self.states[c].clone()?;
        w.set_rollback(rollback);
        w.set_tendon_settings(self.retry_settings).ok()?;
        Some(w)
    }

    /// Retry sample `j` (chunk-local) whose first solve failed, in order of cost:
    /// warm from each of its `retry_neighbours` nearest solved samples; by
    /// continuation along the straight readings path from the nearest one
    /// (`retry_steps` solves at most, a failed step halved, a converged one
    /// doubled); cold from the reference (`retry_cold`). A sample solved here is a
    /// start for the samples retried after it. Updates `out`.
    pub(super) fn retry(&mut self, j: usize, out: &mut Outcome) {
        let p = self.p;
        let q = &self.readings[j * p..(j + 1) * p];
        let near = nearest_solved(
            self.unit,
            p,
            j,
            &self.states,
            self.settings
                .retry_neighbours
                .max(usize::from(self.settings.retry_steps > 0)),
        );
        let mut work = out.work;
        // why the last solve that failed stopped (a converged step of a
        // continuation that did not reach the sample is not the sample's stop)
        let mut stop = out.stop;
        let mut attempt = |w: &mut TendonWorkspace, x: &[f64], start, work: &mut u32| {
            let s = solve_status(w, x, start, work);
            if !ok(s) {
                stop = s;
            }
            ok(s)
        };
        let mut found: Option<(SampleStatus, TendonWorkspace)> = None;
        for &c in near.iter().take(self.settings.retry_neighbours) {
            let Some(mut w) = self.start_from(c, false) else {
                continue;
            };
            if attempt(&mut w, q, Start::Warm, &mut work) {
                found = Some((SampleStatus::ConvergedNeighbour, w));
                break;
            }
        }
        if found.is_none() && self.settings.retry_steps > 0 {
            if let Some(mut w) = near.first().and_then(|&c| self.start_from(c, true)) {
                let from = self.readings[near[0] * p..(near[0] + 1) * p].to_vec();
                let mut buf = vec![0.0; p];
                let (mut t, mut h) = (0.0f64, 0.5f64);
                for _ in 0..self.settings.retry_steps {
                    let tn = (t + h).min(1.0);
                    for ((b, a), z) in buf.iter_mut().zip(&from).zip(q) {
                        *b = a + tn * (z - a);
                    }
                    if attempt(&mut w, &buf, Start::Warm, &mut work) {
                        t = tn;
                        if t >= 1.0 {
                            found = Some((SampleStatus::ConvergedStepped, w));
                            break;
                        }
                        h *= 2.0;
                    } else {
                        h *= 0.5;
                    }
                }
            }
        }
        if found.is_none() && self.settings.retry_cold {
            let mut w = self.base.clone().without_rollback();
            if w.set_tendon_settings(self.retry_settings).is_ok()
                && attempt(&mut w, q, Start::Cold, &mut work)
            {
                found = Some((SampleStatus::ConvergedCold, w));
            }
        }
        out.work = work;
        if let Some((status, mut w)) = found {
            out.stop = Some(SolveStatus::Converged);
            let (tip, marker) = tip_and_marker(&mut w, self.settings.marker_offset_m);
            out.status = status;
            out.residual_m = w.report().residual_m;
            out.tip = tip;
            out.marker = marker;
            if self.settings.check_retries {
                out.check_m = self.cold_check(q, &tip);
            }
            w.set_rollback(false);
            self.states[j] = Some(w);
        } else {
            out.stop = stop;
        }
    }

    /// Distance from `tip` to the tip of a cold solve at `q` from the reference
    /// (the retries' budget), NaN when that does not converge. Its passes are a
    /// check's, not the sample's: not counted.
    fn cold_check(&self, q: &[f64], tip: &Vector3<f64>) -> f64 {
        let mut w = self.base.clone().without_rollback();
        let mut work = 0;
        if w.set_tendon_settings(self.retry_settings).is_ok()
            && ok(solve_status(&mut w, q, Start::Cold, &mut work))
        {
            (w.tip_position() - tip).norm()
        } else {
            f64::NAN
        }
    }
}
