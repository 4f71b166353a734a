//! The reachable workspace: the tips the robot reaches over its actuator box (the
//! readings inside `[robot.limits]`), its convex hull and volume, and the coverage
//! of a recording.
//!
//! **Sampling.** The box `q_min <= q <= q_max` is sampled by the Halton sequence
//! (J. H. Halton, "On the efficiency of certain quasi-random sequences of points in
//! evaluating multi-dimensional integrals", Numer. Math. 2, 84-90, 1960): point `k`
//! (`k = 1, 2, ...`; `k = 0` is the corner `q_min`) has coordinate `i` the radical
//! inverse of `k` in the `i`-th prime base, `phi_b(k) = sum_j d_j b^-(j+1)` for
//! `k = sum_j d_j b^j`. A low-discrepancy sequence covers the box more evenly than
//! independent random points (star discrepancy `O((log N)^d / N)`), and it is
//! deterministic: the same `N` gives the same samples. Its known weakness, correlated
//! coordinates in high bases for small `N`, is mild for the nine tendons of FTDCR v4
//! (bases 2..23) at thousands of samples.
//!
//! **Chaining.** The samples are split into chunks of
//! [`WorkspaceSettings::chunk_samples`] consecutive indices (each chunk, a stretch
//! of a Halton sequence, covers the whole box). Within a chunk the samples are
//! visited in greedy nearest-neighbour order (from the one nearest reading 0, each
//! next the nearest not yet visited, Euclidean in the box scaled to the unit cube),
//! so each readings solve starts warm from a near neighbour
//! ([`crate::tendons::TendonWorkspace::solve_readings`]). Chunks are solved in parallel
//! (`std::thread::scope`, one clone of the workspace per chunk, so the result does
//! not depend on the number of threads).
//!
//! **Bounded work per sample.** Each readings solve runs under a deterministic
//! budget of rod passes ([`WorkspaceSettings::max_passes`],
//! `numerics.tendons.max_passes`): the warm predictor and Newton step from the
//! chain's last converged sample, and when they do not reach the sample, the joint
//! path from the reference equilibrium at reading 0 with what is left; the nested
//! fallback (a full shooting solve per tension iterate) is not run. Measured on the
//! calibrated FTDCR v4 (docs/command.md): a converged sample takes about 24 passes,
//! a failing one stalls after about 77 on its own, where the unbudgeted solve with
//! its nested fallback spent about 950 passes and 0.4 s on it. The samples that
//! fail are counted ([`SampleStatus::Failed`]), never dropped. What fails: on FTDCR
//! v4, samples that pull all three tendons of one section at once (the distal one
//! mostly); continuing to such a sample from reading 0 along a straight line, with
//! steps refined down to 1/2560 of the way, stalled for 11 of 12 probed samples,
//! 47 to 89 % of the way, with every tendon of one section taut at 3.7 to 15.9 N (a
//! turning point of the equilibrium along the path), and paths that move one
//! section at a time or the pay-outs first reached 1 of the 12
//! (`examples/workspace_failures.rs`). Optional, off by default (they found few more samples at many times
//! the cost): a continuation from the last converged sample
//! ([`WorkspaceSettings::max_substeps`], a step that fails is halved, one that
//! converges doubled) and an unbudgeted cold retry
//! ([`WorkspaceSettings::cold_retry`]).
//!
//! **Retries.** After a chain's first pass, its failed samples can be solved again
//! in the same order (so the cloud stays independent of the threads), in order of
//! cost: warm from each of the [`WorkspaceSettings::retry_neighbours`] solved
//! samples of the chain nearest it in the unit cube (their converged states kept
//! from the first pass; a sample a retry solves becomes a start for those after
//! it); by continuation along the straight readings path from the nearest one
//! ([`WorkspaceSettings::retry_steps`]); cold from the reference
//! ([`WorkspaceSettings::retry_cold`]); each solve under
//! [`WorkspaceSettings::retry_passes`]. With [`WorkspaceSettings::check_retries`]
//! a retried sample is checked by a cold solve at the same readings
//! ([`WorkspaceCloud::retry_check_m`]: the same tip, another tip, i.e. a second
//! equilibrium, or no convergence). Every sample keeps why its last solve stopped
//! ([`WorkspaceCloud::stop`]). On the calibrated FTDCR v4 they raise the solved
//! share little (docs/command.md: the failures lie past a fold of every path
//! tried, and the cold path from the reference stalls at the same fold).
//!
//! **Fold test.** With [`WorkspaceSettings::fold_test`] each failed sample's warm
//! path is walked by small steps and the readings solve's joint Jacobian is tested
//! where the walk stops (`fold` module docs, [`fold_test`]): a fold of the branch
//! (`past_fold`), a Jacobian singular in a mode the readings do not drive
//! (`singular`), neither (`regular`), or the sample reached (`reached`). On 2000
//! FTDCR v4 samples: 463, 48, 78 and 6 of the 626 failed (31 walks ran out of
//! solves), at 6.6 times the sampling's CPU (docs/command.md).
//!
//! **Hull.** The convex hull of the converged tips is the `chull` crate's exact
//! (big-integer predicates) quickhull (Barber, Dobkin & Huhdanpaa, "The quickhull
//! algorithm for convex hulls", ACM TOMS 22(4), 1996); the volume is the sum of the
//! tetrahedra from the hull's centroid to its triangles. A convex hull over-states
//! a workspace that is not convex (it fills in the dents and holes between the
//! sampled tips), and under-states it by the parts the samples missed.
//! Layering: uses `tendons` and `robot`; no file or terminal I/O.

mod fold;
mod hull;
mod retry;
mod sample;
mod sequence;

pub use fold::{
    fold_test, FoldClass, FoldTest, FOLD_AHEAD, FOLD_DROP, FOLD_MAX_SOLVES, FOLD_MAX_STEP,
    FOLD_MIN_STEP, FOLD_PUSH,
};
pub use hull::Hull;
pub use sample::sample_workspace;
pub use sequence::{halton, nearest_neighbour_order, radical_inverse};

use crate::error::ModelError;
use crate::statics::SolveStatus;
use nalgebra::Vector3;

/// Settings of [`sample_workspace`] (plain numbers; defaults below).
#[derive(Clone, Debug, PartialEq)]
pub struct WorkspaceSettings {
    /// Samples of the actuator box (>= 1). Default 20,000.
    pub samples: usize,
    /// Samples per warm chain (>= 1): the unit of work of a thread. Default 500
    /// (the greedy nearest-neighbour order costs `O(chunk^2)` distance evaluations).
    pub chunk_samples: usize,
    /// Threads (0: the machine's available parallelism). Default 0.
    pub threads: usize,
    /// Rod passes one readings solve may run while sampling
    /// (`numerics.tendons.max_passes`; deterministic, unlike a time budget). A
    /// budgeted solve runs the joint path only: the warm predictor and Newton from
    /// the chain's last converged sample, then the path from reading 0 with what is
    /// left, and never the nested fallback, whose shooting solves cost ~10 ms each
    /// (module docs). `None`: unbudgeted, the nested fallback bounded by
    /// `max_shooting_solves` (on FTDCR v4 about 950 rod passes and 0.4 s a failing
    /// sample, against 77 passes and 5 ms budgeted; docs/command.md). Default
    /// `Some(400)`: a failing FTDCR v4 sample stalls after about 77 passes on its
    /// own, a converged one takes 24 on average.
    pub max_passes: Option<usize>,
    /// Most solves of the continuation from the chain's last converged readings
    /// toward a sample whose first solve failed (module docs). Default 0 (off: on
    /// 2000 FTDCR v4 samples under the default budget one midpoint step moved the
    /// solved count from 1377 to 1381 at 5 ms more a failed sample).
    pub max_substeps: usize,
    /// After everything else failed, one more solve from the straight rod
    /// (`Start::Cold`), unbudgeted (the nested fallback included). Default false
    /// (off: under a budget the first solve already ran the path from reading 0;
    /// unbudgeted it costs 0.1 to 0.4 s a failing sample).
    pub cold_retry: bool,
    /// Nested shooting solves one readings solve may run while sampling
    /// (`numerics.tendons.max_shooting_solves`, lowered to this when above it):
    /// bounds the unbudgeted solves (`max_passes = None`, `cold_retry`). Default 6.
    pub max_shooting_solves: usize,
    /// Retry pass (module docs, "Retries"): a failed sample is solved again, warm,
    /// from each of its this many nearest solved samples of its chain (in the
    /// box scaled to the unit cube; their converged states are kept). Default 0.
    pub retry_neighbours: usize,
    /// Retry pass: most solves of the continuation along the straight readings
    /// path from the nearest solved sample of the chain (a step that fails is
    /// halved, one that converges doubled). Default 0.
    pub retry_steps: usize,
    /// Retry pass: one more solve cold from the reference (zero readings, the
    /// pretensions), continued in the readings, under `retry_passes`. Default false.
    pub retry_cold: bool,
    /// Rod passes of each solve of the retry pass (`None`: `max_passes`). Default
    /// `Some(40)` ([`WorkspaceSettings::DEFAULT_RETRY_PASSES`]).
    pub retry_passes: Option<usize>,
    /// Check each sample a retry solved by a cold solve at the same readings
    /// ([`WorkspaceCloud::retry_check_m`]; its passes are not counted). Default
    /// false.
    pub check_retries: bool,
    /// Run the fold test on each sample whose first pass failed (`fold` module
    /// docs: walk the warm path from the chain's last converged readings, then
    /// compare the joint Jacobian's smallest singular value at the stall with its
    /// value at the start): [`WorkspaceCloud::fold`]. Each solve of the walk
    /// runs under `retry_passes`; its passes are counted apart
    /// ([`WorkspaceCloud::fold_passes`]). The solved samples are unchanged bit for
    /// bit (the test runs on a copy of the chain's workspace). Default false.
    pub fold_test: bool,
    /// A point fixed to the tip body, in the tip's local frame (m): when given, each
    /// solved sample records it too ([`WorkspaceCloud::markers_m`]), e.g. a
    /// calibration's `marker_offset_m`, so that a recording's measured markers can be
    /// set against the same point of the model (one more pass per sample). Default
    /// `None`.
    pub marker_offset_m: Option<Vector3<f64>>,
}

impl Default for WorkspaceSettings {
    fn default() -> Self {
        Self {
            samples: 20_000,
            chunk_samples: 500,
            threads: 0,
            max_passes: Some(400),
            max_substeps: 0,
            cold_retry: false,
            max_shooting_solves: 6,
            retry_neighbours: Self::DEFAULT_RETRY_NEIGHBOURS,
            retry_steps: Self::DEFAULT_RETRY_STEPS,
            retry_cold: false,
            retry_passes: Some(Self::DEFAULT_RETRY_PASSES),
            check_retries: false,
            fold_test: false,
            marker_offset_m: None,
        }
    }
}

impl WorkspaceSettings {
    /// Default of [`WorkspaceSettings::retry_neighbours`]: 0, the retry pass off.
    /// It buys little for its cost: on 20,000 FTDCR v4 samples, 4 neighbours at 40
    /// passes a retry solved 163 more (68.9 % to 69.7 %) at 2.1 times the rod
    /// passes, and a cold solve confirmed none of them (it stalls at the same
    /// fold); 8 neighbours at 30 passes: 289 more at 2.7 times, 120 s of CPU, past
    /// the 60 s on two cores (docs/command.md).
    pub const DEFAULT_RETRY_NEIGHBOURS: usize = 0;
    /// Default of [`WorkspaceSettings::retry_passes`]: 40 (a converged FTDCR v4
    /// sample takes 24 on average; the rest of a failing retry's passes would go
    /// to the cold path from the reference, which stalls at the same fold).
    pub const DEFAULT_RETRY_PASSES: usize = 40;
    /// Default of [`WorkspaceSettings::retry_steps`].
    pub const DEFAULT_RETRY_STEPS: usize = 0;

    /// Check every number; the error names the field.
    pub fn validate(&self) -> Result<(), ModelError> {
        for (f, v) in [
            ("workspace.samples", self.samples),
            ("workspace.chunk_samples", self.chunk_samples),
            ("workspace.max_shooting_solves", self.max_shooting_solves),
            ("workspace.max_passes", self.max_passes.unwrap_or(1)),
            ("workspace.retry_passes", self.retry_passes.unwrap_or(1)),
        ] {
            if v == 0 {
                return Err(ModelError::OutOfRange {
                    field: f.into(),
                    value: 0.0,
                    why: "at least 1".into(),
                });
            }
        }
        for (f, v) in [
            ("workspace.max_passes", self.max_passes),
            ("workspace.retry_passes", self.retry_passes),
        ] {
            if let Some(m) = v.filter(|&m| m > 100_000) {
                return Err(ModelError::OutOfRange {
                    field: f.into(),
                    value: m as f64,
                    why: "between 1 and 100000 (numerics.tendons.max_passes)".into(),
                });
            }
        }
        if let Some(o) = &self.marker_offset_m {
            ModelError::finite3("workspace.marker_offset_m", &[o.x, o.y, o.z])?;
        }
        Ok(())
    }

    /// Whether the retry pass runs (any of its retries is on).
    pub fn retries(&self) -> bool {
        self.retry_neighbours > 0 || self.retry_steps > 0 || self.retry_cold
    }
}

/// How the readings solve of one sample ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleStatus {
    /// The first solve converged: warm from the chain's last converged sample
    /// (under a budget, or on the path from reading 0 within the same budget).
    Converged,
    /// Converged by continuation from the chain's last converged sample
    /// ([`WorkspaceSettings::max_substeps`]) or, in the retry pass, from the
    /// nearest solved sample ([`WorkspaceSettings::retry_steps`]).
    ConvergedStepped,
    /// Converged by the cold retry ([`WorkspaceSettings::cold_retry`], or
    /// [`WorkspaceSettings::retry_cold`] in the retry pass).
    ConvergedCold,
    /// Converged in the retry pass, warm from one of the nearest solved samples of
    /// its chain ([`WorkspaceSettings::retry_neighbours`]).
    ConvergedNeighbour,
    /// No solve converged (or the readings were rejected): no tip, counted.
    Failed,
}

impl SampleStatus {
    /// The name used in files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Converged => "converged",
            Self::ConvergedStepped => "converged_stepped",
            Self::ConvergedCold => "converged_cold",
            Self::ConvergedNeighbour => "converged_neighbour",
            Self::Failed => "failed",
        }
    }
    /// Every status, in the order of [`WorkspaceCloud::passes_by_status`].
    pub const ALL: [SampleStatus; 5] = [
        Self::Converged,
        Self::ConvergedNeighbour,
        Self::ConvergedStepped,
        Self::ConvergedCold,
        Self::Failed,
    ];
    /// A tip is available.
    pub fn is_solved(self) -> bool {
        self != Self::Failed
    }
}

/// The sampled workspace: per sample (in Halton order, `k = 1..=N`) its readings,
/// tip and status. Two clouds are equal when every field is bit for bit the same
/// (an unsolved sample's NaN tip equals the other cloud's NaN: the comparison asks
/// "the same run?", as a determinism test does).
#[derive(Clone, Debug)]
pub struct WorkspaceCloud {
    /// Readings columns of the driven tendons.
    pub columns: Vec<String>,
    /// Readings of sample `k` (m): `readings_m[k * p .. (k + 1) * p]`.
    pub readings_m: Vec<f64>,
    /// Tip of each sample (m; NaN when not solved).
    pub tips_m: Vec<Vector3<f64>>,
    /// The marker point of each sample (m; empty without
    /// [`WorkspaceSettings::marker_offset_m`], NaN when not solved).
    pub markers_m: Vec<Vector3<f64>>,
    /// Status of each sample.
    pub status: Vec<SampleStatus>,
    /// How each sample's last solve ended: `Converged` for a solved sample; for a
    /// failed one why it stopped (`Stalled`, `MaxIterations`, `BudgetExhausted`,
    /// ...; `None`: its readings were rejected).
    pub stop: Vec<Option<SolveStatus>>,
    /// Work of each sample: rod passes of all its solves
    /// ([`crate::tendons::TendonReport::forward_solves`], line-search trials and
    /// the nested method's passes included). Deterministic, unlike a time: where
    /// the sampling's time goes, per status ([`WorkspaceCloud::passes_by_status`]).
    pub passes: Vec<u32>,
    /// `max_i |G_i|` (m; the tendon conditions' residual,
    /// [`crate::tendons::TendonReport::residual_m`]) of the solve that solved each
    /// sample (at most `numerics.tendons.tolerance_m`), or of a failed sample's
    /// first solve. NaN when no solve ran.
    pub residual_m: Vec<f64>,
    /// For each sample a retry solved, with [`WorkspaceSettings::check_retries`]:
    /// the distance from its tip to the tip of a cold solve from the reference at
    /// the same readings (m; a distance above round-off is a second equilibrium).
    /// NaN when not checked or when that cold solve did not converge.
    pub retry_check_m: Vec<f64>,
    /// With [`WorkspaceSettings::fold_test`], the fold test's verdict on each
    /// failed sample (`None` for a solved sample or without the test).
    pub fold: Vec<Option<FoldClass>>,
    /// Rod passes of each sample's fold test (0 without it; not in `passes`).
    pub fold_passes: Vec<u32>,
}

impl PartialEq for WorkspaceCloud {
    fn eq(&self, other: &Self) -> bool {
        fn bits(a: &[f64], b: &[f64]) -> bool {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
        }
        fn points(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> bool {
            a.len() == b.len()
                && a.iter()
                    .zip(b)
                    .all(|(x, y)| bits(x.as_slice(), y.as_slice()))
        }
        self.columns == other.columns
            && bits(&self.readings_m, &other.readings_m)
            && points(&self.tips_m, &other.tips_m)
            && points(&self.markers_m, &other.markers_m)
            && self.status == other.status
            && self.stop == other.stop
            && self.passes == other.passes
            && bits(&self.residual_m, &other.residual_m)
            && bits(&self.retry_check_m, &other.retry_check_m)
            && self.fold == other.fold
            && self.fold_passes == other.fold_passes
    }
}

impl WorkspaceCloud {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.status.len()
    }
    /// Whether there is no sample.
    pub fn is_empty(&self) -> bool {
        self.status.is_empty()
    }
    /// Readings of sample `k` (m).
    pub fn readings(&self, k: usize) -> &[f64] {
        let p = self.columns.len();
        &self.readings_m[k * p..(k + 1) * p]
    }
    /// The tips of the solved samples.
    pub fn solved_tips(&self) -> Vec<Vector3<f64>> {
        self.tips_m
            .iter()
            .zip(&self.status)
            .filter(|(_, s)| s.is_solved())
            .map(|(t, _)| *t)
            .collect()
    }
    /// The marker points of the solved samples (empty without a marker offset).
    pub fn solved_markers(&self) -> Vec<Vector3<f64>> {
        self.markers_m
            .iter()
            .zip(&self.status)
            .filter(|(_, s)| s.is_solved())
            .map(|(t, _)| *t)
            .collect()
    }
    /// Samples that did not solve.
    pub fn failed(&self) -> usize {
        self.status.iter().filter(|s| !s.is_solved()).count()
    }
    /// Samples that needed the continuation from the previous sample.
    pub fn stepped(&self) -> usize {
        self.status
            .iter()
            .filter(|s| **s == SampleStatus::ConvergedStepped)
            .count()
    }
    /// Per status (in the order of [`SampleStatus::ALL`]: converged, neighbour,
    /// stepped, cold, failed): samples and their rod passes summed.
    pub fn passes_by_status(&self) -> [(usize, u64); 5] {
        let mut out = [(0usize, 0u64); 5];
        for (s, &p) in self.status.iter().zip(&self.passes) {
            let i = SampleStatus::ALL.iter().position(|x| x == s).unwrap_or(4);
            out[i].0 += 1;
            out[i].1 += u64::from(p);
        }
        out
    }
    /// The failed samples by how their last solve ended, most frequent first
    /// (ties by name; `None`: readings rejected).
    pub fn failed_by_stop(&self) -> Vec<(Option<SolveStatus>, usize)> {
        let mut out: Vec<(Option<SolveStatus>, usize)> = Vec::new();
        for (s, stop) in self.status.iter().zip(&self.stop) {
            if s.is_solved() {
                continue;
            }
            match out.iter_mut().find(|(x, _)| x == stop) {
                Some(e) => e.1 += 1,
                None => out.push((*stop, 1)),
            }
        }
        out.sort_by(|a, b| {
            b.1.cmp(&a.1)
                .then(format!("{:?}", a.0).cmp(&format!("{:?}", b.0)))
        });
        out
    }
    /// Samples solved by a retry and checked ([`WorkspaceCloud::retry_check_m`]):
    /// (the cold solve reached the same tip within `tol_m`, a different tip, did
    /// not converge).
    pub fn retry_checks(&self, tol_m: f64) -> (usize, usize, usize) {
        let mut c = (0, 0, 0);
        for (s, d) in self.status.iter().zip(&self.retry_check_m) {
            if !matches!(
                s,
                SampleStatus::ConvergedNeighbour
                    | SampleStatus::ConvergedStepped
                    | SampleStatus::ConvergedCold
            ) {
                continue;
            }
            if d.is_nan() {
                c.2 += 1;
            } else if *d <= tol_m {
                c.0 += 1;
            } else {
                c.1 += 1;
            }
        }
        c
    }
    /// Failed samples per fold-test class (in the order of [`FoldClass::ALL`]),
    /// with the rod passes of their tests summed.
    pub fn failed_by_fold(&self) -> [(usize, u64); 5] {
        let mut out = [(0usize, 0u64); 5];
        for (f, &p) in self.fold.iter().zip(&self.fold_passes) {
            if let Some(i) = f.and_then(|f| FoldClass::ALL.iter().position(|x| *x == f)) {
                out[i].0 += 1;
                out[i].1 += u64::from(p);
            }
        }
        out
    }
    /// Samples that needed the cold retry.
    pub fn cold(&self) -> usize {
        self.status
            .iter()
            .filter(|s| **s == SampleStatus::ConvergedCold)
            .count()
    }
}
