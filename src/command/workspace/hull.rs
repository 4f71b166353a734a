//! The convex hull of the sampled tips and its volume (module docs of [`super`]).

use super::sequence::radical_inverse;
use crate::error::ModelError;
use nalgebra::Vector3;

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
        // one order for the same points: chull's output order changes from run to run
        // (its hash maps), so the vertices are sorted by their coordinates, each
        // triangle starts at its smallest vertex (orientation kept) and the triangles
        // are sorted; the volume is summed in that order, and `hull.obj` is the same file
        let mut order: Vec<usize> = (0..vertices.len()).collect();
        order.sort_by(|&i, &j| {
            let (a, b) = (&vertices[i], &vertices[j]);
            a.x.total_cmp(&b.x)
                .then(a.y.total_cmp(&b.y))
                .then(a.z.total_cmp(&b.z))
        });
        let mut rank = vec![0usize; vertices.len()];
        for (r, &i) in order.iter().enumerate() {
            rank[i] = r;
        }
        let vertices: Vec<Vector3<f64>> = order.iter().map(|&i| vertices[i]).collect();
        let centroid = vertices.iter().sum::<Vector3<f64>>() / vertices.len() as f64;
        for tri in &mut triangles {
            *tri = tri.map(|i| rank[i]);
            let [a, b, c] = tri.map(|i| vertices[i]);
            if (a - centroid).dot(&(b - a).cross(&(c - a))) < 0.0 {
                tri.swap(1, 2);
            }
            let first = (0..3).min_by_key(|&k| tri[k]).unwrap_or(0);
            tri.rotate_left(first);
        }
        triangles.sort_unstable();
        let mut volume = 0.0;
        let mut planes = Vec::with_capacity(triangles.len());
        for tri in &triangles {
            let [a, b, c] = tri.map(|i| vertices[i]);
            let nrm = (b - a).cross(&(c - a));
            volume += (a - centroid).dot(&nrm).abs() / 6.0;
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
}
