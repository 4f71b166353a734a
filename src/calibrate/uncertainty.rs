//! How sure a predicted tip is: the model-error term of its covariance, estimated on
//! held-out training rows (cross-validation), and the coverage of a 90 % region.
//!
//! A calibrated model's error on motions it did not see is mostly model error (the
//! physics it lacks), not parameter or capture noise: on FTDCR v4 the held-out RMSE
//! is millimetres where the parameters' propagated standard errors are tenths of a
//! millimetre. And it grows with the bend. The term used here is an isotropic 3-D
//! Gaussian per row whose variance per coordinate grows with the predicted tip's
//! lateral deflection `d` (distance from the base axis):
//!
//! ```text
//! sigma(d)^2 = a^2 + (b d)^2                          (ModelErrorSpec)
//! ```
//!
//! fitted by maximum likelihood to the held-out residuals `e_i` (3-D, each fold's
//! mean offset removed) of a grouped cross-validation on the training rows only:
//! `max sum_i [ -3/2 ln sigma_i^2 - |e_i|^2 / (2 sigma_i^2) ]`. With `a = s cos(phi)`,
//! `b d_ref = s sin(phi)`, the best `s^2` at a given `phi` is closed form
//! (`sum |e_i|^2 / w_i / (3 n)`, `w_i = cos^2 phi + sin^2 phi (d_i / d_ref)^2`), and
//! `phi` is searched on a grid of [`PHI_GRID`] points over `[0, pi/2]`.
//!
//! A row's 90 % region is the ball `|e|^2 <= chi2_3(0.9) sigma(d)^2`, with
//! `chi2_3(0.9) =` [`CHI2_3_90`] (the 0.9 quantile of the chi-square distribution
//! with 3 degrees of freedom).

use crate::scene::ModelErrorSpec;
use nalgebra::Vector3;

/// The 0.9 quantile of the chi-square distribution with 3 degrees of freedom.
pub const CHI2_3_90: f64 = 6.251_388_631_170_325;

/// Grid points of the mixing angle `phi` in the maximum-likelihood fit.
pub const PHI_GRID: usize = 401;

/// Lateral deflection (m) of point `p` from the axis through `base` along the unit
/// vector `axis`.
pub fn lateral_deflection(p: &Vector3<f64>, base: &Vector3<f64>, axis: &Vector3<f64>) -> f64 {
    let r = p - base;
    (r - axis * axis.dot(&r)).norm()
}

/// Fit [`ModelErrorSpec`] to held-out residuals: `(deflection m, error vector m)`
/// per row (module docs). `None` with fewer than 2 rows or no error at all.
pub fn fit_model_error(samples: &[(f64, Vector3<f64>)], source: &str) -> Option<ModelErrorSpec> {
    let n = samples.len();
    let sq: Vec<f64> = samples.iter().map(|(_, e)| e.norm_squared()).collect();
    if n < 2 || sq.iter().all(|s| *s == 0.0) || sq.iter().any(|s| !s.is_finite()) {
        return None;
    }
    let d_ref = samples.iter().map(|(d, _)| d.abs()).fold(0.0f64, f64::max);
    let d_ref = if d_ref > 0.0 { d_ref } else { 1.0 };
    let mut best: Option<(f64, f64, f64)> = None; // (log-likelihood, s2, phi)
    for k in 0..PHI_GRID {
        let phi = std::f64::consts::FRAC_PI_2 * k as f64 / (PHI_GRID - 1) as f64;
        let (c2, s2phi) = (phi.cos().powi(2), phi.sin().powi(2));
        let w: Vec<f64> = samples
            .iter()
            .map(|(d, _)| c2 + s2phi * (d / d_ref).powi(2))
            .collect();
        if w.iter().any(|w| *w <= 0.0) {
            continue; // phi = pi/2 with a row at zero deflection
        }
        let s2 = sq.iter().zip(&w).map(|(e, w)| e / w).sum::<f64>() / (3.0 * n as f64);
        let ll = -1.5 * w.iter().map(|w| (s2 * w).ln()).sum::<f64>() - 1.5 * n as f64;
        if best.is_none_or(|(b, _, _)| ll > b) {
            best = Some((ll, s2, phi));
        }
    }
    let (_, s2, phi) = best?;
    let s = s2.sqrt();
    Some(ModelErrorSpec {
        sigma_m: s * phi.cos(),
        per_deflection: s * phi.sin() / d_ref,
        rows: n,
        source: source.to_string(),
    })
}

/// Rows whose error lies inside their 90 % region.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Coverage {
    /// Rows inside.
    pub inside: usize,
    /// Rows scored.
    pub total: usize,
}

impl Coverage {
    /// Share of rows inside (NaN without rows).
    pub fn fraction(&self) -> f64 {
        if self.total == 0 {
            f64::NAN
        } else {
            self.inside as f64 / self.total as f64
        }
    }
}

/// Score `(deflection m, error vector m)` rows against the 90 % regions of `term`.
pub fn coverage_90(term: &ModelErrorSpec, rows: &[(f64, Vector3<f64>)]) -> Coverage {
    let inside = rows
        .iter()
        .filter(|(d, e)| e.norm_squared() <= CHI2_3_90 * term.variance(*d))
        .count();
    Coverage {
        inside,
        total: rows.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic standard normals (Box-Muller on a fixed LCG).
    fn normals(n: usize) -> Vec<f64> {
        let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut uniform = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let (u, v) = (uniform(), uniform());
                (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
            })
            .collect()
    }

    #[test]
    fn the_fit_recovers_a_growing_error_and_its_regions_cover_90_percent() {
        // sigma(d) = sqrt(1 mm^2 + (0.05 d)^2), d from 0 to 0.1 m
        let n = 6000;
        let z = normals(3 * n);
        let samples: Vec<(f64, Vector3<f64>)> = (0..n)
            .map(|i| {
                let d = 0.1 * i as f64 / n as f64;
                let s = (1e-6 + (0.05 * d).powi(2)).sqrt();
                (d, Vector3::new(z[3 * i], z[3 * i + 1], z[3 * i + 2]) * s)
            })
            .collect();
        let m = fit_model_error(&samples, "synthetic").unwrap();
        assert!((m.sigma_m - 1e-3).abs() < 0.1e-3, "{m:?}");
        assert!((m.per_deflection - 0.05).abs() < 0.005, "{m:?}");
        let c = coverage_90(&m, &samples);
        assert!((c.fraction() - 0.9).abs() < 0.015, "{c:?}");
        // a term half as large covers far less
        let small = ModelErrorSpec {
            sigma_m: m.sigma_m / 2.0,
            per_deflection: m.per_deflection / 2.0,
            ..m.clone()
        };
        assert!(coverage_90(&small, &samples).fraction() < 0.5);
    }

    #[test]
    fn no_rows_or_no_error_gives_no_term() {
        assert!(fit_model_error(&[], "").is_none());
        assert!(fit_model_error(&[(0.0, Vector3::zeros()); 3], "").is_none());
        let lateral = lateral_deflection(
            &Vector3::new(3.0, 4.0, 9.0),
            &Vector3::zeros(),
            &Vector3::z(),
        );
        assert!((lateral - 5.0).abs() < 1e-15);
    }

    #[test]
    fn a_stored_term_is_checked_naming_its_field() {
        let term = |sigma_m: f64, per_deflection: f64| ModelErrorSpec {
            sigma_m,
            per_deflection,
            ..ModelErrorSpec::default()
        };
        assert!(term(1e-3, 0.0).validate().is_ok());
        let e = term(f64::NAN, 0.1).validate().unwrap_err().to_string();
        assert!(e.contains("calibration.model_error.sigma_m"), "{e}");
        let e = term(1e-3, -1.0).validate().unwrap_err().to_string();
        assert!(e.contains("per_deflection"), "{e}");
        let e = term(0.0, 0.0).validate().unwrap_err().to_string();
        assert!(e.contains("calibration.model_error"), "{e}");
    }
}
