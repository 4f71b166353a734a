//! Automatic choice of the cheapest readings model ([`ReadingsModel`]) that meets
//! accuracy targets: the readings-side twin of [`super::choose`].
//!
//! [`super::choose`] probes a range of *loads*; a tendon robot driven by servo
//! readings is probed on *readings* instead: rows of actuator readings (m, one per
//! displacement-driven tendon, e.g. a sample of the recording to be solved), under the
//! scene's fixed loads. The method is the same:
//!
//! 1. the reference rung ([`AutoSettings::reference`]) solves the rows in order, each
//!    warm-started from the previous one (cold retry when a warm solve does not
//!    converge); rows where it does not converge are left out. Its own error is
//!    estimated as in [`super::choose`]: the same rung at a looser tolerance, whose
//!    distance is divided by the tolerance ratio's error factor;
//! 2. each candidate solves the rows the same way once; its errors are the largest
//!    tip distance and cable-length difference from the reference over the rows. A
//!    candidate that fails at a row, or misses a target, is rejected with the reason
//!    and its cost is that one pass (it cannot be picked, so it is not timed again:
//!    on the shipped two-segment TDCR a coarse rung that stalls costs ~3 s a pass);
//! 3. a candidate within both targets runs [`AutoSettings::repetitions`] more
//!    passes; its cost is the median over them of the mean time of one row (the
//!    streaming case: `track`, `solve --readings`, where every row starts from the
//!    previous one). The cheapest is picked, else the reference (`fallback`).
//!
//! In the returned [`AutoChoice`], `probe_factors` and a [`super::Verdict::Failed`]'s
//! `probe_factor` hold the *positions of the rows* in the slice given (0-based), not
//! load factors. [`AutoSettings::probe_factors`] is not used.

use super::auto::{check_inputs, distance, filter, finish, loose_reference, median, report, Probe};
use super::{AutoChoice, AutoSettings, LadderError, ReadingsModel, Rung};
use crate::error::ModelError;
use crate::loads::Loads;
use crate::robot::Robot;
use crate::statics::Start;
use crate::tendons::Actuation;
use std::time::Instant;

/// Most rows [`probe_rows`] takes from a recording.
pub const PROBE_ROWS: usize = 12;

/// Up to `max` rows of `rows`, evenly spaced from the first to the last, in order
/// (all of them when there are at most `max`): the probe of a recording.
pub fn probe_rows(rows: &[Vec<f64>], max: usize) -> Vec<Vec<f64>> {
    if max < 2 {
        return rows.iter().take(1).cloned().collect();
    }
    if rows.len() <= max {
        return rows.to_vec();
    }
    (0..max)
        .map(|k| rows[k * (rows.len() - 1) / (max - 1)].clone())
        .collect()
}

/// Pick the cheapest of `candidates` (e.g. [`super::readings_ladder`]) whose error
/// against the reference over the reading `rows` is within both targets (module
/// docs). Each row holds one reading (m) per displacement-driven tendon, in cable
/// order; an error names the first row or value that is not usable.
pub fn choose_readings(
    robot: &Robot,
    loads: &Loads,
    rows: &[Vec<f64>],
    settings: &AutoSettings,
    candidates: &[Rung],
) -> Result<AutoChoice, LadderError> {
    check_inputs(robot, loads, settings, candidates)?;
    check_rows(robot, rows)?;
    let nc = robot.cables().len();
    let mut reference = settings.reference.build_readings(robot, loads)?;
    let all = run_rows(reference.as_mut(), rows, nc, 1)?;
    let reference_time_s = all.time_s;
    let keep: Vec<bool> = all.status.iter().map(|s| s.is_converged()).collect();
    if !keep.iter().any(|&k| k) {
        return Err(LadderError::NoCandidate(
            "the reference did not converge at any probe row".into(),
        ));
    }
    let positions: Vec<f64> = (0..rows.len()).map(|i| i as f64).collect();
    let labels = filter(&positions, &keep);
    let rows = filter(rows, &keep);
    let refp = all.kept(&keep);
    let (ref_tip, ref_cable) = match loose_reference(&settings.reference) {
        Some((loose, k)) => {
            let mut m = loose.build_readings(robot, loads)?;
            let (t, c) = distance(&run_rows(m.as_mut(), &rows, nc, 1)?, &refp);
            (t / k, c / k)
        }
        None => (f64::NAN, f64::NAN),
    };
    let mut reports = Vec::with_capacity(candidates.len());
    for rung in candidates {
        let mut model = rung.build_readings(robot, loads)?;
        let mut p = run_rows(model.as_mut(), &rows, nc, 1)?;
        let (tip, cable) = distance(&p, &refp);
        let within = p.failed(&labels).is_none()
            && tip <= settings.tip_tolerance_m
            && cable <= settings.cable_tolerance_m;
        if within {
            // only a candidate that may be picked is timed again
            p.time_s = run_rows(model.as_mut(), &rows, nc, settings.repetitions)?.time_s;
        }
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

/// Every row has one finite reading per displacement-driven tendon.
fn check_rows(robot: &Robot, rows: &[Vec<f64>]) -> Result<(), LadderError> {
    let driven = robot
        .cables()
        .iter()
        .filter(|c| c.actuation == Actuation::Displacement)
        .count();
    if rows.is_empty() {
        return Err(LadderError::NoCandidate("no probe row of readings".into()));
    }
    for (i, r) in rows.iter().enumerate() {
        if r.len() != driven {
            return Err(LadderError::Model(ModelError::Invalid {
                field: format!("rows[{i}]"),
                why: format!(
                    "{} readings for {driven} displacement-driven tendons",
                    r.len()
                ),
            }));
        }
        for (k, q) in r.iter().enumerate() {
            ModelError::finite(format!("rows[{i}][{k}]"), *q)?;
        }
    }
    Ok(())
}

/// Solve `rows` in order, each warm from the previous (a non-converged warm solve is
/// retried cold), recording the tips and the `cables` lengths, `passes` times (at
/// least once; the last pass's solutions are kept). Cost: median over the passes of
/// the mean time of one row.
fn run_rows(
    model: &mut dyn ReadingsModel,
    rows: &[Vec<f64>],
    cables: usize,
    passes: usize,
) -> Result<Probe, LadderError> {
    let mut out = Probe {
        tips: Vec::new(),
        lengths: Vec::new(),
        time_s: f64::NAN,
        status: Vec::new(),
    };
    let mut times = Vec::with_capacity(passes);
    for _ in 0..passes.max(1) {
        out.tips.clear();
        out.lengths.clear();
        out.status.clear();
        let t0 = Instant::now();
        for q in rows {
            let mut rep = model.solve_readings(q, Start::Warm)?;
            if !rep.status.is_converged() {
                rep = model.solve_readings(q, Start::Cold)?;
            }
            out.status.push(rep.status);
            out.tips.push(model.tip_position());
            let mut l = vec![0.0; cables];
            model.cable_lengths_into(&mut l);
            out.lengths.push(l);
        }
        times.push(t0.elapsed().as_secs_f64() / rows.len() as f64);
    }
    out.time_s = median(&mut times);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::probe_rows;

    #[test]
    fn probe_rows_are_evenly_spaced_and_keep_the_ends() {
        let rows: Vec<Vec<f64>> = (0..100).map(|i| vec![i as f64]).collect();
        let p = probe_rows(&rows, 12);
        assert_eq!(p.len(), 12);
        assert_eq!(p[0], vec![0.0]);
        assert_eq!(p[11], vec![99.0]);
        assert!(p.windows(2).all(|w| w[1][0] > w[0][0]));
        assert_eq!(probe_rows(&rows[..5], 12).len(), 5);
        assert_eq!(probe_rows(&rows, 1), vec![vec![0.0]]);
        assert!(probe_rows(&[], 12).is_empty());
    }
}
