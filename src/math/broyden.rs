//! Broyden's "good" secant updates (Broyden, Math. Comp. 19, 1965), one copy for every
//! solver that reuses a Jacobian between evaluations:
//!
//! * [`inverse_update`]: the update of an inverse Jacobian `H ~ J^-1` after an
//!   accepted step, in an inner product that may weigh the trailing unknowns
//!   (Dennis & Schnabel, "Numerical Methods for Unconstrained Optimization and
//!   Nonlinear Equations", eq. 8.1.6 and 8.3.1, inverted by Sherman-Morrison):
//!   `H <- H + (s - H y) s^T W H / (s^T W H y)`. The shooting Newton
//!   (`statics::workspace`) uses it with `W = I`, the tendon solve's joint Newton
//!   with a tension weight.
//! * [`secant_row_update`]: the direct update of one row of a Jacobian `J` (or of a
//!   sensitivity matrix) along a step, `J_r += (y_r - J_r s) s^T / (s^T s)` (Nocedal &
//!   Wright eq. 11.24), which the estimators and the inverse kinematics use.
//!
//! After either update the secant equation holds: `H y = s`, `J s = y`. Nothing
//! allocates: the callers own the scratch.

/// Weights of the inner product of [`inverse_update`]: 1 on the unknowns before
/// `from`, `weight` on the rest (`TailWeight::NONE`: the plain update).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TailWeight {
    /// Index of the first weighted unknown.
    pub from: usize,
    /// Weight of the unknowns from `from` on (dimensionless, > 0).
    pub weight: f64,
}

impl TailWeight {
    /// Every unknown weighed 1: the plain update.
    pub const NONE: Self = Self {
        from: usize::MAX,
        weight: 1.0,
    };

    #[inline]
    fn of(&self, i: usize) -> f64 {
        if i < self.from {
            1.0
        } else {
            self.weight
        }
    }
}

/// When the denominator `d = s^T W H y` of [`inverse_update`] is too small to divide
/// by (the update is then skipped; a non-finite `d` always skips).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkipTest {
    /// `|d| <= 1e-12 |s| |H y|` or `d == 0`: the step and its predicted image are
    /// near orthogonal (the shooting Newton's test, unweighted norms).
    Angle,
    /// `|d| <= 1e-12 s^T W s`: tiny against the step's own weighted length (the
    /// joint Newton's test).
    StepLength,
}

/// Broyden's update of the `m x m` row-major inverse Jacobian `h` with the accepted
/// step `s` and the residual change `y` (both of length `m`), weighted by `w`;
/// `hy` and `sth` are scratch of length `m`. Returns `false` when `skip` says the
/// update is ill-defined (then `h` is unchanged).
pub fn inverse_update(
    h: &mut [f64],
    s: &[f64],
    y: &[f64],
    w: TailWeight,
    skip: SkipTest,
    hy: &mut [f64],
    sth: &mut [f64],
) -> bool {
    let m = s.len();
    // hy = H y
    for (r, row) in h.chunks_exact(m).enumerate() {
        hy[r] = row.iter().zip(y).map(|(a, b)| a * b).sum();
    }
    let den: f64 = (0..m).map(|i| w.of(i) * s[i] * hy[i]).sum();
    let tiny = match skip {
        SkipTest::Angle => den == 0.0 || den.abs() <= 1e-12 * norm(s) * norm(&hy[..m]),
        SkipTest::StepLength => {
            let ss: f64 = (0..m).map(|i| w.of(i) * s[i] * s[i]).sum();
            den.abs() <= 1e-12 * ss.max(f64::MIN_POSITIVE)
        }
    };
    if tiny || !den.is_finite() {
        return false;
    }
    // sth = s^T W H, accumulated row by row (contiguous; per entry the same sum in
    // the same order as a column's)
    sth[..m].fill(0.0);
    for (r, row) in h.chunks_exact(m).enumerate() {
        let a = w.of(r) * s[r];
        for (wc, hc) in sth.iter_mut().zip(row) {
            *wc += a * hc;
        }
    }
    for (r, row) in h.chunks_exact_mut(m).enumerate() {
        let u = (s[r] - hy[r]) / den;
        if u != 0.0 {
            for (hc, wc) in row.iter_mut().zip(sth.iter()) {
                *hc += u * wc;
            }
        }
    }
    true
}

/// Broyden's direct update of one row `row` of a Jacobian along the step `s` whose
/// squared length is `ss` (> 0), given the observed change `y` of that row's
/// output: `row += (y - row . s) s / ss`. Afterwards `row . s = y`.
#[inline]
pub fn secant_row_update(row: &mut [f64], s: &[f64], ss: f64, y: f64) {
    let js: f64 = row.iter().zip(s).map(|(j, v)| j * v).sum();
    let c = (y - js) / ss;
    for (j, v) in row.iter_mut().zip(s) {
        *j += c * v;
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mat_vec(h: &[f64], v: &[f64]) -> Vec<f64> {
        let m = v.len();
        h.chunks_exact(m)
            .map(|row| row.iter().zip(v).map(|(a, b)| a * b).sum())
            .collect()
    }

    fn h0(m: usize) -> Vec<f64> {
        (0..m * m)
            .map(|k| {
                if k % (m + 1) == 0 {
                    2.0
                } else {
                    0.1 * (k as f64).sin()
                }
            })
            .collect()
    }

    /// Any weight and either skip test keep the secant equation `H y = s` (1e-12
    /// relative); weight 1 equals the textbook form `(s - H y) s^T H / (s^T H y)`
    /// entry by entry (1e-14), and a weight changes the update.
    #[test]
    fn inverse_update_keeps_the_secant_equation() {
        let m = 4;
        let s = [0.3, -1.2, 0.05, 0.7];
        let y = [0.2, -0.4, 0.9, 0.1];
        let (mut hy, mut sth) = (vec![0.0; m], vec![0.0; m]);
        let mut results = Vec::new();
        for (w, skip) in [
            (TailWeight::NONE, SkipTest::Angle),
            (TailWeight::NONE, SkipTest::StepLength),
            (
                TailWeight {
                    from: 2,
                    weight: 100.0,
                },
                SkipTest::StepLength,
            ),
        ] {
            let mut h = h0(m);
            assert!(inverse_update(&mut h, &s, &y, w, skip, &mut hy, &mut sth));
            for (got, want) in mat_vec(&h, &y).iter().zip(&s) {
                assert!((got - want).abs() <= 1e-12 * want.abs().max(1.0), "{w:?}");
            }
            results.push(h);
        }
        let h = h0(m);
        let hy0 = mat_vec(&h, &y);
        let den: f64 = (0..m).map(|i| s[i] * hy0[i]).sum();
        for r in 0..m {
            for c in 0..m {
                let sth: f64 = (0..m).map(|k| s[k] * h[k * m + c]).sum();
                let want = h[r * m + c] + (s[r] - hy0[r]) * sth / den;
                assert!((results[0][r * m + c] - want).abs() < 1e-14);
            }
        }
        assert_eq!(results[0], results[1]);
        assert!(results[2] != results[0]);
    }

    /// A step orthogonal to `H y` is skipped by both tests and leaves `h` alone;
    /// a non-finite residual change too.
    #[test]
    fn an_ill_defined_update_is_skipped() {
        let m = 2;
        let mut h = vec![1.0, 0.0, 0.0, 1.0];
        let (mut hy, mut sth) = (vec![0.0; m], vec![0.0; m]);
        for skip in [SkipTest::Angle, SkipTest::StepLength] {
            assert!(!inverse_update(
                &mut h,
                &[1.0, 0.0],
                &[0.0, 1.0],
                TailWeight::NONE,
                skip,
                &mut hy,
                &mut sth
            ));
            assert!(!inverse_update(
                &mut h,
                &[1.0, 0.0],
                &[f64::NAN, 1.0],
                TailWeight::NONE,
                skip,
                &mut hy,
                &mut sth
            ));
        }
        assert_eq!(h, vec![1.0, 0.0, 0.0, 1.0]);
    }

    /// The row update satisfies `row . s = y` (1e-14) and changes the row only
    /// along `s`.
    #[test]
    fn secant_row_update_satisfies_the_secant_equation() {
        let mut row = [1.0, -2.0, 0.5];
        let s = [0.1, 0.2, -0.3];
        let ss: f64 = s.iter().map(|v| v * v).sum();
        secant_row_update(&mut row, &s, ss, 0.7);
        let js: f64 = row.iter().zip(&s).map(|(a, b)| a * b).sum();
        assert!((js - 0.7).abs() < 1e-14);
        // the change is parallel to s
        let d = [row[0] - 1.0, row[1] + 2.0, row[2] - 0.5];
        let k = d[0] / s[0];
        for i in 0..3 {
            assert!((d[i] - k * s[i]).abs() < 1e-14);
        }
    }
}
