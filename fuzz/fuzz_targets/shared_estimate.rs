//! Body of the `estimator_tick` fuzz target, shared by `fuzz/fuzz_targets/estimator_tick.rs`
//! and `tests/fuzz_regressions.rs` (through `#[path]`, like `shared.rs`, whose
//! [`ForwardInput`] and [`Reader`] it reuses).
//!
//! Input layout ([`EstimatorInput::from_bytes`]; every byte string is a valid input,
//! missing bytes read as zero):
//! * bytes `0..104`: a [`ForwardInput`] (robot of 1-2 sections with 0-5 guides and
//!   three cables per guided section, known loads, bounded solver settings);
//! * bytes `104..168`: 32 `u16` fractions of the estimation spec (bounds, priors,
//!   reference and initial values of up to 3 unknowns, noise, tolerances, time budget,
//!   measured reference lengths);
//! * bytes `168..208`: 40 `u8` choices (unknown kinds, sections, axes, cables, which
//!   bounds and priors are present, method among LM / GN / constrained / argmin GN,
//!   iteration limit 1-4, and one "poison" that makes a field invalid);
//! * then up to [`MAX_TICKS`] ticks of [`TICK_BYTES`] each: a flags byte (bits 0-1:
//!   how many changes, c / c-1 / c+2 / none; bit 2: noise given; bits 3-4: how many
//!   noise values), then per cable a kind byte and 8 value bytes for the change, then
//!   the same for the noise. Kinds 0-9 give a plausible value (change within +-5 mm,
//!   noise in 1e-7..1e-3 m), 10-15 NaN, +inf, -inf, raw bits, +-1e100..1e308 and
//!   |x| <= 1e-300 (see `value`).
//!
//! What counts as a bug: a panic; a hang (budgets are small here: the forward
//! settings of `ForwardInput` at a capped resolution, at most 4 estimator iterations
//! per tick and [`INPUT_ITERATION_BUDGET`] per input); a tick overrunning its
//! time budget by more than one step ([`BUDGET_SOLVES`]); a poisoned spec that
//! builds; and after any tick: a status other than `tick`'s own, `NoData` not
//! reported when nothing can be estimated, measured values not the finite inputs,
//! a non-finite current estimate (every later tick warm-starts from it), and, when
//! the status is usable (`Converged`, `Unobservable`, `MaxIterations`, `TimeBudget`),
//! non-finite values, tip pose, section tips or predicted lengths, or values outside
//! the bounds (methods that honour bounds: all but argmin's Gauss-Newton).

// The fuzz target calls `check_estimator`, the regression test `estimator_tick`.
#![allow(dead_code)]

use crate::shared::{ForwardInput, Reader, FORWARD_INPUT_BYTES};
use cablesense::estimate::{
    Axis, EstimateSpec, EstimateStatus, Estimator, Method, UnknownKind, UnknownSpec,
};
use cablesense::{Integrator, Loads, Robot, SolverSettings};

/// Start of the spec fractions.
const SPEC_FRACTIONS: usize = FORWARD_INPUT_BYTES;
/// Start of the spec choices.
const SPEC_CHOICES: usize = SPEC_FRACTIONS + 2 * 32;
/// Start of the ticks.
pub const TICKS_START: usize = SPEC_CHOICES + 40;
/// Cables a robot of `ForwardInput` can have (3 per section, 2 sections).
const MAX_CABLES: usize = 6;
/// Bytes of one tick: a flags byte, then per cable a kind byte and 8 value bytes for
/// the change and the same for the noise.
pub const TICK_BYTES: usize = 1 + 2 * MAX_CABLES * 9;
/// Ticks per input.
pub const MAX_TICKS: usize = 4;
/// Estimator iteration limit (1..=this).
const MAX_ESTIMATE_ITERATIONS: u8 = 4;
/// Per-input work budget, so that the target runs thousands of inputs per second
/// rather than hundreds (it ran 94 k inputs in 240 s; almost all of the time in the
/// forward solves of trial loads): the forward model's resolution is capped (RK4 at
/// most this many steps per section, adaptive at most
/// [`ESTIMATOR_MAX_ADAPTIVE_STEPS`] steps; the forward solver's accuracy is the
/// `forward_solve` target's business, every estimator path is reachable at any
/// resolution), and the ticks of one input stop once they have used
/// [`INPUT_ITERATION_BUDGET`] estimator iterations (a tick is always checked whole;
/// the warm chain after a pathological tick is still checked whenever the first
/// ticks were cheap).
const ESTIMATOR_MAX_RK4_STEPS: usize = 6;
/// See [`ESTIMATOR_MAX_RK4_STEPS`].
const ESTIMATOR_MAX_ADAPTIVE_STEPS: usize = 400;
/// See [`ESTIMATOR_MAX_RK4_STEPS`]: estimator iterations over all ticks of one input.
const INPUT_ITERATION_BUDGET: usize = 8;
/// A tick with a time budget `b` must return within `2 b + BUDGET_SOLVES t + BUDGET_SLACK_S`,
/// where `t` is the time `Estimator::new` took (one or two cold forward solves, measured
/// in the same build and under the same load). The estimator checks its budget between
/// steps, and a forward solve has no time budget of its own, so a tick may overrun by
/// one step: a sensitivity sweep and two forward solves, then the final sweep of the
/// statistics. (argmin's Gauss-Newton is exempt: it does not honour the budget, see
/// the README of `fuzz/regressions/`.)
const BUDGET_SOLVES: f64 = 6.0;
/// See [`BUDGET_SOLVES`] (s).
const BUDGET_SLACK_S: f64 = 0.05;

/// One sample for `Estimator::tick`.
#[derive(Clone, Debug)]
pub struct Tick {
    /// Cable changes (m); any length, any value.
    pub changes: Vec<f64>,
    /// Per-cable noise (m); any length, any value.
    pub sigma: Option<Vec<f64>>,
}

/// Typed input of the `estimator_tick` target.
#[derive(Clone, Debug)]
pub struct EstimatorInput {
    /// Robot, known loads and forward settings.
    pub forward: ForwardInput,
    /// The estimation problem (possibly invalid: see `poison`).
    pub spec: EstimateSpec,
    /// Which field was made invalid (`None`: the spec is built from bounded ranges and
    /// may still be invalid, e.g. `min > max` or an index past the robot's).
    pub poison: Option<Poison>,
    /// The samples.
    pub ticks: Vec<Tick>,
}

/// A field made invalid on purpose: construction must fail with `Err`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Poison {
    NoiseNan,
    ToleranceZero,
    RankToleranceNegative,
    MaxIterationsZero,
    ReferenceLengthsTooMany,
    ReferenceLengthNegative,
    NoUnknowns,
    MinNan,
    InitialInfinite,
    PriorSigmaZero,
    TimeBudgetZero,
    ForwardToleranceNan,
    GravityInfinite,
    TensionsTooMany,
    TensionNegative,
}

const POISONS: [Poison; 15] = [
    Poison::NoiseNan,
    Poison::ToleranceZero,
    Poison::RankToleranceNegative,
    Poison::MaxIterationsZero,
    Poison::ReferenceLengthsTooMany,
    Poison::ReferenceLengthNegative,
    Poison::NoUnknowns,
    Poison::MinNan,
    Poison::InitialInfinite,
    Poison::PriorSigmaZero,
    Poison::TimeBudgetZero,
    Poison::ForwardToleranceNan,
    Poison::GravityInfinite,
    Poison::TensionsTooMany,
    Poison::TensionNegative,
];

/// A value from a kind byte and 8 bytes: mostly `small(bytes)`, sometimes a
/// pathological number.
fn value(kind: u8, b: [u8; 8], small: impl Fn([u8; 8]) -> f64) -> f64 {
    let sign = if b[7] & 0x80 != 0 { -1.0 } else { 1.0 };
    match kind % 16 {
        10 => f64::NAN,
        11 => f64::INFINITY,
        12 => f64::NEG_INFINITY,
        13 => f64::from_le_bytes(b),
        // 1e100 .. 1e308
        14 => sign * 10f64.powf(100.0 + 208.0 * f64::from(b[0]) / 255.0),
        // subnormal and tiny: |x| <= 1e-300
        15 => f64::from(i16::from_le_bytes([b[0], b[1]])) * 1e-305,
        _ => small(b),
    }
}

/// A length change within +-5 mm (zero bytes: 0).
fn small_change(b: [u8; 8]) -> f64 {
    5e-3 * f64::from(i16::from_le_bytes([b[0], b[1]])) / 32767.0
}

/// A noise level in [1e-7, 1e-3] m (zero bytes: 1e-5, the default).
fn small_sigma(b: [u8; 8]) -> f64 {
    let u = f64::from(i16::from_le_bytes([b[0], b[1]])) / 32768.0; // [-1, 1)
    10f64.powf(-5.0 + 2.0 * u)
}

fn values(r: &mut Reader, len: usize, small: fn([u8; 8]) -> f64) -> Vec<f64> {
    let all: Vec<f64> = (0..MAX_CABLES)
        .map(|_| {
            let kind = r.byte();
            let b = [0; 8].map(|_: u8| r.byte());
            value(kind, b, small)
        })
        .collect();
    all[..len.min(MAX_CABLES)]
        .iter()
        .copied()
        .chain(std::iter::repeat_n(0.25e-3, len.saturating_sub(MAX_CABLES)))
        .collect()
}

/// Length of a value vector for `c` cables from two mode bits.
fn mode_len(mode: u8, c: usize) -> usize {
    match mode & 3 {
        0 => c,
        1 => c.saturating_sub(1),
        2 => c + 2,
        _ => 0,
    }
}

impl Tick {
    fn from_bytes(data: &[u8], c: usize) -> Self {
        let mut r = Reader::new(data, 0);
        let flags = r.byte();
        let changes = values(&mut r, mode_len(flags, c), small_change);
        let sigma = values(&mut r, mode_len(flags >> 3, c), small_sigma);
        Self {
            changes,
            sigma: (flags & 0b100 != 0).then_some(sigma),
        }
    }
}

impl EstimatorInput {
    /// Decode (see the module docs). Every byte string is a valid input.
    pub fn from_bytes(data: &[u8]) -> Self {
        let forward = ForwardInput::from_bytes(data);
        // cables of the robot ForwardInput describes (3 per guided section)
        let c = 3 * forward.sections.iter().filter(|s| s.2 > 0).count();
        let n_sections = forward.sections.len();
        let mut f = Reader::new(data, SPEC_FRACTIONS);
        let mut k = Reader::new(data, SPEC_CHOICES);
        let n_unknowns = 1 + usize::from(k.choice(3));
        let mut unknowns = Vec::new();
        for _ in 0..3 {
            let kind = [
                UnknownKind::Force,
                UnknownKind::Torque,
                UnknownKind::Mass,
                UnknownKind::Tension,
            ][usize::from(k.choice(4))];
            let section = match k.choice(8) {
                0..=3 => Some(n_sections - 1),
                4 | 5 => Some(0),
                6 => Some(2), // past the last section
                _ => None,
            };
            let axis = match k.choice(7) {
                0 | 1 => Some(Axis::X),
                2 | 3 => Some(Axis::Y),
                4 | 5 => Some(Axis::Z),
                _ => None,
            };
            let cable = match k.choice(8) {
                j @ 0..=5 => Some(usize::from(j)), // may be past the last cable
                6 => Some(0),
                _ => None,
            };
            let bounds = k.choice(4);
            let prior = k.choice(2) == 1;
            let (min, max) = (f.range(-1.0, 0.5), f.range(-0.5, 1.0));
            let (prior_mean, prior_sigma) = (f.range(-0.5, 0.5), f.log_range(1e-3, 10.0));
            let (reference, initial) = (f.range(-0.05, 0.05), f.range(-0.5, 0.5));
            unknowns.push(UnknownSpec {
                kind,
                section,
                axis,
                cable,
                name: None,
                min: (bounds & 1 != 0).then_some(min),
                max: (bounds & 2 != 0).then_some(max),
                prior_mean: prior.then_some(prior_mean),
                prior_sigma: prior.then_some(prior_sigma),
                reference,
                initial,
            });
        }
        unknowns.truncate(n_unknowns);
        let method = [
            Method::LevenbergMarquardt,
            Method::GaussNewton,
            Method::Constrained,
            Method::ArgminGaussNewton,
        ][usize::from(k.choice(4))];
        let max_iterations = 1 + usize::from(k.choice(MAX_ESTIMATE_ITERATIONS));
        let budget = k.choice(3) != 0;
        let reuse_jacobian = k.choice(2) == 1;
        let measured_reference = k.choice(4) == 0;
        // choices 17..=31 poison one field (zero bytes do not, so short inputs build)
        let poison = match k.choice(32) {
            i @ 17..=31 => Some(POISONS[usize::from(i - 17)]),
            _ => None,
        };
        let noise_m = f.log_range(1e-7, 1e-3);
        let tolerance = f.log_range(1e-12, 1e-4);
        let rank_tolerance = f.log_range(1e-12, 1e-4);
        let time_budget_s = f.log_range(1e-4, 2e-2);
        let reference_lengths: Vec<f64> = (0..c).map(|_| f.range(0.05, 1.0)).collect();
        let mut spec = EstimateSpec {
            noise_m,
            method,
            reference_lengths_m: measured_reference.then_some(reference_lengths),
            max_iterations,
            time_budget_s: budget.then_some(time_budget_s),
            tolerance,
            rank_tolerance,
            reuse_jacobian,
            ..EstimateSpec::new(unknowns)
        };
        match poison {
            Some(Poison::NoiseNan) => spec.noise_m = f64::NAN,
            Some(Poison::ToleranceZero) => spec.tolerance = 0.0,
            Some(Poison::RankToleranceNegative) => spec.rank_tolerance = -1.0,
            Some(Poison::MaxIterationsZero) => spec.max_iterations = 0,
            Some(Poison::ReferenceLengthsTooMany) => {
                spec.reference_lengths_m = Some(vec![0.3; c + 1])
            }
            Some(Poison::ReferenceLengthNegative) if c > 0 => {
                spec.reference_lengths_m = Some(vec![-0.3; c])
            }
            Some(Poison::NoUnknowns) => spec.unknowns.clear(),
            Some(Poison::MinNan) => spec.unknowns[0].min = Some(f64::NAN),
            Some(Poison::InitialInfinite) => spec.unknowns[0].initial = f64::INFINITY,
            Some(Poison::PriorSigmaZero) => spec.unknowns[0].prior_sigma = Some(0.0),
            Some(Poison::TimeBudgetZero) => spec.time_budget_s = Some(0.0),
            _ => {}
        }
        let ticks = data
            .get(TICKS_START..)
            .unwrap_or_default()
            .chunks(TICK_BYTES)
            .take(MAX_TICKS)
            .map(|chunk| Tick::from_bytes(chunk, c))
            .collect::<Vec<_>>();
        // at least one tick, even for a short input (decoded from zeros)
        let ticks = if ticks.is_empty() {
            vec![Tick::from_bytes(&[], c)]
        } else {
            ticks
        };
        Self {
            forward,
            spec,
            // ReferenceLengthNegative on a robot without cables poisons nothing
            poison: poison.filter(|p| c > 0 || *p != Poison::ReferenceLengthNegative),
            ticks,
        }
    }

    /// Robot, known loads and forward settings, with the poisons of those applied.
    fn model(&self) -> Option<(Robot, Loads, SolverSettings)> {
        let robot = self.forward.robot()?;
        let mut loads = self.forward.loads(&robot, [0.0; 3]);
        let mut settings = self.forward.settings.clone();
        // the per-input work budget (see `ESTIMATOR_MAX_RK4_STEPS`)
        settings.integrator = match settings.integrator {
            Integrator::Rk4 { steps_per_section } => Integrator::Rk4 {
                steps_per_section: steps_per_section.min(ESTIMATOR_MAX_RK4_STEPS),
            },
            Integrator::Adaptive { tol, max_steps } => Integrator::Adaptive {
                tol,
                max_steps: max_steps.min(ESTIMATOR_MAX_ADAPTIVE_STEPS),
            },
        };
        match self.poison {
            Some(Poison::ForwardToleranceNan) => settings.tolerance = f64::NAN,
            Some(Poison::GravityInfinite) => loads.gravity_m_s2[1] = f64::INFINITY,
            Some(Poison::TensionsTooMany) => loads.tensions_n.resize(robot.cables().len() + 1, 0.0),
            Some(Poison::TensionNegative) => {
                loads.tensions_n.resize(robot.cables().len().max(1), 0.0);
                loads.tensions_n[0] = -1.0;
            }
            _ => {}
        }
        Some((robot, loads, settings))
    }
}

/// `estimator_tick` target on raw bytes (what the regression test replays).
pub fn estimator_tick(data: &[u8]) {
    check_estimator(&EstimatorInput::from_bytes(data));
}

/// Build the estimator, tick every sample, check the invariants (module docs).
///
/// The time-budget check was wall-clock: on a loaded machine (2 cores, load 11, the
/// fuzzer at `nice 19`) ticks were seen descheduled for 0.1 s, which is no overrun of
/// the estimator's; replayed, the same inputs ran in 1-16 ms. It now compares the
/// thread's CPU time ([`Clock`]), and an input whose tick still overran is run again
/// from scratch and fails only if it overruns in [`BUDGET_ATTEMPTS`] runs in a row;
/// every other check fails at once.
pub fn check_estimator(input: &EstimatorInput) {
    for attempt in 1..=BUDGET_ATTEMPTS {
        match check_once(input) {
            Ok(()) => return,
            Err(overrun) if attempt == BUDGET_ATTEMPTS => {
                panic!("{overrun} (overran in {BUDGET_ATTEMPTS} runs in a row)")
            }
            Err(_) => {}
        }
    }
}

/// The time the budget check compares: this thread's CPU time where Linux gives it
/// (`/proc/thread-self/schedstat`, nanoseconds on the CPU), else wall time. The
/// estimator stops on wall time, which is never less than CPU time, so its CPU time
/// past the budget is still at most one step; but a thread descheduled for 0.1 s
/// (seen at `nice 19` under load 11: ticks of 12 ms on replay took 0.12 s three runs
/// in a row) does not count as an overrun.
struct Clock {
    wall: std::time::Instant,
    cpu: Option<f64>,
}

impl Clock {
    fn thread_cpu_s() -> Option<f64> {
        let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
        let ns: f64 = text.split_whitespace().next()?.parse().ok()?;
        Some(ns * 1e-9)
    }
    fn start() -> Self {
        Self {
            cpu: Self::thread_cpu_s(),
            wall: std::time::Instant::now(),
        }
    }
    /// CPU seconds since `start` (wall seconds without the CPU clock).
    fn elapsed_s(&self) -> f64 {
        match (self.cpu, Self::thread_cpu_s()) {
            (Some(a), Some(b)) => b - a,
            _ => self.wall.elapsed().as_secs_f64(),
        }
    }
}

/// Runs of one input before a time-budget overrun counts (see [`check_estimator`]).
const BUDGET_ATTEMPTS: usize = 3;

/// One run of [`check_estimator`]: panics on every failed check but the time budget's,
/// which it returns.
fn check_once(input: &EstimatorInput) -> Result<(), String> {
    let Some((robot, loads, settings)) = input.model() else {
        // the robot itself was rejected (e.g. holes outside the disks): nothing to poison
        return Ok(());
    };
    let c = robot.cables().len();
    let t_new = Clock::start();
    let est = Estimator::new(robot, loads, settings, input.spec.clone());
    let t_new = t_new.elapsed_s();
    let mut est = match (est, input.poison) {
        (Ok(_), Some(p)) => panic!("poisoned input ({p:?}) built an estimator"),
        (Err(_), _) => return Ok(()),
        (Ok(est), None) => est,
    };
    let spec = &input.spec;
    let p = spec.unknowns.len();
    let lb: Vec<f64> = spec.unknowns.iter().map(UnknownSpec::lower).collect();
    let ub: Vec<f64> = spec.unknowns.iter().map(UnknownSpec::upper).collect();
    let has_prior = spec.unknowns.iter().any(|u| u.prior_sigma.is_some());
    assert_eq!(est.theta().len(), p, "one estimate per unknown");
    let mut iterations = 0;
    for (i, tick) in input.ticks.iter().enumerate() {
        if iterations >= INPUT_ITERATION_BUDGET {
            break;
        }
        let what = format!("tick {i} ({:?}, {tick:?})", spec.method);
        let t0 = Clock::start();
        let status = est.tick(&tick.changes, tick.sigma.as_deref());
        let elapsed = t0.elapsed_s();
        assert_eq!(status, est.status(), "{what}: tick and status() differ");
        if let Some(b) = spec.time_budget_s {
            if spec.method != Method::ArgminGaussNewton
                && elapsed > 2.0 * b + BUDGET_SOLVES * t_new + BUDGET_SLACK_S
            {
                return Err(format!(
                    "{what}: {status:?} after {elapsed} s with a time budget of {b} s \
                     (Estimator::new took {t_new} s)"
                ));
            }
        }
        // which cables the estimator must count as measured
        let valid: Vec<bool> = (0..c)
            .map(|j| {
                let m = tick.changes.get(j).copied().unwrap_or(f64::NAN);
                let s = tick
                    .sigma
                    .as_ref()
                    .and_then(|s| s.get(j).copied())
                    .unwrap_or(spec.noise_m);
                m.is_finite() && s.is_finite() && s > 0.0
            })
            .collect();
        if !has_prior && !valid.contains(&true) {
            assert_eq!(status, EstimateStatus::NoData, "{what}: nothing measured");
        }
        let theta = est.theta().to_vec();
        assert!(
            theta.iter().all(|v| v.is_finite()),
            "{what}: {status:?} left a non-finite estimate {theta:?}"
        );
        let e = est.estimate();
        iterations += e.iterations;
        assert_eq!(
            e.measured_m.len(),
            c,
            "{what}: measured_m {:?}",
            e.measured_m
        );
        for (j, ok) in valid.iter().enumerate() {
            let want = ok.then(|| tick.changes[j]);
            assert_eq!(
                e.measured_m[j], want,
                "{what}: measured_m[{j}] is not the input"
            );
        }
        if usable(status) || usable(e.status) {
            let ctx = || format!("{what}: {status:?} / {:?} but", e.status);
            let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
            assert!(finite(&e.values), "{} values {:?}", ctx(), e.values);
            assert!(
                finite(est.tip_position().as_slice()),
                "{} tip_position {:?}",
                ctx(),
                est.tip_position()
            );
            for pose in std::iter::once(&e.tip).chain(&e.section_tips) {
                assert!(
                    finite(pose.position.as_slice()) && finite(pose.rotation.as_slice()),
                    "{} pose {pose:?} (tip {:?})",
                    ctx(),
                    e.tip
                );
            }
            assert_eq!(e.predicted_m.len(), c, "{} predicted_m", ctx());
            assert!(
                finite(&e.predicted_m),
                "{} predicted_m {:?}",
                ctx(),
                e.predicted_m
            );
            for (j, r) in e.residual_m.iter().enumerate() {
                assert!(
                    r.is_none_or(f64::is_finite),
                    "{} residual_m[{j}] {r:?}",
                    ctx()
                );
            }
            if spec.method != Method::ArgminGaussNewton {
                for k in 0..p {
                    assert!(
                        lb[k] <= e.values[k] && e.values[k] <= ub[k],
                        "{} value {k} = {} outside [{}, {}]",
                        ctx(),
                        e.values[k],
                        lb[k],
                        ub[k]
                    );
                }
            }
        }
    }
    Ok(())
}

/// Statuses whose estimate the docs call usable (with care for the last two).
fn usable(s: EstimateStatus) -> bool {
    matches!(
        s,
        EstimateStatus::Converged
            | EstimateStatus::Unobservable
            | EstimateStatus::MaxIterations
            | EstimateStatus::TimeBudget
    )
}
