//! Continuously routed tendons: the Rucker & Webster 2011 coupled rod/tendon
//! equations ("Statics and dynamics of continuum robots with general tendon routing
//! and external loading", IEEE T-RO 27(6), section III; the same equations as John
//! Till's `ContinuumRobotExamples/05_Tendon_Robot` notes, which cite RW eqs. 15, 16
//! and 18-20), written in the project's `(r, R, n, m)` state.
//!
//! ## Derivation (symbols of RW; local = body frame)
//! Tendon `i` runs at `p_i = p + R r_i(s)` (RW eq. 7), so `p_i' = R q_i` with
//! `q_i = v + u x r_i + r_i'` (RW eq. 8). A frictionless tendon of constant tension
//! `tau_i` is a Cosserat string with internal force `tau_i p_i'/|p_i'|`; its
//! equilibrium makes the rod carry the distributed force and moment (RW eqs. 11-13)
//!
//! ```text
//! f_t = sum_i tau_i (p_i'/|p_i'|)' = sum_i R P_i (u x q_i + q_i'),   P_i = tau_i (I - h h^T)/|q_i|
//! l_t = sum_i (R r_i) x f_t,i                                          h = q_i/|q_i|
//! ```
//!
//! with `q_i' = v' - r_i x u' + u x r_i' + r_i''`: they depend on the strain rates,
//! which depend on `n'`, `m'` through the constitutive law `R^T n = K_se (v - e3)`,
//! `R^T m = K_bt (u - u*)` (thesis eqs. 2.9, 2.12). Writing `R^T n' = K_se v' + u x n_b`,
//! `R^T m' = K_bt u' + u x m_b` (`n_b = R^T n`, `m_b = R^T m`) in `n' = -f - f_t`,
//! `m' = -p' x n - l_t` gives RW's linear system (RW eqs. 14-16)
//!
//! ```text
//! [K_se + A   G       ] [v']   [-u x n_b - R^T f - a        ]
//! [G^T        K_bt + H] [u'] = [-u x m_b - v x n_b - b      ]
//! A = sum P_i,  G = -sum P_i [r_i]x,  H = -sum [r_i]x P_i [r_i]x,
//! a = sum P_i c_i,  b = sum r_i x P_i c_i,  c_i = u x q_i + u x r_i' + r_i''
//! ```
//!
//! (symmetric positive definite for `tau_i >= 0`: solved by `L D L^T`), after which
//! `n' = R (K_se v' + u x n_b)` and `m' = R (K_bt u' + u x m_b)`; `r' = R v`, `R' = R u^`
//! as for the bare rod. A Kirchhoff rod has `v = e3`, `v' = 0`: only the lower
//! 3 x 3 block is solved and `n' = -f - R (G u' + a)`.
//! Where tendon `i` ends (`s_e`, a section end) it pulls the rod at `p_i(s_e)` with
//! `F = -tau_i R h(s_e-)` (RW eqs. 18-20): `n(s+) = n(s-) - F`,
//! `m(s+) = m(s-) - (R r_i) x F` (the jump convention of docs/conventions.md). It is applied right
//! after the interval ending at `s_e` is integrated, before any other event there,
//! so `h` uses the strains just proximal to the end plate.
//!
//! The cable length is `l_i = int_0^{s_e} |p_i'| ds = int |q_i| ds`, integrated with
//! the stepper's own weights (RK4 or the DP5 solution weights), i.e. as an extra state.
//! Everything is generic over [`Real`], so dual passes give exact Jacobians, tension
//! parameters included.

use super::PassBuf;
use crate::integrate::{
    dp45_step_with, rk4_step_with, Coeffs, Dp45Outcome, ErrScale, State, DP45_B, DP45_C, RK4_B,
    RK4_C,
};
use crate::math::{mat_skew, mat_t_vec, mat_vec, Real};
use crate::statics::plan::{Interval, Plan, RoutedCable};
use nalgebra::Vector3;

/// Continuous tendons active on one interval that the fixed-size buffers hold.
pub(crate) const MAX_ROUTED: usize = 16;

/// The continuous tendons over one interval, with their tensions (load scale applied).
pub(crate) struct Active<T: Real> {
    n: usize,
    /// Index into `plan.routed`.
    idx: [usize; MAX_ROUTED],
    tension: [T; MAX_ROUTED],
    tensioned: [bool; MAX_ROUTED],
}

/// The continuous tendons running over `iv` (`None` if there are none).
pub(crate) fn active<T: Real>(
    plan: &Plan,
    buf: &PassBuf<T>,
    iv: &Interval,
    load_scale: f64,
) -> Option<Active<T>> {
    if plan.routed.is_empty() {
        return None;
    }
    let tol = 1e-12 * plan.length;
    let mut a = Active {
        n: 0,
        idx: [0; MAX_ROUTED],
        tension: [T::zero(); MAX_ROUTED],
        tensioned: [false; MAX_ROUTED],
    };
    for (i, rc) in plan.routed.iter().enumerate() {
        if rc.end_s < iv.s1 - tol || a.n == MAX_ROUTED {
            continue;
        }
        a.idx[a.n] = i;
        a.tension[a.n] = tension(plan, buf, rc.cable, load_scale);
        a.tensioned[a.n] = plan.cables[rc.cable].tensioned;
        a.n += 1;
    }
    (a.n > 0).then_some(a)
}

/// Tension of cable `j` (N): the scene's plus its parameter, times the load scale.
fn tension<T: Real>(plan: &Plan, buf: &PassBuf<T>, j: usize, load_scale: f64) -> T {
    let mut t = T::cst(plan.cables[j].tension);
    if let Some(k) = plan.tension_param[j] {
        t += buf.theta[k];
    }
    t.scale(load_scale)
}

#[inline(always)]
fn cross<T: Real>(a: &Vector3<T>, b: &Vector3<T>) -> Vector3<T> {
    Vector3::new(
        a.y * b.z - a.z * b.y,
        a.z * b.x - a.x * b.z,
        a.x * b.y - a.y * b.x,
    )
}

#[inline(always)]
fn cst3<T: Real>(v: &Vector3<f64>) -> Vector3<T> {
    Vector3::new(T::cst(v.x), T::cst(v.y), T::cst(v.z))
}

/// Local strains `(v, u)` of the rod at state `y` (thesis eqs. 2.10, 2.12 inverted).
#[inline(always)]
fn strains<T: Real>(y: &State<T>, c: &Coeffs) -> (Vector3<T>, Vector3<T>, Vector3<T>, Vector3<T>) {
    let nb = mat_t_vec(&y.rot, &y.n);
    let mb = mat_t_vec(&y.rot, &y.m);
    let v = if c.kirchhoff {
        Vector3::new(T::zero(), T::zero(), T::one())
    } else {
        Vector3::new(
            nb.x.scale(c.inv_d.x),
            nb.y.scale(c.inv_d.y),
            nb.z.scale(c.inv_d.z) + T::one(),
        )
    };
    let u = Vector3::new(
        mb.x.scale(c.inv_c.x) + T::cst(c.u_star.x),
        mb.y.scale(c.inv_c.y) + T::cst(c.u_star.y),
        mb.z.scale(c.inv_c.z) + T::cst(c.u_star.z),
    );
    (v, u, nb, mb)
}

/// Right-hand side with the tendons of `act` at arc length `s` (module docs); writes
/// each tendon's length integrand `|q_i|` into `g`.
fn field<T: Real>(
    y: &State<T>,
    s: f64,
    c: &Coeffs,
    routed: &[RoutedCable],
    act: &Active<T>,
    g: &mut [T; MAX_ROUTED],
) -> State<T> {
    let (v, u, nb, mb) = strains(y, c);
    // symmetric 6 x 6 system, rows/cols 0..3 = v', 3..6 = u'
    let mut k = [[T::zero(); 6]; 6];
    for i in 0..3 {
        k[i][i] = T::cst(1.0 / c.inv_d[i]);
        k[i + 3][i + 3] = T::cst(1.0 / c.inv_c[i]);
    }
    let fb = mat_t_vec(&y.rot, &cst3::<T>(&c.f));
    let mut b1 = -(cross(&u, &nb) + fb);
    let mut b2 = -(cross(&u, &mb) + cross(&v, &nb));
    // tendon-only parts of the v' row, kept for the Kirchhoff force balance
    let mut gm = [[T::zero(); 3]; 3];
    let mut am = Vector3::new(T::zero(), T::zero(), T::zero());
    for t in 0..act.n {
        let [r, r1, r2] = routed[act.idx[t]].path.eval(s);
        let q = v + cross(&u, &cst3::<T>(&r)) + cst3::<T>(&r1);
        let nq = q.dot(&q).sqrt();
        g[t] = nq;
        if !act.tensioned[t] {
            continue;
        }
        let inv = T::one() / nq;
        let hh = q * inv;
        let w = act.tension[t] * inv;
        // P = w (I - h h^T)
        let mut p = [[T::zero(); 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                let id = if a == b { w } else { T::zero() };
                p[a][b] = id - w * hh[a] * hh[b];
            }
        }
        let ci = cross(&u, &q) + cross(&u, &cst3::<T>(&r1)) + cst3::<T>(&r2);
        let pc = Vector3::new(
            p[0][0] * ci.x + p[0][1] * ci.y + p[0][2] * ci.z,
            p[1][0] * ci.x + p[1][1] * ci.y + p[1][2] * ci.z,
            p[2][0] * ci.x + p[2][1] * ci.y + p[2][2] * ci.z,
        );
        // X = [r]x (r has z = 0); W = P X
        let x = [[0.0, -r.z, r.y], [r.z, 0.0, -r.x], [-r.y, r.x, 0.0]];
        let mut pw = [[T::zero(); 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                pw[a][b] = p[a][0].scale(x[0][b]) + p[a][1].scale(x[1][b]) + p[a][2].scale(x[2][b]);
            }
        }
        for a in 0..3 {
            for b in 0..3 {
                k[a][b] += p[a][b];
                // G = -P X ; H = X^T P X
                k[a][b + 3] -= pw[a][b];
                k[b + 3][a] -= pw[a][b];
                let h = pw[0][b].scale(x[0][a]) + pw[1][b].scale(x[1][a]) + pw[2][b].scale(x[2][a]);
                k[a + 3][b + 3] += h;
                gm[a][b] -= pw[a][b];
            }
        }
        am += pc;
        b1 -= pc;
        b2 -= cross(&cst3::<T>(&r), &pc);
    }
    let mut rhs = [b1.x, b1.y, b1.z, b2.x, b2.y, b2.z];
    let (vs, us) = if c.kirchhoff {
        let mut k3 = [[T::zero(); 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                k3[a][b] = k[a + 3][b + 3];
            }
        }
        let mut r3 = [rhs[3], rhs[4], rhs[5]];
        ldlt_solve(&mut k3, &mut r3);
        let z = T::zero();
        (Vector3::new(z, z, z), Vector3::new(r3[0], r3[1], r3[2]))
    } else {
        ldlt_solve(&mut k, &mut rhs);
        (
            Vector3::new(rhs[0], rhs[1], rhs[2]),
            Vector3::new(rhs[3], rhs[4], rhs[5]),
        )
    };
    let nbs = if c.kirchhoff {
        // R^T n' = -R^T f - (G u' + a)
        let gu = Vector3::new(
            gm[0][0] * us.x + gm[0][1] * us.y + gm[0][2] * us.z,
            gm[1][0] * us.x + gm[1][1] * us.y + gm[1][2] * us.z,
            gm[2][0] * us.x + gm[2][1] * us.y + gm[2][2] * us.z,
        );
        -(fb + gu + am)
    } else {
        Vector3::new(
            vs.x.scale(1.0 / c.inv_d.x),
            vs.y.scale(1.0 / c.inv_d.y),
            vs.z.scale(1.0 / c.inv_d.z),
        ) + cross(&u, &nb)
    };
    let mbs = Vector3::new(
        us.x.scale(1.0 / c.inv_c.x),
        us.y.scale(1.0 / c.inv_c.y),
        us.z.scale(1.0 / c.inv_c.z),
    ) + cross(&u, &mb);
    State {
        r: mat_vec(&y.rot, &v),
        rot: mat_skew(&y.rot, &u),
        n: mat_vec(&y.rot, &nbs),
        m: mat_vec(&y.rot, &mbs),
    }
}

/// Solve `k x = rhs` in place for a symmetric positive definite `N x N` matrix
/// (`L D L^T` without pivoting). `N` is a constant (6 for the Cosserat rod, 3 for the
/// Kirchhoff rod) so the loops unroll: with a runtime size this solve was 45 % of a
/// routed RHS evaluation (callgrind on `till_warm_ramp`).
// index loops over a symmetric matrix read the lower triangle of other rows
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn ldlt_solve<T: Real, const N: usize>(k: &mut [[T; N]; N], rhs: &mut [T; N]) {
    // only the lower triangle is read: L below the diagonal, D on it
    for j in 0..N {
        let inv = T::one() / k[j][j];
        for i in j + 1..N {
            let kij = k[i][j] * inv;
            for c in j + 1..=i {
                let kcj = k[c][j];
                k[i][c] -= kij * kcj;
            }
        }
        for i in j + 1..N {
            k[i][j] *= inv;
            let rj = rhs[j];
            rhs[i] -= k[i][j] * rj;
        }
    }
    for j in (0..N).rev() {
        let mut x = rhs[j] / k[j][j];
        for i in j + 1..N {
            x -= k[i][j] * rhs[i];
        }
        rhs[j] = x;
    }
}

/// One RK4 step from arc length `s` with the tendons of `act`; adds the tendon
/// lengths over the step to `lengths` (indexed by cable).
#[allow(clippy::too_many_arguments)]
pub(crate) fn rk4_step<T: Real>(
    plan: &Plan,
    y: &State<T>,
    s: f64,
    h: f64,
    c: &Coeffs,
    act: &Active<T>,
    lengths: &mut [T],
) -> State<T> {
    let mut g = [T::zero(); MAX_ROUTED];
    let mut acc = [T::zero(); MAX_ROUTED];
    let out = rk4_step_with(y, h, |y, k| {
        let d = field(y, s + RK4_C[k] * h, c, &plan.routed, act, &mut g);
        for t in 0..act.n {
            acc[t] += g[t].scale(RK4_B[k] * h);
        }
        d
    });
    commit(plan, act, &acc, lengths);
    out
}

/// One DP5(4) step with the tendons of `act`; the length increments (5th-order
/// weights) come back for [`commit`] when the step is accepted.
#[allow(clippy::too_many_arguments)]
pub(crate) fn dp45_step<T: Real>(
    plan: &Plan,
    y: &State<T>,
    s: f64,
    h: f64,
    c: &Coeffs,
    act: &Active<T>,
    tol: f64,
    scale: &ErrScale,
) -> (Dp45Outcome<T>, [T; MAX_ROUTED]) {
    let mut g = [T::zero(); MAX_ROUTED];
    let mut acc = [T::zero(); MAX_ROUTED];
    let out = dp45_step_with(
        y,
        h,
        |y, k| {
            let d = field(y, s + DP45_C[k] * h, c, &plan.routed, act, &mut g);
            if DP45_B[k] != 0.0 {
                for t in 0..act.n {
                    acc[t] += g[t].scale(DP45_B[k] * h);
                }
            }
            d
        },
        tol,
        scale,
    );
    (out, acc)
}

/// Add a step's length increments to the cables' lengths.
pub(crate) fn commit<T: Real>(
    plan: &Plan,
    act: &Active<T>,
    inc: &[T; MAX_ROUTED],
    lengths: &mut [T],
) {
    for t in 0..act.n {
        lengths[plan.routed[act.idx[t]].cable] += inc[t];
    }
}

/// Terminations at the end `iv.s1` of the interval just integrated: each tensioned
/// tendon ending there pulls the rod along its tangent (RW eqs. 18-20).
pub(crate) fn terminate<T: Real>(
    plan: &Plan,
    buf: &PassBuf<T>,
    iv: &Interval,
    y: &mut State<T>,
    load_scale: f64,
) {
    let tol = 1e-12 * plan.length;
    let c = plan.coeffs_for(iv, load_scale);
    let mut strains_here = None;
    for rc in &plan.routed {
        if (rc.end_s - iv.s1).abs() > tol || !plan.cables[rc.cable].tensioned {
            continue;
        }
        let (v, u, _, _) = *strains_here.get_or_insert_with(|| strains(y, &c));
        let [r, r1, _] = rc.path.eval(rc.end_s);
        let q = v + cross(&u, &cst3::<T>(&r)) + cst3::<T>(&r1);
        let t = tension(plan, buf, rc.cable, load_scale) / q.dot(&q).sqrt();
        // tau R h: minus the force F on the rod
        let pull = mat_vec(&y.rot, &(q * t));
        let arm = mat_vec(&y.rot, &cst3::<T>(&r));
        y.n += pull;
        y.m += cross(&arm, &pull);
    }
}

/// Length (m) of cable `j` after the last pass of `buf`: the integral along a
/// continuous path, or the chords through its holes (thesis 3.8.1).
pub(crate) fn cable_length<T: Real>(plan: &Plan, buf: &PassBuf<T>, j: usize) -> T {
    let c = &plan.cables[j];
    if c.routed {
        buf.lengths[j]
    } else {
        crate::cables::path_length_t(&cst3::<T>(&c.base_hole), &buf.holes[j])
    }
}
