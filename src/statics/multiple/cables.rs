//! Tensioned cables under multiple shooting.
//!
//! A tensioned cable pulls each disk of its route along the two straight chords to
//! its neighbouring holes (thesis 3.8.1 routing, the jump conditions of eq. 3.5 as in
//! `statics::pass`), so a disk's jump depends on the poses of the previous and the
//! next disk. A node starts at every cable disk ([`super::intervals::Layout`]) and
//! carries its position as well as its rotation (`theta, n, m, r`, 12 unknowns, with
//! a position continuity residual): the disk that ends interval `i` then reads its
//! neighbours' holes from node unknowns, and interval `i`'s residual depends on its
//! own node, node `i + 1` and the nodes of those two disks, a band a few nodes wide
//! (`super::band`). Its exact Jacobian comes from one `Dual<24>` pass per interval:
//! 12 directions for the own node, 6 (`theta, r`) for each neighbour disk's pose.
//! Positions must be unknowns here: with `r` carried from the previous interval's end
//! (the cable-free layout), a chord would depend on every node between the base and
//! its disk.

use super::intervals::{integrate, Layout, LoadCtx, Nbr};
use super::newton::residual_rows;
use super::{offset, Multi, BASE, CABLE_DIRS, NODE_R};
use crate::integrate::State;
use crate::math::{skew, Dual, Real};
use crate::statics::plan::Plan;
use nalgebra::{Matrix3, Vector3};

/// First dual direction of the previous and of the next disk's pose.
const PREV: usize = NODE_R;
const NEXT: usize = NODE_R + 6;

/// Nodes that start at the previous and the next cable disk of the disk ending
/// interval `k` (none without tensioned cables or without a disk there).
fn neighbours(layout: &Layout, k: usize) -> Option<(Option<usize>, Option<usize>)> {
    if layout.width != NODE_R {
        return None;
    }
    let g = layout.end_disk[k]?;
    let prev = g.checked_sub(1).and_then(|p| layout.disk_node[p]);
    let next = layout.disk_node.get(g + 1).copied().flatten();
    Some((prev, next))
}

/// The neighbour disks' poses for an `f64` pass over interval `k`.
pub(super) fn nbr_f64(layout: &Layout, states: &[State<f64>], k: usize) -> Option<Nbr<f64>> {
    let (prev, next) = neighbours(layout, k)?;
    let pose = |j: usize| (states[j].r, states[j].rot);
    Some(Nbr {
        prev: prev.map(pose),
        next: next.map(pose),
    })
}

type D = Dual<CABLE_DIRS>;

/// A node's state with its unknowns seeded: the base node's `n, m` (directions
/// 0..6); another node's rotation increment (`dR = R e_a^`), `n`, `m` and `r` (0..12),
/// each per unit of the scaled unknown.
fn seed_node(y: &State<f64>, base: bool, fs: f64, ms: f64, ls: f64) -> State<D> {
    let mut out = State {
        r: y.r.map(D::constant),
        rot: y.rot.map(D::constant),
        n: y.n.map(D::constant),
        m: y.m.map(D::constant),
    };
    let (dn, dm) = if base { (0, 3) } else { (3, 6) };
    for a in 0..3 {
        out.n[a].d[dn + a] = fs;
        out.m[a].d[dm + a] = ms;
    }
    if !base {
        seed_pose(y, &mut out, 0, 9, ls);
    }
    out
}

/// Seed the pose of `y` into `out`: rotation increments along directions `d_rot..`,
/// position (per unit of `r/L`) along `d_r..`.
fn seed_pose(y: &State<f64>, out: &mut State<D>, d_rot: usize, d_r: usize, ls: f64) {
    for a in 0..3 {
        let mut e = Vector3::zeros();
        e[a] = 1.0;
        let dr = y.rot * skew(&e);
        for (x, d) in out.rot.iter_mut().zip(dr.iter()) {
            x.d[d_rot + a] = *d;
        }
        out.r[a].d[d_r + a] = ls;
    }
}

/// A neighbour disk's pose, seeded along `d0..d0 + 6` (`theta`, then `r`).
fn pose(y: &State<f64>, d0: usize, ls: f64) -> (Vector3<D>, Matrix3<D>) {
    let mut out = State {
        r: y.r.map(D::constant),
        rot: y.rot.map(D::constant),
        n: Vector3::zeros(),
        m: Vector3::zeros(),
    };
    seed_pose(y, &mut out, d0, d0 + 3, ls);
    (out.r, out.rot)
}

impl Multi {
    /// Exact Jacobian with tensioned cables into the banded LU (module docs). `false`
    /// when a pass failed.
    pub(super) fn jacobian_cables(&mut self, plan: &Plan, ld: LoadCtx) -> bool {
        let Some(layout) = self.layout.as_ref() else {
            return false;
        };
        self.jac_evals += 1;
        self.lu.clear();
        let kn = layout.len();
        let w = NODE_R;
        let (fs, ms, ls) = (plan.force_scale, plan.moment_scale, plan.length);
        for k in 0..kn {
            let y0 = seed_node(&self.nodes[k], k == 0, fs, ms, ls);
            let (prev, next) = neighbours(layout, k).unwrap_or((None, None));
            let nb = layout.end_disk[k].map(|_| Nbr {
                prev: prev.map(|j| {
                    if j == k {
                        (y0.r, y0.rot)
                    } else {
                        pose(&self.nodes[j], PREV, ls)
                    }
                }),
                next: next.map(|j| pose(&self.nodes[j], NEXT, ls)),
            });
            let out = integrate::<D>(
                plan,
                layout,
                k,
                y0,
                ld,
                nb.as_ref(),
                &mut self.rhs_evals,
                None,
                &mut |_, _| {},
            );
            let Ok(y) = out else {
                return false;
            };
            let last = k + 1 == kn;
            let nx = (!last).then(|| &self.nodes[k + 1]);
            let width = if last { BASE } else { w };
            let mut rows = [D::constant(0.0); NODE_R];
            residual_rows(plan, &y, nx, &mut rows[..width]);
            let (row, c0) = (w * k, offset(w, k));
            let own = if k == 0 { BASE } else { w };
            if let Some(nx) = nx {
                // d/d(node k + 1): -(tr E I - E)/2 for the rotation rows, -I otherwise
                let e = nx.rot.transpose() * y.rot.map(|x| x.re());
                let blk = (Matrix3::identity() * e.trace() - e) * -0.5;
                let c1 = offset(w, k + 1);
                for i in 0..3 {
                    for j in 0..3 {
                        self.lu.set(row + i, c1 + j, blk[(i, j)]);
                    }
                }
                for i in 3..w {
                    self.lu.set(row + i, c1 + i, -1.0);
                }
            }
            let lu = &mut self.lu;
            let mut add = |r: usize, c: usize, v: f64| lu.set(r, c, lu.get(r, c) + v);
            for (i, r) in rows.iter().take(width).enumerate() {
                for d in 0..own {
                    add(row + i, c0 + d, r.d[d]);
                }
                // the neighbour disks' poses: theta columns 0..3, r columns 9..12
                let others = [(prev.filter(|&j| j != k), PREV), (next, NEXT)];
                for (j, d0) in others {
                    if let Some(j) = j {
                        let c = offset(w, j);
                        for a in 0..3 {
                            add(row + i, c + a, r.d[d0 + a]);
                            add(row + i, c + 9 + a, r.d[d0 + 3 + a]);
                        }
                    }
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::super::intervals::LoadCtx;
    use super::super::{band, Multi};
    use crate::robot::{CableSpec, GuideSpec, HolesSpec, SectionSpec};
    use crate::statics::plan::Plan;
    use crate::{CrossSection, Loads, Material, PointLoad, Robot, RobotSpec, SolverSettings};

    /// The thesis's Nitinol rod (0.39 m, 1.56 mm) with five disks and three cables
    /// ending on the last one.
    fn robot() -> Robot {
        let section = SectionSpec {
            length_m: 0.39,
            shape: CrossSection::Solid {
                diameter_m: 1.56e-3,
            },
            material: Material {
                youngs_modulus_pa: 62.7e9,
                poisson_ratio: 0.3,
                density_kg_m3: 6800.0,
            },
            shear_coefficient: 1.0,
            precurvature_per_m: [0.0; 3],
            guides: Some(GuideSpec {
                count: 5,
                first_offset_m: 0.0054,
                spacing_m: 0.095,
                thickness_m: 3e-3,
                diameter_m: 0.03,
                mass_kg: 2.2e-3,
                holes: HolesSpec {
                    radius_m: 0.01,
                    angles_deg: vec![90.0, 210.0, 330.0],
                },
                even: Default::default(),
            }),
        };
        Robot::new(RobotSpec {
            limits: None,
            base: Default::default(),
            sections: vec![section],
            cables: (0..3)
                .map(|h| CableSpec {
                    hole: Some(h),
                    ..Default::default()
                })
                .collect(),
            tendons: None,
            friction: None,
        })
        .unwrap()
    }

    /// The banded Jacobian of interval residuals with tensioned cables equals central
    /// differences of the residual (step 1e-6 in the scaled unknowns) to 1e-6 of
    /// `1 + |entry|`, and every entry outside the band is zero there (to the same
    /// tolerance), at a bent state (two Newton Jacobians from the straight rod at half
    /// of a 60 N tip force with tensions of 5 and 2 N).
    #[test]
    fn cable_jacobian_matches_central_differences() {
        let robot = robot();
        let loads = Loads {
            point: vec![PointLoad {
                section: 0,
                force_n: [3.0, -60.0, 2.0],
                ..Default::default()
            }],
            tensions_n: vec![5.0, 2.0, 0.0],
            ..Loads::none()
        };
        let plan = Plan::new(&robot, &loads, &SolverSettings::default(), &[]).unwrap();
        assert!(Multi::supports(&plan));
        let mut m = Multi::new();
        m.build(&plan, 64.0);
        m.straight(&plan);
        let ld = LoadCtx {
            lam: 0.5,
            theta: &[],
        };
        let _ = m.newton(&plan, ld, 1e-10, 2);
        assert!(m.jacobian(&plan, ld));
        let n = m.n_unknowns();
        let layout = m.layout.clone().unwrap();
        let (kl, ku) = band(&layout, m.width);
        let eps = 1e-6;
        let (mut plus, mut minus) = (vec![0.0; n], vec![0.0; n]);
        let mut worst = (0.0f64, 0, 0);
        for c in 0..n {
            for (out, sign) in [(&mut plus, 1.0), (&mut minus, -1.0)] {
                m.dx.fill(0.0);
                m.dx[c] = sign * eps;
                m.step_into(&plan, 1.0, true);
                assert!(m.eval(&plan, ld, true));
                out.copy_from_slice(&m.res_trial);
            }
            for r in 0..n {
                let fd = (plus[r] - minus[r]) / (2.0 * eps);
                let inside = c + kl >= r && c <= r + ku;
                let ex = if inside { m.lu.get(r, c) } else { 0.0 };
                let e = (fd - ex).abs() / (1.0 + fd.abs());
                if e > worst.0 {
                    worst = (e, r, c);
                }
            }
        }
        eprintln!("{n} unknowns, band ({kl}, {ku}), worst (error, row, column) {worst:?}");
        assert!(worst.0 < 1e-6, "worst (error, row, column) {worst:?}");
    }
}
