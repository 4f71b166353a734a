//! The reference branch of a stability map: a model tracked from zero load in fine
//! warm-started steps, with a jump guard.
//!
//! A step that fails, or moves the tip by more than 5 times the previous step's move
//! and more than 1 % of `L` (another equilibrium: warm starts with coarser steps do this
//! near `P L^2/EI` = 41 on the track demo), ends the branch: every later grid point has
//! no reference.
//!
//! The forward reference ([`reference`]) continues past the end of its single-shooting
//! track (warm single shooting fails where the base-to-tip map becomes ill-conditioned,
//! `P L^2/EI` ~ 50-100) with multiple shooting ([`extend_reach`]).

use super::sweep::{loads_at, Direction};
use super::ExperimentError;
use crate::ladder::{ForwardModel, Rung};
use crate::loads::Loads;
use crate::robot::Robot;
use crate::settings::SolverSettings;
use crate::statics::Start;
use nalgebra::Vector3;

/// Tip position (m) and cable lengths (m) at one grid point of a tracked branch.
pub type Tracked = (Vector3<f64>, Vec<f64>);

/// Track a model along `grid` from magnitude 0 in steps of at most `h`:
/// `solve(magnitude, start)` solves and returns whether it converged and the tip;
/// `lengths()` reads the cable lengths of the last solve. `None` from the first
/// grid point the branch does not reach (module docs).
pub fn track_with(
    grid: &[f64],
    h: f64,
    length: f64,
    solve: &mut dyn FnMut(f64, Start) -> Result<(bool, Vector3<f64>), ExperimentError>,
    lengths: &mut dyn FnMut() -> Vec<f64>,
) -> Result<Vec<Option<Tracked>>, ExperimentError> {
    let mut out = Vec::with_capacity(grid.len());
    let (mut ok, mut tip) = solve(0.0, Start::Cold)?;
    let mut moved: f64 = 0.0;
    let mut a = 0.0;
    for &g in grid {
        while ok && a < g - 1e-12 {
            a = (a + h).min(g);
            let (conv, t) = solve(a, Start::Warm)?;
            let d = (t - tip).norm();
            ok = conv && (moved == 0.0 || d < (5.0 * moved).max(0.01 * length));
            moved = d;
            tip = t;
        }
        out.push(ok.then(|| (tip, lengths())));
    }
    Ok(out)
}

/// [`track_with`] for a forward model along a load direction of `base`.
pub fn track(
    model: &mut dyn ForwardModel,
    robot: &Robot,
    base: &Loads,
    dir: Direction,
) -> Result<Vec<Option<Tracked>>, ExperimentError> {
    let nc = robot.cables().len();
    let cell = std::cell::RefCell::new(model);
    track_with(
        dir.grid(),
        dir.reference_step(),
        robot.length(),
        &mut |a, start| {
            let mut m = cell.borrow_mut();
            let rep = m.solve(&loads_at(robot, base, dir, a), start)?;
            Ok((rep.status.is_converged(), m.tip_position()))
        },
        &mut || {
            let mut len = vec![0.0; nc];
            cell.borrow().cable_lengths_into(&mut len);
            len
        },
    )
}

/// The reference's settings for tracking: [`Rung::reference`]'s without load
/// continuation (a failed warm step along the track then fails fast instead of
/// restarting from the unloaded rod) and without the branch guard (the reference must
/// not rely on what the map checks), at a tolerance of at least 1e-10.
pub fn tracking_settings() -> SolverSettings {
    let mut s = Rung::reference()
        .solver_settings()
        .cloned()
        .unwrap_or_default();
    s.continuation = false;
    s.branch_guard = false;
    // the reference's 1e-11 sits at the adaptive 1e-12 pass's noise floor on curled
    // shapes (a warm step stalled at residual 1.05e-11, TrL/EI = 5.7); 1e-10 moves the
    // tip by far less than the map's 5 % of L
    s.tolerance = s.tolerance.max(1e-10);
    s
}

/// Reference tips along a load direction (full Cosserat, adaptive 1e-12, [`track`],
/// then [`extend_reach`]).
pub fn reference(
    robot: &Robot,
    base: &Loads,
    dir: Direction,
) -> Result<Vec<Option<Vector3<f64>>>, ExperimentError> {
    let mut m = Rung::Rod(tracking_settings()).build(robot)?;
    let mut out: Vec<Option<Vector3<f64>>> = track(m.as_mut(), robot, base, dir)?
        .into_iter()
        .map(|p| p.map(|(t, _)| t))
        .collect();
    extend_reach(robot, base, dir, &mut out)?;
    Ok(out)
}

/// Smallest magnitude where the tracked branch may hand over to multiple shooting
/// (below it, a track that ends has met a fold, not ill-conditioning).
const REACH_FROM: f64 = 20.0;

/// Past the last grid point the single-shooting track reached (at least
/// [`REACH_FROM`]), continue the reference with the same settings plus load
/// continuation, i.e. multiple shooting above load intensity 20
/// (`statics::multiple`): a cold solve at that last point is accepted as the hand-over
/// only if its tip is within 1e-6 L of the tracked one (the same branch, reached by
/// another path), then warm steps of 2 % of the magnitude (at least the direction's
/// reference step) with the jump guard of [`track_with`].
pub fn extend_reach(
    robot: &Robot,
    base: &Loads,
    dir: Direction,
    out: &mut [Option<Vector3<f64>>],
) -> Result<(), ExperimentError> {
    let grid = dir.grid();
    let l = robot.length();
    let Some(last) = out.iter().rposition(Option::is_some) else {
        return Ok(());
    };
    if last + 1 >= grid.len() || grid[last] < REACH_FROM {
        return Ok(());
    }
    let mut s = tracking_settings();
    s.continuation = true;
    let mut m = Rung::Rod(s).build(robot)?;
    let rep = m.solve(&loads_at(robot, base, dir, grid[last]), Start::Cold)?;
    let mut tip = m.tip_position();
    let handed = out[last].is_some_and(|t| (t - tip).norm() <= 1e-6 * l);
    if !rep.status.is_converged() || !handed {
        return Ok(());
    }
    let (mut a, mut moved) = (grid[last], 0.0f64);
    for (i, &g) in grid.iter().enumerate().skip(last + 1) {
        let mut ok = true;
        while ok && a < g - 1e-12 {
            a = (a + (0.02 * a).max(dir.reference_step())).min(g);
            let rep = m.solve(&loads_at(robot, base, dir, a), Start::Warm)?;
            let t = m.tip_position();
            let d = (t - tip).norm();
            ok = rep.status.is_converged() && (moved == 0.0 || d < (5.0 * moved).max(0.01 * l));
            moved = d;
            tip = t;
        }
        if !ok {
            break;
        }
        out[i] = Some(tip);
    }
    Ok(())
}
