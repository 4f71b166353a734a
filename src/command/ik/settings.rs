//! Settings of an inverse solve, its secondary objective and its target.

use crate::error::ModelError;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// The secondary objective that resolves the redundancy (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IkObjective {
    /// Readings closest to the previous ones (the call's start). Default.
    #[default]
    Closest,
    /// Least total pull `sum q_i`.
    LeastPull,
    /// Least tension: the sum of squared tensions, a smooth proxy of the peak.
    LeastTension,
}

impl IkObjective {
    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Closest => "closest",
            Self::LeastPull => "least_pull",
            Self::LeastTension => "least_tension",
        }
    }
}

/// Settings of an inverse solve (plain numbers; defaults below).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IkSettings {
    /// A tip within this distance of the target is reached (m, > 0). Default 1e-5.
    pub tolerance_m: f64,
    /// A direction within this angle of the target's is reached (rad, > 0). Default 1e-3.
    pub angle_tolerance_rad: f64,
    /// Gauss-Newton iterations per call (>= 1). Default 30.
    pub max_iterations: usize,
    /// Forward (readings) solves per call, trial steps and the friction fallback's
    /// differences included (>= 1). Default 100.
    pub max_forward_solves: usize,
    /// Rod passes per forward solve (`None`, or between 1 and 100000): each
    /// forward solve of a call (trial steps, the friction fallback's differences)
    /// runs with this [`TendonSettings::max_passes`](crate::TendonSettings::max_passes)
    /// (`TendonReport::forward_solves`: the joint path's `f64` passes of the whole
    /// rod, line-search trials included, and each nested shooting solve as one)
    /// under the cap-only policy, so a call costs at most `max_forward_solves`
    /// times this many passes besides its Jacobians. A trial that runs out is a
    /// failed trial (the step shrinks). Default `None` (unbounded; module docs,
    /// "Budget", for 128 measured on the FTDCR v4).
    pub max_solve_passes: Option<usize>,
    /// Initial trust region: largest change of any reading in the first step (m, > 0).
    /// Default 0.002.
    pub trust_radius_m: f64,
    /// Smallest step: a step below it (m, max-norm) ends the iteration. Default 1e-10.
    pub step_tolerance_m: f64,
    /// Secondary objective. Default `closest`.
    pub objective: IkObjective,
    /// Weight `w` of the secondary objective (>= 0, dimensionless; module docs).
    /// Default 1e-6.
    pub secondary_weight: f64,
    /// Weight `w_r` of the rest term `w_r |N q / 1 mm|^2` (>= 0, dimensionless,
    /// `N` the projector on the tip Jacobian's null space), added to any
    /// objective's step: readings drawn within the redundancy toward zero, a fixed
    /// point, so that a long warm chain does not drift (module docs, "Rest term";
    /// 0 turns it off). Default 1e-3.
    pub rest_weight: f64,
    /// A direction error of 1 rad counts as this much position error (m, > 0).
    /// Default 0.01.
    pub direction_weight_m: f64,
}

impl Default for IkSettings {
    fn default() -> Self {
        Self {
            tolerance_m: 1e-5,
            angle_tolerance_rad: 1e-3,
            max_iterations: 30,
            max_forward_solves: 100,
            max_solve_passes: None,
            trust_radius_m: 0.002,
            step_tolerance_m: 1e-10,
            objective: IkObjective::Closest,
            secondary_weight: 1e-6,
            rest_weight: 1e-3,
            direction_weight_m: 0.01,
        }
    }
}

impl IkSettings {
    /// Check every number; the error names the field.
    pub fn validate(&self) -> Result<(), ModelError> {
        ModelError::positive("ik.tolerance_m", self.tolerance_m)?;
        ModelError::positive("ik.angle_tolerance_rad", self.angle_tolerance_rad)?;
        ModelError::positive("ik.trust_radius_m", self.trust_radius_m)?;
        ModelError::positive("ik.step_tolerance_m", self.step_tolerance_m)?;
        ModelError::non_negative("ik.secondary_weight", self.secondary_weight)?;
        ModelError::non_negative("ik.rest_weight", self.rest_weight)?;
        ModelError::positive("ik.direction_weight_m", self.direction_weight_m)?;
        for (f, v) in [
            ("ik.max_iterations", self.max_iterations),
            ("ik.max_forward_solves", self.max_forward_solves),
        ] {
            if v == 0 {
                return Err(ModelError::OutOfRange {
                    field: f.into(),
                    value: 0.0,
                    why: "at least 1".into(),
                });
            }
        }
        if let Some(m) = self.max_solve_passes.filter(|m| *m == 0 || *m > 100_000) {
            return Err(ModelError::OutOfRange {
                field: "ik.max_solve_passes".into(),
                value: m as f64,
                why: "between 1 and 100000".into(),
            });
        }
        Ok(())
    }
}

/// What to reach: a tip position (m, world frame) and optionally a tip direction
/// (the tip's axis `R(L) e_z`, any non-zero length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkTarget {
    /// Tip position (m).
    pub position_m: Vector3<f64>,
    /// Tip direction (normalised here; `None`: position only).
    pub direction: Option<Vector3<f64>>,
}

impl IkTarget {
    /// A position-only target.
    pub fn position(p: Vector3<f64>) -> Self {
        Self {
            position_m: p,
            direction: None,
        }
    }

    /// Check: finite position, finite non-zero direction (no allocation on success).
    pub fn validate(&self) -> Result<(), ModelError> {
        for k in 0..3 {
            if !self.position_m[k].is_finite() {
                return Err(ModelError::NonFinite {
                    field: format!("target.position_m[{k}]"),
                    value: self.position_m[k],
                });
            }
        }
        if let Some(d) = &self.direction {
            for k in 0..3 {
                if !d[k].is_finite() {
                    return Err(ModelError::NonFinite {
                        field: format!("target.direction[{k}]"),
                        value: d[k],
                    });
                }
            }
            if d.norm() < 1e-12 {
                return Err(ModelError::Invalid {
                    field: "target.direction".into(),
                    why: "has zero length: give a non-zero tip direction, or none".into(),
                });
            }
        }
        Ok(())
    }
}
