//! A fold test of a converged readings solve: the joint Jacobian `F_z` of
//! [`crate::tendons::ift`] at the solve's point, equilibrated, and its smallest
//! singular value, determinant sign and tangent along a readings direction.
//!
//! Along a path of readings `q(lambda)` the converged points `z(lambda)` form a
//! branch of `F(z; q(lambda)) = 0`. Where `F_z` is regular the branch continues
//! (implicit function theorem); at a simple fold (turning point) `F_z` is singular
//! with a one-dimensional null space, the smallest singular value goes to zero like
//! the arclength to the fold (like `sqrt(lambda* - lambda)` in the path parameter),
//! and `det F_z` changes sign on the branch continued past it (Allgower & Georg,
//! *Introduction to Numerical Continuation Methods*, 2003, ch. 2 and 9; Seydel,
//! *Practical Bifurcation and Stability Analysis*, 3rd ed., 2010, section 5.1). A
//! solver that fails where `F_z` is well conditioned is not at a fold.
//!
//! `F_z` mixes units (scaled shooting rows, tendon rows in m; columns of scaled
//! unknowns and tensions in N), so its singular values are taken after one pass of
//! row, then column equilibration (each row, then each column, divided by its largest
//! magnitude; LAPACK `dgeequ`'s scaling, powers of two not enforced): a diagonal
//! scaling, which moves no zero of `det F_z` and makes the values unit-free. The
//! determinant sign is that of the unscaled matrix (positive scales).
//!
//! The probe only reads the tendon workspace's point: one dual sweep at its
//! converged unknowns and tensions (`Workspace::joint_jacobians`, which leaves the
//! shooting iterate, factorisation and warm start untouched); callers that need the
//! workspace's later solves bit-for-bit unchanged run it on a clone.

use super::ift::{assemble_joint_jacobian, reading_gain};
use super::TendonWorkspace;
use crate::math::DenseLu;
use nalgebra::DMatrix;

/// What [`FoldProbe::measure`] found at a converged point.
#[derive(Clone, Debug, PartialEq)]
pub struct FoldPoint {
    /// Smallest singular value of the equilibrated `F_z` (unit-free).
    pub sigma_min: f64,
    /// Largest singular value of the equilibrated `F_z` (unit-free).
    pub sigma_max: f64,
    /// Sign of `det F_z` (+1 or -1; 0 when the factorisation failed).
    pub det_sign: f64,
    /// `dz/dlambda` along the readings direction given to `measure` (scaled shooting
    /// unknowns, then tensions in N per unit of `lambda`); empty when singular.
    pub tangent: Vec<f64>,
    /// The right singular vector of `sigma_min` (the equilibrated `z`'s near-null
    /// direction, unit length).
    pub null_right: Vec<f64>,
    /// `|u^T b| / |b|` with `u` the left singular vector of `sigma_min` and `b` the
    /// equilibrated `-F_q dq` of the readings direction: near 0 when the readings
    /// push along the range of a singular `F_z` (the branch passes a bifurcation
    /// and continues), away from 0 at a fold (the branch turns). NaN for a zero
    /// direction.
    pub push_on_null: f64,
}

/// The buffers of the fold test for one tendon workspace (sized once).
#[derive(Clone, Debug)]
pub struct FoldProbe {
    nx: usize,
    p: usize,
    w: usize,
    jac_s: Vec<f64>,
    jac_m: Vec<f64>,
    x: Vec<f64>,
    lu: DenseLu,
}

impl FoldProbe {
    /// Buffers for `tw`'s sizes.
    pub fn new(tw: &TendonWorkspace) -> Self {
        let ws = tw.workspace();
        let nx = ws.unknowns_vector().len();
        let p = tw.driven().len();
        let w = nx + ws.theta().len();
        let c = ws.robot().cables().len();
        FoldProbe {
            nx,
            p,
            w,
            jac_s: vec![0.0; nx * w],
            jac_m: vec![0.0; c * w],
            x: vec![0.0; nx],
            lu: DenseLu::new(nx + p),
        }
    }

    /// Size of `F_z` (shooting unknowns plus driven tendons).
    pub fn size(&self) -> usize {
        self.nx + self.p
    }

    /// `F_z` at `tw`'s last converged point, whose readings were `readings_m`
    /// (m), with the tangent `dz/dlambda` along the readings direction `dir_m`
    /// (`dq/dlambda`, m; zeros for none). `None` when `tw` holds no converged
    /// point or the sweep failed. Under capstan friction the tendon rows are the
    /// frictionless ones (the `ift` assembly), an approximation.
    pub fn measure(
        &mut self,
        tw: &mut TendonWorkspace,
        readings_m: &[f64],
        dir_m: &[f64],
    ) -> Option<FoldPoint> {
        if !tw.report().status.is_converged() || readings_m.len() != self.p || dir_m.len() != self.p
        {
            return None;
        }
        let (nx, p, w, m) = (self.nx, self.p, self.w, self.nx + self.p);
        let free: Vec<f64> = (0..p)
            .map(|i| tw.rest_free_lengths()[i] - (readings_m[i] - tw.mechanics()[i].zero_offset_m))
            .collect();
        let t = tw.tensions().to_vec();
        let taut = tw.taut().to_vec();
        let mech = tw.mechanics().to_vec();
        let driven = tw.driven().to_vec();
        let ws = tw.workspace_mut();
        self.x.copy_from_slice(ws.unknowns_vector());
        if ws.theta()[..p] != t[..] {
            return None;
        }
        if !ws.joint_jacobians(&self.x, &mut self.jac_s, &mut self.jac_m) {
            return None;
        }
        let a = self.lu.matrix_mut();
        assemble_joint_jacobian(
            nx,
            w,
            &self.jac_s,
            &self.jac_m,
            &driven,
            &mech,
            |i| free[i],
            &t,
            &taut,
            a,
        );
        let mut e = DMatrix::from_row_slice(m, m, a);
        let rows = equilibrate(&mut e);
        let svd = e.svd(true, true);
        let sv = &svd.singular_values;
        let k = sv.imin();
        let (sigma_min, sigma_max) = (sv[k], sv.max());
        let null_right = svd
            .v_t
            .as_ref()
            .map(|v| v.row(k).iter().copied().collect())
            .unwrap_or_default();
        // -F_q dq, row-scaled as `e`
        let b: Vec<f64> = (0..m)
            .map(|r| {
                if r < nx {
                    0.0
                } else {
                    let i = r - nx;
                    reading_gain(&mech[i], t[i], taut[i]) * dir_m[i] / rows[r]
                }
            })
            .collect();
        let bn = b.iter().map(|v| v * v).sum::<f64>().sqrt();
        let push_on_null = svd.u.as_ref().map_or(f64::NAN, |u| {
            u.column(k)
                .iter()
                .zip(&b)
                .map(|(a, b)| a * b)
                .sum::<f64>()
                .abs()
                / bn
        });
        let (det_sign, tangent) = match self.lu.factor() {
            Some(rc) if rc > 1e-14 => {
                // F_z dz = -F_q dq, -F_q = gain_i e_{nx+i} on a taut tendon's row
                let mut col = vec![0.0; m];
                for i in 0..p {
                    col[nx + i] = reading_gain(&mech[i], t[i], taut[i]) * dir_m[i];
                }
                self.lu.solve_in_place(&mut col);
                (self.lu.det_sign(), col)
            }
            Some(_) => (self.lu.det_sign(), Vec::new()),
            None => (0.0, Vec::new()),
        };
        Some(FoldPoint {
            sigma_min,
            sigma_max,
            det_sign,
            tangent,
            null_right,
            push_on_null,
        })
    }
}

/// Divide each row of `a`, then each column, by its largest magnitude (rows or
/// columns of zeros are left); the row scales (1 for a zero row).
fn equilibrate(a: &mut DMatrix<f64>) -> Vec<f64> {
    let mut rows = Vec::with_capacity(a.nrows());
    for mut r in a.row_iter_mut() {
        let s = r.amax();
        if s > 0.0 {
            r /= s;
            rows.push(s);
        } else {
            rows.push(1.0);
        }
    }
    for mut c in a.column_iter_mut() {
        let s = c.amax();
        if s > 0.0 {
            c /= s;
        }
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equilibration_makes_each_row_and_column_peak_at_one() {
        let mut a = DMatrix::from_row_slice(2, 2, &[1e-3, 2e-3, 4.0, 1.0]);
        equilibrate(&mut a);
        for r in a.row_iter() {
            assert!(r.amax() <= 1.0 + 1e-15);
        }
        for c in a.column_iter() {
            assert!((c.amax() - 1.0).abs() < 1e-15);
        }
        // a diagonal scaling keeps the singular matrix singular
        let mut s = DMatrix::from_row_slice(2, 2, &[1e-3, 2e-3, 3.0, 6.0]);
        equilibrate(&mut s);
        assert!(s.determinant().abs() < 1e-15);
    }
}
