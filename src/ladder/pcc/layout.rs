//! The pieces of the PCC rung: where the rod is cut and which marks (disks, section
//! ends) sit on which piece boundary (module docs of `super`).

use super::{Layout, Mark, PccSettings, Piece};
use crate::robot::Robot;
use crate::settings::GuideMass;

impl Layout {
    /// Cut `robot` into pieces for `settings` (already validated).
    pub(super) fn new(robot: Robot, settings: &PccSettings) -> Self {
        let length = robot.length();
        let tol = 1e-12 * length;
        let mut cuts: Vec<(f64, Option<Mark>)> = Vec::new();
        for (k, sec) in robot.sections().iter().enumerate() {
            cuts.push((sec.end(), Some(Mark::SectionEnd(k))));
        }
        for (g, guide) in robot.guides().iter().enumerate() {
            cuts.push((guide.s, Some(Mark::Guide(g))));
            if settings.guide_mass == GuideMass::Accurate && guide.thickness > 0.0 {
                cuts.push((guide.s - guide.thickness / 2.0, None));
                cuts.push((guide.s + guide.thickness / 2.0, None));
            }
        }
        cuts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut pieces = Vec::new();
        let mut guide_boundary = vec![0; robot.guides().len()];
        let mut section_ends = vec![0; robot.sections().len()];
        let mut s0 = 0.0;
        let mut i = 0;
        // marks at s = 0 (a disk at the clamp) sit on boundary 0
        while i < cuts.len() && cuts[i].0 <= tol {
            i += 1;
        }
        while i < cuts.len() {
            let s1 = cuts[i].0.min(length);
            let j0 = i;
            while i < cuts.len() && cuts[i].0 - s1 <= tol {
                i += 1;
            }
            let k = robot.section_at(0.5 * (s0 + s1));
            let sec = &robot.sections()[k];
            let n = ((settings.pieces_per_section as f64) * (s1 - s0) / sec.length)
                .ceil()
                .max(1.0) as usize;
            let mid = 0.5 * (s0 + s1);
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
            for _ in 0..n {
                pieces.push(Piece {
                    h: (s1 - s0) / n as f64,
                    section: k,
                    lambda,
                });
            }
            // the interval's marks sit on its last boundary
            for c in &cuts[j0..i] {
                match c.1 {
                    Some(Mark::Guide(g)) => guide_boundary[g] = pieces.len(),
                    Some(Mark::SectionEnd(k)) => section_ends[k] = pieces.len(),
                    None => {}
                }
            }
            s0 = s1;
        }
        // marks of boundary b are `ordered[at[b]..at[b + 1]]` (a counting sort)
        let nb = pieces.len() + 1;
        let mut at = vec![0usize; nb + 1];
        for &b in guide_boundary.iter().chain(&section_ends) {
            at[b + 1] += 1;
        }
        for b in 0..nb {
            at[b + 1] += at[b];
        }
        let mut fill = at.clone();
        let mut ordered = vec![Mark::SectionEnd(0); at[nb]];
        for (g, &b) in guide_boundary.iter().enumerate() {
            ordered[fill[b]] = Mark::Guide(g);
            fill[b] += 1;
        }
        for (k, &b) in section_ends.iter().enumerate() {
            ordered[fill[b]] = Mark::SectionEnd(k);
            fill[b] += 1;
        }
        let mut guide_cables = vec![Vec::new(); robot.guides().len()];
        for (j, c) in robot.cables().iter().enumerate() {
            for (k, &g) in c.route.iter().enumerate() {
                guide_cables[g].push((j, k));
            }
        }
        Layout {
            straight: crate::ladder::straight_offsets(&robot),
            base_holes: robot
                .cables()
                .iter()
                .map(|c| robot.base_position() + robot.base_rotation() * c.base_hole)
                .collect(),
            guide_mass: settings.guide_mass,
            pieces,
            marks: ordered,
            mark_at: at,
            guide_boundary,
            guide_cables,
            section_ends,
            robot,
        }
    }
}
