//! Automatic choice of the cheapest rung that meets accuracy targets.
//!
//! At solve time, on a probe of the scene's load range (point loads and cable tensions
//! scaled by each of [`AutoSettings::probe_factors`], gravity unchanged):
//!
//! 1. the reference rung ([`Rung::reference`], the next rung up from every candidate)
//!    is solved at each probe load; its own error is estimated by tolerance doubling
//!    twice over: the same model at a 100x looser tolerance, whose distance from the
//!    reference bounds the reference's error 100-fold (the adaptive error scales
//!    linearly with tol, Hairer, Norsett & Wanner, *Solving ODEs I*, section II.4);
//! 2. each candidate is solved cold at each probe load; its error is the largest tip
//!    distance and the largest cable-length difference from the reference over the
//!    probe, and its cost the median wall time of one cold solve;
//! 3. a candidate that fails to converge at any probe load, or whose tip or cable
//!    error exceeds its target, is rejected with the reason; of the rest, the one with
//!    the smallest measured time is picked. If none passes, the reference is used and
//!    the choice says so (`fallback`).

use super::{scale_loads, ForwardModel, LadderError, Rung};
use crate::loads::Loads;
use crate::robot::Robot;
use crate::settings::Integrator;
use crate::statics::{SolveStatus, Start};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::time::Instant;
use thiserror::Error;

/// Why a length with a unit could not be read.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LengthParseError {
    /// No number in front of the unit.
    #[error("`{text}`: expected a number followed by a unit (m, cm, mm, um, nm), e.g. 0.1mm")]
    NoNumber {
        /// The input.
        text: String,
    },
    /// Unknown unit.
    #[error("`{text}`: unknown length unit `{unit}` (use m, cm, mm, um or nm)")]
    Unit {
        /// The input.
        text: String,
        /// The unit found.
        unit: String,
    },
    /// Zero, negative or not finite.
    #[error("`{text}`: a tolerance must be finite and > 0")]
    NotPositive {
        /// The input.
        text: String,
    },
}

/// Parse a length such as `0.1mm`, `1 um`, `2e-6m`, `5µm` into metres. A bare number
/// is in metres. The value must be finite and > 0.
pub fn parse_length(text: &str) -> Result<f64, LengthParseError> {
    let t = text.trim();
    let split = t
        .find(|c: char| c.is_alphabetic() && c != 'e' && c != 'E')
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let value: f64 = num
        .trim()
        .parse()
        .map_err(|_| LengthParseError::NoNumber { text: text.into() })?;
    let scale = match unit.trim() {
        "" | "m" => 1.0,
        "cm" => 1e-2,
        "mm" => 1e-3,
        "um" | "µm" | "μm" => 1e-6,
        "nm" => 1e-9,
        other => {
            return Err(LengthParseError::Unit {
                text: text.into(),
                unit: other.into(),
            })
        }
    };
    let v = value * scale;
    if !(v > 0.0 && v.is_finite()) {
        return Err(LengthParseError::NotPositive { text: text.into() });
    }
    Ok(v)
}

/// Targets and probe of the automatic choice.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AutoSettings {
    /// Largest acceptable tip position error (m, default 1e-4 = 0.1 mm).
    pub tip_tolerance_m: f64,
    /// Largest acceptable cable length error (m, default 1e-6 = 1 um).
    pub cable_tolerance_m: f64,
    /// Factors applied to the point loads and tensions to probe the load range
    /// (default `[0, 0.5, 1, 1.5]`; identical probe loads are solved once).
    pub probe_factors: Vec<f64>,
    /// Timed cold solves per candidate and probe load; the median is the cost
    /// (default 3).
    pub repetitions: usize,
    /// The rung errors are measured against (default [`Rung::reference`]).
    pub reference: Rung,
}

impl Default for AutoSettings {
    fn default() -> Self {
        Self {
            tip_tolerance_m: 1e-4,
            cable_tolerance_m: 1e-6,
            probe_factors: vec![0.0, 0.5, 1.0, 1.5],
            repetitions: 3,
            reference: Rung::reference(),
        }
    }
}

impl AutoSettings {
    /// Check every field.
    pub fn validate(&self) -> Result<(), LadderError> {
        for (field, v) in [
            ("auto.tip_tolerance_m", self.tip_tolerance_m),
            ("auto.cable_tolerance_m", self.cable_tolerance_m),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(LadderError::Setting {
                    field: field.into(),
                    value: v,
                    why: "finite and > 0".into(),
                });
            }
        }
        if self.probe_factors.is_empty() {
            return Err(LadderError::NoCandidate("no probe factor".into()));
        }
        for (i, f) in self.probe_factors.iter().enumerate() {
            if !(f.is_finite() && *f >= 0.0) {
                return Err(LadderError::Setting {
                    field: format!("auto.probe_factors[{i}]"),
                    value: *f,
                    why: "finite and >= 0".into(),
                });
            }
        }
        if self.repetitions == 0 {
            return Err(LadderError::Setting {
                field: "auto.repetitions".into(),
                value: 0.0,
                why: "at least 1".into(),
            });
        }
        Ok(())
    }
}

/// What happened to one candidate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Meets both targets and is the cheapest that does.
    Picked,
    /// Meets both targets, but a cheaper candidate does too.
    Slower,
    /// Tip error above target.
    TipError {
        /// Estimated error (m).
        error_m: f64,
        /// Target (m).
        tolerance_m: f64,
    },
    /// Cable length error above target (tip within target).
    CableError {
        /// Estimated error (m).
        error_m: f64,
        /// Target (m).
        tolerance_m: f64,
    },
    /// Did not converge at a probe load.
    Failed {
        /// Probe factor where it failed.
        probe_factor: f64,
        /// Its status there.
        status: SolveStatus,
    },
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Picked => write!(f, "picked: cheapest within both targets"),
            Self::Slower => write!(f, "within targets but slower"),
            Self::TipError {
                error_m,
                tolerance_m,
            } => write!(
                f,
                "tip error {:.3} mm > {:.3} mm",
                error_m * 1e3,
                tolerance_m * 1e3
            ),
            Self::CableError {
                error_m,
                tolerance_m,
            } => write!(
                f,
                "cable error {:.3} um > {:.3} um",
                error_m * 1e6,
                tolerance_m * 1e6
            ),
            Self::Failed {
                probe_factor,
                status,
            } => write!(
                f,
                "did not converge at load factor {probe_factor}: {status:?}"
            ),
        }
    }
}

/// One candidate's measured error and cost.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CandidateReport {
    /// The rung.
    pub rung: Rung,
    /// Its label.
    pub label: String,
    /// Largest tip distance from the reference over the probe (m; infinite if failed).
    pub tip_error_m: f64,
    /// Largest cable length difference from the reference over the probe (m).
    pub cable_error_m: f64,
    /// Median wall time of one cold solve (s).
    pub time_s: f64,
    /// Outcome.
    pub verdict: Verdict,
}

/// The result of [`choose`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AutoChoice {
    /// Index of the picked candidate, `None` when none met the targets.
    pub picked: Option<usize>,
    /// The rung to use: the picked candidate, or the reference as a fallback.
    pub rung: Rung,
    /// True when no candidate met the targets and the reference is used.
    pub fallback: bool,
    /// Every candidate, in the order given.
    pub candidates: Vec<CandidateReport>,
    /// Probe factors actually solved (duplicates removed).
    pub probe_factors: Vec<f64>,
    /// Reference label.
    pub reference: String,
    /// Estimated tip error of the reference itself (m).
    pub reference_tip_error_m: f64,
    /// Estimated cable error of the reference itself (m).
    pub reference_cable_error_m: f64,
    /// Mean time of one reference solve over the probe, warm-started from the previous
    /// probe load (s).
    pub reference_time_s: f64,
}

impl AutoChoice {
    /// The picked candidate's report, if any.
    pub fn picked_report(&self) -> Option<&CandidateReport> {
        self.picked.map(|i| &self.candidates[i])
    }
}

/// Solutions of one model over the probe: tips, lengths, median time.
pub(super) struct Probe {
    pub(super) tips: Vec<nalgebra::Vector3<f64>>,
    pub(super) lengths: Vec<Vec<f64>>,
    pub(super) time_s: f64,
    pub(super) status: Vec<SolveStatus>,
}

impl Probe {
    /// First probe (its label in `labels`: a load factor, or a row's position) where
    /// the model did not converge.
    pub(super) fn failed(&self, labels: &[f64]) -> Option<(f64, SolveStatus)> {
        self.status
            .iter()
            .zip(labels)
            .find(|(s, _)| !s.is_converged())
            .map(|(s, f)| (*f, *s))
    }

    /// The probes where `keep` is true.
    pub(super) fn kept(&self, keep: &[bool]) -> Self {
        Self {
            tips: filter(&self.tips, keep),
            lengths: filter(&self.lengths, keep),
            status: filter(&self.status, keep),
            time_s: self.time_s,
        }
    }
}

/// The items of `v` where `keep` is true.
pub(super) fn filter<T: Clone>(v: &[T], keep: &[bool]) -> Vec<T> {
    v.iter()
        .zip(keep)
        .filter(|(_, k)| **k)
        .map(|(x, _)| x.clone())
        .collect()
}

fn run_probe(
    model: &mut dyn ForwardModel,
    probes: &[(f64, Loads)],
    repetitions: usize,
) -> Result<Probe, LadderError> {
    let nc = model.robot().cables().len();
    let mut out = Probe {
        tips: Vec::with_capacity(probes.len()),
        lengths: Vec::with_capacity(probes.len()),
        time_s: 0.0,
        status: Vec::with_capacity(probes.len()),
    };
    let mut times = Vec::with_capacity(probes.len() * repetitions);
    for (_, loads) in probes {
        // with repetitions: the first call is untimed (it may build buffers for this
        // load structure), then cold solves are timed; without: one warm-started solve
        // from the previous probe load, retried cold (used for the reference)
        let mut rep = if repetitions == 0 {
            let r = model.solve(loads, Start::Warm)?;
            if r.status.is_converged() {
                r
            } else {
                model.solve(loads, Start::Cold)?
            }
        } else {
            model.solve(loads, Start::Cold)?
        };
        for _ in 0..repetitions {
            let t0 = Instant::now();
            rep = model.solve(loads, Start::Cold)?;
            times.push(t0.elapsed().as_secs_f64());
        }
        out.status.push(rep.status);
        out.tips.push(model.tip_position());
        let mut l = vec![0.0; nc];
        model.cable_lengths_into(&mut l);
        out.lengths.push(l);
    }
    out.time_s = median(&mut times);
    Ok(out)
}

/// Median (NaN for an empty slice); sorts in place.
pub(crate) fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Largest tip distance and cable-length difference between two probes (m;
/// infinite where either is NaN).
pub(super) fn distance(a: &Probe, b: &Probe) -> (f64, f64) {
    let mut tip: f64 = 0.0;
    let mut cable: f64 = 0.0;
    for (ta, tb) in a.tips.iter().zip(&b.tips) {
        let d = (ta - tb).norm();
        tip = if d.is_nan() {
            f64::INFINITY
        } else {
            tip.max(d)
        };
    }
    for (la, lb) in a.lengths.iter().zip(&b.lengths) {
        for (x, y) in la.iter().zip(lb) {
            let d = (x - y).abs();
            cable = if d.is_nan() {
                f64::INFINITY
            } else {
                cable.max(d)
            };
        }
    }
    (tip, cable)
}

/// Pick the cheapest of `candidates` whose error, estimated against the reference on
/// a probe of the load range around `loads`, is within both targets (module docs).
pub fn choose(
    robot: &Robot,
    loads: &Loads,
    settings: &AutoSettings,
    candidates: &[Rung],
) -> Result<AutoChoice, LadderError> {
    check_inputs(robot, loads, settings, candidates)?;
    let mut probes: Vec<(f64, Loads)> = Vec::new();
    for &f in &settings.probe_factors {
        let l = scale_loads(loads, f);
        if !probes.iter().any(|(_, p)| *p == l) {
            probes.push((f, l));
        }
    }
    // probe loads in increasing order, so that the reference can warm-start
    probes.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut reference = settings.reference.build(robot)?;
    let t0 = Instant::now();
    let all = run_probe(reference.as_mut(), &probes, 0)?;
    let reference_time_s = t0.elapsed().as_secs_f64() / probes.len() as f64;
    // keep only the probe loads where the reference converged
    let keep: Vec<bool> = all.status.iter().map(|s| s.is_converged()).collect();
    if !keep.iter().any(|&k| k) {
        return Err(LadderError::NoCandidate(
            "the reference did not converge at any probe load".into(),
        ));
    }
    let probes: Vec<(f64, Loads)> = filter(&probes, &keep);
    let labels: Vec<f64> = probes.iter().map(|(f, _)| *f).collect();
    let refp = all.kept(&keep);
    // the reference's own error: the same model at a 100x looser tolerance
    let (ref_tip, ref_cable) = match loose_reference(&settings.reference) {
        Some((loose, k)) => {
            let mut m = loose.build(robot)?;
            let p = run_probe(m.as_mut(), &probes, 0)?;
            let (t, c) = distance(&p, &refp);
            (t / k, c / k)
        }
        None => (f64::NAN, f64::NAN),
    };
    let mut reports = Vec::with_capacity(candidates.len());
    for rung in candidates {
        let mut model = rung.build(robot)?;
        let p = run_probe(model.as_mut(), &probes, settings.repetitions)?;
        let (tip, cable) = distance(&p, &refp);
        reports.push(report(rung, &p, &labels, tip, cable, settings));
    }
    Ok(finish(
        reports,
        settings,
        labels,
        (ref_tip, ref_cable),
        reference_time_s,
    ))
}

/// Settings and loads valid, and at least one candidate.
pub(super) fn check_inputs(
    robot: &Robot,
    loads: &Loads,
    settings: &AutoSettings,
    candidates: &[Rung],
) -> Result<(), LadderError> {
    settings.validate()?;
    loads.validate(robot)?;
    if candidates.is_empty() {
        return Err(LadderError::NoCandidate(
            "the candidate list is empty".into(),
        ));
    }
    Ok(())
}

/// The reference at a looser tolerance and the factor by which its distance from the
/// reference overestimates the reference's own error: adaptive at 100x the
/// tolerance (error linear in tol), RK4 at half the steps (Richardson: 2^4 - 1).
/// `None` for a curvature rung (its error is not a tolerance's).
pub(super) fn loose_reference(reference: &Rung) -> Option<(Rung, f64)> {
    let Rung::Rod(s) = reference else {
        return None;
    };
    let mut loose = s.clone();
    let k = match s.integrator {
        Integrator::Adaptive { tol, max_steps } => {
            loose.integrator = Integrator::Adaptive {
                tol: tol * 100.0,
                max_steps,
            };
            100.0
        }
        Integrator::Rk4 { steps_per_section } => {
            loose.integrator = Integrator::Rk4 {
                steps_per_section: (steps_per_section / 2).max(1),
            };
            15.0
        }
    };
    Some((Rung::Rod(loose), k))
}

/// A candidate's verdict against the targets (before the cheapest is picked).
pub(super) fn report(
    rung: &Rung,
    p: &Probe,
    labels: &[f64],
    tip: f64,
    cable: f64,
    settings: &AutoSettings,
) -> CandidateReport {
    let verdict = if let Some((probe_factor, status)) = p.failed(labels) {
        Verdict::Failed {
            probe_factor,
            status,
        }
    } else if tip > settings.tip_tolerance_m {
        Verdict::TipError {
            error_m: tip,
            tolerance_m: settings.tip_tolerance_m,
        }
    } else if cable > settings.cable_tolerance_m {
        Verdict::CableError {
            error_m: cable,
            tolerance_m: settings.cable_tolerance_m,
        }
    } else {
        Verdict::Slower
    };
    CandidateReport {
        rung: rung.clone(),
        label: rung.label(),
        tip_error_m: tip,
        cable_error_m: cable,
        time_s: p.time_s,
        verdict,
    }
}

/// Pick the cheapest candidate within both targets and assemble the choice.
pub(super) fn finish(
    mut reports: Vec<CandidateReport>,
    settings: &AutoSettings,
    labels: Vec<f64>,
    (ref_tip, ref_cable): (f64, f64),
    reference_time_s: f64,
) -> AutoChoice {
    let picked = reports
        .iter()
        .enumerate()
        .filter(|(_, r)| r.verdict == Verdict::Slower)
        .min_by(|a, b| a.1.time_s.total_cmp(&b.1.time_s))
        .map(|(i, _)| i);
    if let Some(i) = picked {
        reports[i].verdict = Verdict::Picked;
    }
    AutoChoice {
        picked,
        rung: picked.map_or_else(|| settings.reference.clone(), |i| reports[i].rung.clone()),
        fallback: picked.is_none(),
        candidates: reports,
        probe_factors: labels,
        reference: settings.reference.label(),
        reference_tip_error_m: ref_tip,
        reference_cable_error_m: ref_cable,
        reference_time_s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lengths_with_units() {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * b.abs();
        assert!(close(parse_length("0.1mm").unwrap(), 1e-4));
        assert!(close(parse_length("1um").unwrap(), 1e-6));
        assert!(close(parse_length(" 2 µm ").unwrap(), 2e-6));
        assert!(close(parse_length("1e-3m").unwrap(), 1e-3));
        assert!(close(parse_length("1e-3").unwrap(), 1e-3));
        assert!(close(parse_length("3cm").unwrap(), 0.03));
        assert!(close(parse_length("5nm").unwrap(), 5e-9));
        assert!(parse_length("mm").is_err());
        assert!(parse_length("1 furlong").is_err());
        assert!(parse_length("-1mm").is_err());
        assert!(parse_length("0um").is_err());
        assert!(parse_length("nan mm").is_err());
        assert!(parse_length("").is_err());
    }
}
