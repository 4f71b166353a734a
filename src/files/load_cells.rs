//! A synthetic load-cell recording of a tendon robot under a known, changing tip
//! load: the demo input of `cablesense estimate`/`track` on
//! `data/load_cells/tdcr_load_cells.toml` (`data/load_cells/tdcr_load_cells.csv` is
//! this module's output for [`Recipe::default`]; `tests/estimate_tendon_loads.rs`
//! regenerates it and compares).
//!
//! Row `k` of `n` (time `t = k dt`):
//! * readings: segment 1 pulls its first tendon by `pull_m sin(2 pi t / period)` and
//!   releases the other two by half that; segment 2 the same with a quarter-period
//!   lag and half the amplitude;
//! * the unknowns of the scene's `[estimate]` table, in order: component `i` is
//!   `load_amplitude[i] (1 - cos(2 pi t / period)) / 2` (so every load starts at 0);
//! * every driven tendon's load cell: the model's tension at those loads and readings
//!   ([`crate::estimate::TendonLoadEstimator::predict`]) plus Gaussian noise of the
//!   scene's `load_cell_sigma_n` (xorshift64 and Box-Muller from `seed`), clipped
//!   at 0 (a load cell does not read negative);
//! * every passive (measuring) cable's length change from the reference state: the
//!   model's plus Gaussian noise of the scene's `noise_m` (the same generator, drawn
//!   after the load cells; a scene without passive cables draws nothing).
//!
//! Columns: `t_s`, each tendon's reading column (unit `[readings] scale_m`),
//! `tension_<cable>` (N), `length_<cable>` per passive cable (unit `[readings]
//! length_scale_m`, default `scale_m`), and the true unknowns as `true_<name>`
//! (ignored by the readings parser, for comparison).

use crate::estimate::{EstimateError, TendonLoadEstimator};
use crate::scene::Scene;
use crate::ModelError;
use std::fmt::Write;

/// How the synthetic recording moves (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Recipe {
    /// Rows.
    pub rows: usize,
    /// Time step (s).
    pub dt_s: f64,
    /// Period of the pull and load cycles (s).
    pub period_s: f64,
    /// Pull amplitude of segment 1's first tendon (m).
    pub pull_m: f64,
    /// Peak value of each unknown (its unit: N, N m, kg), in the spec's order.
    pub load_amplitude: Vec<f64>,
    /// Noise seed.
    pub seed: u64,
}

impl Default for Recipe {
    /// The shipped demo: 40 rows at 0.05 s over a 2 s cycle, 0.4 mm pull, tip force
    /// up to (0.06, -0.04) N and a 20 g payload.
    fn default() -> Self {
        Self {
            rows: 40,
            dt_s: 0.05,
            period_s: 2.0,
            pull_m: 4e-4,
            load_amplitude: vec![0.06, -0.04, 0.02],
            seed: 2026,
        }
    }
}

/// Standard normal samples: xorshift64 (Marsaglia 2003) and Box-Muller.
struct Gaussian(u64);

impl Gaussian {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn sample(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// The load estimator of a scene with displacement-driven tendons and an
/// `[estimate]` table (robot, loads, numerics and spec from the scene).
pub fn estimator(scene: &Scene) -> Result<TendonLoadEstimator, EstimateError> {
    let spec = scene.estimate.clone().ok_or_else(|| ModelError::Invalid {
        field: "estimate".into(),
        why: "the scene has no [estimate] table: nothing to estimate".into(),
    })?;
    TendonLoadEstimator::new(
        scene.build_robot()?,
        scene.loads.clone(),
        scene.numerics.clone(),
        spec,
    )
}

/// A readings parser for `est`'s tendons, with the scene's `[readings]` table.
pub fn parser(scene: &Scene, est: &mut TendonLoadEstimator) -> super::readings::ReadingsParser {
    scene.readings_parser(est.estimator().model().tendons())
}

/// The recording of `recipe` on `scene` (which needs displacement-driven tendons and
/// an `[estimate]` table with as many unknowns as `recipe.load_amplitude`), as CSV.
pub fn synthesize(scene: &Scene, recipe: &Recipe) -> Result<String, EstimateError> {
    let mut model = estimator(scene)?;
    let spec = model.estimator().spec().clone();
    if spec.unknowns.len() != recipe.load_amplitude.len() {
        return Err(ModelError::Invalid {
            field: "load_amplitude".into(),
            why: format!(
                "{} amplitudes for {} unknowns",
                recipe.load_amplitude.len(),
                spec.unknowns.len()
            ),
        }
        .into());
    }
    let sigma = spec.load_cell_sigma_n;
    let names: Vec<String> = model.estimator().names().to_vec();
    let tendons: Vec<String> = model.tendons().to_vec();
    let columns: Vec<String> = model.estimator().model().tendons().columns().to_vec();
    let nt = tendons.len();
    let robot = model.estimator().model().tendons().workspace().robot();
    let passive: Vec<(usize, String)> = robot
        .cables()
        .iter()
        .enumerate()
        .filter(|(_, c)| c.actuation == crate::tendons::Actuation::Passive)
        .map(|(j, c)| (j, c.name.clone()))
        .collect();
    let units = scene.readings.clone().unwrap_or_default();
    let (scale, length_scale) = (units.scale_m, units.length_scale());
    let mut out = String::from("t_s");
    for c in &columns {
        write!(out, ",{c}").ok();
    }
    for t in &tendons {
        write!(out, ",tension_{t}").ok();
    }
    for (_, c) in &passive {
        write!(out, ",length_{c}").ok();
    }
    for n in &names {
        write!(out, ",true_{n}").ok();
    }
    out.push('\n');
    let mut noise = Gaussian(recipe.seed.max(1));
    for k in 0..recipe.rows {
        let t = k as f64 * recipe.dt_s;
        let phase = std::f64::consts::TAU * t / recipe.period_s;
        let mut q = vec![0.0; nt];
        // three tendons per segment, in scene order (the first of each pulls)
        for (seg, (amp, lag)) in [(recipe.pull_m, 0.0), (0.5 * recipe.pull_m, 0.25)]
            .iter()
            .enumerate()
        {
            let d = amp * (phase - std::f64::consts::TAU * lag).sin();
            for (i, qi) in q.iter_mut().enumerate().skip(3 * seg).take(3) {
                *qi = if i == 3 * seg { d } else { -0.5 * d };
            }
        }
        let theta: Vec<f64> = recipe
            .load_amplitude
            .iter()
            .map(|a| a * 0.5 * (1.0 - phase.cos()))
            .collect();
        let pred = model.predict(&theta, &q)?;
        if !pred.status.is_converged() {
            return Err(ModelError::Invalid {
                field: format!("row {k}"),
                why: format!("the forward model did not converge: {:?}", pred.status),
            }
            .into());
        }
        write!(out, "{t:.3}").ok();
        for v in &q {
            write!(out, ",{:.9e}", v / scale).ok();
        }
        for v in &pred.tensions_n {
            write!(out, ",{:.6}", (v + sigma * noise.sample()).max(0.0)).ok();
        }
        for (j, _) in &passive {
            let l = pred.length_changes_m[*j] + spec.noise_m * noise.sample();
            write!(out, ",{:.9e}", l / length_scale).ok();
        }
        for v in &theta {
            write!(out, ",{v:.9e}").ok();
        }
        out.push('\n');
    }
    Ok(out)
}
