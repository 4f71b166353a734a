//! What a solve hands out: unknowns, residuals, cable lengths, base wrench, tip and
//! the full [`Solution`].

use super::super::pass::cable_length;
use super::*;

impl Workspace {
    /// Current scaled shooting unknowns (layout in the `statics` module docs).
    pub fn unknowns_vector(&self) -> &[f64] {
        &self.x
    }

    /// Scaled shooting residual at the current unknowns (after a solve or
    /// [`Workspace::adopt_unknowns`]); its max-norm is `report().residual`.
    pub fn residual_vector(&self) -> &[f64] {
        &self.res
    }

    /// Scaled shooting residual at scaled unknowns `x` into `out` (diagnostics and
    /// tests); `false` when the integration failed.
    pub fn shooting_residual(&mut self, x: &[f64], out: &mut [f64]) -> bool {
        self.x_trial.copy_from_slice(x);
        let ok = self.eval_trial(1.0);
        out.copy_from_slice(&self.b64.res);
        ok
    }

    /// Exact (dual-number) shooting Jacobian at `x`, row-major `n x n`.
    pub fn shooting_jacobian(&mut self, x: &[f64]) -> Option<Vec<f64>> {
        let saved = std::mem::replace(&mut self.x, x.to_vec());
        let ok = self.jacobian(1.0);
        self.lu_valid = false;
        self.x = saved;
        let n = self.plan.n_unknowns;
        ok.then(|| self.lu.matrix_mut()[..n * n].to_vec())
    }

    /// Cable lengths of the last evaluated point (m), indexed like `robot.cables`.
    /// No allocation.
    pub fn cable_lengths_into(&self, out: &mut [f64]) {
        if self.multi_active {
            return self.multi.cable_lengths_into(&self.plan, out);
        }
        for (j, o) in out.iter_mut().enumerate().take(self.plan.cables.len()) {
            *o = cable_length(&self.plan, &self.b64, j);
        }
    }

    /// Base internal force and moment of the current solution `(n(0), m(0))`.
    pub fn base_wrench(&self) -> (Vector3<f64>, Vector3<f64>) {
        let p = &self.plan;
        if self.multi_active {
            return self.multi.base_wrench();
        }
        if p.closed_form {
            let m = Vector3::new(self.x[0], self.x[1], self.x[2]) * p.moment_scale;
            (p.closed_n0, m)
        } else {
            (
                Vector3::new(self.x[0], self.x[1], self.x[2]) * p.force_scale,
                Vector3::new(self.x[3], self.x[4], self.x[5]) * p.moment_scale,
            )
        }
    }

    /// Tip position of the last evaluated point (m).
    pub fn tip_position(&self) -> Vector3<f64> {
        if self.multi_active {
            return self.multi.tip();
        }
        self.tip
    }

    /// Tip axis `R(L) e_z` of the last evaluated point (unit vector, world frame): the
    /// direction the tip points in, for a direction target of inverse kinematics.
    pub fn tip_axis(&self) -> Vector3<f64> {
        if self.multi_active {
            return self.multi.tip_axis();
        }
        self.tip_axis
    }

    /// Full solution of the current point (allocates: samples, poses, lengths).
    pub fn solution(&mut self) -> Solution {
        if self.multi_active {
            return self.multi.solution(&self.robot, &self.plan, self.report);
        }
        let mut rec = Recording::default();
        self.b64.x.copy_from_slice(&self.x);
        let _ = pass(&self.plan, &mut self.b64, 1.0, Some(&mut rec));
        let guides = self
            .robot
            .guides()
            .iter()
            .zip(&rec.guides)
            .map(|(g, pose)| GuidePose {
                section: g.section,
                index: g.index,
                s: g.s,
                pose: *pose,
            })
            .collect();
        let cables = self
            .robot
            .cables()
            .iter()
            .zip(&self.plan.cables)
            .enumerate()
            .map(|(j, (c, pc))| CableLength {
                name: c.name.clone(),
                total_m: cable_length(&self.plan, &self.b64, j),
                segments_m: if pc.routed {
                    vec![self.b64.lengths[j]]
                } else {
                    segments(&pc.base_hole, &self.b64.holes[j])
                },
            })
            .collect();
        let (base_force, base_moment) = self.base_wrench();
        Solution {
            report: self.report,
            samples: rec.samples,
            section_tips: rec.section_tips,
            guides,
            cables,
            base_force,
            base_moment,
        }
    }
}
