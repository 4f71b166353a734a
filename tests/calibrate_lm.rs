//! The calibration's numerical parts on problems with closed-form answers:
//! Levenberg-Marquardt (exact-data exponential fit, linear least squares against the
//! normal equations, a bound that is active, Huber against an outlier), the default
//! central-difference Jacobian, Kabsch/Umeyama on known transforms, and the error
//! statistics. Tolerances are stated at each assertion.

use cablesense::calibrate::{
    central_differences, kabsch, levenberg_marquardt, percentile, rotation_vector, umeyama, Bounds,
    ErrorStats, Huber, LeastSquares, LmSettings, LmStatus, RigidTransform, TipErrors,
};
use cablesense::nalgebra::{DMatrix, DVector, Vector3};

/// `y_i = a exp(-b t_i) + c`, with an analytic Jacobian unless `fd`.
struct Exp {
    t: Vec<f64>,
    y: Vec<f64>,
    fd: bool,
}

impl LeastSquares for Exp {
    type Error = String;
    fn unknowns(&self) -> usize {
        3
    }
    fn residual_count(&self) -> usize {
        self.t.len()
    }
    fn residuals(&mut self, z: &[f64], out: &mut [f64]) -> Result<(), String> {
        for (i, (t, y)) in self.t.iter().zip(&self.y).enumerate() {
            out[i] = z[0] * (-z[1] * t).exp() + z[2] - y;
        }
        Ok(())
    }
    fn jacobian(&mut self, z: &[f64], r: &[f64], jac: &mut DMatrix<f64>) -> Result<(), String> {
        if self.fd {
            let _ = r;
            return central_differences(self, z, 1e-6, jac);
        }
        for (i, t) in self.t.iter().enumerate() {
            let e = (-z[1] * t).exp();
            jac[(i, 0)] = e;
            jac[(i, 1)] = -z[0] * t * e;
            jac[(i, 2)] = 1.0;
        }
        Ok(())
    }
}

fn exp_problem(fd: bool) -> Exp {
    let t: Vec<f64> = (0..40).map(|i| i as f64 * 0.1).collect();
    let y = t.iter().map(|t| 2.5 * (-1.3 * t).exp() + 0.4).collect();
    Exp { t, y, fd }
}

#[test]
fn lm_recovers_exact_exponential() {
    for fd in [false, true] {
        let mut p = exp_problem(fd);
        let res = levenberg_marquardt(
            &mut p,
            &[1.0, 0.3, 0.0],
            &Bounds::none(3),
            &LmSettings::default(),
            &mut |_| {},
        )
        .unwrap();
        assert_eq!(res.status, LmStatus::Converged, "fd {fd}");
        // exact data: the optimum is the truth (1e-7 relative; FD Jacobian alike)
        for (got, want) in res.z.iter().zip([2.5, 1.3, 0.4]) {
            assert!((got - want).abs() < 1e-7 * want, "fd {fd}: {got} vs {want}");
        }
        assert!(res.cost < 1e-20, "{}", res.cost);
    }
}

#[test]
fn central_differences_match_the_analytic_jacobian() {
    let mut p = exp_problem(false);
    let z = [2.0, 0.9, 0.1];
    let mut r = vec![0.0; 40];
    p.residuals(&z, &mut r).unwrap();
    let mut ja = DMatrix::zeros(40, 3);
    p.jacobian(&z, &r, &mut ja).unwrap();
    let mut jf = DMatrix::zeros(40, 3);
    central_differences(&mut p, &z, 1e-5, &mut jf).unwrap();
    // O(h^2) truncation with h = 1e-5: 1e-8 absolute on entries of order 1
    assert!((&ja - &jf).amax() < 1e-8, "{}", (&ja - &jf).amax());
}

/// Linear residuals `X z - y`.
struct Linear {
    x: DMatrix<f64>,
    y: DVector<f64>,
}

impl LeastSquares for Linear {
    type Error = String;
    fn unknowns(&self) -> usize {
        self.x.ncols()
    }
    fn residual_count(&self) -> usize {
        self.x.nrows()
    }
    fn residuals(&mut self, z: &[f64], out: &mut [f64]) -> Result<(), String> {
        let r = &self.x * DVector::from_column_slice(z) - &self.y;
        out.copy_from_slice(r.as_slice());
        Ok(())
    }
}

fn line_data() -> Linear {
    // intercept and centred slope: orthogonal columns
    let t: Vec<f64> = (0..21).map(|i| i as f64 * 0.1 - 1.0).collect();
    let x = DMatrix::from_fn(21, 2, |i, j| if j == 0 { 1.0 } else { t[i] });
    let y = DVector::from_fn(21, |i, _| {
        0.7 + 2.0 * t[i] + 0.05 * ((i * 7 % 5) as f64 - 2.0)
    });
    Linear { x, y }
}

#[test]
fn lm_matches_normal_equations_and_respects_an_active_bound() {
    let mut p = line_data();
    let exact = (p.x.transpose() * &p.x)
        .cholesky()
        .unwrap()
        .solve(&(p.x.transpose() * &p.y));
    let res = levenberg_marquardt(
        &mut p,
        &[0.0, 0.0],
        &Bounds::none(2),
        &LmSettings::default(),
        &mut |_| {},
    )
    .unwrap();
    for k in 0..2 {
        // 1e-9 absolute against the normal equations
        assert!((res.z[k] - exact[k]).abs() < 1e-9, "{:?} vs {exact}", res.z);
    }
    // slope bounded above 1.5 (unconstrained about 2): with orthogonal columns the
    // constrained optimum is the clamped slope and the unchanged intercept
    let bounds = Bounds {
        lower: vec![f64::NEG_INFINITY, f64::NEG_INFINITY],
        upper: vec![f64::INFINITY, 1.5],
    };
    let res = levenberg_marquardt(
        &mut p,
        &[0.0, 0.0],
        &bounds,
        &LmSettings::default(),
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(res.status, LmStatus::Converged);
    assert!((res.z[1] - 1.5).abs() < 1e-12, "{:?}", res.z);
    assert!((res.z[0] - exact[0]).abs() < 1e-9, "{:?}", res.z);
}

/// The line fit with a Jacobian of the wrong sign: every trial goes uphill and is
/// rejected, the damping grows until the steps vanish. That is not a minimum: the
/// status is `Stalled`, not `Converged` (the residual still correlates with a
/// column: `gradient_cosine` near 1, far above `STATIONARY_COSINE`), and the
/// values are the start's.
struct WrongSign(Linear);

impl LeastSquares for WrongSign {
    type Error = String;
    fn unknowns(&self) -> usize {
        self.0.unknowns()
    }
    fn residual_count(&self) -> usize {
        self.0.residual_count()
    }
    fn residuals(&mut self, z: &[f64], out: &mut [f64]) -> Result<(), String> {
        self.0.residuals(z, out)
    }
    fn jacobian(&mut self, _z: &[f64], _r: &[f64], jac: &mut DMatrix<f64>) -> Result<(), String> {
        jac.copy_from(&(-&self.0.x));
        Ok(())
    }
}

#[test]
fn a_fit_whose_steps_vanish_away_from_a_minimum_is_not_converged() {
    let mut p = WrongSign(line_data());
    let res = levenberg_marquardt(
        &mut p,
        &[0.0, 0.0],
        &Bounds::none(2),
        &LmSettings::default(),
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(res.status, LmStatus::Stalled, "{res:?}");
    assert_eq!(res.z, [0.0, 0.0]);
}

#[test]
fn huber_loss_resists_an_outlier() {
    let mut p = line_data();
    p.y[10] += 5.0; // one gross outlier at t = 0
    let ls = levenberg_marquardt(
        &mut p,
        &[0.0, 0.0],
        &Bounds::none(2),
        &LmSettings::default(),
        &mut |_| {},
    )
    .unwrap();
    let hub = LmSettings {
        huber: Some(Huber {
            threshold: 0.1,
            group: 1,
            rows: 21,
        }),
        ..LmSettings::default()
    };
    let rb = levenberg_marquardt(&mut p, &[0.0, 0.0], &Bounds::none(2), &hub, &mut |_| {}).unwrap();
    // least squares moves the intercept by 5/21 = 0.238; Huber caps the outlier's
    // pull at threshold/n: the intercept stays within 0.02 of 0.7
    assert!((ls.z[0] - 0.7).abs() > 0.2, "{:?}", ls.z);
    assert!((rb.z[0] - 0.7).abs() < 0.02, "{:?}", rb.z);
    assert!(rb.weights[10] < 0.05, "outlier weight {}", rb.weights[10]);
}

fn points() -> Vec<Vector3<f64>> {
    (0..12)
        .map(|i| {
            let f = i as f64;
            Vector3::new((f * 1.7).sin(), (f * 0.9).cos() * 2.0, f * 0.3 - 1.0)
        })
        .collect()
}

#[test]
fn kabsch_recovers_a_known_rotation_and_translation() {
    for w in [
        Vector3::new(0.3, -1.2, 2.0),
        Vector3::new(0.0, 0.0, 3.1), // near pi
        Vector3::new(1e-9, 0.0, 0.0),
    ] {
        let truth = RigidTransform::from_vector(&w, &Vector3::new(0.1, -2.0, 0.5));
        let a = points();
        let b: Vec<Vector3<f64>> = a.iter().map(|p| truth.apply(p)).collect();
        let fit = kabsch(&a, &b).unwrap();
        // exact points: 1e-12 on R and t, 1e-9 on the rotation vector
        assert!((fit.rotation - truth.rotation).amax() < 1e-12, "{w}");
        assert!((fit.translation - truth.translation).amax() < 1e-12, "{w}");
        assert!((rotation_vector(&fit.rotation) - w).amax() < 1e-9, "{w}");
        assert!((fit.rotation.determinant() - 1.0).abs() < 1e-12);
    }
    // a mirrored set: still a proper rotation (det +1), never a reflection
    let a = points();
    let b: Vec<Vector3<f64>> = a.iter().map(|p| Vector3::new(-p.x, p.y, p.z)).collect();
    let fit = kabsch(&a, &b).unwrap();
    assert!((fit.rotation.determinant() - 1.0).abs() < 1e-12);
    // collinear points have no unique rotation
    let line: Vec<Vector3<f64>> = (0..5).map(|i| Vector3::new(i as f64, 0.0, 0.0)).collect();
    assert!(kabsch(&line, &line).is_none());
    // Umeyama's scale: mm read as m is a factor 1000 (1e-9 relative)
    let truth = RigidTransform::from_vector(&Vector3::new(0.2, 0.1, -0.4), &Vector3::zeros());
    let b: Vec<Vector3<f64>> = a.iter().map(|p| truth.apply(p) * 1e3).collect();
    let (_, c) = umeyama(&a, &b, true).unwrap();
    assert!((c - 1e3).abs() < 1e-6, "{c}");
}

#[test]
fn error_statistics_and_the_mean_offset_convention() {
    // percentile type 7: median of 1..=4 is 2.5, p95 is 3.85
    let v = [1.0, 2.0, 3.0, 4.0];
    assert!((percentile(&v, 0.5) - 2.5).abs() < 1e-15);
    assert!((percentile(&v, 0.95) - 3.85).abs() < 1e-12);
    let s = ErrorStats::of(&[3.0, 4.0]);
    assert!((s.rmse_m - 12.5f64.sqrt()).abs() < 1e-15 && s.max_m == 4.0);
    // a constant offset is removed entirely by the upstream convention
    let meas = points();
    let off = Vector3::new(1e-3, -2e-3, 0.5e-3);
    let model: Vec<Vector3<f64>> = meas.iter().map(|p| p + off).collect();
    let e = TipErrors::of(&model, &meas);
    assert!((e.raw.rmse_m - off.norm()).abs() < 1e-15);
    assert!(e.mean_removed.rmse_m < 1e-15);
    assert!((Vector3::from(e.mean_offset_m) - off).amax() < 1e-15);
}
