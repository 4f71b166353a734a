//! The jumps of the state at the pass's events (thesis 3.5 jump conditions): a
//! section's end (recorded), a point load or payload, and a disk (its weight and the
//! chord forces of the cables through it, thesis 3.8.1 routing, under the plan's
//! cable coupling).

use super::small::det_small;
use super::{arc, jump_block, seed_jump, unit, v3, PassBuf, Pose, Recording};
use crate::integrate::State;
use crate::math::{mat_vec_f64, Real};
use crate::statics::plan::{Event, ParamSite, Plan};
use nalgebra::Vector3;

pub(super) fn apply_event<T: Real>(
    plan: &Plan,
    e: Event,
    y: &mut State<T>,
    buf: &mut PassBuf<T>,
    load_scale: f64,
    rec: Option<&mut Recording>,
) {
    let ls = plan.length;
    match e {
        Event::SectionEnd(k) => {
            if let Some(r) = rec {
                r.section_tips[k] = Pose::of(y);
            }
        }
        Event::Point(i) => {
            // n+ = n- - F, m+ = m- - tau (thesis 3.5.1 and 3.5.3: m(s+) = m(s-) - tau_st)
            let p = &plan.points[i];
            let (mut f, mut tau) = if p.body {
                (
                    mat_vec_f64(&y.rot, &p.force),
                    mat_vec_f64(&y.rot, &p.torque),
                )
            } else {
                (v3::<T>(&p.force), v3::<T>(&p.torque))
            };
            f += v3::<T>(&(plan.gravity * p.mass));
            for &k in &plan.point_params[i] {
                let th = buf.theta[k];
                match plan.params[k] {
                    ParamSite::Force { axis, .. } => f[axis] += th,
                    ParamSite::Torque { axis, .. } => tau[axis] += th,
                    ParamSite::Mass { .. } => f += v3::<T>(&plan.gravity).map(|g| g * th),
                    ParamSite::Tension { .. } => {}
                }
            }
            y.n -= f.map(|x| x.scale(load_scale));
            y.m -= tau.map(|x| x.scale(load_scale));
        }
        Event::Guide(g) => {
            if let Some(r) = rec {
                r.guides[g] = Pose::of(y);
            }
            if plan.point_guides {
                y.n -= v3::<T>(&(plan.gravity * (plan.guide_mass[g] * load_scale)));
            }
            if plan.arc {
                arc::guide_chords(plan, g, y, buf);
                return;
            }
            for &(j, k) in &plan.guide_cables[g] {
                let c = &plan.cables[j];
                let arm = mat_vec_f64(&y.rot, &c.hole_local[k]);
                let p = y.r + arm;
                buf.holes[j][k] = p;
                if let Some(u) = c.unknowns {
                    if k >= 1 {
                        let i0 = u + 3 * (k - 1);
                        for a in 0..3 {
                            buf.res[i0 + a] = (p[a] - buf.x[i0 + a].scale(ls)).scale(1.0 / ls);
                        }
                    }
                }
                if !c.tensioned {
                    continue;
                }
                let t = actuator_tension(plan, buf, j, load_scale);
                let prev = if k == 0 {
                    v3::<T>(&c.base_hole)
                } else {
                    buf.holes[j][k - 1]
                };
                // the cable pulls the disk along both straight chords (thesis 3.8.1
                // routing); with friction each chord has its own share of the
                // actuator's tension (capstan factors, `crate::robot::friction`)
                let (t, t_next) = if k + 1 < c.len {
                    (t.scale(c.factor[k]), t.scale(c.factor[k + 1]))
                } else {
                    (t.scale(c.factor[k]), t)
                };
                let mut f = unit(prev - p).map(|x| x * t);
                if k + 1 < c.len && plan.condensed {
                    let next = v3::<T>(&buf.next[j][k]);
                    if T::DIRS > 0 {
                        // this chord's share of B = d(n, m)/dq (folded at the next disk)
                        let pos = plan.pending[g].iter().position(|&(jj, _)| jj == j);
                        let chord = buf.next[j][k] - p.map(|x| x.re());
                        let l = 3 * plan.pending[g].len();
                        let (arm_re, t_re) = (arm.map(|x| x.re()), t_next.re());
                        jump_block(buf, l, pos.unwrap_or(0), chord, arm_re, t_re);
                    }
                    f += unit(next - p).map(|x| x * t_next);
                } else if k + 1 < c.len {
                    if let Some(u) = c.unknowns {
                        let i0 = u + 3 * k;
                        let next = Vector3::new(buf.x[i0], buf.x[i0 + 1], buf.x[i0 + 2])
                            .map(|x| x.scale(ls));
                        f += unit(next - p).map(|x| x * t_next);
                    }
                }
                y.n -= f;
                y.m -= arm.cross(&f);
            }
            if T::DIRS > 0 && plan.condensed && !plan.pending[g].is_empty() {
                seed_jump(y);
            }
        }
    }
}

/// Tension of cable `j` at its actuator (N) at `load_scale`: the given value plus its
/// load parameter, if any (the chords' shares follow from the capstan factors).
#[inline]
pub(super) fn actuator_tension<T: Real>(
    plan: &Plan,
    buf: &PassBuf<T>,
    j: usize,
    load_scale: f64,
) -> T {
    let mut t = T::cst(plan.cables[j].tension);
    if let Some(k) = plan.tension_param[j] {
        t += buf.theta[k];
    }
    t.scale(load_scale)
}

/// Determinant of `d(n, m)/d(n0, m0)` (6 x 6), or of `dm/dm0` (3 x 3) when `n(0)` is
/// in closed form, from the first derivative directions of a dual state seeded along
/// the base wrench. It is positive at the base; a zero crossing along the rod is a
/// conjugate point (Jacobi's condition), past which the equilibrium is not a minimum
/// of the potential energy of the clamped-free rod under dead loads.
pub(super) fn wrench_det<T: Real>(plan: &Plan, y: &State<T>) -> f64 {
    let k = if plan.closed_form { 3 } else { 6 };
    let mut a = [0.0; 36];
    for c in 0..k {
        for r in 0..3 {
            if k == 3 {
                a[r * 3 + c] = y.m[r].eps()[c];
            } else {
                a[r * 6 + c] = y.n[r].eps()[c];
                a[(r + 3) * 6 + c] = y.m[r].eps()[c];
            }
        }
    }
    det_small(&mut a[..k * k], k)
}
