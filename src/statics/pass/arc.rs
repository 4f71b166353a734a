//! Arc coupling ([`crate::settings::CableCoupling::Arc`]): a disk's chord forces
//! without the not-yet-integrated next disk.
//!
//! A tensioned cable pulls its disk along the chord back to the previous hole and the
//! chord on to the next one (thesis 3.8.1 routing). The next hole lies on a disk the
//! pass has not reached. Instead of solving for it (`condensed`, `exact`), this
//! predicts it: the gap of arc length `h` to the next disk is taken as a circular
//! arc with the curvature and strain at the gap's midpoint,
//!
//! ```text
//! body frame (m, n: R^T m, R^T n just after the disk; thesis eqs. 2.3-2.12 with no
//! distributed load over the gap):
//!   m' = -u x m - v x n,   n' = -u x n,   m'' ~ -u' x m - u x m' + v x (u x n)
//!   u = C^-1 m + u*,       v = D^-1 n + e3   (e3 for a Kirchhoff rod)
//! ```
//!
//! The moment is taken to second order in `s`; the rotation over the gap takes the
//! mean curvature (`phi = h u_mean`) and the position the mean weighted by
//! `2 (h - s) / h^2` (`psi`), both exact for a curvature quadratic in `s`, and the
//! strain's mean (`v_mean = v + (h/2) D^-1 n'`: a shear reverses over a gap along a
//! chord). The next disk's pose relative to this one is then `E = exp(phi^)`,
//! `tau = h V(psi) v_mean`, and the next hole in this disk's frame is `tau + E rho'`
//! (`rho'` its hole vector on the next disk; Murray, Li and Sastry 1994, eqs. 2.14 and
//! 2.36 for `E` and `V`). The chord force is
//! `t d/|d|` along `d = tau + E rho' - rho` in this disk's frame, rotated to the world
//! by `R` (the moment `R (rho x f)` likewise). The state after the jump (`n+`,
//! `m+`) depends on these forces, so the prediction and the jump are iterated
//! [`SolverSettings::arc_rounds`] times (rounds; default [`ARC_ROUNDS`]). They start
//! from each chord on as the mirror image of its chord back through the disk's plane
//! (exact on a circular arc of equal gaps), corrected by what the rounds changed at
//! the disks just before: the last disk's correction (force and moment in the disk's
//! frame), or its linear extrapolation `2 c_1 - c_2` from the last two (with two
//! rounds or more), when those disks send their chords on along the same cables
//! (`Plan::arc_carry`; along a segment the curvature changes smoothly from disk to
//! disk, so the corrections do too). A fixed count and a start computed within the
//! same pass, so the pass stays an explicit, smooth function of the unknowns and dual
//! passes give its exact derivatives.
//!
//! What it neglects: the moment's terms beyond second order in `s` (a hole error of
//! about `h theta^4` for a gap bending by `theta`), the distributed load on the gap,
//! and what the fixed-point iteration leaves (it contracts by about
//! `sum t (h^2/6 + rho h/2) / EI` a round, ~0.25 on the FTDCR v4). The cable lengths
//! use the integrated holes, as with every coupling. Measured against `condensed` in
//! `tests/arc_coupling.rs`.

use super::{unit, v3, PassBuf};
use crate::integrate::{Coeffs, State};
use crate::math::{cross, fma, mat_t_vec, mat_vec, mat_vec_f64, Dual, Real};
#[cfg(doc)]
use crate::settings::{SolverSettings, ARC_ROUNDS};
use crate::statics::plan::{ArcChord, Plan};
use nalgebra::{Matrix3, Vector3};

/// `sin x / x`, `(1 - cos x) / x^2` and `(x - sin x) / x^3` of `x = sqrt(x2)`: series
/// for `x2 <= 0.25` (truncation below 3e-11; no square root, so a dual at `x = 0` has
/// finite derivatives), closed form above.
///
/// For a dual `x2` the three functions and their derivatives are evaluated once at
/// the value (a `Dual<1>`: the same value arithmetic as an `f64`), and the chain rule
/// ([`Real::chain`]) gives every direction with one product each, instead of a
/// dozen dual operations per function (a `Dual<15>` sweep on the FTDCR v4 val rows:
/// benches/README.md).
#[inline]
fn exp_coefficients<T: Real>(x2: T) -> (T, T, T) {
    if T::DIRS == 0 {
        return exp_series(x2);
    }
    let (a, b, c) = exp_series(Dual::<1>::variable(x2.re(), 0));
    (
        x2.chain(a.v, a.d[0]),
        x2.chain(b.v, b.d[0]),
        x2.chain(c.v, c.d[0]),
    )
}

/// The functions of [`exp_coefficients`] over any scalar.
#[inline]
fn exp_series<T: Real>(x2: T) -> (T, T, T) {
    if x2.re() <= 0.25 {
        let one = T::one();
        let a = one
            + x2.scale(-1.0 / 6.0)
                * (one
                    + x2.scale(-1.0 / 20.0)
                        * (one + x2.scale(-1.0 / 42.0) * (one + x2.scale(-1.0 / 72.0))));
        let b = (one
            + x2.scale(-1.0 / 12.0)
                * (one
                    + x2.scale(-1.0 / 30.0)
                        * (one + x2.scale(-1.0 / 56.0) * (one + x2.scale(-1.0 / 90.0)))))
        .scale(0.5);
        let c = (one
            + x2.scale(-1.0 / 20.0)
                * (one
                    + x2.scale(-1.0 / 42.0)
                        * (one + x2.scale(-1.0 / 72.0) * (one + x2.scale(-1.0 / 110.0)))))
        .scale(1.0 / 6.0);
        (a, b, c)
    } else {
        let x = x2.sqrt();
        let (s, co) = x.sin_cos();
        (s / x, (T::one() - co) / x2, (x - s) / (x2 * x))
    }
}

/// `a x b` for a plain `f64` vector `b` (a hole vector).
#[inline(always)]
fn cross_f64<T: Real>(a: &Vector3<T>, b: &Vector3<f64>) -> Vector3<T> {
    Vector3::new(
        a.y.scale(b.z) - a.z.scale(b.y),
        a.z.scale(b.x) - a.x.scale(b.z),
        a.x.scale(b.y) - a.y.scale(b.x),
    )
}

/// `a + c` for a plain `f64` vector `c`: only the value parts change
/// ([`Real::add_cst`]; the same values as adding `c` promoted to `T`).
#[inline(always)]
fn plus_f64<T: Real>(a: Vector3<T>, c: &Vector3<f64>) -> Vector3<T> {
    Vector3::new(a.x.add_cst(c.x), a.y.add_cst(c.y), a.z.add_cst(c.z))
}

/// `b x a` for a plain `f64` vector `b`.
#[inline(always)]
fn f64_cross<T: Real>(b: &Vector3<f64>, a: &Vector3<T>) -> Vector3<T> {
    -cross_f64(a, b)
}

/// The predicted gap to the next disk (this disk's frame): the next disk's rotation
/// `E` and the position `tau` of its centre.
struct Gap<T: Real> {
    e: Matrix3<T>,
    tau: Vector3<T>,
}

/// The arc over a gap of length `h` with the stiffness `co`, from the body-frame
/// internal force `nl` and moment `ml` just after the disk (module docs).
#[inline]
fn predict_gap<T: Real>(h: f64, co: &Coeffs, nl: &Vector3<T>, ml: &Vector3<T>) -> Gap<T> {
    let v = if co.kirchhoff {
        Vector3::new(T::zero(), T::zero(), T::one())
    } else {
        Vector3::new(
            nl.x.scale(co.inv_d.x),
            nl.y.scale(co.inv_d.y),
            nl.z.scale(co.inv_d.z).add_cst(1.0),
        )
    };
    // body-frame moment over the gap to second order in s (no distributed load):
    // m' = -u x m - v x n, n' = -u x n, m'' = -u' x m - u x m' + v x (u x n)
    let bend = |m: &Vector3<T>| {
        Vector3::new(
            m.x.scale(co.inv_c.x),
            m.y.scale(co.inv_c.y),
            m.z.scale(co.inv_c.z),
        )
    };
    let u0 = plus_f64(bend(ml), &co.u_star);
    let m1 = -(cross(&u0, ml) + cross(&v, nl));
    let u1 = bend(&m1);
    let un = cross(&u0, nl);
    let m2 = cross(&v, &un) - cross(&u0, &m1) - cross(&u1, ml);
    // the rotation takes the mean curvature, the position the mean weighted by
    // 2 (h - s) / h^2 (both exact for a curvature quadratic in s)
    let at = |w1: f64, w2: f64| {
        let m = ml + m1.map(|x| x.scale(w1 * h)) + m2.map(|x| x.scale(w2 * h * h));
        plus_f64(bend(&m), &co.u_star).map(|x| x.scale(h))
    };
    let (phi, psi) = (at(0.5, 1.0 / 6.0), at(1.0 / 3.0, 1.0 / 12.0));
    let (a, b, _) = exp_coefficients(phi.dot(&phi));
    let (_, bp, cp) = exp_coefficients(psi.dot(&psi));
    // E = I + a phi^ + b phi^2 (phi^2 = phi phi^T - |phi|^2 I)
    let (pa, pb) = (phi.map(|x| x * a), phi.map(|x| x * b));
    let p2 = phi.dot(&phi) * b;
    let one = T::one();
    let e = Matrix3::new(
        one + pb.x * phi.x - p2,
        pb.x * phi.y - pa.z,
        pb.x * phi.z + pa.y,
        pb.y * phi.x + pa.z,
        one + pb.y * phi.y - p2,
        pb.y * phi.z - pa.x,
        pb.z * phi.x - pa.y,
        pb.z * phi.y + pa.x,
        one + pb.z * phi.z - p2,
    );
    // the strain's mean over the gap (n turns in the body frame: n' = -u x n, so
    // a shear at the disk reverses over a gap along a chord)
    let vm = if co.kirchhoff {
        v
    } else {
        let dn = un.map(|x| x.scale(-0.5 * h));
        v + Vector3::new(
            dn.x.scale(co.inv_d.x),
            dn.y.scale(co.inv_d.y),
            dn.z.scale(co.inv_d.z),
        )
    };
    let pv = cross(&psi, &vm);
    let tau = (vm + pv.map(|x| x * bp) + cross(&psi, &pv).map(|x| x * cp)).map(|x| x.scale(h));
    Gap { e, tau }
}

/// One round's chords on (module docs) from the body-frame state `(nl, mlp)` just
/// after the disk, summed in the disk's frame (force, moment). `tension(j)` is cable
/// `j`'s chord tension; `per_chord` sees each chord with the value parts of its `d`
/// and `d . d` (for the force per newton of tension, `d / |d|`).
#[inline(always)]
fn round_chords<S: Real>(
    plan: &Plan,
    g: usize,
    nl: &Vector3<S>,
    mlp: &Vector3<S>,
    tension: impl Fn(usize) -> S,
    mut per_chord: impl FnMut(&ArcChord, &Vector3<f64>, f64),
) -> (Vector3<S>, Vector3<S>) {
    let z = Vector3::new(S::zero(), S::zero(), S::zero());
    let (mut fl, mut ml) = (z, z);
    // one prediction per gap (every cable's, when the routes run disk to disk)
    let mut gap: Option<Gap<S>> = None;
    for a in &plan.arc_chords[g] {
        if a.new_gap {
            gap = None;
        }
        let gp = gap.get_or_insert_with(|| predict_gap(a.gap.0, &plan.coeffs[a.gap.1], nl, mlp));
        let d = plus_f64(gp.tau + mat_vec_f64(&gp.e, &a.rho_next), &-a.rho);
        // t d / |d| (as `unit(d) * t`, with one product fewer per component)
        let dd = d.dot(&d);
        let f = if dd.re() > 0.0 {
            per_chord(a, &d.map(|x| x.re()), dd.re());
            let s = tension(a.cable) / dd.sqrt();
            d.map(|x| x * s)
        } else {
            d
        };
        fl += f;
        ml += f64_cross(&a.rho, &f);
    }
    (fl, ml)
}

/// `y += a x` over derivative parts.
#[inline(always)]
fn axpy(y: &mut [f64], a: f64, x: &[f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi = fma(a, *xi, *yi);
    }
}

/// [`round_chords`] for a dual `T` by the chain rule. A round depends on the duals'
/// directions only through its six inputs `(nl, mlp)` and the chord tensions, and on
/// a tension only linearly (`f = t d / |d|`). So the round runs once over a
/// `Dual<6>` seeded along its inputs (the same value arithmetic as over `T`, so the
/// same values), and each output's directions are its six partials times the
/// inputs' directions plus, per chord, `d / |d|` (and `rho x d / |d|`) times the
/// tension's. A `Dual<15>` sweep on the FTDCR v4 val rows: 3.9 % fewer instructions
/// (benches/README.md). Not inlined: inlined into `guide_chords` the
/// sweep took 1.6 % more instructions than this way.
#[inline(never)]
fn round_chained<T: Real>(
    plan: &Plan,
    g: usize,
    nl: &Vector3<T>,
    mlp: &Vector3<T>,
    arc_t: &[T],
) -> (Vector3<T>, Vector3<T>) {
    let inputs = [nl.x, nl.y, nl.z, mlp.x, mlp.y, mlp.z];
    let seed = |k: usize| Dual::<6>::variable(inputs[k].re(), k);
    let (nl6, ml6) = (
        Vector3::new(seed(0), seed(1), seed(2)),
        Vector3::new(seed(3), seed(4), seed(5)),
    );
    // the tensions' terms first, then the values and the inputs' terms
    let mut out = [T::zero(); 6];
    let (f6, m6) = round_chords(
        plan,
        g,
        &nl6,
        &ml6,
        |j| Dual::<6>::constant(arc_t[j].re()),
        |a, d, dd| {
            let u = d * (1.0 / dd.sqrt());
            let um = a.rho.cross(&u);
            let te = arc_t[a.cable].eps();
            for k in 0..3 {
                axpy(out[k].eps_mut(), u[k], te);
                axpy(out[3 + k].eps_mut(), um[k], te);
            }
        },
    );
    let local = [f6.x, f6.y, f6.z, m6.x, m6.y, m6.z];
    for (o, l) in out.iter_mut().zip(&local) {
        *o = o.add_cst(l.v);
        for (i, x) in inputs.iter().enumerate() {
            axpy(o.eps_mut(), l.d[i], x.eps());
        }
    }
    (
        Vector3::new(out[0], out[1], out[2]),
        Vector3::new(out[3], out[4], out[5]),
    )
}

/// The chords of guide `g` under the arc coupling: records the holes, applies the
/// jump of `(n, m)` of every tensioned cable's chords to `y`.
pub(super) fn guide_chords<T: Real>(plan: &Plan, g: usize, y: &mut State<T>, buf: &mut PassBuf<T>) {
    let z = Vector3::new(T::zero(), T::zero(), T::zero());
    // the chords back to the previous holes: fixed
    let (mut jn, mut jm) = (z, z);
    // the first guess of the chords on: each the mirror image of the chord back
    // through the disk's plane (exact on a circular arc of equal gaps)
    let (mut gn, mut gm) = (z, z);
    let axis = Vector3::new(y.rot[(0, 2)], y.rot[(1, 2)], y.rot[(2, 2)]);
    let mut any_next = false;
    for &(j, k) in &plan.guide_cables[g] {
        let c = &plan.cables[j];
        let arm = mat_vec_f64(&y.rot, &c.hole_local[k]);
        let p = y.r + arm;
        buf.holes[j][k] = p;
        if !c.tensioned {
            continue;
        }
        let t_act = buf.arc_act[j];
        let t = t_act.scale(c.factor[k]);
        let prev = if k == 0 {
            v3::<T>(&c.base_hole)
        } else {
            buf.holes[j][k - 1]
        };
        let u = unit(prev - p);
        let f = u.map(|x| x * t);
        jn += f;
        jm += cross(&arm, &f);
        if k + 1 < c.len {
            any_next = true;
            let t_next = t_act.scale(c.factor[k + 1]);
            buf.arc_t[j] = t_next;
            let ua = u.dot(&axis);
            let f = (u - axis.map(|x| x * (ua + ua))).map(|x| x * t_next);
            gn += f;
            gm += cross(&arm, &f);
        }
    }
    if !any_next {
        y.n -= jn;
        y.m -= jm;
        return;
    }
    // the chords on to the predicted next holes, summed in this disk's frame: the
    // mirrored chords, corrected as the rounds of the guides just before corrected
    // theirs (module docs)
    let (mut fl, mut ml) = (mat_t_vec(&y.rot, &gn), mat_t_vec(&y.rot, &gm));
    let (fl_mirror, ml_mirror) = (fl, ml);
    let carry = if buf.arc_corr_g.wrapping_add(1) == g {
        plan.arc_carry[g]
    } else {
        0
    };
    let [(c1f, c1m), (c2f, c2m)] = buf.arc_corr;
    match carry {
        0 => {}
        1 => {
            fl += c1f;
            ml += c1m;
        }
        _ => {
            fl += c1f + c1f - c2f;
            ml += c1m + c1m - c2m;
        }
    }
    let (jnl, jml) = (mat_t_vec(&y.rot, &jn), mat_t_vec(&y.rot, &jm));
    let (nl0, ml0) = (mat_t_vec(&y.rot, &y.n), mat_t_vec(&y.rot, &y.m));
    for _ in 0..plan.arc_rounds {
        // the state after the jump as the last round left it
        let (nl, mlp) = (nl0 - jnl - fl, ml0 - jml - ml);
        (fl, ml) = if T::DIRS == 0 {
            round_chords(plan, g, &nl, &mlp, |j| buf.arc_t[j], |_, _, _| {})
        } else {
            round_chained(plan, g, &nl, &mlp, &buf.arc_t)
        };
    }
    buf.arc_corr = [(fl - fl_mirror, ml - ml_mirror), buf.arc_corr[0]];
    buf.arc_corr_g = g;
    y.n -= jn + mat_vec(&y.rot, &fl);
    y.m -= jm + mat_vec(&y.rot, &ml);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The series branch against the closed form, on both sides of its threshold
    /// (relative 1e-10: the series' truncation is below 3e-11 at `x^2 = 0.25`).
    #[test]
    fn exp_coefficients_match_the_closed_form() {
        for x in [1e-3, 0.1, 0.3, 0.49, 0.501, 1.0, 2.5] {
            let (a, b, c) = exp_coefficients(x * x);
            let (s, co) = f64::sin_cos(x);
            let want = [s / x, (1.0 - co) / (x * x), (x - s) / (x * x * x)];
            for (got, want) in [a, b, c].into_iter().zip(want) {
                assert!(
                    (got - want).abs() <= 1e-10 * want.abs(),
                    "x {x}: {got} vs {want}"
                );
            }
        }
    }

    /// The rounds' carried start (module docs), on the shipped FTDCR v4 scene solved
    /// warm from the servo readings of the 443 val rows: the tips with 2 rounds
    /// from the carried start (the scene's `arc_rounds`) lie as close to the tips of
    /// the rounds' fixed point (40 rounds from the mirrored chords, no carry) as those
    /// of 3 rounds from the mirrored chords alone (the coupling without the carry),
    /// by the mean and by the largest distance; 2 rounds from the mirrored chords lie
    /// several times farther. One round from the carried start converges on every row
    /// within 0.1 mm on average. Measured: mean / max 6.7 / 60 um carried, 7.0 / 91 um
    /// 3 rounds mirrored, 32 / 336 um 2 rounds mirrored, 39 / 270 um 1 round carried.
    #[test]
    fn two_rounds_from_the_carried_start_are_as_close_as_three_from_the_mirror() {
        let scene = crate::Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
        let text = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").expect("shipped data");
        let tips = |rounds: usize, carry: bool| {
            let mut scene = scene.clone();
            scene.numerics.arc_rounds = rounds;
            let mut tw = scene.tendon_workspace().expect("workspace");
            let plan = tw.workspace_mut().plan_mut();
            assert!(plan.arc && plan.arc_rounds == rounds);
            assert_eq!(
                plan.arc_carry.iter().max(),
                Some(&if rounds >= 2 { 2 } else { 1 })
            );
            if !carry {
                plan.arc_carry.iter_mut().for_each(|c| *c = 0);
            }
            let mut parser = scene.readings_parser(&tw);
            let rows: Vec<_> = text
                .lines()
                .enumerate()
                .filter_map(|(i, l)| parser.line(i + 1, l).ok().flatten())
                .collect();
            assert_eq!(rows.len(), 443);
            rows.iter()
                .map(|row| {
                    let rep = tw.solve_readings(&row.readings_m).expect("row");
                    assert!(rep.status.is_converged(), "{rounds} {carry}: {rep:?}");
                    tw.tip_position()
                })
                .collect::<Vec<_>>()
        };
        let fixed = tips(40, false);
        let from = |t: &[Vector3<f64>]| {
            let d: Vec<f64> = t.iter().zip(&fixed).map(|(a, b)| (a - b).norm()).collect();
            let mean = d.iter().sum::<f64>() / d.len() as f64;
            (mean, d.iter().fold(0.0f64, |m, x| m.max(*x)))
        };
        let carried = from(&tips(2, true));
        let (three, two) = (from(&tips(3, false)), from(&tips(2, false)));
        let one = from(&tips(1, true));
        let um = |(a, b): (f64, f64)| format!("{:.2} / {:.1} um", a * 1e6, b * 1e6);
        println!(
            "tips from the fixed point, mean / max: carried {}, 3 mirrored {}, 2 mirrored {}, \
             1 carried {}",
            um(carried),
            um(three),
            um(two),
            um(one)
        );
        assert!(
            carried.0 <= three.0 && carried.1 <= three.1,
            "{carried:?} {three:?}"
        );
        assert!(two.0 > 3.0 * carried.0, "{two:?} {carried:?}");
        // one round (its correction carried, not extrapolated): every row converges
        // (asserted in `tips`), within 0.1 mm on average
        assert!(one.0 < 1e-4, "{one:?}");
    }

    /// The chain rule of a dual's [`exp_coefficients`] against the series and the
    /// closed form evaluated over the dual itself (every direction through every
    /// operation): the same values bit for bit, derivatives within 1e-12 relative
    /// (the closed form cancels: 1e-13 apart at `x = 0.501`),
    /// on both sides of the series' threshold.
    #[test]
    fn chained_exp_coefficients_match_the_dual_series() {
        for x in [1e-3, 0.1, 0.3, 0.49, 0.501, 1.0, 2.5] {
            let mut x2 = Dual::<3>::variable(x * x, 0);
            x2.d = [1.0, -0.37, 2.5];
            let got = exp_coefficients(x2);
            let want = exp_series(x2);
            for (g, w) in [got.0, got.1, got.2]
                .into_iter()
                .zip([want.0, want.1, want.2])
            {
                assert_eq!(g.v, w.v, "x {x}");
                for (a, b) in g.d.iter().zip(&w.d) {
                    assert!(
                        (a - b).abs() <= 1e-12 * b.abs().max(1e-3),
                        "x {x}: {a} vs {b}"
                    );
                }
            }
        }
    }

    /// A round by the chain rule ([`round_chained`]) against the same round over
    /// `Dual<15>` in every operation ([`round_chords`]), at guides of each segment
    /// of the shipped FTDCR v4 scene, with inputs and tensions whose directions are
    /// all nonzero: the same values bit for bit, the derivatives within 1e-11 of the
    /// largest. Fails if a tension's term or an input's partials go missing.
    #[test]
    fn a_chained_round_is_the_dual_round() {
        let scene = crate::Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
        let mut tw = scene.tendon_workspace().expect("workspace");
        let plan = tw.workspace_mut().plan_mut().clone();
        type D = Dual<15>;
        let var = |v: f64, k: usize| {
            let mut x = D::constant(v);
            for (i, d) in x.d.iter_mut().enumerate() {
                *d = ((i * 7 + k * 13) % 11) as f64 / 11.0 - 0.4;
            }
            x
        };
        // body-frame force (N) and moment (N m) just after a disk, as on the robot
        let nl = Vector3::new(var(0.3, 0), var(-0.2, 1), var(-6.0, 2));
        let ml = Vector3::new(var(4e-3, 3), var(-2e-3, 4), var(1e-4, 5));
        let arc_t: Vec<D> = (0..plan.cables.len())
            .map(|j| var(1.5 + 0.3 * j as f64, 6 + j))
            .collect();
        let mut checked = 0;
        for g in [0, 4, 12, 15, 25] {
            if plan.arc_chords[g].is_empty() {
                continue;
            }
            checked += 1;
            let (f1, m1) = round_chained(&plan, g, &nl, &ml, &arc_t);
            let (f2, m2) = round_chords(&plan, g, &nl, &ml, |j| arc_t[j], |_, _, _| {});
            for (a, b) in f1.iter().chain(m1.iter()).zip(f2.iter().chain(m2.iter())) {
                assert_eq!(a.v, b.v, "guide {g}");
                let top = b.d.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                for (x, y) in a.d.iter().zip(&b.d) {
                    assert!((x - y).abs() <= 1e-11 * top, "guide {g}: {x} vs {y}");
                }
                assert!(top > 0.0);
            }
        }
        assert_eq!(checked, 5);
    }

    /// A Kirchhoff gap under a pure bending moment (no force) is a circular arc:
    /// the predicted pose is that arc's, exactly (rotation about x by `theta = h k`,
    /// centre at `(0, -(1 - cos theta)/k, sin theta/k)`), to 1e-14 relative.
    #[test]
    fn a_gap_under_pure_bending_is_the_exact_arc() {
        let (ei, k, h) = (2.5e-3, 7.0, 0.02);
        let co = Coeffs {
            inv_c: Vector3::new(1.0 / ei, 1.0 / ei, 1.0 / (0.77 * ei)),
            inv_d: Vector3::zeros(),
            u_star: Vector3::zeros(),
            f: Vector3::zeros(),
            kirchhoff: true,
        };
        let gap = predict_gap(h, &co, &Vector3::zeros(), &Vector3::new(ei * k, 0.0, 0.0));
        let t = h * k;
        let tau = Vector3::new(0.0, -(1.0 - t.cos()) / k, t.sin() / k);
        let e = nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), t).into_inner();
        assert!((gap.tau - tau).norm() <= 1e-14 * h, "{} vs {tau}", gap.tau);
        assert!((gap.e - e).norm() <= 1e-14, "{} vs {e}", gap.e);
    }
}
