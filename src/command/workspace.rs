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

use crate::error::ModelError;
use crate::robot::ActuatorLimits;
use crate::statics::Start;
use crate::tendons::TendonWorkspace;
use nalgebra::Vector3;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

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

/// The `n`-th prime (0-based: 2, 3, 5, ...).
fn nth_prime(n: usize) -> u64 {
    let mut found = 0;
    let mut c = 2u64;
    loop {
        if (2..c).take_while(|d| d * d <= c).all(|d| c % d != 0) {
            if found == n {
                return c;
            }
            found += 1;
        }
        c += 1;
    }
}

/// Radical inverse of `k` in base `b` (Halton 1960): the digits of `k` mirrored
/// about the radix point, in `[0, 1)`.
pub fn radical_inverse(mut k: u64, b: u64) -> f64 {
    let (mut f, mut r) = (1.0, 0.0);
    let inv = 1.0 / b as f64;
    while k > 0 {
        f *= inv;
        r += f * (k % b) as f64;
        k /= b;
    }
    r
}

/// Point `k` of the `dim`-dimensional Halton sequence (bases the first `dim` primes),
/// in the unit cube.
pub fn halton(k: u64, dim: usize) -> Vec<f64> {
    (0..dim).map(|i| radical_inverse(k, nth_prime(i))).collect()
}

/// Greedy nearest-neighbour order of `points` (each `dim` long, flat), starting
/// from the point nearest `start`. `O(n^2)` distance evaluations.
pub fn nearest_neighbour_order(points: &[f64], dim: usize, start: &[f64]) -> Vec<usize> {
    let n = points.len() / dim.max(1);
    let d2 = |i: usize, x: &[f64]| -> f64 {
        points[i * dim..(i + 1) * dim]
            .iter()
            .zip(x)
            .map(|(a, b)| (a - b) * (a - b))
            .sum()
    };
    let mut visited = vec![false; n];
    let mut order = Vec::with_capacity(n);
    let mut here = start.to_vec();
    for _ in 0..n {
        let mut best = (f64::INFINITY, usize::MAX);
        for (j, v) in visited.iter().enumerate() {
            if !v {
                let d = d2(j, &here);
                if d < best.0 {
                    best = (d, j);
                }
            }
        }
        let j = best.1;
        visited[j] = true;
        order.push(j);
        here.copy_from_slice(&points[j * dim..(j + 1) * dim]);
    }
    order
}

/// Solve one sample's readings `q`, warm from the chain's last converged readings
/// `from` (updated on success): directly; else by continuation along the segment
/// from `from` to `q` (a step that fails is halved, one that converges is doubled,
/// at most `max_substeps` solves); else cold. `buf` is scratch of `q`'s length.
fn solve_sample(
    ws: &mut TendonWorkspace,
    q: &[f64],
    from: &mut [f64],
    buf: &mut [f64],
    max_substeps: usize,
) -> SampleStatus {
    let ok = |r: Result<crate::tendons::TendonReport, ModelError>| {
        r.is_ok_and(|r| r.status.is_converged())
    };
    if ok(ws.solve_readings(q)) {
        from.copy_from_slice(q);
        return SampleStatus::Converged;
    }
    // (a failed solve is rolled back: the warm state is `from`'s again)
    let (mut t, mut h) = (0.0f64, 0.5f64);
    for _ in 0..max_substeps {
        let tn = (t + h).min(1.0);
        for ((b, a), z) in buf.iter_mut().zip(from.iter()).zip(q) {
            *b = a + tn * (z - a);
        }
        if ok(ws.solve_readings(buf)) {
            t = tn;
            if t >= 1.0 {
                from.copy_from_slice(q);
                return SampleStatus::ConvergedStepped;
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
    if ok(ws.solve_readings_from(q, Start::Cold)) {
        from.copy_from_slice(q);
        return SampleStatus::ConvergedCold;
    }
    SampleStatus::Failed
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
    let mut ts = *base.tendon_settings();
    ts.max_shooting_solves = ts.max_shooting_solves.min(settings.max_shooting_solves);
    base.set_tendon_settings(ts)?;
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
    type Row = (usize, Vector3<f64>, Vector3<f64>, SampleStatus);
    let results: Mutex<Vec<Row>> = Mutex::new(Vec::with_capacity(n));
    let first_error: Mutex<Option<ModelError>> = Mutex::new(None);
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let c = next_chunk.fetch_add(1, Ordering::Relaxed);
                let Some(range) = chunks.get(c) else { break };
                // a fresh copy per chunk: the result does not depend on the threads
                let mut ws = base.clone();
                let order =
                    nearest_neighbour_order(&unit[range.start * p..range.end * p], p, &zero_unit);
                let mut out = Vec::with_capacity(order.len());
                // each chain starts from reading 0 (a known converged state)
                let mut from = vec![0.0; p];
                let mut buf = vec![0.0; p];
                let start_ok = ws
                    .solve_readings(&from)
                    .is_ok_and(|r| r.status.is_converged())
                    || ws
                        .solve_readings_from(&from, Start::Cold)
                        .is_ok_and(|r| r.status.is_converged());
                for j in order {
                    let k = range.start + j;
                    let q = &readings_m[k * p..(k + 1) * p];
                    let status = if start_ok {
                        solve_sample(&mut ws, q, &mut from, &mut buf, settings.max_substeps)
                    } else {
                        SampleStatus::Failed
                    };
                    let nan = Vector3::repeat(f64::NAN);
                    let (tip, marker) = if status.is_solved() {
                        let tip = ws.tip_position();
                        let marker = match settings.marker_offset_m {
                            Some(o) => {
                                let pose = *ws.workspace_mut().solution().tip();
                                pose.position + pose.rotation * o
                            }
                            None => nan,
                        };
                        (tip, marker)
                    } else {
                        (nan, nan)
                    };
                    out.push((k, tip, marker, status));
                    progress(done.fetch_add(1, Ordering::Relaxed) + 1);
                }
                match results.lock() {
                    Ok(mut r) => r.extend(out),
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
    for (k, t, m, s) in results {
        tips_m[k] = t;
        markers_m[k] = m;
        status[k] = s;
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
    })
}

/// A convex hull in 3-D: its vertices (m), triangles with outward normals and volume.
#[derive(Clone, Debug, PartialEq)]
pub struct Hull {
    /// Hull vertices (m).
    pub vertices: Vec<Vector3<f64>>,
    /// Triangles (indices into `vertices`), counter-clockwise seen from outside.
    pub triangles: Vec<[usize; 3]>,
    /// Enclosed volume (m^3).
    pub volume_m3: f64,
    /// Outward unit normal and offset of each triangle's plane (`n . x = c`).
    planes: Vec<(Vector3<f64>, f64)>,
}

impl Hull {
    /// The convex hull of `points` (m; finite) by the `chull` crate's exact quickhull
    /// (module docs). Errors: fewer than 4 points, a non-finite point, or all points
    /// in one plane (no volume).
    pub fn of(points: &[Vector3<f64>]) -> Result<Self, ModelError> {
        if points.len() < 4 {
            return Err(ModelError::Invalid {
                field: "hull".into(),
                why: format!("{} points: a hull in 3-D needs at least 4", points.len()),
            });
        }
        if let Some(k) = points.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
            return Err(ModelError::NonFinite {
                field: format!("hull point {k}"),
                value: f64::NAN,
            });
        }
        // millimetres: the exact wrapper scales by 1/epsilon into integers
        let pts: Vec<Vec<f64>> = points
            .iter()
            .map(|p| vec![p.x * 1e3, p.y * 1e3, p.z * 1e3])
            .collect();
        let h = chull::ConvexHullWrapper::try_new(&pts, None).map_err(|e| ModelError::Invalid {
            field: "hull".into(),
            why: format!("no 3-D hull of {} points: {e}", points.len()),
        })?;
        // (indices into the returned points, which may be a compacted copy)
        let (all, idx) = h.vertices_indices();
        // keep only the points the triangles use
        let mut map = std::collections::BTreeMap::new();
        let mut vertices = Vec::new();
        let mut triangles = Vec::with_capacity(idx.len() / 3);
        for t in idx.chunks_exact(3) {
            let mut tri = [0usize; 3];
            for (slot, &i) in tri.iter_mut().zip(t) {
                let v = all.get(i).ok_or_else(|| ModelError::Invalid {
                    field: "hull".into(),
                    why: "the hull library returned an index out of range".into(),
                })?;
                *slot = *map.entry(i).or_insert_with(|| {
                    vertices.push(Vector3::new(v[0], v[1], v[2]) * 1e-3);
                    vertices.len() - 1
                });
            }
            triangles.push(tri);
        }
        if triangles.len() < 4 {
            return Err(ModelError::Invalid {
                field: "hull".into(),
                why: "the points span no volume (all in one plane or line)".into(),
            });
        }
        let centroid = vertices.iter().sum::<Vector3<f64>>() / vertices.len() as f64;
        let mut volume = 0.0;
        let mut planes = Vec::with_capacity(triangles.len());
        for tri in &mut triangles {
            let [a, b, c] = tri.map(|i| vertices[i]);
            let mut nrm = (b - a).cross(&(c - a));
            let six_v = (a - centroid).dot(&nrm);
            if six_v < 0.0 {
                tri.swap(1, 2);
                nrm = -nrm;
            }
            volume += six_v.abs() / 6.0;
            let len = nrm.norm();
            let u = if len > 0.0 { nrm / len } else { nrm };
            planes.push((u, u.dot(&a)));
        }
        if volume.is_nan() || volume <= 0.0 {
            return Err(ModelError::Invalid {
                field: "hull".into(),
                why: "the points span no volume (all in one plane or line)".into(),
            });
        }
        Ok(Self {
            vertices,
            triangles,
            volume_m3: volume,
            planes,
        })
    }

    /// Signed distance of `x` outside the hull's farthest plane (m): `<= 0` inside.
    /// (For a point outside, the largest plane excess: a lower bound of its true
    /// distance to the hull.)
    pub fn excess(&self, x: &Vector3<f64>) -> f64 {
        self.planes
            .iter()
            .map(|(n, c)| n.dot(x) - c)
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// Whether `x` lies inside the hull or within `tolerance_m` of its planes.
    pub fn contains(&self, x: &Vector3<f64>, tolerance_m: f64) -> bool {
        self.excess(x) <= tolerance_m
    }

    /// Axis-aligned bounds (m).
    pub fn bounds(&self) -> (Vector3<f64>, Vector3<f64>) {
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for v in &self.vertices {
            lo = lo.inf(v);
            hi = hi.sup(v);
        }
        (lo, hi)
    }

    /// The fraction of this hull's volume that `other` covers, by quasi-Monte Carlo:
    /// `n` 3-D Halton points in this hull's bounds, the share of those inside this
    /// hull that are inside `other` too (error about `1/sqrt(n)` at most, less for a
    /// low-discrepancy sequence).
    pub fn covered_fraction(&self, other: &Hull, n: usize) -> f64 {
        let (lo, hi) = self.bounds();
        let (mut inside, mut both) = (0usize, 0usize);
        for k in 1..=n as u64 {
            let u = Vector3::new(
                radical_inverse(k, 2),
                radical_inverse(k, 3),
                radical_inverse(k, 5),
            );
            let x = lo + (hi - lo).component_mul(&u);
            if self.contains(&x, 0.0) {
                inside += 1;
                if other.contains(&x, 0.0) {
                    both += 1;
                }
            }
        }
        if inside == 0 {
            0.0
        } else {
            both as f64 / inside as f64
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radical_inverse_digits() {
        assert_eq!(radical_inverse(1, 2), 0.5);
        assert_eq!(radical_inverse(6, 2), 0.375); // 110 -> 0.011
        assert!((radical_inverse(5, 3) - 7.0 / 9.0).abs() < 1e-15); // 12 -> 0.21
        assert_eq!(nth_prime(8), 23);
    }

    #[test]
    fn unit_cube_hull() {
        let mut pts = Vec::new();
        for k in 1..400u64 {
            pts.push(Vector3::new(
                radical_inverse(k, 2),
                radical_inverse(k, 3),
                radical_inverse(k, 5),
            ));
        }
        for c in 0..8 {
            pts.push(Vector3::new(
                (c & 1) as f64,
                ((c >> 1) & 1) as f64,
                ((c >> 2) & 1) as f64,
            ));
        }
        let h = Hull::of(&pts).unwrap();
        assert!((h.volume_m3 - 1.0).abs() < 1e-12, "{}", h.volume_m3);
        assert!(pts.iter().all(|p| h.contains(p, 1e-12)));
        assert!(!h.contains(&Vector3::new(1.01, 0.5, 0.5), 0.0));
    }

    #[test]
    fn nn_order_visits_all_once() {
        let pts = [0.0, 0.0, 5.0, 5.0, 1.0, 1.0, 4.0, 4.0];
        let o = nearest_neighbour_order(&pts, 2, &[0.0, 0.0]);
        assert_eq!(o, vec![0, 2, 3, 1]);
    }
}
