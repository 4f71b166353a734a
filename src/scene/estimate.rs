//! Serializable description of an estimation problem (the `[estimate]` table).

use crate::error::ModelError;
use crate::robot::Robot;
use serde::{Deserialize, Serialize};

/// What an unknown is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UnknownKind {
    /// World-frame force component (N) at the end of `section`.
    Force,
    /// World-frame torque component (N m) at the end of `section`.
    Torque,
    /// Payload mass (kg) at the end of `section`.
    Mass,
    /// Tension (N) of `cable`.
    Tension,
}

/// World axis of a force or torque component.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Axis {
    /// World x.
    X,
    /// World y.
    Y,
    /// World z.
    Z,
}

/// One unknown load, with optional bounds and Gaussian prior. Its value adds to
/// whatever the scene's `[loads]` already has there.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnknownSpec {
    /// Kind of load.
    pub kind: UnknownKind,
    /// Section at whose end a force/torque/mass acts.
    #[serde(default)]
    pub section: Option<usize>,
    /// Axis of a force/torque.
    #[serde(default)]
    pub axis: Option<Axis>,
    /// Cable of a tension.
    #[serde(default)]
    pub cable: Option<usize>,
    /// Name in reports (default e.g. `force_y@s0`).
    #[serde(default)]
    pub name: Option<String>,
    /// Lower bound (default: 0 for masses and tensions, unbounded otherwise).
    #[serde(default)]
    pub min: Option<f64>,
    /// Upper bound (default unbounded).
    #[serde(default)]
    pub max: Option<f64>,
    /// Prior mean (default 0 when `prior_sigma` is set).
    #[serde(default)]
    pub prior_mean: Option<f64>,
    /// Prior standard deviation (same unit as the unknown); none = no prior.
    #[serde(default)]
    pub prior_sigma: Option<f64>,
    /// Value the encoders were zeroed at (default 0, e.g. "no payload").
    #[serde(default)]
    pub reference: f64,
    /// Starting value of the first estimate (default 0).
    #[serde(default)]
    pub initial: f64,
}

impl UnknownSpec {
    /// An unknown of `kind` with every option at its default: no site, name, bounds or
    /// prior; reference and initial value 0.
    pub fn new(kind: UnknownKind) -> Self {
        Self {
            kind,
            section: None,
            axis: None,
            cable: None,
            name: None,
            min: None,
            max: None,
            prior_mean: None,
            prior_sigma: None,
            reference: 0.0,
            initial: 0.0,
        }
    }

    /// A world-frame force component at the end of `section`, otherwise defaults.
    pub fn force(section: usize, axis: Axis) -> Self {
        Self {
            section: Some(section),
            axis: Some(axis),
            ..Self::new(UnknownKind::Force)
        }
    }

    /// Display name.
    pub fn display_name(&self) -> String {
        if let Some(n) = &self.name {
            return n.clone();
        }
        let axis = match self.axis {
            Some(Axis::X) => "x",
            Some(Axis::Y) => "y",
            Some(Axis::Z) => "z",
            None => "",
        };
        match self.kind {
            UnknownKind::Force => format!("force_{axis}@s{}", self.section.unwrap_or(0)),
            UnknownKind::Torque => format!("torque_{axis}@s{}", self.section.unwrap_or(0)),
            UnknownKind::Mass => format!("mass@s{}", self.section.unwrap_or(0)),
            UnknownKind::Tension => format!("tension@c{}", self.cable.unwrap_or(0)),
        }
    }
    /// Lower bound with the physical default.
    pub fn lower(&self) -> f64 {
        self.min.unwrap_or(match self.kind {
            UnknownKind::Mass | UnknownKind::Tension => 0.0,
            _ => f64::NEG_INFINITY,
        })
    }
    /// Upper bound.
    pub fn upper(&self) -> f64 {
        self.max.unwrap_or(f64::INFINITY)
    }
}

/// Inverse method.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Gauss-Newton on the crate's workspace (bounds by projection).
    GaussNewton,
    /// Levenberg-Marquardt on the crate's workspace (bounds by projection). Default.
    #[default]
    LevenbergMarquardt,
    /// Each Gauss-Newton step a box-constrained QP solved by clarabel (exact bounds:
    /// a slack cable comes out at tension 0).
    Constrained,
    /// argmin's `GaussNewton` through its `Executor` (offline comparison; allocates,
    /// no bounds, fails on rank loss).
    ArgminGaussNewton,
}

/// The estimation problem.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstimateSpec {
    /// The unknowns (at least one).
    pub unknowns: Vec<UnknownSpec>,
    /// Default encoder noise standard deviation (m), per cable unless a sample gives
    /// its own. Default 1e-5 m.
    #[serde(default = "default_noise")]
    pub noise_m: f64,
    /// Method (default `levenberg_marquardt`).
    #[serde(default)]
    pub method: Method,
    /// Absolute cable lengths (m) measured when the encoders were zeroed. Default:
    /// the model's lengths with every unknown at its `reference` value.
    #[serde(default)]
    pub reference_lengths_m: Option<Vec<f64>>,
    /// Iteration limit per sample (default 20).
    #[serde(default = "default_iterations")]
    pub max_iterations: usize,
    /// Wall-time budget per sample (s); the best estimate so far is returned with
    /// status `time_budget`. Default none.
    #[serde(default)]
    pub time_budget_s: Option<f64>,
    /// Convergence: step below `tolerance * (1 + |theta|)` per unknown (default 1e-10).
    #[serde(default = "default_tol")]
    pub tolerance: f64,
    /// Relative eigenvalue of the (scaled) Fisher information below which a
    /// direction is reported unobservable (default 1e-8).
    #[serde(default = "default_rank_tol")]
    pub rank_tolerance: f64,
    /// Reuse the exact length sensitivities across iterations and samples while the
    /// cost drops as predicted (default true). Exact fixed point for consistent
    /// measurements; with inconsistent (noisy, redundant) ones the bias is second
    /// order. `false` recomputes them every iteration.
    #[serde(default = "default_true")]
    pub reuse_jacobian: bool,
    /// Largest RMS of the weighted cable residuals `r_j / sigma_j` a `converged`
    /// estimate may leave (default 50): beyond it the stationary point does not
    /// explain the data (a local minimum, or data the model cannot produce) and the
    /// status is `stalled`. Raise it for data with known model mismatch.
    #[serde(default = "default_max_rms_sigma")]
    pub max_rms_sigma: f64,
    /// RMS of the weighted cable residuals `r_j / sigma_j` above which an estimate's
    /// [`crate::estimate::Fit`] is `poor` (default 3): the data are not explained to
    /// within the stated noise, so the model, its parameters or `noise_m` are wrong,
    /// whatever the status says. With a correct model and noise the RMS is about
    /// `sqrt((cables - rank) / cables)` (0.58 for three cables and two unknowns); 3
    /// is a chi-square tail probability below 1e-6 for one redundant cable of three.
    #[serde(default = "default_poor_fit_rms_sigma")]
    pub poor_fit_rms_sigma: f64,
    /// Default load-cell noise standard deviation (N) of a measured tendon tension
    /// (`tension_<cable>` columns of a readings row, tendon scenes only), unless a
    /// sample gives its own. Default 0.01 N (a few-kilogram load cell with a 24-bit
    /// amplifier resolves about 1 g).
    #[serde(default = "default_load_cell_sigma")]
    pub load_cell_sigma_n: f64,
}

fn default_noise() -> f64 {
    1e-5
}
fn default_iterations() -> usize {
    20
}
fn default_tol() -> f64 {
    1e-10
}
fn default_rank_tol() -> f64 {
    1e-8
}
fn default_max_rms_sigma() -> f64 {
    50.0
}
fn default_poor_fit_rms_sigma() -> f64 {
    3.0
}
fn default_load_cell_sigma() -> f64 {
    1e-2
}
fn default_true() -> bool {
    true
}

impl EstimateSpec {
    /// A spec with these unknowns and every other field at its default.
    pub fn new(unknowns: Vec<UnknownSpec>) -> Self {
        Self {
            unknowns,
            noise_m: default_noise(),
            method: Method::default(),
            reference_lengths_m: None,
            max_iterations: default_iterations(),
            time_budget_s: None,
            tolerance: default_tol(),
            rank_tolerance: default_rank_tol(),
            reuse_jacobian: true,
            max_rms_sigma: default_max_rms_sigma(),
            poor_fit_rms_sigma: default_poor_fit_rms_sigma(),
            load_cell_sigma_n: default_load_cell_sigma(),
        }
    }

    /// Check against the robot.
    pub fn validate(&self, robot: &Robot) -> Result<(), ModelError> {
        if self.unknowns.is_empty() {
            return Err(ModelError::Invalid {
                field: "estimate.unknowns".into(),
                why: "at least one unknown".into(),
            });
        }
        ModelError::positive("estimate.noise_m", self.noise_m)?;
        ModelError::positive("estimate.max_rms_sigma", self.max_rms_sigma)?;
        ModelError::positive("estimate.poor_fit_rms_sigma", self.poor_fit_rms_sigma)?;
        ModelError::positive("estimate.load_cell_sigma_n", self.load_cell_sigma_n)?;
        if self.max_iterations == 0 || self.max_iterations > 10_000 {
            return Err(ModelError::OutOfRange {
                field: "estimate.max_iterations".into(),
                value: self.max_iterations as f64,
                why: "between 1 and 10000".into(),
            });
        }
        ModelError::positive("estimate.tolerance", self.tolerance)?;
        ModelError::positive("estimate.rank_tolerance", self.rank_tolerance)?;
        if let Some(t) = self.time_budget_s {
            ModelError::positive("estimate.time_budget_s", t)?;
        }
        if let Some(r) = &self.reference_lengths_m {
            if r.len() != robot.cables().len() {
                return Err(ModelError::Invalid {
                    field: "estimate.reference_lengths_m".into(),
                    why: format!("{} values for {} cables", r.len(), robot.cables().len()),
                });
            }
            for (j, v) in r.iter().enumerate() {
                ModelError::positive(format!("estimate.reference_lengths_m[{j}]"), *v)?;
            }
        }
        for (i, u) in self.unknowns.iter().enumerate() {
            let f = format!("estimate.unknowns[{i}]");
            match u.kind {
                UnknownKind::Tension => {
                    let c = u.cable.ok_or_else(|| ModelError::Invalid {
                        field: format!("{f}.cable"),
                        why: "a tension unknown needs `cable`".into(),
                    })?;
                    if c >= robot.cables().len() {
                        return Err(ModelError::BadIndex {
                            field: format!("{f}.cable"),
                            index: c,
                            count: robot.cables().len(),
                        });
                    }
                }
                kind => {
                    let s = u.section.ok_or_else(|| ModelError::Invalid {
                        field: format!("{f}.section"),
                        why: "a force/torque/mass unknown needs `section`".into(),
                    })?;
                    if s >= robot.sections().len() {
                        return Err(ModelError::BadIndex {
                            field: format!("{f}.section"),
                            index: s,
                            count: robot.sections().len(),
                        });
                    }
                    if kind != UnknownKind::Mass && u.axis.is_none() {
                        return Err(ModelError::Invalid {
                            field: format!("{f}.axis"),
                            why: "x, y or z".into(),
                        });
                    }
                }
            }
            for (name, v) in [("min", u.min), ("max", u.max), ("prior_mean", u.prior_mean)] {
                if let Some(v) = v {
                    ModelError::finite(format!("{f}.{name}"), v)?;
                }
            }
            if let Some(s) = u.prior_sigma {
                ModelError::positive(format!("{f}.prior_sigma"), s)?;
            }
            ModelError::finite(format!("{f}.reference"), u.reference)?;
            ModelError::finite(format!("{f}.initial"), u.initial)?;
            if u.lower() > u.upper() {
                return Err(ModelError::OutOfRange {
                    field: format!("{f}.min"),
                    value: u.lower(),
                    why: format!("exceeds max = {}", u.upper()),
                });
            }
            // one load twice: the data see only the sum of the two, so neither can be
            // estimated (and reports keyed by name would show one of them)
            let site = |u: &UnknownSpec| match u.kind {
                UnknownKind::Tension => (u.kind, u.cable, None, None),
                UnknownKind::Mass => (u.kind, None, u.section, None),
                _ => (u.kind, None, u.section, u.axis),
            };
            if let Some(j) = self.unknowns[..i].iter().position(|v| site(v) == site(u)) {
                return Err(ModelError::Invalid {
                    field: f.clone(),
                    why: format!(
                        "the same load as estimate.unknowns[{j}] ({}): each load can be an unknown once",
                        self.unknowns[j].display_name()
                    ),
                });
            }
            let name = u.display_name();
            if let Some(j) = self.unknowns[..i]
                .iter()
                .position(|v| v.display_name() == name)
            {
                return Err(ModelError::Invalid {
                    field: format!("{f}.name"),
                    why: format!(
                        "`{name}` is also the name of estimate.unknowns[{j}]: names must be unique"
                    ),
                });
            }
        }
        Ok(())
    }
}
