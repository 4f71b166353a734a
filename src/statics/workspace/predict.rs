//! Secant predictor of warm solves along a load ramp: when the new loads continue
//! the last load step in the same direction (`L2 - L1 = alpha (L1 - L0)`, all load
//! values and load parameters together), Newton starts from the linear extrapolation
//! `x1 + alpha (x1 - x0)` of the last two solutions instead of `x1` (the natural-
//! parameter secant predictor of continuation methods, Allgower & Georg,
//! "Introduction to Numerical Continuation Methods", ch. 2, here along the user's own
//! load path). Its error is second order in the load step, where the plain warm start's
//! is first order; with the solutions before that on the same load line the
//! extrapolation is quadratic or cubic (Lagrange). On Till's tension ramp
//! (`continuous/till_warm_ramp`) the start's scaled residual drops from 0.16 (plain
//! warm start) to 4e-7 (linear), 3e-10 (quadratic) and mostly below the 1e-10
//! tolerance (cubic): most solves then take no Newton step at all.
//!
//! The same weights extrapolate an auxiliary vector kept with each solution: the
//! condensed coupling's settled next holes in their guides' frames
//! (`crate::statics::pass::local_next`). Those move with the loads directly (a tension
//! step bends each disk gap), which the pass's own prediction from the change of the
//! unknowns does not see; extrapolated along the load path, the first pass of a ramp
//! step starts its local iterations 1e-13 L away instead of 1e-9..1e-6 L (Till's robot
//! on 100 disks: 1.5 -> 0.5 gap re-integrations a gap, `examples/till_ramp_profile.rs`).
//!
//! Refined solutions: a solve stops once its residual is below the tolerance, so a
//! kept solution is off by up to a tolerance's worth, and the cubic's weights
//! (4, -6, 4, -1) amplify that about eightfold: on Till's robot with 100 disks the
//! predicted start's residual was 1-4 tolerances (median 2e-10 against 1e-10), so
//! 85 % of the ramp's solves needed a Newton step after it, and a solve that did not
//! (residual just below the tolerance) poisoned the next prediction. The history
//! therefore keeps each solution moved by one more chord step `-H r` (the solve's
//! last inverse Jacobian with its Broyden updates; a small linear solve, no pass),
//! whose residual is that of a Newton step from it; the solve still hands back and
//! reports the point it evaluated. Measured in `examples/till_ramp_profile.rs` (see
//! `benches/README.md`).
//!
//! It is used only when the unknowns are exactly the last solution (nothing moved
//! them since, e.g. [`super::Workspace::set_theta_predicted`]'s own predictor) and the
//! previous solve started warm from the solution before. Buffers are sized once
//! (`clone_from` reuses the loads' vectors); nothing allocates once warm.

use crate::loads::Loads;

/// Largest `|alpha|` extrapolated (the load step relative to the previous one).
const MAX_RATIO: f64 = 4.0;
/// Load steps count as parallel when the part of `L2 - L1` off the direction of
/// `L1 - L0` is at most this fraction of `|L2 - L1|` (its square must stay above the
/// round-off of `|d2|^2 - (d1.d2)^2/|d1|^2`, ~1e-16 relative; the ignored part moves
/// the prediction by this fraction of the load step's effect).
const PARALLEL_TOL: f64 = 1e-6;

/// One solution of the path: unknowns, loads and load parameters.
#[derive(Clone, Debug)]
struct Point {
    /// The solution as the solve handed it back (a warm start from it is recognised
    /// by these values) ...
    x_ret: Vec<f64>,
    /// ... and as the extrapolation uses it (refined, see the module docs).
    x: Vec<f64>,
    /// Auxiliary values extrapolated with `x` (see the module docs).
    aux: Vec<f64>,
    loads: Loads,
    theta: Vec<f64>,
    valid: bool,
}

impl Point {
    fn new(n: usize, naux: usize) -> Self {
        Self {
            x_ret: vec![0.0; n],
            x: vec![0.0; n],
            aux: vec![0.0; naux],
            loads: Loads::none(),
            theta: Vec::new(),
            valid: false,
        }
    }
}

/// Smallest distance between two nodes `t` of the extrapolation (in load steps).
const MIN_SPACING: f64 = 0.25;
/// Nodes of the Lagrange polynomial: up to cubic extrapolation.
const NODES: usize = 4;
/// Solutions kept (more than [`NODES`]): where a ramp turns back, the loads revisit
/// solutions a few steps old, and the nodes nearest the new loads are taken among
/// all kept solutions on the load line (see [`Secant::start`]).
const POINTS: usize = 8;

/// The last solutions (see the module docs).
#[derive(Clone, Debug)]
pub(super) struct Secant {
    /// `pts[0]` is the latest solution (`x1`, `L1`), `pts[1]` the one before (`x0`,
    /// `L0`), and so on; a point is valid only if the solve that produced the point
    /// before it in the list started from it.
    pts: [Point; POINTS],
    /// The current solve started from `pts[0]` (set by [`Secant::start`]).
    from_sol: bool,
    /// Stamp of the contents, fresh (process-wide unique) at every change: two
    /// predictors with the same stamp hold the same values, so the rollback's copy
    /// skips the points when the stamps agree (a tendon row's joint path never
    /// touches this predictor: ~1 200 instructions a 1 kHz tick saved).
    stamp: u64,
}

/// A stamp no predictor has held before.
fn fresh_stamp() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

impl Secant {
    /// `n` unknowns and `naux` auxiliary values per solution.
    pub fn new(n: usize, naux: usize) -> Self {
        Self {
            pts: std::array::from_fn(|_| Point::new(n, naux)),
            from_sol: false,
            stamp: fresh_stamp(),
        }
    }

    /// Start of a solve that begins at `x` (warm) with `loads`, `theta`: moves `x` to
    /// the prediction when it applies (`predict`) and returns whether it did; `aux`
    /// (the auxiliary values, length `naux`) is then extrapolated with the same
    /// weights, else left alone.
    ///
    /// With `d = L1 - L0`, every kept solution `k` whose loads lie on the line
    /// `L1 + t_k d` (`t = 0` for `L1`, `-1` for `L0`) is a candidate node of the
    /// Lagrange polynomial `x(t)`, evaluated at the new loads' `t = alpha` (linear
    /// with two nodes, quadratic with three, cubic with four: along a steady ramp the
    /// error drops by about one load step's ratio per node). The nodes are the
    /// candidates nearest `alpha`, at least [`MIN_SPACING`] apart: along a steady
    /// ramp the last four solutions; where the ramp turns back
    /// the solutions it revisits (a node at `alpha` itself makes the prediction that
    /// solution). Why: on Till's robot with 100 disks (`examples/till_ramp_profile`)
    /// the second step after a turn had only the two nodes `0, -1` (the third point
    /// sat on the first) and cost 3-5 Newton iterations.
    pub fn start(
        &mut self,
        x: &mut [f64],
        aux: &mut [f64],
        loads: &Loads,
        theta: &[f64],
        predict: bool,
    ) -> bool {
        self.stamp = fresh_stamp();
        self.from_sol = self.pts[0].valid && self.pts[0].x_ret == x;
        // the latest solution is consumed: it is noted again if this solve converges
        self.pts[0].valid = false;
        if !(predict && self.from_sol && self.pts[1].valid) {
            return false;
        }
        // the load line: from the newest solution back to the one before it, or past
        // solutions at the same loads (a ramp that rests for a step) to the first at
        // other loads. Not further: a solution at the new loads found further back (a
        // cycle through a few loads) would make the prediction a replay, not a warm
        // start (and `benches/forward.rs`'s `forward_warm` cycle would measure that)
        let p1 = &self.pts[0];
        let Some(j) = (1..POINTS)
            .take_while(|&j| self.pts[j].valid)
            .find(|&j| self.pts[j].loads != p1.loads || self.pts[j].theta != p1.theta)
        else {
            return false;
        };
        let Some(alpha) = ratio(&self.pts[j], p1, loads, theta) else {
            return false;
        };
        if alpha == 0.0 {
            return false;
        }
        // candidates (point, t) on the line, among the valid (chained) points
        let (p0, p1) = (&self.pts[j], &self.pts[0]);
        let mut cand = [(0usize, 0.0f64); POINTS];
        cand[1] = (j, -1.0);
        let mut nc = 2;
        for k in 1..POINTS {
            if !self.pts[k].valid {
                break;
            }
            if k == j {
                continue;
            }
            if let Some(tk) = ratio(p0, p1, &self.pts[k].loads, &self.pts[k].theta) {
                cand[nc] = (k, tk);
                nc += 1;
            }
        }
        // nearest to alpha first (stable: ties keep the newer point)
        cand[..nc].sort_by(|a, b| (a.1 - alpha).abs().total_cmp(&(b.1 - alpha).abs()));
        let mut node = [0usize; NODES];
        let mut t = [0.0; NODES];
        let mut nodes = 0;
        for &(k, tk) in &cand[..nc] {
            // nodes closer than a quarter step would make the weights large
            if nodes < NODES && t[..nodes].iter().all(|ti| (tk - ti).abs() >= MIN_SPACING) {
                node[nodes] = k;
                t[nodes] = tk;
                nodes += 1;
            }
        }
        let mut w = [0.0; NODES];
        for (k, wk) in w.iter_mut().enumerate().take(nodes) {
            *wk = (0..nodes)
                .filter(|&j| j != k)
                .map(|j| (alpha - t[j]) / (t[k] - t[j]))
                .product();
        }
        for (i, xi) in x.iter_mut().enumerate() {
            *xi = (0..nodes).map(|k| w[k] * self.pts[node[k]].x[i]).sum();
        }
        for (i, ai) in aux.iter_mut().enumerate() {
            *ai = (0..nodes).map(|k| w[k] * self.pts[node[k]].aux[i]).sum();
        }
        true
    }

    /// End of a solve: `x` solves `loads`, `theta` when `converged` (`aux`: its
    /// auxiliary values); `x_hist` is the same solution refined by a chord step (or
    /// `x` itself), which the extrapolation uses.
    pub fn finish(
        &mut self,
        converged: bool,
        x: &[f64],
        x_hist: &[f64],
        aux: &[f64],
        loads: &Loads,
        theta: &[f64],
    ) {
        self.stamp = fresh_stamp();
        if !converged {
            self.pts.iter_mut().for_each(|p| p.valid = false);
            return;
        }
        // from_sol: `pts[0]` (consumed by `start`) still holds the solution this one
        // started from; the points shift down by one (buffers rotate, no allocation)
        self.pts[0].valid = self.from_sol;
        self.pts.rotate_right(1);
        // a point stays valid only while the chain of warm starts is unbroken
        for k in 1..POINTS {
            self.pts[k].valid &= self.from_sol && (k == 1 || self.pts[k - 1].valid);
        }
        self.from_sol = false;
        let sol = &mut self.pts[0];
        sol.x_ret.copy_from_slice(x);
        sol.x.copy_from_slice(x_hist);
        sol.aux.copy_from_slice(aux);
        copy_loads(&mut sol.loads, loads);
        sol.theta.clear();
        sol.theta.extend_from_slice(theta);
        sol.valid = true;
    }
}

/// `dst = src` reusing `dst`'s vectors (the derived `Clone::clone_from` of `Loads`
/// would allocate afresh).
fn copy_loads(dst: &mut Loads, src: &Loads) {
    dst.gravity_m_s2 = src.gravity_m_s2;
    dst.point.clone_from(&src.point);
    dst.tensions_n.clone_from(&src.tensions_n);
}

/// `alpha` with `(loads, theta) - p1 = alpha (p1 - p0)`, when the two load steps are
/// parallel, the load structure is the same and `|alpha| <= MAX_RATIO`.
fn ratio(p0: &Point, p1: &Point, loads: &Loads, theta: &[f64]) -> Option<f64> {
    let (l0, l1, l2) = (&p0.loads, &p1.loads, loads);
    if l0.point.len() != l2.point.len()
        || l1.point.len() != l2.point.len()
        || p0.theta.len() != theta.len()
        || p1.theta.len() != theta.len()
    {
        return None;
    }
    let same_sites = l2.point.iter().enumerate().all(|(i, p)| {
        let (a, b) = (&l0.point[i], &l1.point[i]);
        a.section == p.section && b.section == p.section && a.frame == p.frame && b.frame == p.frame
    });
    if !same_sites {
        return None;
    }
    // sums over all load values: d1 = L1 - L0, d2 = L2 - L1
    let (mut d11, mut d12, mut d22) = (0.0, 0.0, 0.0);
    let mut add = |a: f64, b: f64, c: f64| {
        let (d1, d2) = (b - a, c - b);
        d11 += d1 * d1;
        d12 += d1 * d2;
        d22 += d2 * d2;
    };
    for k in 0..3 {
        add(l0.gravity_m_s2[k], l1.gravity_m_s2[k], l2.gravity_m_s2[k]);
    }
    for (i, p) in l2.point.iter().enumerate() {
        let (a, b) = (&l0.point[i], &l1.point[i]);
        for k in 0..3 {
            add(a.force_n[k], b.force_n[k], p.force_n[k]);
            add(a.torque_nm[k], b.torque_nm[k], p.torque_nm[k]);
        }
        add(a.mass_kg, b.mass_kg, p.mass_kg);
    }
    let nt = l0
        .tensions_n
        .len()
        .max(l1.tensions_n.len())
        .max(l2.tensions_n.len());
    for j in 0..nt {
        add(l0.tension(j), l1.tension(j), l2.tension(j));
    }
    for ((a, b), c) in p0.theta.iter().zip(&p1.theta).zip(theta) {
        add(*a, *b, *c);
    }
    if d11 <= 0.0 {
        return None;
    }
    let alpha = d12 / d11;
    // |d2 - alpha d1|^2 = d22 - alpha d12 (>= 0 up to round-off)
    let off = (d22 - alpha * d12).max(0.0);
    (alpha.abs() <= MAX_RATIO && off <= PARALLEL_TOL * PARALLEL_TOL * d22).then_some(alpha)
}

impl crate::math::warm::WarmCopy for Point {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src, copy: [x_ret, x, aux, theta, valid], keep: [loads]);
        copy_loads(&mut self.loads, &src.loads);
    }
}

impl crate::math::warm::WarmCopy for Secant {
    fn warm_copy_from(&mut self, src: &Self) {
        if self.stamp == src.stamp {
            return;
        }
        crate::math::warm::warm_fields!(self, src, copy: [pts, from_sol, stamp], keep: []);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn loads(t: f64) -> Loads {
        Loads {
            tensions_n: vec![t, 0.0],
            ..Loads::none()
        }
    }

    /// A quadratic path `x(T)` is predicted exactly (1e-13) from three or four
    /// solutions on one load line, also where the ramp turns back.
    #[test]
    fn quadratic_path_is_extrapolated_exactly() {
        let xs = |t: f64| [1.0 + 0.5 * t - 0.3 * t * t, 2.0 * t * t];
        let mut s = Secant::new(2, 0);
        let ts = [1.0, 1.1, 1.2, 1.3, 1.2, 1.1, 0.9];
        for (k, &t) in ts.iter().enumerate() {
            let mut x = if k == 0 { xs(t) } else { xs(ts[k - 1]) };
            let predicted = s.start(&mut x, &mut [], &loads(t), &[], true);
            assert_eq!(predicted, k >= 2, "step {k}");
            if k >= 3 && k != 5 {
                // k = 5: the last loads are 1.2, 1.3, 1.2 (two equal): linear only
                let e = xs(t);
                assert!(
                    (x[0] - e[0]).abs() < 1e-13 && (x[1] - e[1]).abs() < 1e-13,
                    "{k} {x:?} {e:?}"
                );
            }
            s.finish(true, &xs(t), &xs(t), &[], &loads(t), &[]);
        }
    }

    /// Where a ramp turns back or rests a step, the solution it revisits is the
    /// prediction (a node at the new loads), exactly (1e-15) even on a path that no
    /// polynomial fits; on new ground the prediction is the cubic through the four
    /// nearest solutions (off by 1.3e-3 here, where the plain warm start is off by
    /// 0.29).
    #[test]
    fn revisited_solutions_are_the_prediction_at_a_turn_and_after_a_rest() {
        let xs = |t: f64| [(3.0 * t).sin(), t.exp()];
        let mut s = Secant::new(2, 0);
        // up, turn, rest, down past the start
        let ts = [1.0, 1.1, 1.2, 1.3, 1.2, 1.1, 1.1, 1.0, 0.9];
        for (k, &t) in ts.iter().enumerate() {
            let mut x = if k == 0 { xs(t) } else { xs(ts[k - 1]) };
            let predicted = s.start(&mut x, &mut [], &loads(t), &[], true);
            let e = xs(t);
            let err = (x[0] - e[0]).abs().max((x[1] - e[1]).abs());
            match k {
                // revisited: 1.2 (k = 4: the solution of k = 2), 1.1 (k = 5), 1.0
                // (k = 7, after the rest at 1.1: the line runs back to 1.2)
                4 | 5 | 7 => assert!(predicted && err <= 1e-15, "step {k}: {err:.3e}"),
                // the rest: same loads as the last solution, nothing to predict
                6 => assert!(!predicted && err == 0.0, "step {k}"),
                // new ground beyond the start: cubic through 1.0 .. 1.3 (0.9 is
                // 1 step from its nearest node)
                8 => assert!(predicted && err <= 2e-3, "step {k}: {err:.3e}"),
                _ => {}
            }
            s.finish(true, &e, &e, &[], &loads(t), &[]);
        }
    }

    /// A cycle through three loads off one line is not predicted, though the
    /// solution at the new loads is kept from the last cycle (a replay is no warm
    /// start: `forward_warm` in `benches/forward.rs` cycles that way).
    #[test]
    fn a_cycle_off_the_line_is_not_replayed() {
        let xs = |l: &Loads| [l.tensions_n[0] + 0.5 * l.tensions_n[1], l.tensions_n[1]];
        let cycle = [[1.0, 0.0], [1.1, 0.0], [1.1, 0.1]];
        let mut s = Secant::new(2, 0);
        let mut last: Option<[f64; 2]> = None;
        for k in 0..9 {
            let l = Loads {
                tensions_n: cycle[k % 3].to_vec(),
                ..Loads::none()
            };
            let mut x = last.unwrap_or_else(|| xs(&l));
            let before = x;
            assert!(!s.start(&mut x, &mut [], &l, &[], true), "step {k}");
            assert_eq!(x, before, "step {k}");
            let e = xs(&l);
            s.finish(true, &e, &e, &[], &l, &[]);
            last = Some(e);
        }
    }

    /// A linear path `x(T) = x_a + T x_b` is predicted exactly (1e-15) for any ratio of
    /// the load steps; a turn of direction (not parallel) is not predicted.
    #[test]
    fn linear_path_is_extrapolated_exactly_and_turns_are_not() {
        let xs = |t: f64| [1.0 + 0.5 * t, -2.0 * t];
        let mut s = Secant::new(2, 0);
        let mut x = xs(1.0);
        assert!(!s.start(&mut x, &mut [], &loads(1.0), &[], true));
        s.finish(true, &x, &x, &[], &loads(1.0), &[]);
        let mut x = xs(1.0);
        assert!(
            !s.start(&mut x, &mut [], &loads(1.5), &[], true),
            "one point only"
        );
        let x = xs(1.5);
        s.finish(true, &x, &x, &[], &loads(1.5), &[]);
        let mut x = xs(1.5);
        assert!(s.start(&mut x, &mut [], &loads(1.2), &[], true));
        let e = xs(1.2);
        assert!(
            (x[0] - e[0]).abs() < 1e-15 && (x[1] - e[1]).abs() < 1e-15,
            "{x:?}"
        );
        s.finish(true, &e, &e, &[], &loads(1.2), &[]);
        // a second cable's tension: not along the last step
        let mut x = e;
        let mut turn = loads(1.2);
        turn.tensions_n[1] = 0.3;
        assert!(!s.start(&mut x, &mut [], &turn, &[], true));
        assert_eq!(x, e);
        // unknowns moved since the solve (another predictor): left alone
        s.finish(true, &e, &e, &[], &loads(1.2), &[]);
        let mut x = [e[0] + 1e-3, e[1]];
        assert!(!s.start(&mut x, &mut [], &loads(1.0), &[], true));
    }
}
