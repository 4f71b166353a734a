//! What a multiple-shooting solve hands out, all from the node states (never
//! re-integrated from the base, which at large loads would lose every digit): the
//! recorded samples, poses and cable holes, and the solution's parts.

use super::Multi;
use crate::cables::{path_length, segments, CableLength};
use crate::robot::Robot;
use crate::statics::pass::Pose;
use crate::statics::plan::Plan;
use crate::statics::{GuidePose, Solution};

impl Multi {
    /// Record the current node states for the outputs (one `f64` pass per interval).
    pub(crate) fn keep_record(&mut self, plan: &Plan, theta: &[f64]) {
        self.last = self.record(plan, theta);
    }

    /// Cable lengths of the recorded solution (m), indexed like `robot.cables`.
    pub(crate) fn cable_lengths_into(&self, plan: &Plan, out: &mut [f64]) {
        for (j, (c, o)) in plan.cables.iter().zip(out.iter_mut()).enumerate() {
            *o = path_length(&c.base_hole, &self.last.holes[j]);
        }
    }

    /// The recorded solution with `report` (allocates).
    pub(crate) fn solution(
        &self,
        robot: &Robot,
        plan: &Plan,
        report: super::SolveReport,
    ) -> Solution {
        let rec = &self.last.rec;
        let guides = robot
            .guides()
            .iter()
            .zip(&rec.guides)
            .map(|(g, pose): (_, &Pose)| GuidePose {
                section: g.section,
                index: g.index,
                s: g.s,
                pose: *pose,
            })
            .collect();
        let cables = robot
            .cables()
            .iter()
            .zip(&plan.cables)
            .enumerate()
            .map(|(j, (c, pc))| CableLength {
                name: c.name.clone(),
                total_m: path_length(&pc.base_hole, &self.last.holes[j]),
                segments_m: segments(&pc.base_hole, &self.last.holes[j]),
            })
            .collect();
        let (base_force, base_moment) = self.base_wrench();
        Solution {
            report,
            samples: rec.samples.clone(),
            section_tips: rec.section_tips.clone(),
            guides,
            cables,
            base_force,
            base_moment,
        }
    }
}
