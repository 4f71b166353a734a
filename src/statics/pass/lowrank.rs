//! The condensed coupling's local inverse in low-rank form.
//!
//! A segment's local iteration (`condensed::settle_segment`) steps the assumed next
//! holes `q` (`L = 3 k` coordinates for `k` pending cables) with
//! `H ~ (I - dp/dq)^-1`. The sweep's exact value is `M = I + C K` (`C = dp/dj`,
//! `L x 6`; `K = (I - B C)^-1 B`, `6 x L`: Woodbury, see `condensed::fold_segment`),
//! and every Broyden update adds one outer product, so
//!
//! ```text
//! H = I + C K + sum_t u_t v_t^T
//! ```
//!
//! is kept as its factors: `H x` costs `12 L + 2 L t` operations instead of the
//! `L^2` of the explicit matrix (and its Broyden update `4 L + 2 L t` instead of
//! `2 L^2`). Why: on the FTDCR v4 robot (nine tendons through the first segment's
//! disks, `L = 27`) the explicit `27 x 27` products and copies were most of an `f64`
//! pass's local iteration (`settle_segment` 27 % of a warm recorded row's
//! instructions).
//!
//! Per guide, the stored buffer (`PassBuf::mlin`) is `[C | K | U | V]`: `C` row-major
//! `L x 6`, `K` row-major `6 x L`, then up to [`KEPT_TERMS`] Broyden terms, the
//! vectors `u_t` (rows of `U`) and `v_t` (rows of `V`), each of length `L`.

use crate::statics::plan::JUMP_DIRS;

/// Broyden terms a guide keeps for the next pass (`H` improved by a settled local
/// iteration; the next pass then starts from it instead of the sweep's `M`). A
/// segment that needed more updates than this starts the next pass from the sweep's
/// `M` again: each kept term costs `2 L` per product, so many would cost more than the
/// explicit matrix they replace.
pub(crate) const KEPT_TERMS: usize = 4;

/// Length of a guide's stored buffer for `l` hole coordinates.
pub(crate) fn stored_len(l: usize) -> usize {
    2 * JUMP_DIRS * l + 2 * KEPT_TERMS * l
}

/// The `C K` part of a guide's stored buffer (`2 * 6 * l` values).
pub(super) fn base(stored: &[f64], l: usize) -> &[f64] {
    &stored[..2 * JUMP_DIRS * l]
}

/// The kept terms' `(U, V)` of a guide's stored buffer.
pub(super) fn kept(stored: &[f64], l: usize) -> (&[f64], &[f64]) {
    let off = 2 * JUMP_DIRS * l;
    let (u, v) = stored[off..].split_at(KEPT_TERMS * l);
    (u, v)
}

/// Mutable form of [`kept`].
pub(super) fn kept_mut(stored: &mut [f64], l: usize) -> (&mut [f64], &mut [f64]) {
    let off = 2 * JUMP_DIRS * l;
    let (u, v) = stored[off..].split_at_mut(KEPT_TERMS * l);
    (u, v)
}

/// `out = H x` with `H = I + C K + sum_{t < terms} u_t v_t^T`; `base` is `[C | K]`
/// (`None`: no `C K` part, the plain fixed point's `I`), `u`, `v` hold the terms'
/// vectors row by row (`l` each).
pub(super) fn apply(
    base: Option<&[f64]>,
    l: usize,
    u: &[f64],
    v: &[f64],
    terms: usize,
    x: &[f64],
    out: &mut [f64],
) {
    let x = &x[..l];
    let out = &mut out[..l];
    out.copy_from_slice(x);
    if let Some(b) = base {
        let (c, k) = b.split_at(JUMP_DIRS * l);
        // the JUMP_DIRS dot products side by side (independent chains; per row the
        // same sum in the same order as `iter().sum()` from -0.0: bit-identical)
        let mut kx = [-0.0f64; JUMP_DIRS];
        for (col, &xc) in x.iter().enumerate() {
            for (t, acc) in kx.iter_mut().enumerate() {
                *acc += k[t * l + col] * xc;
            }
        }
        for (o, row) in out.iter_mut().zip(c.chunks_exact(JUMP_DIRS)) {
            *o += row.iter().zip(&kx).map(|(a, b)| a * b).sum::<f64>();
        }
    }
    for t in 0..terms {
        let (ut, vt) = (&u[t * l..(t + 1) * l], &v[t * l..(t + 1) * l]);
        let d: f64 = vt.iter().zip(x).map(|(a, b)| a * b).sum();
        for (o, a) in out.iter_mut().zip(ut) {
            *o += d * a;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `apply` equals the explicit `(I + C K + sum u v^T) x`.
    #[test]
    fn apply_matches_the_explicit_matrix() {
        let l = 9;
        let f = |i: usize| ((i * 7919 % 101) as f64 - 50.0) / 37.0;
        let c: Vec<f64> = (0..l * JUMP_DIRS).map(f).collect();
        let k: Vec<f64> = (0..l * JUMP_DIRS).map(|i| f(i + 500)).collect();
        let u: Vec<f64> = (0..2 * l).map(|i| f(i + 900)).collect();
        let v: Vec<f64> = (0..2 * l).map(|i| f(i + 1300)).collect();
        let x: Vec<f64> = (0..l).map(|i| f(i + 1700)).collect();
        let mut base = c.clone();
        base.extend(&k);
        let mut out = vec![0.0; l];
        apply(Some(&base), l, &u, &v, 2, &x, &mut out);
        for r in 0..l {
            let mut want = x[r];
            for col in 0..l {
                let mut m = (0..JUMP_DIRS)
                    .map(|t| c[r * JUMP_DIRS + t] * k[t * l + col])
                    .sum::<f64>();
                m += (0..2).map(|t| u[t * l + r] * v[t * l + col]).sum::<f64>();
                want += m * x[col];
            }
            assert!((out[r] - want).abs() <= 1e-12 * (1.0 + want.abs()), "{r}");
        }
        // no base, no terms: the identity
        apply(None, l, &u, &v, 0, &x, &mut out);
        assert_eq!(out, x);
    }
}
