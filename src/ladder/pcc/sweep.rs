//! Steps 1-3 of a PCC sweep (module docs of `super`), generic over [`Real`] so that
//! the same code runs over `f64` (the solver) and dual numbers (the sensitivities).

use super::{Buf, Layout, Mark};
use crate::ladder::arc::arc_pose_t;
use crate::ladder::sens::unit_t;
use crate::math::Real;
use crate::settings::GuideMass;
use nalgebra::Vector3;

impl Layout {
    /// Step 1 of a sweep: poses and holes from `b.u`.
    pub(super) fn kinematics<T: Real>(&self, b: &mut Buf<T>) {
        for (i, p) in self.pieces.iter().enumerate() {
            let s = b.bound[i];
            b.mid[i] = arc_pose_t(&s, &b.u[i], 0.5 * p.h);
            b.quarter[i] = arc_pose_t(&s, &b.u[i], 0.75 * p.h).position;
            b.bound[i + 1] = arc_pose_t(&s, &b.u[i], p.h);
        }
        for (j, c) in self.robot.cables().iter().enumerate() {
            for (k, &g) in c.route.iter().enumerate() {
                let pose = &b.bound[self.guide_boundary[g]];
                let hole = c.hole_local[k].map(T::cst);
                b.hole_pts[j][k] = pose.position + pose.rotation * hole;
            }
        }
        for (j, d) in self.straight.iter().enumerate() {
            if let Some(d) = d {
                let end = self.robot.cables()[j].end_section;
                b.continuous[j] = self
                    .pieces
                    .iter()
                    .zip(&b.u)
                    .filter(|(p, _)| p.section <= end)
                    .map(|(p, u)| crate::ladder::straight_arc_length(u, d, p.h))
                    .fold(T::zero(), |a, l| a + l);
            }
        }
    }

    /// Steps 2-3: new curvatures into `b.u_new` at load scale `lam`; returns the
    /// largest change times `L`.
    pub(super) fn moments<T: Real>(&self, b: &mut Buf<T>, lam: f64) -> f64 {
        let g = b.loads.gravity * lam;
        let gt = g.map(T::cst);
        let secs = self.robot.sections();
        let mut n = Vector3::<T>::zeros();
        let mut m = Vector3::<T>::zeros();
        let mut change: f64 = 0.0;
        for i in (0..self.pieces.len()).rev() {
            let bi = i + 1;
            let rb = b.bound[bi].position;
            // loads at boundary bi (distal end of piece i); m is about rb
            for mark in &self.marks[self.mark_at[bi]..self.mark_at[bi + 1]] {
                match *mark {
                    Mark::SectionEnd(k) => {
                        for p in b.loads.points.iter().filter(|p| p.section == k) {
                            let rot = &b.bound[bi].rotation;
                            let (f, t) = if p.body {
                                (rot * p.force, rot * p.torque)
                            } else {
                                (p.force, p.torque)
                            };
                            n += f.map(|x| x.scale(lam)) + gt * p.mass;
                            m += t.map(|x| x.scale(lam));
                        }
                    }
                    Mark::Guide(gi) => {
                        // a point mass under the point model, and under the accurate
                        // one for a disk of zero thickness (its limit; statics::plan)
                        let guide = &self.robot.guides()[gi];
                        if self.guide_mass == GuideMass::Point
                            || (self.guide_mass == GuideMass::Accurate && guide.thickness <= 0.0)
                        {
                            n += (g * guide.mass).map(T::cst);
                        }
                        for &(j, k) in &self.guide_cables[gi] {
                            let t = b.loads.tensions[j].scale(lam);
                            if t == T::zero() {
                                continue;
                            }
                            let pts = &b.hole_pts[j];
                            let p = pts[k];
                            let prev = if k == 0 {
                                self.base_holes[j].map(T::cst)
                            } else {
                                pts[k - 1]
                            };
                            let mut f = unit_t(prev - p) * t;
                            if k + 1 < pts.len() {
                                f += unit_t(pts[k + 1] - p) * t;
                            }
                            n += f;
                            m += (p - rb).cross(&f);
                        }
                    }
                }
            }
            let piece = self.pieces[i];
            let w = (g * (piece.lambda * piece.h)).map(T::cst);
            let ra = b.bound[i].position;
            let rm = b.mid[i].position;
            // midpoint moment: transport from rb plus the distal half's weight
            let c_half = (rm + b.quarter[i].map(|x| x.scale(4.0)) + rb).map(|x| x.scale(1.0 / 6.0));
            let m_mid = m + (rb - rm).cross(&n) + (c_half - rm).cross(&w.map(|x| x.scale(0.5)));
            let sec = &secs[piece.section];
            let mut ml = b.mid[i].rotation.transpose() * m_mid;
            // straight continuous tendons spanning this piece: the free-body term at
            // the midpoint (module docs of `super`)
            for (j, d) in self.straight.iter().enumerate() {
                let t = b.loads.tensions[j].scale(lam);
                match d {
                    Some(d)
                        if self.robot.cables()[j].end_section >= piece.section
                            && t != T::zero() =>
                    {
                        let dt = d.map(T::cst);
                        let tl = unit_t(Vector3::z().map(T::cst) + b.u[i].cross(&dt));
                        ml += dt.cross(&(tl * (-t)));
                    }
                    _ => {}
                }
            }
            let stiff = &sec.stiffness.bend_twist;
            let pre = &sec.precurvature;
            let u = Vector3::from_fn(|a, _| ml[a].scale(1.0 / stiff[a]) + T::cst(pre[a]));
            for a in 0..3 {
                change = change.max((u[a].re() - b.u[i][a].re()).abs());
            }
            b.u_new[i] = u;
            // transport (n, m) to the piece's start
            let c = (ra + rm.map(|x| x.scale(4.0)) + rb).map(|x| x.scale(1.0 / 6.0));
            m += (rb - ra).cross(&n) + (c - ra).cross(&w);
            n += w;
        }
        change * self.robot.length()
    }
}
