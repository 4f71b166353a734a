//! Residual, exact banded Jacobian and Newton with a backtracking line search for the
//! multiple-shooting unknowns (layout in the module docs).

use super::cables::nbr_f64;
use super::intervals::{integrate, LoadCtx};
use super::{max_abs, norm2, offset, Multi, BASE, NODE, NODE_R};
use crate::integrate::State;
use crate::math::newton::{chord_newton, ChordNewton, Test};
use crate::math::{exp_so3, Dual, Real};
use crate::statics::plan::Plan;
use crate::statics::SolveStatus;
use nalgebra::{Matrix3, Vector3};

/// `vee((E - E^T)/2)`: the rotation mismatch of `E = R_next^T R_end` (zero when the
/// two frames agree; the rotation vector to first order).
#[inline]
fn skew_vee<T: Real>(e: &Matrix3<T>) -> Vector3<T> {
    Vector3::new(
        (e[(2, 1)] - e[(1, 2)]).scale(0.5),
        (e[(0, 2)] - e[(2, 0)]).scale(0.5),
        (e[(1, 0)] - e[(0, 1)]).scale(0.5),
    )
}

/// Residual rows of interval `k` from its end state `y` and the next node `next`
/// (`None`: the free tip, `n(L+) = m(L+) = 0`, thesis table 2.1), into `out`.
pub(super) fn residual_rows<T: Real>(
    plan: &Plan,
    y: &State<T>,
    next: Option<&State<f64>>,
    out: &mut [T],
) {
    let (fs, ms) = (plan.force_scale, plan.moment_scale);
    match next {
        Some(nx) => {
            let e = nx.rot.map(T::cst).transpose() * y.rot;
            let rho = skew_vee(&e);
            for a in 0..3 {
                out[a] = rho[a];
                out[3 + a] = (y.n[a] - T::cst(nx.n[a])).scale(1.0 / fs);
                out[6 + a] = (y.m[a] - T::cst(nx.m[a])).scale(1.0 / ms);
                if out.len() > NODE {
                    // with tensioned cables: position continuity (`r` is a node unknown)
                    out[9 + a] = (y.r[a] - T::cst(nx.r[a])).scale(1.0 / plan.length);
                }
            }
        }
        None => {
            for a in 0..3 {
                out[a] = y.n[a].scale(1.0 / fs);
                out[3 + a] = y.m[a].scale(1.0 / ms);
            }
        }
    }
}

impl Multi {
    /// Residual at the node states (`trial`: at `trial`, into `res_trial`); also the
    /// interval end states and each node's position. `false` when a pass failed.
    pub(super) fn eval(&mut self, plan: &Plan, ld: LoadCtx, trial: bool) -> bool {
        let Some(layout) = self.layout.as_ref() else {
            return false;
        };
        let (states, res) = if trial {
            (&mut self.trial, &mut self.res_trial)
        } else {
            (&mut self.nodes, &mut self.res)
        };
        let kn = layout.len();
        let w = layout.width;
        for k in 0..kn {
            let nb = nbr_f64(layout, states, k);
            let out = integrate::<f64>(
                plan,
                layout,
                k,
                states[k],
                ld,
                nb.as_ref(),
                &mut self.rhs_evals,
                None,
                &mut |_, _| {},
            );
            let Ok(y) = out else {
                res.fill(f64::INFINITY);
                return false;
            };
            self.ends[k] = y;
            let row = w * k;
            let width = if k + 1 < kn { w } else { BASE };
            residual_rows(plan, &y, states.get(k + 1), &mut res[row..row + width]);
            if k + 1 < kn && w == NODE {
                states[k + 1].r = y.r;
            }
        }
        res.iter().all(|r| r.is_finite())
    }

    /// Exact Jacobian at the node states into the banded LU (one `Dual<9>` pass per
    /// interval). `false` when a pass failed.
    pub(super) fn jacobian(&mut self, plan: &Plan, ld: LoadCtx) -> bool {
        if self.width == NODE_R {
            return self.jacobian_cables(plan, ld);
        }
        let Some(layout) = self.layout.as_ref() else {
            return false;
        };
        self.jac_evals += 1;
        self.lu.clear();
        let kn = layout.len();
        let (fs, ms) = (plan.force_scale, plan.moment_scale);
        for k in 0..kn {
            let y0 = seeded(&self.nodes[k], k == 0, fs, ms);
            let out = integrate::<Dual<NODE>>(
                plan,
                layout,
                k,
                y0,
                ld,
                None,
                &mut self.rhs_evals,
                None,
                &mut |_, _| {},
            );
            let Ok(y) = out else {
                return false;
            };
            let last = k + 1 == kn;
            let next = (!last).then(|| &self.nodes[k + 1]);
            let mut rows = [Dual::<NODE>::constant(0.0); NODE];
            residual_rows(plan, &y, next, &mut rows);
            let (row, c0) = (NODE * k, offset(NODE, k));
            let (width, dirs) = (
                if last { BASE } else { NODE },
                if k == 0 { BASE } else { NODE },
            );
            for (i, r) in rows.iter().take(width).enumerate() {
                for d in 0..dirs {
                    self.lu.set(row + i, c0 + d, r.d[d]);
                }
            }
            if let Some(nx) = next {
                // d/d(node k + 1): -(tr E I - E)/2 for the rotation rows, -I otherwise
                let e = nx.rot.transpose() * y.rot.map(|x| x.re());
                let blk = (Matrix3::identity() * e.trace() - e) * -0.5;
                let c1 = offset(NODE, k + 1);
                for i in 0..3 {
                    for j in 0..3 {
                        self.lu.set(row + i, c1 + j, blk[(i, j)]);
                    }
                }
                for i in 3..NODE {
                    self.lu.set(row + i, c1 + i, -1.0);
                }
            }
        }
        true
    }

    /// `dst = src (+) alpha dx`: base node `n, m`; other nodes `R <- R exp(theta^)`,
    /// `n`, `m` (scaled by `F`, `M`).
    pub(super) fn step_into(&mut self, plan: &Plan, alpha: f64, to_trial: bool) {
        let (fs, ms, ls) = (plan.force_scale, plan.moment_scale, plan.length);
        let w = self.width;
        let (src, dst) = if to_trial {
            (&self.nodes, &mut self.trial)
        } else {
            (&self.ok, &mut self.nodes)
        };
        let dx = if to_trial { &self.dx } else { &self.tan };
        for (k, (s, d)) in src.iter().zip(dst.iter_mut()).enumerate() {
            *d = *s;
            let o = offset(w, k);
            let v = |i: usize| Vector3::new(dx[i], dx[i + 1], dx[i + 2]) * alpha;
            if k == 0 {
                d.n += v(o) * fs;
                d.m += v(o + 3) * ms;
            } else {
                d.rot = s.rot * exp_so3(&v(o));
                d.n += v(o + 3) * fs;
                d.m += v(o + 6) * ms;
                if w == NODE_R {
                    d.r += v(o + 9) * ls;
                }
            }
        }
    }

    /// Newton at the current node states until `max_abs(res) <= tol`, at most
    /// `max_jacobians` fresh Jacobians ([`chord_newton`]: a factorisation left from
    /// an earlier point is reused while its full step shrinks `||r||_2` by
    /// [`crate::math::newton::CHORD_CONTRACTION`]; a fresh exact Jacobian's step gets
    /// a backtracking line search). Adds the accepted steps to `moved`; counts fresh
    /// Jacobians in `fresh`.
    pub(super) fn newton(
        &mut self,
        plan: &Plan,
        ld: LoadCtx,
        tol: f64,
        max_jacobians: usize,
    ) -> (SolveStatus, usize) {
        self.fresh = 0;
        if !self.eval(plan, ld, false) {
            return (SolveStatus::NonFinite, 0);
        }
        let mut problem = Nodes {
            m: self,
            plan,
            ld,
            tol,
        };
        let out = chord_newton(&mut problem, max_jacobians);
        self.fresh = out.jacobians;
        (out.end.into(), out.iterations)
    }
}

/// The node unknowns' system at fixed loads, as [`chord_newton`] drives it.
struct Nodes<'a> {
    m: &'a mut Multi,
    plan: &'a Plan,
    ld: LoadCtx<'a>,
    /// Converged at `max_abs(res) <= tol`.
    tol: f64,
}

impl ChordNewton for Nodes<'_> {
    fn test(&mut self) -> Test {
        if max_abs(&self.m.res) <= self.tol {
            Test::Converged
        } else {
            Test::Step
        }
    }

    fn jacobian_ok(&mut self) -> &mut bool {
        &mut self.m.lu_valid
    }

    fn jacobian(&mut self) -> bool {
        self.m.jacobian(self.plan, self.ld)
    }

    fn factor(&mut self) -> Option<f64> {
        self.m.lu.factor()
    }

    fn step(&mut self, _fresh: bool) {
        let m = &mut *self.m;
        for i in 0..m.n_unknowns() {
            m.dx[i] = -m.res[i];
        }
        m.lu.solve_in_place(&mut m.dx);
    }

    fn norm(&self) -> f64 {
        norm2(&self.m.res)
    }

    fn trial(&mut self, alpha: f64) -> Option<f64> {
        self.m.step_into(self.plan, alpha, true);
        let ok = self.m.eval(self.plan, self.ld, true);
        ok.then(|| norm2(&self.m.res_trial))
    }

    /// Take the trial point (reached by `alpha dx`) as the current one.
    fn accept(&mut self, alpha: f64, _fresh: bool) {
        let m = &mut *self.m;
        std::mem::swap(&mut m.nodes, &mut m.trial);
        std::mem::swap(&mut m.res, &mut m.res_trial);
        for (moved, d) in m.moved.iter_mut().zip(&m.dx) {
            *moved += alpha * d;
        }
    }

    fn restore(&mut self) {
        self.m.eval(self.plan, self.ld, false);
    }
}

/// Node state with the dual directions of its unknowns: the base node's `n`, `m`
/// (directions 0..6), another node's rotation increment (`dR = R e_a^`, directions
/// 0..3), `n` and `m` (3..9), each per unit of the scaled unknown.
fn seeded(y: &State<f64>, base: bool, fs: f64, ms: f64) -> State<Dual<NODE>> {
    let mut out = State {
        r: y.r.map(Dual::constant),
        rot: y.rot.map(Dual::constant),
        n: y.n.map(Dual::constant),
        m: y.m.map(Dual::constant),
    };
    let (dn, dm) = if base { (0, 3) } else { (3, 6) };
    for a in 0..3 {
        out.n[a].d[dn + a] = fs;
        out.m[a].d[dm + a] = ms;
        if !base {
            let mut e = Vector3::zeros();
            e[a] = 1.0;
            let dr = y.rot * crate::math::skew(&e);
            for (x, d) in out.rot.iter_mut().zip(dr.iter()) {
                x.d[a] = *d;
            }
        }
    }
    out
}
