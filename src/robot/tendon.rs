//! Serializable tendon description: how each cable is actuated, its mechanics
//! (stretch, series spring, pretension), its own hole routing, and friction.
//!
//! Units: N for `stiffness_n` (the axial stiffness `EA_t` of the tendon, so strain 1
//! costs `EA_t` newtons), N/m for the series spring, N for tensions, m and degrees for
//! holes, and the capstan coefficient `mu` is dimensionless.

use crate::error::ModelError;
use serde::{Deserialize, Serialize};

/// How a cable is driven (scene key `actuation`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Actuation {
    /// A given tension (`loads.tensions_n`), as a force-controlled actuator or a
    /// hanging weight. The default, and the behaviour before tendons existed.
    #[default]
    Tension,
    /// A measuring cable: zero tension, its length is only read.
    Passive,
    /// Position-controlled: the actuator reading `q` (m, positive = pulled) sets the
    /// tendon's free length `L0 - q`; the tension follows from the shape
    /// ([`crate::tendons::TendonWorkspace`]).
    Displacement,
}

/// Mechanics of a tendon (scene `[robot.tendons]` for every cable, or per cable
/// `tendon = { .. }`, which overrides field by field).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TendonSpec {
    /// Axial stiffness `EA_t` of the tendon (N), > 0; `inf` is an inextensible
    /// tendon. Required for displacement-driven tendons (no default: a braided
    /// polymer line and a steel wire differ a hundredfold).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stiffness_n: Option<f64>,
    /// Stiffness of a spring in series at the actuator (N/m), > 0; default none
    /// (infinitely stiff). Also the place for the compliance of the tendon's lead
    /// outside the robot and of the servo horn.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub series_stiffness_n_per_m: Option<f64>,
    /// Second-order term `b` of the series spring (m/N^2), any finite sign; default
    /// 0 (the linear spring). The spring's extension is `e(T) = T/k_s + b T^2`
    /// ([`TendonMechanics::series_extension`]): `b > 0` softens it as the tension
    /// grows, `b < 0` is a toe region (soft at low tension, stiffening to the linear
    /// region beyond `T* = 1/(4 k_s |b|)`, where its stiffness is `2 k_s`). A
    /// negative value needs `series_stiffness_n_per_m`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub series_quadratic_m_per_n2: Option<f64>,
    /// Tension at reading `q = 0` (N), >= 0; default 0 (just taut). It fixes the
    /// free length `L0` (see [`crate::tendons::TendonWorkspace`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pretension_n: Option<f64>,
    /// Encoder zero offset (m): the reading that corresponds to `q = 0`. Default 0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zero_offset_m: Option<f64>,
}

impl TendonSpec {
    /// Field-by-field override: `self`'s values win over `defaults`.
    pub fn or(&self, defaults: &TendonSpec) -> TendonSpec {
        TendonSpec {
            stiffness_n: self.stiffness_n.or(defaults.stiffness_n),
            series_stiffness_n_per_m: self
                .series_stiffness_n_per_m
                .or(defaults.series_stiffness_n_per_m),
            series_quadratic_m_per_n2: self
                .series_quadratic_m_per_n2
                .or(defaults.series_quadratic_m_per_n2),
            pretension_n: self.pretension_n.or(defaults.pretension_n),
            zero_offset_m: self.zero_offset_m.or(defaults.zero_offset_m),
        }
    }

    /// Check every given value; `field` is the table's path.
    pub fn validate(&self, field: &str) -> Result<(), ModelError> {
        if let Some(ea) = self.stiffness_n {
            if ea.is_nan() || ea <= 0.0 {
                return Err(ModelError::NonPositive {
                    field: format!("{field}.stiffness_n"),
                    value: ea,
                });
            }
        }
        if let Some(k) = self.series_stiffness_n_per_m {
            if k.is_nan() || k <= 0.0 {
                return Err(ModelError::NonPositive {
                    field: format!("{field}.series_stiffness_n_per_m"),
                    value: k,
                });
            }
        }
        if let Some(b) = self.series_quadratic_m_per_n2 {
            ModelError::finite(format!("{field}.series_quadratic_m_per_n2"), b)?;
        }
        if let Some(t) = self.pretension_n {
            ModelError::non_negative(format!("{field}.pretension_n"), t)?;
        }
        if let Some(z) = self.zero_offset_m {
            ModelError::finite(format!("{field}.zero_offset_m"), z)?;
        }
        Ok(())
    }
}

/// A tendon's own hole, used on every disk it passes and on the base plate
/// (scene `routing = { radius_m, angle_deg, offsets_deg }`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoutingSpec {
    /// Distance of the hole from the backbone axis (m), >= 0.
    pub radius_m: f64,
    /// Hole angle (degrees) from local `+x` towards `+y`.
    pub angle_deg: f64,
    /// Extra angle (degrees) on the disks of section `k` (`offsets_deg[k]`, missing
    /// entries 0): a tendon that is re-routed between sections. The base plate uses
    /// section 0's angle.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub offsets_deg: Vec<f64>,
}

impl RoutingSpec {
    /// Hole angle (rad) on the disks of section `k`.
    pub fn angle_rad(&self, section: usize) -> f64 {
        (self.angle_deg + self.offsets_deg.get(section).copied().unwrap_or(0.0)).to_radians()
    }

    /// Check the numbers; `field` is the table's path.
    pub fn validate(&self, field: &str) -> Result<(), ModelError> {
        ModelError::non_negative(format!("{field}.radius_m"), self.radius_m)?;
        ModelError::finite(format!("{field}.angle_deg"), self.angle_deg)?;
        for (k, o) in self.offsets_deg.iter().enumerate() {
            ModelError::finite(format!("{field}.offsets_deg[{k}]"), *o)?;
        }
        Ok(())
    }
}

/// Tendon-on-disk friction (scene `[robot.friction]`; off when absent).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrictionSpec {
    /// Capstan coefficient `mu` (-), >= 0: over a wrap angle `theta` the tension
    /// changes by the factor `exp(+-mu theta)`.
    pub mu: f64,
    /// Reading change (m) below which a tendon keeps the direction it last moved in
    /// (so encoder noise does not flip the friction). Default 1e-5.
    #[serde(default = "default_deadband")]
    pub deadband_m: f64,
    /// Slide length (m) over which a tendon's friction turns round after it reverses
    /// (a first-order, Dahl-type pre-sliding law): each reading change `dq` moves the
    /// direction state `s` (in `[-1, 1]`, -1 pulled in, +1 paid out) towards
    /// `-sign(dq)` by the factor `1 - exp(-|dq| / slide_m)`, and the capstan factor
    /// per hole is `exp(s mu theta)`. Physically the elastic stretch a tendon takes
    /// before its contact points slip (of the order of `T L / EA`). Absent: the
    /// switching law (the direction flips at once beyond `deadband_m`), which makes
    /// the model non-smooth in the readings and in the parameters that shift them;
    /// with `slide_m` the model is continuous in both, so a least-squares fit can use
    /// its sensitivities. When set, `deadband_m` is not used.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slide_m: Option<f64>,
}

impl FrictionSpec {
    /// Check the numbers.
    pub fn validate(&self) -> Result<(), ModelError> {
        ModelError::non_negative("robot.friction.mu", self.mu)?;
        ModelError::non_negative("robot.friction.deadband_m", self.deadband_m)?;
        if let Some(slide) = self.slide_m {
            if slide.is_nan() || slide <= 0.0 || slide.is_infinite() {
                return Err(ModelError::NonPositive {
                    field: "robot.friction.slide_m".into(),
                    value: slide,
                });
            }
        }
        Ok(())
    }
}

fn default_deadband() -> f64 {
    1e-5
}

#[cfg(test)]
mod tests {
    use super::super::friction::FrictionLaw;
    use super::*;

    fn law(slide_m: Option<f64>) -> FrictionSpec {
        FrictionSpec {
            mu: 0.1,
            deadband_m: 1e-5,
            slide_m,
        }
    }

    /// No table or `mu = 0` is frictionless; a slide length picks the pre-sliding
    /// law, else the switching one.
    #[test]
    fn the_table_resolves_to_its_law() {
        assert!(FrictionLaw::of(None).is_frictionless());
        let mut zero = law(Some(1e-4));
        zero.mu = 0.0;
        assert!(FrictionLaw::of(Some(&zero)).is_frictionless());
        assert_eq!(
            FrictionLaw::of(Some(&law(Some(1e-4)))),
            FrictionLaw::CapstanPreSliding {
                mu: 0.1,
                slide_m: 1e-4
            }
        );
        assert_eq!(
            FrictionLaw::of(Some(&law(None))),
            FrictionLaw::CapstanSwitching {
                mu: 0.1,
                deadband_m: 1e-5
            }
        );
        assert_eq!(
            FrictionLaw::Frictionless.next_direction(0.0, 1.0),
            (0.0, true)
        );
    }

    #[test]
    fn the_switching_law_flips_beyond_the_deadband_only() {
        let f = FrictionLaw::of(Some(&law(None)));
        assert_eq!(f.next_direction(0.0, 2e-5), (-1.0, true));
        assert_eq!(f.next_direction(-1.0, -2e-5), (1.0, true));
        // below the deadband: unchanged, and the reading is not taken as a move
        assert_eq!(f.next_direction(-1.0, 5e-6), (-1.0, false));
    }

    #[test]
    fn the_pre_sliding_law_turns_round_continuously() {
        let slide = 2e-4;
        let f = FrictionLaw::of(Some(&law(Some(slide))));
        // pulled in from rest by one slide length: 1 - 1/e of the way to -1
        let (s, moved) = f.next_direction(0.0, slide);
        assert!(moved);
        assert!((s + 1.0 - (-1.0f64).exp()).abs() < 1e-15, "{s}");
        // continuous in dq at a reversal: tiny moves either way barely change s
        let (up, _) = f.next_direction(-1.0, 1e-12);
        let (down, _) = f.next_direction(-1.0, -1e-12);
        assert!(
            (up + 1.0).abs() < 1e-12 && (down + 1.0).abs() < 1e-7,
            "{up} {down}"
        );
        // a long move settles on the moving direction; the state stays in [-1, 1]
        let (s, _) = f.next_direction(-1.0, -50.0 * slide);
        assert!((s - 1.0).abs() < 1e-12 && s <= 1.0);
        // two steps equal one step of their sum (the law is exact, not a time step)
        let (a, _) = f.next_direction(0.3, 1e-4);
        let (b, _) = f.next_direction(a, 2e-4);
        let (c, _) = f.next_direction(0.3, 3e-4);
        assert!((b - c).abs() < 1e-14, "{b} {c}");
    }

    #[test]
    fn a_slide_length_must_be_positive_and_finite() {
        for bad in [0.0, -1e-4, f64::NAN, f64::INFINITY] {
            let e = law(Some(bad)).validate().unwrap_err().to_string();
            assert!(e.contains("robot.friction.slide_m"), "{e}");
        }
        assert!(law(Some(1e-4)).validate().is_ok());
    }
}

/// Resolved mechanics of one tendon (SI units).
///
/// A taut tendon of free length `L_f` at tension `T` covers the path
/// `L_f (1 + s T/EA_t) + e(T)` ([`TendonMechanics::covered`]; `s` the chords' mean
/// capstan factor, 1 without friction), with the series spring's extension
///
/// ```text
/// e(T) = T/k_s + b tau (2T - tau),   tau = clamp(T, 0, T*),
/// T* = 1/(4 k_s |b|) when b < 0, else infinite
/// ```
///
/// that is `T/k_s + b T^2` on `0 <= T <= T*`, continued linearly (C1) beyond `T*`
/// and below 0 (a converged tension is >= 0; iterates may not be). `b = 0` is the
/// linear spring, bit for bit. The quadratic is the second-order Taylor term of a
/// smooth load-extension curve: `b < 0` the "toe" of a braided or twisted line,
/// whose crimped fibres straighten and are recruited as the load grows (stiffening
/// to a linear region; Kastelic, Palley & Baer, J. Biomech. 13 (1980) 887-893, the
/// crimp model of the toe of tendon's stress-strain curve; a wire rope's or braided
/// line's "constructional elongation" on top of its material's linear one: Carl Stahl
/// Technocables, "Wire rope science: elongation"), `b > 0` a lead or horn
/// that yields more as the load grows (a softening spring). The tangent compliance
/// `de/dT = 1/k_s + 2 b tau` is `>= 1/(2 k_s) > 0` for every `T`, so the covered
/// length increases with the tension whatever the sign of `b`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TendonMechanics {
    /// Axial stiffness `EA_t` (N); `inf` = inextensible.
    pub stiffness_n: f64,
    /// Series spring at the actuator (N/m); `inf` = none.
    pub series_stiffness_n_per_m: f64,
    /// Second-order term `b` of the series spring's extension (m/N^2); 0 = linear.
    pub series_quadratic_m_per_n2: f64,
    /// Tension at reading 0 (N).
    pub pretension_n: f64,
    /// Encoder reading at `q = 0` (m).
    pub zero_offset_m: f64,
}

impl TendonMechanics {
    /// From a (validated) spec; `None` without a stiffness.
    pub fn resolve(spec: &TendonSpec) -> Option<Self> {
        Some(Self {
            stiffness_n: spec.stiffness_n?,
            series_stiffness_n_per_m: spec.series_stiffness_n_per_m.unwrap_or(f64::INFINITY),
            series_quadratic_m_per_n2: spec.series_quadratic_m_per_n2.unwrap_or(0.0),
            pretension_n: spec.pretension_n.unwrap_or(0.0),
            zero_offset_m: spec.zero_offset_m.unwrap_or(0.0),
        })
    }

    /// Linear compliance `dl/dT` at zero tension of the taut tendon at free length
    /// `free` (m/N), with `stretch` the length-weighted mean tension factor of its
    /// chords (1 without friction): `free s/EA_t + 1/k_s`. The tangent at tension
    /// `T` adds the series spring's second-order term
    /// ([`TendonMechanics::tangent_compliance`]).
    pub fn compliance(&self, free: f64, stretch: f64) -> f64 {
        free * stretch / self.stiffness_n + 1.0 / self.series_stiffness_n_per_m
    }

    /// Tension (N) where a negative second-order term's quadratic ends (struct
    /// docs): `1/(4 k_s |b|)`; infinite for `b >= 0`.
    fn toe_end(&self) -> f64 {
        let b = self.series_quadratic_m_per_n2;
        if b < 0.0 {
            0.25 / (self.series_stiffness_n_per_m * -b)
        } else {
            f64::INFINITY
        }
    }

    /// Second-order part of the series spring's extension at tension `t` (m):
    /// `b tau (2t - tau)`, `tau = clamp(t, 0, T*)` (struct docs); 0 when `b = 0`.
    pub fn series_extension_nonlinear(&self, t: f64) -> f64 {
        let b = self.series_quadratic_m_per_n2;
        if b == 0.0 {
            return 0.0;
        }
        let tau = t.clamp(0.0, self.toe_end());
        b * tau * (2.0 * t - tau)
    }

    /// The series spring's extension `e(T)` (m) at tension `t` (struct docs).
    pub fn series_extension(&self, t: f64) -> f64 {
        t / self.series_stiffness_n_per_m + self.series_extension_nonlinear(t)
    }

    /// Tangent compliance `d covered / dT` (m/N) at free length `free`, tension `t`
    /// and mean tension factor `stretch`: [`TendonMechanics::compliance`] plus the
    /// second-order term's `2 b tau` (exact, the derivative of
    /// [`TendonMechanics::covered`] in `t`).
    pub fn tangent_compliance(&self, free: f64, t: f64, stretch: f64) -> f64 {
        let c = self.compliance(free, stretch);
        let b = self.series_quadratic_m_per_n2;
        if b == 0.0 {
            return c;
        }
        c + 2.0 * b * t.clamp(0.0, self.toe_end())
    }

    /// Path length (m) a taut tendon of free length `free` covers at tension `t`.
    pub fn covered(&self, free: f64, t: f64, stretch: f64) -> f64 {
        let linear = free + t * self.compliance(free, stretch);
        if self.series_quadratic_m_per_n2 == 0.0 {
            return linear;
        }
        linear + self.series_extension_nonlinear(t)
    }

    /// Free length `L0` (m) from the reference path `l_ref` at the pretension:
    /// `L0 = (l_ref - e(T0)) / (1 + T0/EA_t)`.
    pub fn free_length_at_rest(&self, l_ref: f64) -> f64 {
        let t0 = self.pretension_n;
        let spring = if self.series_quadratic_m_per_n2 == 0.0 {
            l_ref - t0 / self.series_stiffness_n_per_m
        } else {
            l_ref - t0 / self.series_stiffness_n_per_m - self.series_extension_nonlinear(t0)
        };
        spring / (1.0 + t0 / self.stiffness_n)
    }
}

#[cfg(test)]
mod spring_tests {
    use super::*;

    fn mech(b: f64) -> TendonMechanics {
        TendonMechanics {
            stiffness_n: 2e4,
            series_stiffness_n_per_m: 3000.0,
            series_quadratic_m_per_n2: b,
            pretension_n: 0.8,
            zero_offset_m: 0.0,
        }
    }

    #[test]
    fn without_the_second_order_term_the_law_is_the_linear_one_bit_for_bit() {
        let m = mech(0.0);
        for (free, t, s) in [(0.2, 0.0, 1.0), (0.19, 3.7, 1.0), (0.21, 11.3, 1.04)] {
            let linear = free * s / m.stiffness_n + 1.0 / m.series_stiffness_n_per_m;
            assert_eq!(m.covered(free, t, s), free + t * linear);
            assert_eq!(m.tangent_compliance(free, t, s), linear);
        }
        let t0 = m.pretension_n;
        assert_eq!(
            m.free_length_at_rest(0.2),
            (0.2 - t0 / m.series_stiffness_n_per_m) / (1.0 + t0 / m.stiffness_n)
        );
    }

    /// The tangent compliance is the covered length's derivative in the tension (a
    /// central difference), the extension is `T/k + b T^2` inside the quadratic, the
    /// covered length grows with the tension on both sides of the toe's end, and the
    /// rest free length covers the reference path at the pretension.
    #[test]
    fn the_tangent_compliance_is_the_derivative_of_the_covered_length() {
        let k = 3000.0;
        for b in [4e-5, -2e-5] {
            let m = mech(b);
            let t_star = if b < 0.0 {
                0.25 / (k * -b)
            } else {
                f64::INFINITY
            };
            // (not at 0 or T*, where the second derivative jumps)
            for t in [-0.5, 0.3, 1.5, 4.0, 4.2, 9.0] {
                let (free, s, h) = (0.2, 1.0, 1e-6);
                let fd = (m.covered(free, t + h, s) - m.covered(free, t - h, s)) / (2.0 * h);
                let exact = m.tangent_compliance(free, t, s);
                assert!(
                    (fd - exact).abs() < 1e-6 * exact,
                    "b {b} t {t}: {fd} vs {exact}"
                );
                assert!(exact >= 0.5 / k, "b {b} t {t}: not monotone ({exact})");
                if (0.0..=t_star).contains(&t) {
                    let e = m.series_extension(t);
                    assert!((e - (t / k + b * t * t)).abs() < 1e-15, "{e}");
                }
            }
            let l0 = m.free_length_at_rest(0.2);
            let back = m.covered(l0, m.pretension_n, 1.0);
            assert!((back - 0.2).abs() < 1e-15, "b {b}: {back}");
        }
        // (b < 0: the toe ends at 1/(4 k |b|) = 4.17 N, where the stiffness is 2k)
        let m = mech(-2e-5);
        let beyond = m.tangent_compliance(0.0, 8.0, 1.0);
        assert!((beyond - 0.5 / k).abs() < 1e-15, "{beyond}");
    }

    #[test]
    fn a_second_order_term_must_be_finite() {
        for bad in [f64::NAN, f64::INFINITY] {
            let spec = TendonSpec {
                series_quadratic_m_per_n2: Some(bad),
                ..TendonSpec::default()
            };
            let e = spec.validate("robot.tendons").unwrap_err().to_string();
            assert!(e.contains("robot.tendons.series_quadratic_m_per_n2"), "{e}");
        }
    }
}
