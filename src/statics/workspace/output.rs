//! What a solve hands out: unknowns, residuals, cable lengths, base wrench, tip and
//! the full [`Solution`].

use super::super::pass::cable_length;
use super::*;

impl Workspace {
    /// Current scaled shooting unknowns (layout in the `statics` module docs).
    pub fn unknowns_vector(&self) -> &[f64] {
        &self.it.x
    }

    /// Scaled shooting residual at the current unknowns (after a solve or
    /// [`Workspace::adopt_unknowns`]); its max-norm is `report().residual`.
    pub fn residual_vector(&self) -> &[f64] {
        &self.it.res
    }

    /// Scaled shooting residual at scaled unknowns `x` into `out` (diagnostics and
    /// tests); `false` when the integration failed.
    pub fn shooting_residual(&mut self, x: &[f64], out: &mut [f64]) -> bool {
        self.it.x_trial.copy_from_slice(x);
        let ok = self.eval_trial(1.0);
        out.copy_from_slice(&self.bufs.b64.res);
        ok
    }

    /// Exact (dual-number) shooting Jacobian at `x`, row-major `n x n`.
    pub fn shooting_jacobian(&mut self, x: &[f64]) -> Option<Vec<f64>> {
        let saved = std::mem::replace(&mut self.it.x, x.to_vec());
        let ok = self.jacobian(1.0);
        self.jac.lu_valid = false;
        self.it.x = saved;
        let n = self.prob.plan.n_unknowns;
        ok.then(|| self.jac.lu.matrix_mut()[..n * n].to_vec())
    }

    /// Cable lengths of the last evaluated point (m), indexed like `robot.cables`.
    /// No allocation.
    pub fn cable_lengths_into(&self, out: &mut [f64]) {
        if self.multi.active {
            return self.multi.solver.cable_lengths_into(&self.prob.plan, out);
        }
        for (j, o) in out.iter_mut().enumerate().take(self.prob.plan.cables.len()) {
            *o = cable_length(&self.prob.plan, &self.bufs.b64, j);
        }
    }

    /// Base internal force and moment of the current solution `(n(0), m(0))`.
    pub fn base_wrench(&self) -> (Vector3<f64>, Vector3<f64>) {
        let p = &self.prob.plan;
        if self.multi.active {
            return self.multi.solver.base_wrench();
        }
        if p.closed_form {
            let m = Vector3::new(self.it.x[0], self.it.x[1], self.it.x[2]) * p.moment_scale;
            (p.closed_n0, m)
        } else {
            (
                Vector3::new(self.it.x[0], self.it.x[1], self.it.x[2]) * p.force_scale,
                Vector3::new(self.it.x[3], self.it.x[4], self.it.x[5]) * p.moment_scale,
            )
        }
    }

    /// Tip position of the last evaluated point (m).
    pub fn tip_position(&self) -> Vector3<f64> {
        if self.multi.active {
            return self.multi.solver.tip();
        }
        self.out.tip
    }

    /// Tip axis `R(L) e_z` of the last evaluated point (unit vector, world frame): the
    /// direction the tip points in, for a direction target of inverse kinematics.
    pub fn tip_axis(&self) -> Vector3<f64> {
        if self.multi.active {
            return self.multi.solver.tip_axis();
        }
        self.out.tip_axis
    }

    /// Full solution of the current point (allocates: samples, poses, lengths).
    pub fn solution(&mut self) -> Solution {
        if self.multi.active {
            return self
                .multi
                .solver
                .solution(&self.prob.robot, &self.prob.plan, self.out.report);
        }
        let mut rec = Recording::default();
        self.bufs.b64.x.copy_from_slice(&self.it.x);
        let _ = pass(&self.prob.plan, &mut self.bufs.b64, 1.0, Some(&mut rec));
        let guides = self
            .prob
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
            .prob
            .robot
            .cables()
            .iter()
            .zip(&self.prob.plan.cables)
            .enumerate()
            .map(|(j, (c, pc))| CableLength {
                name: c.name.clone(),
                total_m: cable_length(&self.prob.plan, &self.bufs.b64, j),
                segments_m: if pc.routed {
                    vec![self.bufs.b64.lengths[j]]
                } else {
                    segments(&pc.base_hole, &self.bufs.b64.holes[j])
                },
            })
            .collect();
        let (base_force, base_moment) = self.base_wrench();
        Solution {
            report: self.out.report,
            samples: rec.samples,
            section_tips: rec.section_tips,
            guides,
            cables,
            base_force,
            base_moment,
        }
    }
}
