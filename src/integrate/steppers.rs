//! One step of classical RK4 and of Dormand-Prince 5(4) on a [`State`].

use super::{rhs, Coeffs, State};
use crate::math::{orthonormalize, Real};

/// One classical RK4 step of length `h`; `R` is re-orthonormalised afterwards
/// (a Newton-Schulz step, exact for dual numbers). Four RHS evaluations.
#[inline]
pub fn rk4_step<T: Real>(y: &State<T>, h: f64, c: &Coeffs) -> State<T> {
    // Inlined all the way down: as a separate closure the RHS was not inlined into the
    // pass and its `State` went through memory (`forward_warm/average/rk4_24` 10 -> 15.6 us
    // with the same instruction count, found by bisection).
    rk4_step_with(
        y,
        h,
        #[inline(always)]
        |y, _| rhs(y, c),
    )
}

/// Stage abscissae `c_k` (fractions of the step) of [`rk4_step_with`].
pub const RK4_C: [f64; 4] = [0.0, 0.5, 0.5, 1.0];
/// Stage weights `b_k` of [`rk4_step_with`].
pub const RK4_B: [f64; 4] = [1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0];

/// [`rk4_step`] with any right-hand side `f(y, stage)`, evaluated at stage
/// `k = 0..4` at `s + RK4_C[k] h` (a non-autonomous field, or one that integrates a
/// quadrature alongside with the weights [`RK4_B`]).
#[inline(always)]
pub fn rk4_step_with<T: Real>(
    y: &State<T>,
    h: f64,
    mut f: impl FnMut(&State<T>, usize) -> State<T>,
) -> State<T> {
    // accumulated in place, each stage's derivative used once and dropped (the same
    // operations in the same order as `y + h/6 k1 + h/3 k2 + h/3 k3 + h/6 k4` built
    // from copies, so bit-identical; the copies were `memcpy`s of 3 kB per stage for a
    // `Dual<21>` state)
    let k = f(y, 0);
    let mut out = y.add_scaled(&k, h / 6.0);
    let mut stage = y.add_scaled(&k, 0.5 * h);
    let k = f(&stage, 1);
    out.axpy(&k, h / 3.0);
    stage.set_add_scaled(y, &k, 0.5 * h);
    let k = f(&stage, 2);
    out.axpy(&k, h / 3.0);
    stage.set_add_scaled(y, &k, h);
    let k = f(&stage, 3);
    out.axpy(&k, h / 6.0);
    out.rot = orthonormalize(&out.rot);
    out
}

/// Result of one attempted DP5(4) step.
pub struct Dp45Outcome<T: Real> {
    /// Fifth-order solution at `s + h`.
    pub y: State<T>,
    /// Scaled error estimate (accept when <= 1).
    pub err: f64,
}

/// Scales that make the state components comparable in the error norm.
#[derive(Clone, Copy, Debug)]
pub struct ErrScale {
    /// Length scale (m).
    pub length: f64,
    /// Force scale (N).
    pub force: f64,
    /// Moment scale (N m).
    pub moment: f64,
}

/// One Dormand-Prince 5(4) step (7 RHS evaluations); error measured on value parts,
/// scaled by `scale`, relative to `tol`.
pub fn dp45_step<T: Real>(
    y: &State<T>,
    h: f64,
    c: &Coeffs,
    tol: f64,
    scale: &ErrScale,
) -> Dp45Outcome<T> {
    dp45_step_with(
        y,
        h,
        #[inline(always)]
        |y, _| rhs(y, c),
        tol,
        scale,
    )
}

/// Stage abscissae `c_k` of [`dp45_step_with`] (stage 6 is the FSAL point `s + h`).
pub const DP45_C: [f64; 7] = [0.0, 0.2, 0.3, 0.8, 8.0 / 9.0, 1.0, 1.0];
/// Fifth-order weights `b_k` of [`dp45_step_with`] (the accepted solution).
pub const DP45_B: [f64; 7] = [
    35.0 / 384.0,
    0.0,
    500.0 / 1113.0,
    125.0 / 192.0,
    -2187.0 / 6784.0,
    11.0 / 84.0,
    0.0,
];

/// [`dp45_step`] with any right-hand side `f(y, stage)`, stage `k` at
/// `s + DP45_C[k] h` (see [`rk4_step_with`]).
pub fn dp45_step_with<T: Real>(
    y: &State<T>,
    h: f64,
    mut f: impl FnMut(&State<T>, usize) -> State<T>,
    tol: f64,
    scale: &ErrScale,
) -> Dp45Outcome<T> {
    const A21: f64 = 1.0 / 5.0;
    const A31: f64 = 3.0 / 40.0;
    const A32: f64 = 9.0 / 40.0;
    const A41: f64 = 44.0 / 45.0;
    const A42: f64 = -56.0 / 15.0;
    const A43: f64 = 32.0 / 9.0;
    const A51: f64 = 19372.0 / 6561.0;
    const A52: f64 = -25360.0 / 2187.0;
    const A53: f64 = 64448.0 / 6561.0;
    const A54: f64 = -212.0 / 729.0;
    const A61: f64 = 9017.0 / 3168.0;
    const A62: f64 = -355.0 / 33.0;
    const A63: f64 = 46732.0 / 5247.0;
    const A64: f64 = 49.0 / 176.0;
    const A65: f64 = -5103.0 / 18656.0;
    const B1: f64 = 35.0 / 384.0;
    const B3: f64 = 500.0 / 1113.0;
    const B4: f64 = 125.0 / 192.0;
    const B5: f64 = -2187.0 / 6784.0;
    const B6: f64 = 11.0 / 84.0;
    // error coefficients b - b*
    const E1: f64 = 71.0 / 57600.0;
    const E3: f64 = -71.0 / 16695.0;
    const E4: f64 = 71.0 / 1920.0;
    const E5: f64 = -17253.0 / 339200.0;
    const E6: f64 = 22.0 / 525.0;
    const E7: f64 = -1.0 / 40.0;

    let k1 = f(y, 0);
    let k2 = f(&y.add_scaled(&k1, h * A21), 1);
    let k3 = f(&y.add_scaled(&k1, h * A31).add_scaled(&k2, h * A32), 2);
    let k4 = f(
        &y.add_scaled(&k1, h * A41)
            .add_scaled(&k2, h * A42)
            .add_scaled(&k3, h * A43),
        3,
    );
    let k5 = f(
        &y.add_scaled(&k1, h * A51)
            .add_scaled(&k2, h * A52)
            .add_scaled(&k3, h * A53)
            .add_scaled(&k4, h * A54),
        4,
    );
    let k6 = f(
        &y.add_scaled(&k1, h * A61)
            .add_scaled(&k2, h * A62)
            .add_scaled(&k3, h * A63)
            .add_scaled(&k4, h * A64)
            .add_scaled(&k5, h * A65),
        5,
    );
    let mut y5 = y
        .add_scaled(&k1, h * B1)
        .add_scaled(&k3, h * B3)
        .add_scaled(&k4, h * B4)
        .add_scaled(&k5, h * B5)
        .add_scaled(&k6, h * B6);
    let k7 = f(&y5, 6);
    let zero = State {
        r: y.r.map(|_| T::zero()),
        rot: y.rot.map(|_| T::zero()),
        n: y.n.map(|_| T::zero()),
        m: y.m.map(|_| T::zero()),
    };
    let e = zero
        .add_scaled(&k1, h * E1)
        .add_scaled(&k3, h * E3)
        .add_scaled(&k4, h * E4)
        .add_scaled(&k5, h * E5)
        .add_scaled(&k6, h * E6)
        .add_scaled(&k7, h * E7)
        .value();
    let yv = y5.value();
    let mut err = 0.0f64;
    let mut acc = |ei: f64, yi: f64, sc: f64| {
        let w = tol * (sc + yi.abs());
        err = err.max(ei.abs() / w);
    };
    for i in 0..3 {
        acc(e.r[i], yv.r[i], scale.length);
        acc(e.n[i], yv.n[i], scale.force);
        acc(e.m[i], yv.m[i], scale.moment);
    }
    for i in 0..9 {
        acc(e.rot[i], yv.rot[i], 1.0);
    }
    y5.rot = orthonormalize(&y5.rot);
    Dp45Outcome { y: y5, err }
}
