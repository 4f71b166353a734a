//! Continuous tendon routing: the path `r_i(s)` of a tendon in the rod's cross-section
//! (local frame, `z = 0`) and its arc-length derivatives `r_i'`, `r_i''`, the
//! geometry of Rucker & Webster 2011 ("Statics and dynamics of continuum robots with
//! general tendon routing and external loading", IEEE T-RO 27(6)), where the tendon
//! runs at `p_i(s) = p(s) + R(s) r_i(s)`.
//!
//! Scene form (`[[robot.cables]]` with `routing = "continuous"`):
//! - `path = { straight = { radius_m, angle_deg } }`: `r = rho (cos a, sin a, 0)`;
//! - `path = { helical = { radius_m, start_angle_deg, pitch_m_per_turn } }` (or
//!   `rate_rad_per_m` instead of the pitch): `a(s) = a0 + w s`, `w = 2 pi / pitch`;
//! - `path = { table = { points_m = [[s, x, y], ...] } }`: a natural cubic spline
//!   through the points (C2; zero second derivative at both ends), `s` strictly
//!   increasing and covering `[0, end]` of the cable.
//!
//! `s` is the arc length from the robot base (m); the tendon runs from the base plate
//! (`s = 0`) to the end of its `end_section`.

use super::tendon::RoutingSpec;
use crate::error::ModelError;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// A continuous tendon path in the cross-section (scene `path = { .. }`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum PathSpec {
    /// Parallel to the backbone at a fixed offset.
    Straight {
        /// Distance from the backbone axis (m), >= 0.
        radius_m: f64,
        /// Angle from local `+x` towards `+y` (degrees).
        angle_deg: f64,
    },
    /// A helix around the backbone: angle `start + rate s`.
    Helical {
        /// Distance from the backbone axis (m), >= 0.
        radius_m: f64,
        /// Angle at `s = 0` (degrees).
        start_angle_deg: f64,
        /// Backbone length per full turn (m), non-zero; negative = left-handed.
        /// Give this or `rate_rad_per_m`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pitch_m_per_turn: Option<f64>,
        /// Angular rate (rad/m). Give this or `pitch_m_per_turn`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        rate_rad_per_m: Option<f64>,
    },
    /// Points `[s, x, y]` (m) joined by a natural cubic spline.
    Table {
        /// At least two points, `s` strictly increasing, covering the cable's span.
        points_m: Vec<[f64; 3]>,
    },
}

/// The evaluable, validated path.
#[derive(Clone, Debug, PartialEq)]
pub enum TendonPath {
    /// Constant offset (local, m).
    Straight(Vector3<f64>),
    /// `radius (cos(a0 + w s), sin(a0 + w s), 0)`.
    Helical {
        /// m
        radius: f64,
        /// rad
        start: f64,
        /// rad/m
        rate: f64,
    },
    /// Natural cubic splines `x(s)`, `y(s)`.
    Spline {
        /// Knots (m).
        s: Vec<f64>,
        /// Values `x`, `y` at the knots (m).
        xy: [Vec<f64>; 2],
        /// Second derivatives at the knots (1/m).
        m2: [Vec<f64>; 2],
    },
}

/// `r`, `r'`, `r''` at one arc length (local frame; m, -, 1/m).
pub type PathPoint = [Vector3<f64>; 3];

impl PathSpec {
    /// Validate and build the path of a cable spanning `[0, end]` (m); `max_radius`
    /// bounds the distance from the axis (the disks' radius on the sections it
    /// crosses, infinite without disks). `field` is the path used in errors.
    pub fn build(&self, field: &str, end: f64, max_radius: f64) -> Result<TendonPath, ModelError> {
        let check_radius = |f: String, rho: f64| -> Result<(), ModelError> {
            ModelError::non_negative(f.clone(), rho)?;
            if rho > max_radius {
                return Err(ModelError::OutOfRange {
                    field: f,
                    value: rho,
                    why: format!("the path leaves the disks it passes (radius {max_radius} m)"),
                });
            }
            Ok(())
        };
        match *self {
            Self::Straight {
                radius_m,
                angle_deg,
            } => {
                check_radius(format!("{field}.straight.radius_m"), radius_m)?;
                let a = ModelError::finite(format!("{field}.straight.angle_deg"), angle_deg)?
                    .to_radians();
                Ok(TendonPath::Straight(Vector3::new(
                    radius_m * a.cos(),
                    radius_m * a.sin(),
                    0.0,
                )))
            }
            Self::Helical {
                radius_m,
                start_angle_deg,
                pitch_m_per_turn,
                rate_rad_per_m,
            } => {
                let f = format!("{field}.helical");
                check_radius(format!("{f}.radius_m"), radius_m)?;
                let a0 = ModelError::finite(format!("{f}.start_angle_deg"), start_angle_deg)?;
                let rate = match (pitch_m_per_turn, rate_rad_per_m) {
                    (Some(p), None) => {
                        ModelError::finite(format!("{f}.pitch_m_per_turn"), p)?;
                        if p == 0.0 {
                            return Err(ModelError::OutOfRange {
                                field: format!("{f}.pitch_m_per_turn"),
                                value: p,
                                why: "a helix needs a non-zero pitch (use `straight` for none)"
                                    .into(),
                            });
                        }
                        2.0 * PI / p
                    }
                    (None, Some(w)) => ModelError::finite(format!("{f}.rate_rad_per_m"), w)?,
                    _ => {
                        return Err(ModelError::Invalid {
                            field: f,
                            why: "give exactly one of `pitch_m_per_turn` and `rate_rad_per_m`"
                                .into(),
                        })
                    }
                };
                Ok(TendonPath::Helical {
                    radius: radius_m,
                    start: a0.to_radians(),
                    rate,
                })
            }
            Self::Table { ref points_m } => {
                let f = format!("{field}.table.points_m");
                if points_m.len() < 2 {
                    return Err(ModelError::Invalid {
                        field: f,
                        why: format!("at least two points, got {}", points_m.len()),
                    });
                }
                for (k, p) in points_m.iter().enumerate() {
                    ModelError::finite3(&format!("{f}[{k}]"), p)?;
                    if k > 0 && p[0] <= points_m[k - 1][0] {
                        return Err(ModelError::OutOfRange {
                            field: format!("{f}[{k}][0]"),
                            value: p[0],
                            why: format!(
                                "s must increase strictly (the previous point is at s = {})",
                                points_m[k - 1][0]
                            ),
                        });
                    }
                    check_radius(format!("{f}[{k}] (radius)"), p[1].hypot(p[2]))?;
                }
                let (first, last) = (points_m[0][0], points_m[points_m.len() - 1][0]);
                let tol = 1e-12 * end.max(1.0);
                if first > tol || last < end - tol {
                    return Err(ModelError::OutOfRange {
                        field: f,
                        value: if first > tol { first } else { last },
                        why: format!(
                            "the table covers s = [{first}, {last}] m; the cable runs over [0, {end}] m"
                        ),
                    });
                }
                let s: Vec<f64> = points_m.iter().map(|p| p[0]).collect();
                let x: Vec<f64> = points_m.iter().map(|p| p[1]).collect();
                let y: Vec<f64> = points_m.iter().map(|p| p[2]).collect();
                let m2 = [
                    natural_second_derivatives(&s, &x),
                    natural_second_derivatives(&s, &y),
                ];
                Ok(TendonPath::Spline { s, xy: [x, y], m2 })
            }
        }
    }
}

/// Second derivatives `M_k` of the natural cubic spline through `(s_k, v_k)`
/// (`M_0 = M_n = 0`; the tridiagonal system of the C2 conditions, solved by the
/// Thomas algorithm: diagonally dominant, no pivoting needed).
fn natural_second_derivatives(s: &[f64], v: &[f64]) -> Vec<f64> {
    let n = s.len();
    let mut m = vec![0.0; n];
    if n < 3 {
        return m;
    }
    // interior rows i = 1..n-1: h_{i-1} M_{i-1} + 2 (h_{i-1} + h_i) M_i + h_i M_{i+1} = rhs_i
    let mut diag = vec![0.0; n];
    let mut rhs = vec![0.0; n];
    let mut upper = vec![0.0; n];
    for i in 1..n - 1 {
        let (h0, h1) = (s[i] - s[i - 1], s[i + 1] - s[i]);
        diag[i] = 2.0 * (h0 + h1);
        upper[i] = h1;
        rhs[i] = 6.0 * ((v[i + 1] - v[i]) / h1 - (v[i] - v[i - 1]) / h0);
        if i > 1 {
            let w = h0 / diag[i - 1];
            diag[i] -= w * upper[i - 1];
            rhs[i] -= w * rhs[i - 1];
        }
    }
    for i in (1..n - 1).rev() {
        m[i] = (rhs[i] - upper[i] * m[i + 1]) / diag[i];
    }
    m
}

impl TendonPath {
    /// `r`, `r'`, `r''` at arc length `s` (m from the robot base).
    pub fn eval(&self, s: f64) -> PathPoint {
        match self {
            Self::Straight(r) => [*r, Vector3::zeros(), Vector3::zeros()],
            Self::Helical {
                radius,
                start,
                rate,
            } => {
                let (sn, cs) = (start + rate * s).sin_cos();
                [
                    Vector3::new(radius * cs, radius * sn, 0.0),
                    Vector3::new(-radius * rate * sn, radius * rate * cs, 0.0),
                    Vector3::new(-radius * rate * rate * cs, -radius * rate * rate * sn, 0.0),
                ]
            }
            Self::Spline { s: knots, xy, m2 } => {
                let n = knots.len();
                // interval k with knots[k] <= s < knots[k + 1] (clamped to the ends)
                let k = knots.partition_point(|&x| x <= s).clamp(1, n - 1) - 1;
                let h = knots[k + 1] - knots[k];
                let (a, b) = ((knots[k + 1] - s) / h, (s - knots[k]) / h);
                let mut out = [Vector3::zeros(); 3];
                for c in 0..2 {
                    let (v0, v1, m0, m1) = (xy[c][k], xy[c][k + 1], m2[c][k], m2[c][k + 1]);
                    out[0][c] = a * v0
                        + b * v1
                        + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * h * h / 6.0;
                    out[1][c] = (v1 - v0) / h
                        + ((1.0 - 3.0 * a * a) * m0 + (3.0 * b * b - 1.0) * m1) * h / 6.0;
                    out[2][c] = a * m0 + b * m1;
                }
                out
            }
        }
    }

    /// Largest distance from the axis over `[0, end]` (m), sampled for splines.
    pub fn max_radius(&self, end: f64) -> f64 {
        match self {
            Self::Straight(r) => r.norm(),
            Self::Helical { radius, .. } => *radius,
            Self::Spline { .. } => (0..=256)
                .map(|k| self.eval(end * k as f64 / 256.0)[0].norm())
                .fold(0.0, f64::max),
        }
    }
}

/// Structural checks of a continuously routed cable (`field` is `robot.cables[j]`);
/// the path's numbers are checked when the robot is built ([`PathSpec::build`]).
pub(crate) fn validate_cable(c: &super::CableSpec, field: &str) -> Result<(), ModelError> {
    if !c.continuous {
        return Err(ModelError::Invalid {
            field: format!("{field}.path"),
            why: "a path needs `routing = \"continuous\"` (disk-routed cables use `hole` or a routing table)".into(),
        });
    }
    if c.path.is_none() {
        return Err(ModelError::Invalid {
            field: format!("{field}.path"),
            why: "`routing = \"continuous\"` needs a path: `{ straight = { radius_m, angle_deg } }`, `{ helical = { radius_m, start_angle_deg, pitch_m_per_turn } }` or `{ table = { points_m = [[s, x, y], ..] } }`".into(),
        });
    }
    if c.hole.is_some() {
        return Err(ModelError::Invalid {
            field: format!("{field}.hole"),
            why: "a continuously routed tendon has no disk hole".into(),
        });
    }
    Ok(())
}

/// The scene key `routing` of a cable: the string `"continuous"` or a hole table
/// `{ radius_m, angle_deg, offsets_deg }` ([`RoutingSpec`], the disk-routed form).
#[derive(Clone, Debug, PartialEq)]
pub enum RoutingField {
    /// `routing = "continuous"`: the tendon follows `path` along the rod.
    Continuous,
    /// The cable's own hole on every disk.
    Holes(RoutingSpec),
}

impl Serialize for RoutingField {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Continuous => s.serialize_str("continuous"),
            Self::Holes(h) => h.serialize(s),
        }
    }
}

impl<'de> Deserialize<'de> for RoutingField {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = RoutingField;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("\"continuous\" or a table { radius_m, angle_deg, offsets_deg }")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Self::Value, E> {
                match v {
                    "continuous" => Ok(RoutingField::Continuous),
                    _ => Err(E::invalid_value(serde::de::Unexpected::Str(v), &self)),
                }
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                a: A,
            ) -> Result<Self::Value, A::Error> {
                RoutingSpec::deserialize(serde::de::value::MapAccessDeserializer::new(a))
                    .map(RoutingField::Holes)
            }
        }
        d.deserialize_any(V)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spline_reproduces_a_cubic_inside_and_its_derivatives() {
        // a natural spline is exact for a straight line; for a parabola it matches at
        // the knots. Linear x(s) = 0.01 + 0.02 s, y(s) = -0.003 s: exact everywhere.
        let pts: Vec<[f64; 3]> = (0..6)
            .map(|k| {
                let s = 0.1 * k as f64;
                [s, 0.01 + 0.02 * s, -0.003 * s]
            })
            .collect();
        let p = PathSpec::Table { points_m: pts }
            .build("t", 0.5, f64::INFINITY)
            .unwrap();
        let [r, d, dd] = p.eval(0.237);
        assert!((r.x - (0.01 + 0.02 * 0.237)).abs() < 1e-15);
        assert!((d.x - 0.02).abs() < 1e-14 && (d.y + 0.003).abs() < 1e-14);
        assert!(dd.norm() < 1e-12);
    }

    #[test]
    fn helix_derivatives_match_central_differences() {
        let p = PathSpec::Helical {
            radius_m: 0.01,
            start_angle_deg: 30.0,
            pitch_m_per_turn: Some(0.2),
            rate_rad_per_m: None,
        }
        .build("h", 0.5, f64::INFINITY)
        .unwrap();
        let h = 1e-5;
        let (a, b, c) = (p.eval(0.3 - h), p.eval(0.3), p.eval(0.3 + h));
        // truncation h^2 |r'''| / 6 = 5.2e-9 at |r'''| = 0.01 (2 pi / 0.2)^3
        assert!(((c[0] - a[0]) / (2.0 * h) - b[1]).norm() < 1e-8);
        // truncation h^2 |r| / 6 = 1.6e-7 at |r| = 0.01 (2 pi / 0.2)^4
        assert!(((c[1] - a[1]) / (2.0 * h) - b[2]).norm() < 3e-7);
    }
}
