//! The arc-length plan of a forward solve: intervals between events (section ends,
//! guide disks, disk edges, point loads) with constant ODE coefficients, the events
//! themselves, the cable routing and the layout of the shooting unknowns.
//!
//! Structure (intervals, events, unknowns) depends on the robot, the settings and
//! which loads exist; the load *values* can be updated in place without allocating.

use crate::error::ModelError;
use crate::integrate::Coeffs;
use crate::loads::{Frame, Loads};
use crate::robot::Robot;
use crate::settings::{CableCoupling, GuideMass, Integrator, RodModel, SolverSettings};
use nalgebra::{Matrix3, Vector3};

mod parts;
pub use parts::ParamSite;
pub(crate) use parts::{ArcChord, Event, Interval, PlanCable, PlanPoint, RoutedCable};

/// Everything a pass needs.
#[derive(Clone, Debug)]
pub(crate) struct Plan {
    pub intervals: Vec<Interval>,
    pub events: Vec<Event>,
    pub start_events: std::ops::Range<usize>,
    pub coeffs: Vec<Coeffs>,
    pub gravity: Vector3<f64>,
    pub points: Vec<PlanPoint>,
    pub cables: Vec<PlanCable>,
    /// `(cable, route position)` of each guide.
    pub guide_cables: Vec<Vec<(usize, usize)>>,
    /// Mass (kg) applied as a point at each guide's event (see `Plan::new`).
    pub guide_mass: Vec<f64>,
    /// Some guide mass is applied as a point.
    pub point_guides: bool,
    pub base_r: Vector3<f64>,
    pub base_rot: Matrix3<f64>,
    /// `n(0)` is known in closed form (thesis eq. 2.8 / table 3.1): only `m(0)` is shot.
    pub closed_form: bool,
    /// `n(0)` at full load when `closed_form` (N).
    pub closed_n0: Vector3<f64>,
    pub n_unknowns: usize,
    pub length: f64,
    pub force_scale: f64,
    pub moment_scale: f64,
    pub integrator: Integrator,
    pub n_sections: usize,
    pub n_guides: usize,
    /// Load parameters `theta`.
    pub params: Vec<ParamSite>,
    /// Parameters acting at each point load.
    pub point_params: Vec<Vec<usize>>,
    /// Tension parameter of each cable.
    pub tension_param: Vec<Option<usize>>,
    /// Condensed cable coupling ([`crate::settings::CableCoupling::Condensed`]): the
    /// next-hole positions are solved per segment inside the pass, not shot for.
    pub condensed: bool,
    /// Per guide: `(cable, route position)` of the tensioned cables whose next hole
    /// (route position + 1, on the next guide) the chord at this guide points to.
    /// Filled only when `condensed`.
    pub pending: Vec<Vec<(usize, usize)>>,
    /// Arc coupling ([`crate::settings::CableCoupling::Arc`]): the chord towards the
    /// next hole points at a predicted hole (`statics::pass::arc`); no hole unknowns.
    pub arc: bool,
    /// Arc coupling, per guide: the chords on to a predicted next hole, in the order
    /// of `guide_cables` (the tensioned cables that go on). Empty otherwise.
    pub arc_chords: Vec<Vec<ArcChord>>,
    /// Arc coupling, per guide: how many of the guides just before it (0, 1 or 2)
    /// send their chords on along the same cables in the same order, so that their
    /// rounds' corrections start this guide's rounds (`statics::pass::arc`); at most 1
    /// with a single round (one round's corrections are far from converged, and
    /// extrapolated their error grows).
    pub arc_carry: Vec<u8>,
    /// Arc coupling: rounds of the next-hole prediction at a disk
    /// ([`SolverSettings::arc_rounds`]).
    pub arc_rounds: usize,
    /// Local dual directions a sweep carries: [`JUMP_DIRS`] when `condensed`, else 0.
    pub max_local: usize,
    /// Largest `3 * pending[g].len()`: the size of a segment's local iteration.
    pub max_pending_dirs: usize,
    /// Continuously routed cables (see `statics::pass::continuous`).
    pub routed: Vec<RoutedCable>,
}

/// Tensioned cables through one disk that the condensed coupling handles. A dual
/// pass carries [`JUMP_DIRS`] local directions whatever the count, so the limit is
/// only the size (`3 x` this, squared) of the per-segment matrices of the `f64`
/// local iteration; 16 covers five segments of three tendons and four of four.
pub(crate) const MAX_CONDENSED_CABLES: usize = 16;

/// Local dual directions of the condensed coupling: the jump of `(n, m)` at a disk.
/// The next-hole positions `q` (3 per pending cable) enter the pass only through
/// that jump, so `dq/dz` follows from a 6 x 6 solve (see `statics::pass`).
pub(crate) const JUMP_DIRS: usize = 6;

impl Plan {
    pub fn new(
        robot: &Robot,
        loads: &Loads,
        settings: &SolverSettings,
        params: &[ParamSite],
    ) -> Result<Self, ModelError> {
        settings.validate()?;
        loads.validate(robot)?;
        let length = robot.length();
        let tol = 1e-12 * length;
        // marks: (s, Some(event)) or (s, None) for a plain breakpoint
        let mut marks: Vec<(f64, Option<Event>)> = Vec::new();
        for (k, sec) in robot.sections().iter().enumerate() {
            marks.push((sec.end(), Some(Event::SectionEnd(k))));
        }
        for (g, guide) in robot.guides().iter().enumerate() {
            marks.push((guide.s, Some(Event::Guide(g))));
            if settings.guide_mass == GuideMass::Accurate && guide.thickness > 0.0 {
                marks.push((guide.s - guide.thickness / 2.0, None));
                marks.push((guide.s + guide.thickness / 2.0, None));
            }
        }
        for (i, p) in loads.point.iter().enumerate() {
            marks.push((robot.sections()[p.section].end(), Some(Event::Point(i))));
        }
        marks.sort_by(|a, b| a.0.total_cmp(&b.0));

        let mut events = Vec::new();
        let mut start_events = 0..0;
        let mut breaks: Vec<(f64, std::ops::Range<usize>)> = Vec::new();
        let mut i = 0;
        while i < marks.len() {
            let s = marks[i].0;
            let e0 = events.len();
            while i < marks.len() && marks[i].0 - s <= tol {
                if let Some(e) = marks[i].1 {
                    events.push(e);
                }
                i += 1;
            }
            if s <= tol {
                start_events = e0..events.len();
            } else {
                breaks.push((s.min(length), e0..events.len()));
            }
        }

        let (steps, adaptive) = match settings.integrator {
            Integrator::Rk4 { steps_per_section } => (steps_per_section, false),
            Integrator::Adaptive { .. } => (1, true),
        };
        let mut intervals = Vec::with_capacity(breaks.len());
        let mut s0 = 0.0;
        for (s1, ev) in breaks {
            let mid = 0.5 * (s0 + s1);
            let k = robot.section_at(mid);
            let sec = &robot.sections()[k];
            let mut lambda = sec.stiffness.linear_density;
            let gs = &robot.guides()[sec.guides.clone()];
            match settings.guide_mass {
                GuideMass::Average => lambda += gs.iter().map(|g| g.mass).sum::<f64>() / sec.length,
                GuideMass::Accurate => {
                    for g in gs {
                        if g.thickness > 0.0 && (mid - g.s).abs() < g.thickness / 2.0 {
                            lambda += g.mass / g.thickness;
                        }
                    }
                }
                GuideMass::None | GuideMass::Point => {}
            }
            // RK4 steps of the interval: its share of the section's steps, rounded up.
            // The share is computed in floating point, so an interval that is exactly
            // `1/steps` of its section (a disk gap when `steps` equals the disks per
            // section) can come out as 1 + 4e-16 and would get two steps: a relative
            // slack of 1e-9 keeps such a share at one step.
            let n = if adaptive {
                1
            } else {
                let share = (steps as f64) * (s1 - s0) / sec.length;
                (share * (1.0 - 1e-9)).ceil().max(1.0) as usize
            };
            intervals.push(Interval {
                s0,
                s1,
                section: k,
                lambda,
                steps: n,
                events: ev,
            });
            s0 = s1;
        }

        let coeffs = robot
            .sections()
            .iter()
            .map(|sec| Coeffs {
                inv_c: sec.stiffness.bend_twist.map(|x| 1.0 / x),
                inv_d: sec.stiffness.shear_stretch.map(|x| 1.0 / x),
                u_star: sec.precurvature,
                f: Vector3::zeros(),
                kirchhoff: settings.rod_model == RodModel::Kirchhoff,
            })
            .collect();

        let mut guide_cables = vec![Vec::new(); robot.guides().len()];
        let mut cables = Vec::with_capacity(robot.cables().len());
        let body_loads = loads.point.iter().any(|p| p.frame == Frame::Body);
        let mut point_params = vec![Vec::new(); loads.point.len()];
        let mut tension_param = vec![None; robot.cables().len()];
        for (k, p) in params.iter().enumerate() {
            let (index, count, field) = match *p {
                ParamSite::Force { point, .. }
                | ParamSite::Torque { point, .. }
                | ParamSite::Mass { point } => {
                    (point, loads.point.len(), "estimate parameter point load")
                }
                ParamSite::Tension { cable } => {
                    (cable, robot.cables().len(), "estimate parameter cable")
                }
            };
            if index >= count {
                return Err(ModelError::BadIndex {
                    field: field.into(),
                    index,
                    count,
                });
            }
            match *p {
                ParamSite::Tension { cable } => tension_param[cable] = Some(k),
                _ => point_params[index].push(k),
            }
        }
        let is_tensioned = |j: usize| loads.tension(j) > 0.0 || tension_param[j].is_some();
        let tensioned = (0..robot.cables().len()).any(is_tensioned);
        let closed_form = !body_loads && !tensioned;
        let mut n_unknowns = if closed_form { 3 } else { 6 };
        // Condensed coupling needs every pending chord at guide g to end on guide
        // g + 1 (routes run through consecutive disks) and few enough cables per disk.
        let mut pending = vec![Vec::new(); robot.guides().len()];
        for (j, c) in robot.cables().iter().enumerate() {
            if is_tensioned(j) {
                for k in 0..c.route.len().saturating_sub(1) {
                    pending[c.route[k]].push((j, k));
                }
            }
        }
        let consecutive = robot
            .cables()
            .iter()
            .enumerate()
            .all(|(j, c)| !is_tensioned(j) || c.route.windows(2).all(|w| w[1] == w[0] + 1));
        let max_pending = pending.iter().map(Vec::len).max().unwrap_or(0);
        let condensed = settings.cable_coupling == CableCoupling::Condensed
            && consecutive
            && max_pending > 0
            && max_pending <= MAX_CONDENSED_CABLES;
        if !condensed {
            pending.iter_mut().for_each(Vec::clear);
        }
        let arc = settings.cable_coupling == CableCoupling::Arc;
        let max_local = if condensed { JUMP_DIRS } else { 0 };
        let max_pending_dirs = if condensed { 3 * max_pending } else { 0 };
        for (j, c) in robot.cables().iter().enumerate() {
            for (k, &g) in c.route.iter().enumerate() {
                guide_cables[g].push((j, k));
            }
            let unknowns = if !condensed && !arc && is_tensioned(j) && c.route.len() > 1 {
                let u = n_unknowns;
                n_unknowns += 3 * (c.route.len() - 1);
                Some(u)
            } else {
                None
            };
            cables.push(PlanCable {
                tension: loads.tension(j),
                tensioned: is_tensioned(j),
                base_hole: robot.base_position() + robot.base_rotation() * c.base_hole,
                hole_local: c.hole_local.clone(),
                factor: vec![1.0; c.route.len()],
                len: c.route.len(),
                end_s: c.end_s,
                end_hole: c
                    .path
                    .as_ref()
                    .map_or_else(|| c.hole_local[c.route.len() - 1], |p| p.eval(c.end_s)[0]),
                routed: c.path.is_some(),
                unknowns,
                shortest_chord: shortest_chord(robot, &c.route),
                gap: if arc {
                    c.route
                        .windows(2)
                        .map(|w| {
                            let (s0, s1) = (robot.guides()[w[0]].s, robot.guides()[w[1]].s);
                            (s1 - s0, robot.section_at(0.5 * (s0 + s1)))
                        })
                        .collect()
                } else {
                    Vec::new()
                },
            });
        }
        let arc_chords: Vec<Vec<ArcChord>> = guide_cables
            .iter()
            .map(|list| {
                let mut out: Vec<ArcChord> = Vec::new();
                for &(j, k) in list {
                    if !(arc && cables[j].tensioned && k + 1 < cables[j].len) {
                        continue;
                    }
                    let gap = cables[j].gap[k];
                    out.push(ArcChord {
                        cable: j,
                        rho: cables[j].hole_local[k],
                        rho_next: cables[j].hole_local[k + 1],
                        gap,
                        new_gap: out.last().is_none_or(|a| a.gap != gap),
                    });
                }
                out
            })
            .collect();
        let same_cables = |a: &[ArcChord], b: &[ArcChord]| {
            !a.is_empty() && a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.cable == y.cable)
        };
        let depth = if settings.arc_rounds >= 2 { 2 } else { 1 };
        let arc_carry: Vec<u8> = (0..arc_chords.len())
            .map(|g| match g {
                0 => 0,
                _ if !same_cables(&arc_chords[g], &arc_chords[g - 1]) => 0,
                1 => 1,
                _ if !same_cables(&arc_chords[g - 1], &arc_chords[g - 2]) => 1,
                _ => depth,
            })
            .collect();
        let ei = robot.sections()[0].stiffness.bend_twist.x;
        let mut plan = Self {
            intervals,
            events,
            start_events,
            coeffs,
            gravity: Vector3::from(loads.gravity_m_s2),
            points: Vec::new(),
            cables,
            guide_cables,
            // masses applied as points at the guide events: every disk under the
            // point model; under the accurate model a disk of zero thickness (its
            // distributed band would be empty: the limit is a point mass)
            guide_mass: robot
                .guides()
                .iter()
                .map(|g| match settings.guide_mass {
                    GuideMass::Point => g.mass,
                    GuideMass::Accurate if g.thickness <= 0.0 => g.mass,
                    _ => 0.0,
                })
                .collect(),
            point_guides: robot.guides().iter().any(|g| g.mass > 0.0)
                && matches!(settings.guide_mass, GuideMass::Point | GuideMass::Accurate),
            base_r: *robot.base_position(),
            base_rot: *robot.base_rotation(),
            closed_form,
            closed_n0: Vector3::zeros(),
            n_unknowns,
            length,
            force_scale: ei / (length * length),
            moment_scale: ei / length,
            integrator: settings.integrator,
            n_sections: robot.sections().len(),
            n_guides: robot.guides().len(),
            params: params.to_vec(),
            point_params,
            tension_param,
            condensed,
            arc,
            arc_chords,
            arc_carry,
            arc_rounds: settings.arc_rounds,
            pending,
            max_local,
            max_pending_dirs,
            routed: robot
                .cables()
                .iter()
                .enumerate()
                .filter_map(|(j, c)| {
                    c.path.as_ref().map(|p| RoutedCable {
                        cable: j,
                        path: p.clone(),
                        end_s: c.end_s,
                    })
                })
                .collect(),
        };
        plan.points = loads
            .point
            .iter()
            .map(|p| PlanPoint {
                section: p.section,
                force: Vector3::zeros(),
                torque: Vector3::zeros(),
                body: p.frame == Frame::Body,
                mass: 0.0,
            })
            .collect();
        plan.set_load_values(loads);
        Ok(plan)
    }

    /// True when `loads` keeps this plan's structure (same point-load sites and frames,
    /// same set of tensioned cables), so only values need updating.
    pub fn same_structure(&self, loads: &Loads) -> bool {
        loads.point.len() == self.points.len()
            && self
                .points
                .iter()
                .zip(&loads.point)
                .all(|(pp, p)| pp.section == p.section && pp.body == (p.frame == Frame::Body))
            && loads.tensions_n.len() <= self.cables.len()
            && self.cables.iter().enumerate().all(|(j, c)| {
                (loads.tension(j) > 0.0 || self.tension_param[j].is_some()) == c.tensioned
            })
    }

    /// Copy load values (no allocation). The structure must match.
    pub fn set_load_values(&mut self, loads: &Loads) {
        self.gravity = Vector3::from(loads.gravity_m_s2);
        for (pp, p) in self.points.iter_mut().zip(&loads.point) {
            pp.force = Vector3::from(p.force_n);
            pp.torque = Vector3::from(p.torque_nm);
            pp.mass = p.mass_kg;
        }
        for (j, c) in self.cables.iter_mut().enumerate() {
            c.tension = loads.tension(j);
        }
        self.closed_n0 = self.straight_wrench(1.0).0;
    }

    /// Distributed force on an interval (N/m), scaled by the continuation factor.
    #[inline]
    pub fn coeffs_for(&self, iv: &Interval, load_scale: f64) -> Coeffs {
        let mut c = self.coeffs[iv.section];
        c.f = self.gravity * (iv.lambda * load_scale);
        c
    }

    /// Resultant external force and its moment about the base on the *straight* rod
    /// (cables included), used for `n(0)` in closed form and for cold starts.
    pub fn straight_wrench(&self, load_scale: f64) -> (Vector3<f64>, Vector3<f64>) {
        let axis = self.base_rot * Vector3::z();
        let at = |s: f64| self.base_r + axis * s;
        let (mut f, mut m) = (Vector3::zeros(), Vector3::zeros());
        let mut add = |p: Vector3<f64>, force: Vector3<f64>, torque: Vector3<f64>| {
            f += force;
            m += (p - self.base_r).cross(&force) + torque;
        };
        for iv in &self.intervals {
            let w = self.gravity * (iv.lambda * (iv.s1 - iv.s0) * load_scale);
            add(at(0.5 * (iv.s0 + iv.s1)), w, Vector3::zeros());
        }
        let located = self.start_events.clone().map(|e| (0.0, e)).chain(
            self.intervals
                .iter()
                .flat_map(|iv| iv.events.clone().map(move |e| (iv.s1, e))),
        );
        for (s, ei) in located {
            match self.events[ei] {
                Event::Point(i) => {
                    let p = &self.points[i];
                    let (fw, tw) = if p.body {
                        (self.base_rot * p.force, self.base_rot * p.torque)
                    } else {
                        (p.force, p.torque)
                    };
                    add(
                        at(s),
                        (fw + self.gravity * p.mass) * load_scale,
                        tw * load_scale,
                    );
                }
                Event::Guide(g) if self.point_guides => add(
                    at(s),
                    self.gravity * (self.guide_mass[g] * load_scale),
                    Vector3::zeros(),
                ),
                _ => {}
            }
        }
        for c in &self.cables {
            if c.tension > 0.0 {
                let p = at(c.end_s) + self.base_rot * c.end_hole;
                add(p, -axis * (c.tension * load_scale), Vector3::zeros());
            }
        }
        (f, m)
    }
}

/// Shortest chord (m) of a route of guide indices: base plate (`s = 0`) to the
/// first disk, then disk to disk; infinite for an empty route.
fn shortest_chord(robot: &Robot, route: &[usize]) -> f64 {
    let mut h = f64::INFINITY;
    let mut s_prev = 0.0;
    for &g in route {
        let s = robot.guides()[g].s;
        h = h.min(s - s_prev);
        s_prev = s;
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Scene;

    /// The arc coupling's per-guide chord lists hold exactly the tensioned cables that
    /// go on from the guide, in `guide_cables` order, with their two hole vectors and
    /// gap, and a "new gap" flag on the first chord of each gap; other couplings have
    /// empty lists. On the demo scene (two of six cables tensioned, two sections of
    /// four guides).
    #[test]
    fn arc_chord_lists_hold_the_tensioned_cables_that_go_on() {
        let scene = Scene::load("data/scenes/demo_two_section.toml").expect("shipped scene");
        let robot = scene.build_robot().expect("robot");
        let arc = SolverSettings {
            cable_coupling: CableCoupling::Arc,
            ..scene.numerics.clone()
        };
        let plan = Plan::new(&robot, &scene.loads, &arc, &[]).expect("plan");
        let mut chords = 0;
        for (g, list) in plan.guide_cables.iter().enumerate() {
            let got = &plan.arc_chords[g];
            let want: Vec<(usize, usize)> = list
                .iter()
                .copied()
                .filter(|&(j, k)| plan.cables[j].tensioned && k + 1 < plan.cables[j].len)
                .collect();
            assert_eq!(got.len(), want.len(), "guide {g}");
            for (i, (a, &(j, k))) in got.iter().zip(&want).enumerate() {
                let c = &plan.cables[j];
                assert_eq!(a.cable, j, "guide {g}");
                assert_eq!(a.rho, c.hole_local[k], "guide {g} cable {j}");
                assert_eq!(a.rho_next, c.hole_local[k + 1], "guide {g} cable {j}");
                assert_eq!(a.gap, c.gap[k], "guide {g} cable {j}");
                assert_eq!(a.new_gap, i == 0 || got[i - 1].gap != a.gap, "guide {g}");
            }
            chords += got.len();
        }
        // cables 0 and 4 are tensioned; each goes on from every guide of its route
        // but the last
        let want: usize = [0, 4].iter().map(|&j| plan.cables[j].len - 1).sum();
        assert!(want > 0);
        assert_eq!(chords, want);
        let condensed = Plan::new(&robot, &scene.loads, &scene.numerics, &[]).expect("plan");
        assert!(!condensed.arc);
        assert!(condensed.arc_chords.iter().all(|c| c.is_empty()));
    }
}
