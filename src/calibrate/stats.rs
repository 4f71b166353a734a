//! Statistics of a fit: tip-error summaries (raw, and with the mean offset removed
//! as the upstream FTDCR metric does), parameter covariance, correlation, and the
//! directions in parameter space the data cannot see.

use nalgebra::{DMatrix, Vector3};
use serde::{Deserialize, Serialize};

/// Summary of a set of point distances (m).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ErrorStats {
    /// Number of points.
    pub count: usize,
    /// Root mean square (m).
    pub rmse_m: f64,
    /// Median (m).
    pub median_m: f64,
    /// 95th percentile (m, linear interpolation between order statistics).
    pub p95_m: f64,
    /// Largest (m).
    pub max_m: f64,
}

impl ErrorStats {
    /// Statistics of the distances `d` (m).
    pub fn of(d: &[f64]) -> Self {
        if d.is_empty() {
            return Self::default();
        }
        let mut s = d.to_vec();
        s.sort_by(f64::total_cmp);
        Self {
            count: s.len(),
            rmse_m: (s.iter().map(|x| x * x).sum::<f64>() / s.len() as f64).sqrt(),
            median_m: percentile(&s, 0.5),
            p95_m: percentile(&s, 0.95),
            max_m: s[s.len() - 1],
        }
    }
}

/// Percentile `q` in `[0, 1]` of sorted values (linear interpolation, "type 7").
pub fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let pos = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let (i, f) = (pos.floor() as usize, pos.fract());
    if i + 1 < sorted.len() {
        sorted[i] * (1.0 - f) + sorted[i + 1] * f
    } else {
        sorted[i]
    }
}

/// Tip errors of one data split.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TipErrors {
    /// Euclidean distance model - measured (both in the robot base frame).
    pub raw: ErrorStats,
    /// The upstream convention: the mean offset between model and measured points
    /// over the split is subtracted first.
    pub mean_removed: ErrorStats,
    /// That mean offset, model minus measured (m, base frame).
    pub mean_offset_m: [f64; 3],
}

impl TipErrors {
    /// Errors of `model[i]` against `measured[i]`.
    pub fn of(model: &[Vector3<f64>], measured: &[Vector3<f64>]) -> Self {
        let diff: Vec<Vector3<f64>> = model.iter().zip(measured).map(|(a, b)| a - b).collect();
        if diff.is_empty() {
            return Self::default();
        }
        let mean = diff.iter().sum::<Vector3<f64>>() / diff.len() as f64;
        let raw: Vec<f64> = diff.iter().map(|d| d.norm()).collect();
        let removed: Vec<f64> = diff.iter().map(|d| (d - mean).norm()).collect();
        Self {
            raw: ErrorStats::of(&raw),
            mean_removed: ErrorStats::of(&removed),
            mean_offset_m: [mean.x, mean.y, mean.z],
        }
    }
}

/// A combination of parameters the data cannot determine.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Unidentifiable {
    /// Two parameters with |correlation| above the threshold.
    Correlated {
        /// First parameter.
        a: String,
        /// Second parameter.
        b: String,
        /// Their correlation.
        correlation: f64,
    },
    /// A near-null singular direction of the (column-normalised) Jacobian.
    NullDirection {
        /// Its singular value over the largest one.
        relative_singular_value: f64,
        /// Parameter name and component, in units of each parameter's scale
        /// (relative changes for moduli and diameters), largest component +-1;
        /// components below 0.01 omitted. Moving along it leaves the fit unchanged.
        direction: Vec<(String, f64)>,
    },
}

impl std::fmt::Display for Unidentifiable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Correlated { a, b, correlation } => {
                write!(f, "{a} and {b} correlate at {correlation:+.4}")
            }
            Self::NullDirection {
                relative_singular_value,
                direction,
            } => {
                write!(
                    f,
                    "direction the data cannot see (singular value {relative_singular_value:.1e} of the largest): "
                )?;
                let parts: Vec<String> = direction
                    .iter()
                    .map(|(n, c)| format!("{c:+.3} {n}"))
                    .collect();
                f.write_str(&parts.join(", "))
            }
        }
    }
}

/// Covariance of fitted parameters and what the data cannot separate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamStatistics {
    /// Standard errors in the parameters' units; NaN for parameters in a
    /// near-null direction (not determined by the data: no value is invented).
    pub std_errors: Vec<f64>,
    /// Covariance (parameter units), row-major `n x n`.
    pub covariance: Vec<f64>,
    /// Correlation matrix, row-major `n x n` (NaN where a standard error is NaN).
    pub correlation: Vec<f64>,
    /// Singular values of the column-normalised weighted Jacobian over the largest, largest first.
    pub singular_values: Vec<f64>,
    /// Residual variance factor `s^2 = sum(w r^2) / (m - n)` (whitened, 1 when the
    /// stated noise is right).
    pub residual_variance: f64,
    /// Flags: correlated pairs and null directions.
    pub unidentifiable: Vec<Unidentifiable>,
}

/// Threshold of |correlation| above which a pair is flagged.
pub const CORRELATION_LIMIT: f64 = 0.98;
/// Singular value (relative to the largest) below which a direction counts as null.
pub const NULL_DIRECTION_LIMIT: f64 = 1e-4;

/// Covariance `s^2 (J^T W J)^-1` and identifiability from the whitened Jacobian `jw`
/// (`sqrt(W) J`, rows = residuals, columns = scaled unknowns `z_i = x_i / scale_i`),
/// the whitened cost `sum(w r^2)`, the number of data residuals (priors excluded) and
/// the parameter names and scales.
pub fn parameter_statistics(
    jw: &DMatrix<f64>,
    weighted_ssr: f64,
    data_residuals: usize,
    names: &[String],
    scale: &[f64],
) -> ParamStatistics {
    let n = jw.ncols();
    let dof = data_residuals.saturating_sub(n).max(1);
    let s2 = weighted_ssr / dof as f64;
    // column-normalise: singular directions in comparable units
    let norms: Vec<f64> = (0..n)
        .map(|k| jw.column(k).norm().max(f64::MIN_POSITIVE))
        .collect();
    let mut jn = jw.clone();
    for (k, nk) in norms.iter().enumerate() {
        jn.column_mut(k).scale_mut(1.0 / nk);
    }
    let svd = jn.clone().svd(false, true);
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    let sv: Vec<f64> = order.iter().map(|&i| svd.singular_values[i]).collect();
    let smax = sv.first().copied().unwrap_or(0.0);
    let v_t = svd.v_t.expect("requested");
    let mut flags = Vec::new();
    let mut undetermined = vec![false; n];
    // null directions (also those missing because there are fewer rows than unknowns)
    let mut null_dirs: Vec<Vec<f64>> = Vec::new();
    for &i in &order {
        if svd.singular_values[i] <= NULL_DIRECTION_LIMIT * smax {
            null_dirs.push(v_t.row(i).iter().copied().collect());
        }
    }
    for (d, &rel) in null_dirs.iter().zip(
        sv.iter()
            .filter(|s| **s <= NULL_DIRECTION_LIMIT * smax)
            .map(|s| s / smax.max(f64::MIN_POSITIVE))
            .collect::<Vec<_>>()
            .iter(),
    ) {
        // in units of each parameter's scale: dz_k = v_k / norm_k
        let phys: Vec<f64> = (0..n).map(|k| d[k] / norms[k]).collect();
        let big = phys.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let sign = phys
            .iter()
            .copied()
            .find(|x| x.abs() == big)
            .unwrap_or(1.0)
            .signum();
        let mut direction = Vec::new();
        for k in 0..n {
            let c = sign * phys[k] / big;
            if c.abs() >= 0.01 {
                undetermined[k] = true;
                direction.push((names[k].clone(), c));
            }
        }
        flags.push(Unidentifiable::NullDirection {
            relative_singular_value: rel,
            direction,
        });
    }
    // pseudo-inverse of J^T J in normalised columns, then unscale
    let mut cov_n = DMatrix::zeros(n, n);
    for &i in &order {
        let s = svd.singular_values[i];
        if s > NULL_DIRECTION_LIMIT * smax {
            let v = v_t.row(i).transpose();
            cov_n += (&v * v.transpose()) / (s * s);
        }
    }
    let mut cov = DMatrix::zeros(n, n);
    for a in 0..n {
        for b in 0..n {
            cov[(a, b)] = s2 * cov_n[(a, b)] / (norms[a] * norms[b]) * scale[a] * scale[b];
        }
    }
    let std_errors: Vec<f64> = (0..n)
        .map(|k| {
            if undetermined[k] {
                f64::NAN
            } else {
                cov[(k, k)].max(0.0).sqrt()
            }
        })
        .collect();
    let mut corr = vec![f64::NAN; n * n];
    for a in 0..n {
        for b in 0..n {
            if !undetermined[a] && !undetermined[b] {
                let d = (cov[(a, a)] * cov[(b, b)]).sqrt();
                corr[a * n + b] = if d > 0.0 { cov[(a, b)] / d } else { f64::NAN };
            }
        }
    }
    for a in 0..n {
        for b in a + 1..n {
            let c = corr[a * n + b];
            if c.abs() > CORRELATION_LIMIT {
                flags.push(Unidentifiable::Correlated {
                    a: names[a].clone(),
                    b: names[b].clone(),
                    correlation: c,
                });
            }
        }
    }
    ParamStatistics {
        std_errors,
        covariance: cov.transpose().as_slice().to_vec(),
        correlation: corr,
        singular_values: sv.iter().map(|s| s / smax.max(f64::MIN_POSITIVE)).collect(),
        residual_variance: s2,
        unidentifiable: flags,
    }
}
