//! A rung's short label (`cc`, `pcc/point/8`, `cosserat/accurate/adaptive-1e-8`, ...) and
//! its inverse, [`Rung::from_label`]: what `--model LABEL` on the command line, the
//! pareto table and the automatic choice's report spell a rung as.
//!
//! A label names what distinguishes the rungs of the ladders ([`super::LadderGrid`]):
//! the family, the guide-mass model, the PCC pieces or the rod's integrator and its
//! cable coupling. Every other setting is the ladders' own: the settings' defaults, and
//! at most [`ADAPTIVE_MAX_STEPS`] steps for an adaptive integrator. So
//! `Rung::from_label(&r.label()) == Ok(r)` for every rung a ladder lists, and
//! `Rung::from_label(s)?.label() == s` for every label it prints.

use super::{CcSettings, LadderError, PccSettings, Rung};
use crate::settings::{CableCoupling, GuideMass, Integrator, RodModel, SolverSettings};

/// Step limit of the adaptive integrator in every ladder's rod rungs (and so in a
/// rung read from its label).
pub const ADAPTIVE_MAX_STEPS: usize = 100_000;

/// The spellings [`Rung::from_label`] takes, for error messages.
pub const LABEL_SPELLINGS: &str = "cc, pcc/<mass>/<pieces>, \
kirchhoff/<mass>/<integrator>[/arc|/exact] or cosserat/<mass>/<integrator>[/arc|/exact], \
with <mass> one of none, average, accurate, point and <integrator> rk4-<steps> or \
adaptive-<tol> (e.g. cc, pcc/point/16, kirchhoff/average/rk4-16, \
cosserat/accurate/adaptive-1e-8, cosserat/point/rk4-10/arc)";

const MASSES: [GuideMass; 4] = [
    GuideMass::None,
    GuideMass::Average,
    GuideMass::Accurate,
    GuideMass::Point,
];

impl Rung {
    /// Short label, e.g. `cc`, `pcc/point/8`, `kirchhoff/average/rk4-16`,
    /// `cosserat/accurate/adaptive-1e-8`; a rod rung whose cable coupling is not the
    /// default (`condensed`) ends in `/arc` or `/exact`
    /// (`cosserat/point/rk4-10/arc`). The inverse is [`Rung::from_label`].
    pub fn label(&self) -> String {
        match self {
            Self::ConstantCurvature(_) => "cc".into(),
            Self::PiecewiseConstantCurvature(p) => {
                format!(
                    "pcc/{}/{}",
                    guide_mass_name(p.guide_mass),
                    p.pieces_per_section
                )
            }
            Self::Rod(s) => {
                let model = match s.rod_model {
                    RodModel::Cosserat => "cosserat",
                    RodModel::Kirchhoff => "kirchhoff",
                };
                let int = match s.integrator {
                    Integrator::Rk4 { steps_per_section } => format!("rk4-{steps_per_section}"),
                    Integrator::Adaptive { tol, .. } => format!("adaptive-{tol:.0e}"),
                };
                let coupling = match s.cable_coupling {
                    CableCoupling::Condensed => "",
                    CableCoupling::Arc => "/arc",
                    CableCoupling::Exact => "/exact",
                };
                format!("{model}/{}/{int}{coupling}", guide_mass_name(s.guide_mass))
            }
        }
    }

    /// The rung a label names: the inverse of [`Rung::label`] (module docs: the
    /// settings a label does not name are the ladders' defaults). Whether the rung
    /// suits a robot or a job is its builder's question, not this one's.
    ///
    /// An error ([`LadderError::Label`]) names the part of the label that is wrong
    /// and lists the valid spellings. A label that is valid but not the canonical
    /// spelling of its rung is refused (`cosserat/point/rk4-8/condensed`: the default
    /// coupling is spelled by leaving it out; `adaptive-1.5e-8`: a label keeps one
    /// significant digit of the tolerance), so the label printed for the rung is the
    /// one given.
    ///
    /// ```
    /// use cablesense::ladder::Rung;
    /// let r = Rung::from_label("kirchhoff/point/rk4-16/arc").unwrap();
    /// assert_eq!(r.label(), "kirchhoff/point/rk4-16/arc");
    /// let e = Rung::from_label("cosserat/heavy/rk4-8").unwrap_err().to_string();
    /// assert!(e.contains("`heavy`"), "{e}");
    /// ```
    pub fn from_label(label: &str) -> Result<Rung, LadderError> {
        let bad = |why: String| LadderError::Label {
            label: label.to_string(),
            why,
        };
        let parts: Vec<&str> = label.split('/').collect();
        match parts[0] {
            "cc" => match parts.get(1) {
                None => Ok(Rung::ConstantCurvature(CcSettings::default())),
                Some(_) => Err(bad(format!(
                    "`cc` takes no settings (not `{}`)",
                    parts[1..].join("/")
                ))),
            },
            "pcc" => {
                if parts.len() != 3 {
                    return Err(bad(format!(
                        "a PCC label has 3 parts, pcc/<mass>/<pieces>, not {}",
                        parts.len()
                    )));
                }
                Ok(Rung::PiecewiseConstantCurvature(PccSettings {
                    guide_mass: parse_mass(parts[1]).map_err(bad)?,
                    pieces_per_section: parse_count(parts[2], "pieces per section").map_err(bad)?,
                    ..PccSettings::default()
                }))
            }
            family @ ("kirchhoff" | "cosserat") => {
                if !(3..=4).contains(&parts.len()) {
                    return Err(bad(format!(
                        "a rod label has 3 or 4 parts, {family}/<mass>/<integrator>[/arc|/exact], not {}",
                        parts.len()
                    )));
                }
                let rod_model = match family {
                    "kirchhoff" => RodModel::Kirchhoff,
                    _ => RodModel::Cosserat,
                };
                let cable_coupling =
                    match parts.get(3) {
                        None => CableCoupling::Condensed,
                        Some(&"arc") => CableCoupling::Arc,
                        Some(&"exact") => CableCoupling::Exact,
                        Some(&"condensed") => return Err(bad(
                            "the default coupling `condensed` is spelled by leaving the part out"
                                .into(),
                        )),
                        Some(other) => {
                            return Err(bad(format!(
                            "`{other}` is not a cable coupling (arc, exact; none for the default)"
                        )))
                        }
                    };
                Ok(Rung::Rod(SolverSettings {
                    rod_model,
                    guide_mass: parse_mass(parts[1]).map_err(bad)?,
                    integrator: parse_integrator(parts[2]).map_err(bad)?,
                    cable_coupling,
                    ..SolverSettings::default()
                }))
            }
            other => Err(bad(format!(
                "`{other}` is not a rung family (cc, pcc, kirchhoff, cosserat)"
            ))),
        }
    }
}

/// Scene-file spelling of a guide-mass model.
pub fn guide_mass_name(g: GuideMass) -> &'static str {
    match g {
        GuideMass::None => "none",
        GuideMass::Average => "average",
        GuideMass::Accurate => "accurate",
        GuideMass::Point => "point",
    }
}

fn parse_mass(s: &str) -> Result<GuideMass, String> {
    MASSES
        .into_iter()
        .find(|&g| guide_mass_name(g) == s)
        .ok_or_else(|| format!("`{s}` is not a guide-mass model (none, average, accurate, point)"))
}

/// A whole number of at least 1 (pieces or steps per section).
fn parse_count(s: &str, what: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!(
            "`{s}` is not a number of {what} (a whole number, at least 1)"
        )),
    }
}

fn parse_integrator(s: &str) -> Result<Integrator, String> {
    if let Some(n) = s.strip_prefix("rk4-") {
        return Ok(Integrator::Rk4 {
            steps_per_section: parse_count(n, "RK4 steps per section")?,
        });
    }
    if let Some(t) = s.strip_prefix("adaptive-") {
        let tol = match t.parse::<f64>() {
            Ok(tol) if tol.is_finite() && tol > 0.0 => tol,
            _ => {
                return Err(format!(
                    "`{t}` is not an adaptive tolerance (a positive number such as 1e-8)"
                ))
            }
        };
        // the label prints one significant digit: refuse what it would print otherwise
        let printed = format!("{tol:.0e}");
        if printed.parse::<f64>() != Ok(tol) {
            return Err(format!(
                "the adaptive tolerance `{t}` has more than one significant digit (labels spell it like {printed})"
            ));
        }
        return Ok(Integrator::Adaptive {
            tol,
            max_steps: ADAPTIVE_MAX_STEPS,
        });
    }
    Err(format!(
        "`{s}` is not an integrator (rk4-<steps> or adaptive-<tol>, e.g. rk4-16, adaptive-1e-8)"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ladder::LadderGrid;
    use proptest::prelude::*;

    fn mass() -> impl Strategy<Value = GuideMass> {
        prop::sample::select(MASSES.to_vec())
    }

    /// Any rung a label can name: the label's parts drawn at random, every other
    /// setting the ladders' (module docs).
    fn rung() -> impl Strategy<Value = Rung> {
        let integrator = prop_oneof![
            (1usize..=1_000_000).prop_map(|n| Integrator::Rk4 {
                steps_per_section: n
            }),
            // one significant digit, as the label prints it
            (1u32..=9, -20i32..=2).prop_map(|(d, k)| Integrator::Adaptive {
                tol: format!("{d}e{k}").parse().unwrap(),
                max_steps: ADAPTIVE_MAX_STEPS,
            }),
        ];
        let coupling = prop::sample::select(vec![
            CableCoupling::Condensed,
            CableCoupling::Arc,
            CableCoupling::Exact,
        ]);
        let model = prop::sample::select(vec![RodModel::Kirchhoff, RodModel::Cosserat]);
        prop_oneof![
            Just(Rung::ConstantCurvature(CcSettings::default())),
            (mass(), 1usize..=10_000).prop_map(|(g, n)| {
                Rung::PiecewiseConstantCurvature(PccSettings {
                    pieces_per_section: n,
                    guide_mass: g,
                    ..PccSettings::default()
                })
            }),
            (model, mass(), integrator, coupling).prop_map(|(m, g, i, c)| {
                Rung::Rod(SolverSettings {
                    rod_model: m,
                    guide_mass: g,
                    integrator: i,
                    cable_coupling: c,
                    ..SolverSettings::default()
                })
            }),
        ]
    }

    proptest! {
        #[test]
        fn from_label_inverts_label(r in rung()) {
            let label = r.label();
            prop_assert_eq!(Rung::from_label(&label), Ok(r), "label {}", label);
        }
    }

    /// Every rung of every named ladder on every shipped scene (data/scenes and the
    /// thesis tables' scenes, data/thesis/table_*.toml): read back from its label it
    /// is the same rung, so its label too.
    #[test]
    fn every_ladder_rung_reads_back_from_its_label() {
        let grids = [
            LadderGrid::full(),
            LadderGrid::auto(),
            LadderGrid::readings(),
            LadderGrid::stability_forward(),
            LadderGrid::stability_readings(),
        ];
        let mut robots = 0;
        let mut labels = std::collections::BTreeSet::new();
        for dir in ["data/scenes", "data/thesis"] {
            let mut paths: Vec<_> = std::fs::read_dir(dir)
                .expect("shipped data")
                .map(|e| e.expect("entry").path())
                .filter(|p| p.extension().is_some_and(|x| x == "toml"))
                // data/thesis/fitted.toml holds fitted parameters, not a scene
                .filter(|p| dir == "data/scenes" || p.to_string_lossy().contains("table_"))
                .collect();
            paths.sort();
            for path in paths {
                let scene = crate::Scene::load(&path).expect("shipped scene");
                let robot = scene.build_robot().expect("shipped robot");
                robots += 1;
                for grid in &grids {
                    for r in grid.rungs(&robot) {
                        let label = r.label();
                        let back = Rung::from_label(&label)
                            .unwrap_or_else(|e| panic!("{}: {label}: {e}", path.display()));
                        assert_eq!(back.label(), label, "{}", path.display());
                        assert_eq!(back, r, "{}: {label}", path.display());
                        labels.insert(label);
                    }
                }
            }
        }
        // the scenes give the ladders' every family, mass model and coupling
        assert!(robots >= 10, "{robots} shipped robots");
        for part in [
            "cc",
            "pcc/none/",
            "pcc/point/",
            "kirchhoff/",
            "/accurate/",
            "/arc",
        ] {
            assert!(labels.iter().any(|l| l.contains(part)), "{part}");
        }
    }

    /// A bad label names its bad part and lists the spellings.
    #[test]
    fn bad_labels_name_the_bad_part() {
        for (label, part) in [
            ("", "``"),
            ("bogus", "`bogus` is not a rung family"),
            ("cc/8", "`8`"),
            ("pcc/point", "3 parts"),
            ("pcc/heavy/8", "`heavy` is not a guide-mass model"),
            ("pcc/point/zero", "`zero` is not a number of pieces"),
            ("pcc/point/0", "`0` is not a number of pieces"),
            ("cosserat/heavy/rk4-8", "`heavy`"),
            ("kirchhoff/point", "3 or 4 parts"),
            ("kirchhoff/point/rk5-8", "`rk5-8` is not an integrator"),
            ("kirchhoff/point/rk4-", "`` is not a number of RK4 steps"),
            (
                "cosserat/point/adaptive-x",
                "`x` is not an adaptive tolerance",
            ),
            (
                "cosserat/point/adaptive--1e-8",
                "`-1e-8` is not an adaptive",
            ),
            ("cosserat/point/adaptive-inf", "`inf` is not an adaptive"),
            ("cosserat/point/adaptive-3.7e-8", "like 4e-8"),
            ("cosserat/point/rk4-8/condensed", "leaving the part out"),
            (
                "cosserat/point/rk4-8/chord",
                "`chord` is not a cable coupling",
            ),
            ("cosserat/point/rk4-8/arc/x", "3 or 4 parts"),
        ] {
            let e = Rung::from_label(label).expect_err(label).to_string();
            assert!(e.contains(&format!("`{label}`")), "{e}");
            assert!(e.contains(part), "{label}: {e}");
            assert!(e.contains(LABEL_SPELLINGS), "{e}");
        }
        // a tolerance spelled otherwise but with the label's one digit is the same rung
        let r = Rung::from_label("cosserat/point/adaptive-0.0001").unwrap();
        assert_eq!(r.label(), "cosserat/point/adaptive-1e-4");
    }
}
