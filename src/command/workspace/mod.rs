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
//! ([`TendonWorkspace::solve_readings`]); a warm solve that does not converge is
//! tried once more cold (straight rod, pretensions). Chunks are solved in parallel
//! (`std::thread::scope`, one clone of the workspace per chunk, so the result does
//! not depend on the number of threads).
//!
//! **Hull.** The convex hull of the converged tips is the `chull` crate's exact
//! (big-integer predicates) quickhull (Barber, Dobkin & Huhdanpaa, "The quickhull
//! algorithm for convex hulls", ACM TOMS 22(4), 1996); the volume is the sum of the
//! tetrahedra from the hull's centroid to its triangles. A convex hull over-states
//! a workspace that is not convex (it fills in the dents and holes between the
//! sampled tips), and under-states it by the parts the samples missed.
//! Layering: uses `tendons` and `robot`; no file or terminal I/O.

mod hull;
mod sample;
mod sequence;

pub use hull::Hull;
pub use sample::sample_workspace;
pub use sequence::{halton, nearest_neighbour_order, radical_inverse};

use crate::error::ModelError;
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
    /// Most solves of the continuation toward a sample whose direct warm solve
    /// failed (module docs). Default 3.
    pub max_substeps: usize,
    /// Nested shooting solves one readings solve may run while sampling
    /// (`numerics.tendons.max_shooting_solves`, lowered to this when above it): a
    /// sample the solver cannot reach then fails after bounded work. Default 6.
    pub max_shooting_solves: usize,
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
            max_substeps: 3,
            max_shooting_solves: 6,
            marker_offset_m: None,
        }
    }
}

impl WorkspaceSettings {
    /// Check every number; the error names the field.
    pub fn validate(&self) -> Result<(), ModelError> {
        for (f, v) in [
            ("workspace.samples", self.samples),
            ("workspace.chunk_samples", self.chunk_samples),
            ("workspace.max_shooting_solves", self.max_shooting_solves),
        ] {
            if v == 0 {
                return Err(ModelError::OutOfRange {
                    field: f.into(),
                    value: 0.0,
                    why: "at least 1".into(),
                });
            }
        }
        if let Some(o) = &self.marker_offset_m {
            ModelError::finite3("workspace.marker_offset_m", &[o.x, o.y, o.z])?;
        }
        Ok(())
    }
}

/// How the readings solve of one sample ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleStatus {
    /// Converged warm from the previous sample of its chain.
    Converged,
    /// Converged by continuation from the previous sample (module docs).
    ConvergedStepped,
    /// The warm solve failed; a cold solve converged.
    ConvergedCold,
    /// Neither converged (or the readings were rejected): no tip.
    Failed,
}

impl SampleStatus {
    /// The name used in files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Converged => "converged",
            Self::ConvergedStepped => "converged_stepped",
            Self::ConvergedCold => "converged_cold",
            Self::Failed => "failed",
        }
    }
    /// A tip is available.
    pub fn is_solved(self) -> bool {
        self != Self::Failed
    }
}

/// The sampled workspace: per sample (in Halton order, `k = 1..=N`) its readings,
/// tip and status.
#[derive(Clone, Debug, PartialEq)]
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
    /// Samples that needed the cold retry.
    pub fn cold(&self) -> usize {
        self.status
            .iter()
            .filter(|s| **s == SampleStatus::ConvergedCold)
            .count()
    }
}
