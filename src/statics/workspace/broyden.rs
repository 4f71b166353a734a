//! Broyden reuse of the chord Jacobian: chord steps take `dx = -H r` with `H` the
//! inverse of the last factorised Jacobian, improved after every accepted step by
//! Broyden's "good" update in inverse form (Broyden 1965; Dennis & Schnabel,
//! "Numerical Methods for Unconstrained Optimization and Nonlinear Equations",
//! eq. 8.1.6 inverted by Sherman-Morrison):
//!
//! ```text
//! H <- H + (s - H y) (s^T H) / (s^T H y),   s = x+ - x,  y = r(x+) - r(x)
//! ```
//!
//! Along a warm ramp the loads move the Jacobian slowly and the steps point the same
//! way solve after solve, so the secant information keeps the reused matrix accurate
//! where it is used: chord steps contract much faster than with the frozen Jacobian
//! (Till's tension ramp, `continuous/till_warm_ramp`: 4.9 Newton passes a solve
//! before, 4.0 with the updates alone), and the exact Jacobian is still refreshed
//! when a step fails to contract (`CHORD_CONTRACTION`).
//!
//! Warm solves without load parameters only (`Jacobian::use_broyden` of `parts.rs`; the estimators'
//! inner solves keep their paths): cold solves and continuation keep the
//! plain chord steps (`forward_cold_tensioned` took 1.6x as long with the updates).
//! `H` is rebuilt from the LU factors whenever they change (any factorisation, also
//! by continuation or sensitivities: [`DenseLu::factorizations`]). Buffers are sized
//! once; nothing allocates.

use crate::math::broyden::{inverse_update, SkipTest, TailWeight};
use crate::math::DenseLu;

/// Inverse-Jacobian state of the chord steps (`n x n`, row-major).
#[derive(Clone, Debug)]
pub(super) struct Broyden {
    n: usize,
    h: Vec<f64>,
    /// `DenseLu::factorizations()` that `h` was built from (`None`: not built).
    built_from: Option<u64>,
    y: Vec<f64>,
    hy: Vec<f64>,
    sh: Vec<f64>,
}

impl Broyden {
    pub fn new(n: usize) -> Self {
        Self {
            n,
            h: vec![0.0; n * n],
            built_from: None,
            y: vec![0.0; n],
            hy: vec![0.0; n],
            sh: vec![0.0; n],
        }
    }

    /// Make `h` the inverse of the current LU factors unless it already descends
    /// from them (then it keeps its Broyden updates).
    pub fn sync(&mut self, lu: &DenseLu) {
        if self.built_from == Some(lu.factorizations()) {
            return;
        }
        let n = self.n;
        // column c of the inverse: solve A x = e_c (hy as scratch)
        for c in 0..n {
            self.hy.iter_mut().for_each(|v| *v = 0.0);
            self.hy[c] = 1.0;
            lu.solve_in_place(&mut self.hy);
            for r in 0..n {
                self.h[r * n + c] = self.hy[r];
            }
        }
        self.built_from = Some(lu.factorizations());
    }

    /// `dx = -H r`.
    pub fn step(&self, r: &[f64], dx: &mut [f64]) {
        let n = self.n;
        for (i, d) in dx.iter_mut().enumerate().take(n) {
            let row = &self.h[i * n..(i + 1) * n];
            *d = -row.iter().zip(r).map(|(a, b)| a * b).sum::<f64>();
        }
    }

    /// Broyden's inverse update with the accepted step `s = x+ - x` and `y = r+ - r`
    /// (`r_old`, `r_new`): [`inverse_update`] unweighted, skipped when `s^T H y` is
    /// too small to divide by ([`SkipTest::Angle`]).
    pub fn update(&mut self, s: &[f64], r_old: &[f64], r_new: &[f64]) {
        let n = self.n;
        for (y, (a, b)) in self.y.iter_mut().zip(r_new.iter().zip(r_old)) {
            *y = a - b;
        }
        inverse_update(
            &mut self.h,
            &s[..n],
            &self.y,
            TailWeight::NONE,
            SkipTest::Angle,
            &mut self.hy,
            &mut self.sh,
        );
    }
}

impl crate::math::warm::WarmCopy for Broyden {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src, copy: [n, h, built_from, y, hy, sh], keep: []);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// After one update `H` satisfies the secant equation `H y = s` (to round-off,
    /// 1e-14 relative) and equals the exact inverse for a linear map that changed by
    /// a rank-one term along the step.
    #[test]
    fn update_satisfies_the_secant_equation() {
        let mut lu = DenseLu::new(3);
        let a = [4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0];
        lu.matrix_mut().copy_from_slice(&a);
        lu.factor().unwrap();
        let mut b = Broyden::new(3);
        b.sync(&lu);
        // H A = I
        for r in 0..3 {
            for c in 0..3 {
                let v: f64 = (0..3).map(|k| b.h[r * 3 + k] * a[k * 3 + c]).sum();
                let e = if r == c { 1.0 } else { 0.0 };
                assert!((v - e).abs() < 1e-14, "{r} {c} {v}");
            }
        }
        let s = [0.3, -0.2, 0.1];
        let y = [1.0, 0.5, -0.7];
        b.update(&s, &[0.0; 3], &y);
        let mut hy = [0.0; 3];
        b.step(&y, &mut hy);
        for i in 0..3 {
            assert!((-hy[i] - s[i]).abs() < 1e-14, "{hy:?}");
        }
        // a new factorisation replaces the updated matrix
        lu.matrix_mut().copy_from_slice(&a);
        lu.factor().unwrap();
        b.sync(&lu);
        let mut x = [0.0; 3];
        b.step(&[4.0, 1.0, 0.5], &mut x);
        assert!((x[0] + 1.0).abs() < 1e-14 && x[1].abs() < 1e-14 && x[2].abs() < 1e-14);
    }
}
