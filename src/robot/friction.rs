//! Capstan friction of a tendon on its disks (Euler-Eytelwein: over a wrap angle
//! `theta` the tension changes by `exp(+-mu theta)`).
//!
//! The tendon bends at each hole it passes by the angle between its incoming and
//! outgoing chords (at the base plate: between the backbone axis, along which it
//! arrives from the actuator, and the first chord). Pulled in (reading rising), the
//! tendon slides towards the actuator and friction opposes it: the tension falls
//! from the actuator towards the tip, factor `exp(-mu theta)` per hole. Paid out
//! (reading falling), it rises, `exp(+mu theta)`. The termination disk holds the
//! knot: no wrap there.

use super::tendon::FrictionSpec;
use nalgebra::Vector3;

/// Angle (rad) between two directions, robust near 0 and pi.
fn wrap_angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// Relative tension of each chord of a tendon: `out[k]` for the chord ending at
/// route hole `k` (chord 0 starts at the base hole). `axis` is the backbone's
/// direction at the base, `sign` -1 while pulled in, +1 while paid out, 0 at rest.
/// `out.len()` must equal `holes.len()`.
pub fn capstan_factors(
    mu: f64,
    sign: f64,
    axis: &Vector3<f64>,
    base: &Vector3<f64>,
    holes: &[Vector3<f64>],
    out: &mut [f64],
) {
    if mu == 0.0 || sign == 0.0 || holes.is_empty() {
        out.iter_mut().for_each(|f| *f = 1.0);
        return;
    }
    let mut prev = *base;
    let mut dir_in = *axis;
    let mut factor = 1.0;
    for (k, p) in holes.iter().enumerate() {
        let d = p - prev;
        let n = d.norm();
        let dir_out = if n > 0.0 { d / n } else { dir_in };
        factor *= (sign * mu * wrap_angle(&dir_in, &dir_out)).exp();
        out[k] = factor;
        dir_in = dir_out;
        prev = *p;
    }
}

/// The friction law of the tendons on their disks, resolved once from the scene's
/// `[robot.friction]` table ([`FrictionSpec`]). The solvers ask the law, never the
/// numbers: whether there is friction ([`FrictionLaw::is_frictionless`]), how a
/// tendon's sliding direction follows its readings ([`FrictionLaw::next_direction`])
/// and what the chords' tension factors are ([`FrictionLaw::chord_factors`]). A new
/// law is a variant here and its fields in the scene table (`robot/tendon.rs`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FrictionLaw {
    /// No `[robot.friction]` table, or `mu = 0`.
    Frictionless,
    /// Capstan friction per hole (module docs) with a sliding direction that
    /// switches at once when a reading moves by more than `deadband_m` (m).
    CapstanSwitching {
        /// Coefficient of friction (dimensionless, > 0).
        mu: f64,
        /// Reading change (m) below which the direction is kept.
        deadband_m: f64,
    },
    /// Capstan friction per hole with a first-order (Dahl-type) pre-sliding
    /// turn-round over the slide length `slide_m` (m): continuous in the readings
    /// ([`FrictionSpec::slide_m`]).
    CapstanPreSliding {
        /// Coefficient of friction (dimensionless, > 0).
        mu: f64,
        /// Slide length (m, > 0).
        slide_m: f64,
    },
}

impl FrictionLaw {
    /// The law of a robot's `[robot.friction]` table (absent or `mu = 0`:
    /// frictionless).
    pub fn of(spec: Option<&FrictionSpec>) -> Self {
        match spec {
            Some(f) if f.mu > 0.0 => match f.slide_m {
                Some(slide_m) => Self::CapstanPreSliding { mu: f.mu, slide_m },
                None => Self::CapstanSwitching {
                    mu: f.mu,
                    deadband_m: f.deadband_m,
                },
            },
            _ => Self::Frictionless,
        }
    }

    /// No friction: the tendon tension is the same along the whole tendon.
    #[inline]
    pub fn is_frictionless(&self) -> bool {
        matches!(self, Self::Frictionless)
    }

    /// The coefficient of friction (0 when frictionless).
    pub fn mu(&self) -> f64 {
        match *self {
            Self::Frictionless => 0.0,
            Self::CapstanSwitching { mu, .. } | Self::CapstanPreSliding { mu, .. } => mu,
        }
    }

    /// The direction state after a reading change `dq` (m) from state `s` (in
    /// `[-1, 1]`, -1 pulled in, +1 paid out): the switching law (-1 or +1 once `|dq|`
    /// exceeds the deadband, else unchanged) or the pre-sliding law (towards
    /// `-sign(dq)` by the factor `1 - exp(-|dq| / slide_m)`). Returns the new state
    /// and whether the reading counts as a move (the switching law keeps its last
    /// reading below the deadband, so slow creeps still add up); frictionless, the
    /// state is kept and every reading counts.
    pub fn next_direction(&self, s: f64, dq: f64) -> (f64, bool) {
        match *self {
            Self::Frictionless => (s, true),
            Self::CapstanPreSliding { slide_m, .. } => {
                if dq == 0.0 {
                    return (s, true);
                }
                let target = if dq > 0.0 { -1.0 } else { 1.0 };
                (target + (s - target) * (-dq.abs() / slide_m).exp(), true)
            }
            Self::CapstanSwitching { deadband_m, .. } => {
                if dq.abs() > deadband_m {
                    (if dq > 0.0 { -1.0 } else { 1.0 }, true)
                } else {
                    (s, false)
                }
            }
        }
    }

    /// Relative tension of each chord of a tendon in direction state `sign`
    /// ([`capstan_factors`]; all 1 when frictionless).
    pub fn chord_factors(
        &self,
        sign: f64,
        axis: &Vector3<f64>,
        base: &Vector3<f64>,
        holes: &[Vector3<f64>],
        out: &mut [f64],
    ) {
        capstan_factors(self.mu(), sign, axis, base, holes, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straight_tendon_has_no_friction_and_a_bend_follows_the_capstan_law() {
        let axis = Vector3::z();
        let base = Vector3::new(0.01, 0.0, 0.0);
        let holes = [Vector3::new(0.01, 0.0, 0.01), Vector3::new(0.01, 0.0, 0.02)];
        let mut out = [0.0; 2];
        capstan_factors(0.3, -1.0, &axis, &base, &holes, &mut out);
        assert_eq!(out, [1.0, 1.0]);
        // a 90 degree turn at the first hole: exp(-mu pi/2) on the second chord
        let holes = [Vector3::new(0.01, 0.0, 0.01), Vector3::new(0.02, 0.0, 0.01)];
        capstan_factors(0.3, -1.0, &axis, &base, &holes, &mut out);
        assert!((out[0] - 1.0).abs() < 1e-15);
        assert!((out[1] - (-0.3 * std::f64::consts::FRAC_PI_2).exp()).abs() < 1e-15);
    }
}
