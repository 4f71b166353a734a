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
