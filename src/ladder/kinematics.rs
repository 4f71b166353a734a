//! Constant-curvature kinematics of displacement-driven tendons: actuator readings ->
//! one arc `(kappa_k, phi_k)` per section, in closed form.
//!
//! This is the classic constant-curvature model of a tendon-driven robot (Webster &
//! Jones 2010, "Design and kinematic modeling of constant curvature continuum robots:
//! a review", IJRR 29(13), section 3.1.1, the robot-specific mapping for tendon
//! robots): a section of length `L` bent by `theta = kappa L` in the plane at angle
//! `phi` (measured in the section's local `xy` plane from `+x` towards `+y`, the
//! direction the backbone bends towards) changes the path of an inextensible tendon
//! through holes at radius `r` and angle `sigma` by
//!
//! ```text
//! Delta l = -r theta cos(phi - sigma) = -d . w,   w = theta (cos phi, sin phi),  d = r (cos sigma, sin sigma)
//! ```
//!
//! linear in the bending vector `w` (a continuous tendon on a straight path at offset
//! `d` obeys the same law on every section it spans; a helical or tabulated one is
//! refused, naming its `path`). A tendon pulled in by `q` (reading, m, positive =
//! pulled, zero offset removed as in [`crate::tendons::TendonWorkspace`]) and ending on
//! section `e` shortens its path by `q`, so `sum_{k <= e} d_k . w_k = q` (code `d`, `w`,
//! `q`; paper `r_i`, `sigma_i`, `phi`, `theta`, `Delta l_i`). Ignored: tendon stretch,
//! pretension, the rod's axial strain, the chords between disks, friction and every
//! external load (gravity, payloads): the model is kinematics only.
//!
//! **Sections in order (PCC).** The sections are solved base to tip: section `k` is
//! determined by the tendons ending on it, with the path change the sections before
//! it already cause to each of them **subtracted** from its reading,
//! `sum_i d_ik . w_k = q_i - sum_{k' < k} d_ik' . w_k'` (the proximal segment's
//! contribution to a distal tendon, Webster & Jones 2010 section 3.1.1 for multiple
//! segments). Distal tendons passing a section do not change its arc in this model.
//!
//! **Least squares and slack (the `taut` rule).** With more than two tendons ending on
//! a section the readings over-determine `w_k`; it is their least-squares solution
//! (the common-mode part of the readings, e.g. all three pulled by the same amount, is
//! what an axial strain would take up, and bends nothing). One tendon alone bends the
//! section towards itself (the minimum-norm solution); two collinear tendons likewise.
//! Slack tendons contribute nothing. The rule, per section: the **pulled** tendons
//! (reading, less the proximal path change, above 1e-12 m) are taut; the arc is fitted
//! to them; every other tendon whose reading is at least the path change that arc
//! requires (`q_i >= d_i . w`: the arc would stretch it) is taut too, and the arc is
//! refitted, until no tendon is added. The rest are slack: paid out more than the bend
//! takes up, their paths are shorter than their free lengths. With antagonistic
//! readings (one pulled, the others paid out at least as far as the bend needs) this
//! uses exactly the pulled ones; with kinematically consistent readings, all; with
//! every tendon paid out, none, and the section is straight (as it is when no tendon
//! ends on it; its precurvature, if any, kept). Every tendon then obeys the
//! complementarity of `crate::tendons` in the inextensible limit up to the
//! least-squares residual: slack ones have `q_i < d_i . w`.

use super::LadderError;
use crate::error::ModelError;
use crate::robot::{Robot, TendonPath};
use crate::tendons::Actuation;
use nalgebra::{Vector2, Vector3};

/// Deficit (m) beyond which a tendon is declared slack.
const SLACK_TOL_M: f64 = 1e-12;

/// Readings -> constant-curvature arcs of every section (module docs).
#[derive(Clone, Debug)]
pub struct TendonKinematics {
    /// Cable index of each displacement-driven tendon (reading order).
    driven: Vec<usize>,
    /// Encoder zero offset of each driven tendon (m).
    zero: Vec<f64>,
    /// Section on whose last disk each driven tendon ends.
    ends: Vec<usize>,
    /// `d_ik`: hole of driven tendon `i` on section `k <= ends[i]` (local xy, m).
    holes: Vec<Vec<Vector2<f64>>>,
    /// Section lengths (m) and precurvatures (1/m, local).
    lengths: Vec<f64>,
    pre: Vec<Vector3<f64>>,
    /// Bending vector `w_k = theta_k (cos phi_k, sin phi_k)` of the last solve (rad).
    w: Vec<Vector2<f64>>,
    /// Whether each driven tendon was taut in the last solve.
    taut: Vec<bool>,
    rhs: Vec<f64>,
}

impl TendonKinematics {
    /// Build for `robot`; an error when no cable is displacement-driven.
    pub fn new(robot: &Robot) -> Result<Self, LadderError> {
        let ns = robot.sections().len();
        let mut me = Self {
            driven: Vec::new(),
            zero: Vec::new(),
            ends: Vec::new(),
            holes: Vec::new(),
            lengths: robot.sections().iter().map(|s| s.length).collect(),
            pre: robot.sections().iter().map(|s| s.precurvature).collect(),
            w: vec![Vector2::zeros(); ns],
            taut: Vec::new(),
            rhs: Vec::new(),
        };
        for (j, c) in robot.cables().iter().enumerate() {
            if c.actuation != Actuation::Displacement {
                continue;
            }
            // a continuous tendon on a straight path at offset `d` changes its length
            // by `-d . w` over an arc, like holes at `d` on every disk (the path is the
            // parallel curve at `d`: `|e3 + u x d| = 1 - kappa d . (cos phi, sin phi)`,
            // Kirchhoff, `super::straight_arc_length`); a helical or tabulated path
            // turns in the cross-section, so no single `d` per section exists
            let straight = match &c.path {
                None => None,
                Some(TendonPath::Straight(d)) => Some(Vector2::new(d.x, d.y)),
                Some(_) => {
                    return Err(LadderError::Model(ModelError::Invalid {
                        field: format!("robot.cables[{j}].path"),
                        why: "a displacement-driven tendon on a helical or tabulated continuous path does not keep a section's curvature constant: the constant-curvature kinematics take straight paths only (drive it through the rod rungs' readings solve)".into(),
                    }))
                }
            };
            let holes = (0..=c.end_section)
                .map(|k| {
                    if let Some(d) = straight {
                        return d;
                    }
                    // the hole on this section's first disk; a section without disks
                    // uses the nearest disk before it, else the base plate (as the CC
                    // rung's moment arms)
                    let on = c.route.iter().position(|&g| robot.guides()[g].section == k);
                    let before = c.route.iter().rposition(|&g| robot.guides()[g].section < k);
                    let d = match on.or(before) {
                        Some(i) => c.hole_local[i],
                        None => c.base_hole,
                    };
                    Vector2::new(d.x, d.y)
                })
                .collect();
            me.driven.push(j);
            me.zero.push(c.mechanics.map_or(0.0, |m| m.zero_offset_m));
            me.ends.push(c.end_section);
            me.holes.push(holes);
        }
        if me.driven.is_empty() {
            return Err(LadderError::Model(ModelError::Invalid {
                field: "robot.cables".into(),
                why: "no cable has `actuation = \"displacement\"`: no readings to map".into(),
            }));
        }
        me.taut = vec![true; me.driven.len()];
        me.rhs = vec![0.0; me.driven.len()];
        Ok(me)
    }

    /// Cable indices of the displacement-driven tendons, in reading order (as
    /// [`crate::tendons::TendonWorkspace::driven`]).
    pub fn driven(&self) -> &[usize] {
        &self.driven
    }

    /// Map readings (m, one per driven tendon, positive = pulled) to one arc per
    /// section. An error names the reading that is missing or not finite.
    pub fn solve(&mut self, readings_m: &[f64]) -> Result<(), LadderError> {
        if readings_m.len() != self.driven.len() {
            return Err(LadderError::Model(ModelError::Invalid {
                field: "readings".into(),
                why: format!(
                    "{} readings for {} displacement-driven tendons",
                    readings_m.len(),
                    self.driven.len()
                ),
            }));
        }
        for (i, q) in readings_m.iter().enumerate() {
            ModelError::finite(format!("readings[{i}]"), *q)?;
            self.rhs[i] = q - self.zero[i];
            self.taut[i] = true;
        }
        for k in 0..self.w.len() {
            // subtract what the sections before k already do to the tendons ending on k
            for i in 0..self.driven.len() {
                if self.ends[i] == k {
                    for kp in 0..k {
                        self.rhs[i] -= self.holes[i][kp].dot(&self.w[kp]);
                    }
                }
            }
            // start from the pulled tendons; add every other one the fitted arc would
            // stretch (reading at least the path change it requires), refit, repeat
            for i in 0..self.driven.len() {
                if self.ends[i] == k {
                    self.taut[i] = self.rhs[i] > SLACK_TOL_M;
                }
            }
            self.w[k] = loop {
                let w = self.least_squares(k);
                let mut added = false;
                for i in 0..self.driven.len() {
                    if self.ends[i] == k
                        && !self.taut[i]
                        && self.rhs[i] >= self.holes[i][k].dot(&w) - SLACK_TOL_M
                    {
                        self.taut[i] = true;
                        added = true;
                    }
                }
                if !added {
                    break w;
                }
            };
        }
        Ok(())
    }

    /// Least-squares `w_k` from the taut tendons ending on section `k` (the
    /// minimum-norm solution when they span one direction only; zero when none).
    fn least_squares(&self, k: usize) -> Vector2<f64> {
        let (mut n, mut b) = (nalgebra::Matrix2::<f64>::zeros(), Vector2::zeros());
        for i in 0..self.driven.len() {
            if self.ends[i] == k && self.taut[i] {
                let d = self.holes[i][k];
                n += d * d.transpose();
                b += d * self.rhs[i];
            }
        }
        let tr = n.trace();
        if tr <= 0.0 {
            return Vector2::zeros();
        }
        if n.determinant() > 1e-12 * tr * tr {
            n.try_inverse().map_or(Vector2::zeros(), |inv| inv * b)
        } else {
            // rank one: N = tr v v^T and b lies along v, so pinv(N) b = b / tr
            b / tr
        }
    }

    /// Bending angle `theta_k` (rad) and bending-plane angle `phi_k` (rad, local,
    /// from `+x` towards `+y`) of section `k` from the last solve.
    pub fn angles(&self, k: usize) -> (f64, f64) {
        let w = self.w[k];
        (w.norm(), w.y.atan2(w.x))
    }

    /// Curvature `kappa_k = theta_k / L_k` (1/m) of section `k` from the last solve.
    pub fn kappa(&self, k: usize) -> f64 {
        self.w[k].norm() / self.lengths[k]
    }

    /// Local curvature vector of section `k`: `u* + kappa (-sin phi, cos phi, 0)`
    /// (the backbone bends towards `(cos phi, sin phi, 0)`; thesis eq. 2.12's `u`).
    pub fn curvature(&self, k: usize) -> Vector3<f64> {
        let w = self.w[k] / self.lengths[k];
        self.pre[k] + Vector3::new(-w.y, w.x, 0.0)
    }

    /// Whether each driven tendon was taut in the last solve (reading order).
    pub fn taut(&self) -> &[bool] {
        &self.taut
    }

    /// The readings (m, reading order, zero offsets included) that bend every
    /// section `k` by `arcs[k] = (theta_k, phi_k)` (rad) in this model:
    /// `q_i = sum_{k <= e_i} d_ik . w_k` (the inverse of [`Self::solve`] for
    /// consistent readings). Sections beyond `arcs.len()` stay straight.
    pub fn readings_for(&self, arcs: &[(f64, f64)]) -> Vec<f64> {
        (0..self.driven.len())
            .map(|i| {
                self.zero[i]
                    + (0..=self.ends[i])
                        .filter_map(|k| arcs.get(k).map(|a| (k, a)))
                        .map(|(k, &(theta, phi))| {
                            self.holes[i][k].dot(&(Vector2::new(phi.cos(), phi.sin()) * theta))
                        })
                        .sum::<f64>()
            })
            .collect()
    }

    /// Path change (m) the last solve's arcs give driven tendon `i`:
    /// `-sum_{k <= e_i} d_ik . w_k` (zero offset not included).
    pub fn path_change(&self, i: usize) -> f64 {
        -(0..=self.ends[i])
            .map(|k| self.holes[i][k].dot(&self.w[k]))
            .sum::<f64>()
    }
}
