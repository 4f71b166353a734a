//! The round-off floor of the scaled shooting residual: the smallest `tolerance` a
//! solve can meet reliably with the chosen integrator, robot and loads.
//!
//! Below the floor the residual of one state is not a function of the state alone:
//! evaluating it again (after the condensed coupling's next holes moved by an ulp, or
//! after an ulp-sized Newton step) changes it by about the floor, so a tolerance there
//! makes `Converged` a coin toss (the `forward_solve` fuzzer found a warm re-solve of a
//! converged point ending `Stalled` at residual 2.23e-12 against tolerance 2.14e-12,
//! and a continuation ending at 1.3e-12 against 1.0e-12). A solve therefore uses
//! `max(settings.tolerance, floor)` (docs/scene-format.md, `[numerics]`, `SolveReport::tolerance`).
//!
//! Two sources, both in the scaled units of the residual (forces over `EI/L^2`,
//! moments over `EI/L`, `EI` the smallest bending stiffness):
//! - integration: every step and disk event rounds the state, whose size is set by the
//!   load: `eps (N_steps + N_disks) (1 + I + sum_j T_j L^2 / EI)` with `I` the load
//!   intensity (`intensity.rs`) and `T_j L^2 / EI` the axial load of tensioned cable `j`
//!   on the rod (`N_steps` per interval for RK4; for the adaptive integrator the step
//!   count is estimated as `tol^(-1/5)` per section, its order-5 error law);
//! - cable coupling: the next-hole positions of a tensioned cable are resolved to
//!   [`LOCAL_TOL`] of `L` (condensed coupling's inner solve; with exact coupling they
//!   are shooting unknowns of size ~1 in units of `L`, a few ulps), and a hole error
//!   `e L` moves the boundary residual by `T L^2 / (EI h) e`, `h` the shortest chord of
//!   the cable's route: `LOCAL_TOL sum_j T_j L^2 / (EI h_j)`.
//!
//! The floor is [`FLOOR_SAFETY`] times their sum. Checked on 1500 random
//! `forward_solve` inputs (half at tolerance 1e-17, raised to the floor): every
//! converged solve stayed converged on warm re-solves. With a safety of 10 the floor
//! passed the default 1e-10 on the track demo near its fold (2.5e-10 at `T r L/EI` 7.9)
//! and the tracked branch stalled there; 3 keeps it at 7.5e-11. On the tdcr-modeling
//! scene it is 4.8e-11, on the fuzzer's repro 1.1e-11.
//!
//! This is an estimate made before the solve. The condensed coupling's settle noise
//! can exceed it near the end of the documented region (up to ~8e-10 on the track
//! demo's tension ramp, against an estimate of ~1.5e-10): a solve also raises its
//! tolerance to what two settled evaluations of the same unknowns disagree by
//! (`workspace/noise.rs`).

use super::pass::LOCAL_TOL;
use super::plan::{ParamSite, PlanCable};
use crate::loads::Loads;
use crate::robot::Robot;
use crate::settings::{Integrator, SolverSettings};

/// Margin of the floor over the estimated round-off: Newton can then always take a
/// residual that a re-evaluation pushed just above the floor back below it.
pub(crate) const FLOOR_SAFETY: f64 = 3.0;

/// Round-off floor (dimensionless, like `tolerance`) of the scaled shooting residual for
/// `loads` plus the load parameters `theta` at `params` on `robot` with `settings`;
/// `cables` the plan's cables of `robot` (their shortest chords).
/// `intensity` is [`super::intensity::load_intensity`] of the same loads.
pub(crate) fn residual_floor(
    robot: &Robot,
    loads: &Loads,
    settings: &SolverSettings,
    cables: &[PlanCable],
    params: &[ParamSite],
    theta: &[f64],
    intensity: f64,
) -> f64 {
    let ei = robot.min_bending_stiffness();
    let length = robot.length();
    let sections = robot.sections().len() as f64;
    let steps = match settings.integrator {
        Integrator::Rk4 { steps_per_section } => steps_per_section as f64 * sections,
        Integrator::Adaptive { tol, .. } => tol.powf(-0.2) * sections,
    };
    let disks = robot.guides().len() as f64;
    // tension of cable j with its load parameters (an upper bound, as in
    // `intensity.rs`); no allocation: this runs at every solve of a control loop
    let tension = |j: usize| -> f64 {
        let from_params: f64 = params
            .iter()
            .zip(theta)
            .filter(|(site, _)| **site == ParamSite::Tension { cable: j })
            .map(|(_, th)| th.abs())
            .sum();
        loads.tension(j).abs() + from_params
    };
    let (mut axial, mut coupling) = (0.0, 0.0);
    for (j, c) in cables.iter().enumerate() {
        let t = tension(j);
        if t == 0.0 {
            continue;
        }
        axial += t * length * length / ei;
        // shortest chord of the route: base plate to the first disk, then disk to disk
        let h = c.shortest_chord;
        if h.is_finite() && h > 0.0 {
            coupling += t * length * length / (ei * h);
        }
    }
    let rounding = f64::EPSILON * (steps + disks) * (1.0 + intensity + axial);
    let floor = FLOOR_SAFETY * (rounding + LOCAL_TOL * coupling);
    if floor.is_finite() {
        floor
    } else {
        f64::INFINITY
    }
}
