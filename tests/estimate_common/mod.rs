//! Helpers shared by the estimator tests (`tests/estimate_*.rs`): robot builders
//! (copied from `tests/common`, owned by another engineer), the forward "truth"
//! that turns loads into measured cable-length changes, a tolerance helper and a
//! tiny seeded Gaussian generator.
//!
//! The truth is computed only with the public forward API (`cablesense::solve`),
//! with the unknowns applied to a [`Loads`] value here, independently of how the
//! estimator applies them (its `ParamSite`s inside the workspace).
#![allow(dead_code)]

use cablesense::estimate::{Axis, EstimateSpec, Estimator, Method, UnknownKind, UnknownSpec};
use cablesense::nalgebra::Vector3;
use cablesense::{Loads, PointLoad, Robot, SolverSettings};
use std::f64::consts::PI;

/// Every inverse method of the design card.
pub const METHODS: [Method; 4] = [
    Method::GaussNewton,
    Method::LevenbergMarquardt,
    Method::Constrained,
    Method::ArgminGaussNewton,
];

// ---------------------------------------------------------------------------
// Tolerance helper (same contract as `tests/common::Tol`).

/// `|got - want| <= abs + rel * |want|`; the message names what and the index.
#[derive(Clone, Copy, Debug)]
pub struct Tol {
    pub abs: f64,
    pub rel: f64,
}

impl Tol {
    pub fn abs(abs: f64) -> Self {
        Self { abs, rel: 0.0 }
    }
    pub fn both(abs: f64, rel: f64) -> Self {
        Self { abs, rel }
    }
    /// True when `got` is finite and within tolerance of `want`.
    pub fn ok(&self, got: f64, want: f64) -> bool {
        got.is_finite() && (got - want).abs() <= self.abs + self.rel * want.abs()
    }
    /// `None` when every entry is within tolerance, else a message naming the first
    /// offending index (for `prop_assert!` and plain `assert!`).
    pub fn err(&self, what: &str, got: &[f64], want: &[f64]) -> Option<String> {
        if got.len() != want.len() {
            return Some(format!("{what}: {} values, want {}", got.len(), want.len()));
        }
        (0..got.len()).find(|&i| !self.ok(got[i], want[i])).map(|i| {
            format!(
                "{what}[{i}]: got {:e}, want {:e}, |diff| = {:e} > {:e} (all: got {got:?}, want {want:?})",
                got[i],
                want[i],
                (got[i] - want[i]).abs(),
                self.abs + self.rel * want[i].abs()
            )
        })
    }
    #[track_caller]
    pub fn check(&self, what: &str, got: &[f64], want: &[f64]) {
        if let Some(m) = self.err(what, got, want) {
            panic!("{m}");
        }
    }
    #[track_caller]
    pub fn check3(&self, what: &str, got: &Vector3<f64>, want: &Vector3<f64>) {
        self.check(what, got.as_slice(), want.as_slice());
    }
}

// ---------------------------------------------------------------------------
// Robots: the builders of tests/common/mod.rs, shared rather than copied (every
// crate that declares `mod estimate_common` declares `mod common` beside it).

pub use crate::common::{five_guide_robot, horizontal, two_section_robot_first_at};

/// [`five_guide_robot`] clamped horizontally: backbone along world +x, so gravity
/// `[0, 0, -9.81]` acts across the rod.
pub fn horizontal_five_guide_robot() -> Robot {
    five_guide_robot().with_base(horizontal(), Vector3::zeros())
}

/// Two sections (0.2 m each, 1.56 mm then 1.2 mm) with four guides each at
/// 0.045, 0.095, 0.145, 0.195 m from the section start; cables 0-2 end on section
/// 0, 3-5 on section 1. Base along world +z.
pub fn two_section_robot() -> Robot {
    two_section_robot_first_at(0.045)
}

// ---------------------------------------------------------------------------
// Unknowns.

fn unknown(kind: UnknownKind) -> UnknownSpec {
    UnknownSpec::new(kind)
}

/// World-frame force component at the end of `section`.
pub fn force(section: usize, axis: Axis) -> UnknownSpec {
    UnknownSpec {
        section: Some(section),
        axis: Some(axis),
        ..unknown(UnknownKind::Force)
    }
}

/// World-frame torque component at the end of `section`.
pub fn torque(section: usize, axis: Axis) -> UnknownSpec {
    UnknownSpec {
        section: Some(section),
        axis: Some(axis),
        ..unknown(UnknownKind::Torque)
    }
}

/// Tension of `cable` (default bound `>= 0`).
pub fn tension(cable: usize) -> UnknownSpec {
    UnknownSpec {
        cable: Some(cable),
        ..unknown(UnknownKind::Tension)
    }
}

// ---------------------------------------------------------------------------
// Problems: robot, known loads, settings, unknowns.

#[derive(Clone, Debug)]
pub struct Problem {
    pub robot: Robot,
    pub loads: Loads,
    pub settings: SolverSettings,
    pub unknowns: Vec<UnknownSpec>,
}

impl Problem {
    /// The known loads with the unknowns set to `theta`, applied the documented way:
    /// force/torque components are world-frame and add to the world-frame point load
    /// at the section end (created when absent), masses add to its payload, tensions
    /// add to the cable's tension.
    pub fn loads_at(&self, theta: &[f64]) -> Loads {
        assert_eq!(theta.len(), self.unknowns.len());
        let mut loads = self.loads.clone();
        for (u, &v) in self.unknowns.iter().zip(theta) {
            match u.kind {
                UnknownKind::Tension => {
                    let j = u.cable.unwrap();
                    if loads.tensions_n.len() <= j {
                        loads.tensions_n.resize(j + 1, 0.0);
                    }
                    loads.tensions_n[j] += v;
                }
                kind => {
                    let s = u.section.unwrap();
                    let i = match loads.point.iter().position(|p| p.section == s) {
                        Some(i) => i,
                        None => {
                            loads.point.push(PointLoad {
                                section: s,
                                ..Default::default()
                            });
                            loads.point.len() - 1
                        }
                    };
                    let axis = match u.axis {
                        Some(Axis::X) => 0,
                        Some(Axis::Y) => 1,
                        Some(Axis::Z) => 2,
                        None => usize::MAX,
                    };
                    match kind {
                        UnknownKind::Force => loads.point[i].force_n[axis] += v,
                        UnknownKind::Torque => loads.point[i].torque_nm[axis] += v,
                        _ => loads.point[i].mass_kg += v,
                    }
                }
            }
        }
        loads
    }

    /// Forward solve at `theta` (cold start); `None` when it does not converge.
    pub fn forward(&self, theta: &[f64]) -> Option<cablesense::Solution> {
        let sol = cablesense::solve(&self.robot, &self.loads_at(theta), &self.settings)
            .expect("valid loads");
        sol.report.status.is_converged().then_some(sol)
    }

    /// Absolute cable lengths with every unknown at its `reference` value.
    pub fn reference_lengths(&self) -> Vec<f64> {
        let r: Vec<f64> = self.unknowns.iter().map(|u| u.reference).collect();
        lengths(&self.forward(&r).expect("reference solve converges"))
    }

    /// Measured changes `length(theta) - reference` and the true solution; `None`
    /// when the forward model does not converge at `theta`.
    pub fn measure(
        &self,
        theta: &[f64],
        reference: &[f64],
    ) -> Option<(Vec<f64>, cablesense::Solution)> {
        let sol = self.forward(theta)?;
        let changes = lengths(&sol)
            .iter()
            .zip(reference)
            .map(|(l, r)| l - r)
            .collect();
        Some((changes, sol))
    }

    pub fn spec(&self, method: Method) -> EstimateSpec {
        EstimateSpec {
            method,
            ..EstimateSpec::new(self.unknowns.clone())
        }
    }

    pub fn estimator(&self, spec: EstimateSpec) -> Estimator {
        Estimator::new(
            self.robot.clone(),
            self.loads.clone(),
            self.settings.clone(),
            spec,
        )
        .expect("estimator builds")
    }

    /// Cable-length sensitivities `d(change_j)/d(theta_k)` (row-major `c x p`) by
    /// central finite differences of the forward model with step `h_k` (an
    /// independent check of the estimator's exact implicit sensitivities).
    pub fn fd_jacobian(&self, theta: &[f64], h: &[f64]) -> Vec<f64> {
        let p = theta.len();
        let c = self.robot.cables().len();
        let mut g = vec![0.0; c * p];
        for k in 0..p {
            let mut tp = theta.to_vec();
            let mut tm = theta.to_vec();
            tp[k] += h[k];
            tm[k] -= h[k];
            let lp = lengths(&self.forward(&tp).expect("fd solve +"));
            let lm = lengths(&self.forward(&tm).expect("fd solve -"));
            for j in 0..c {
                g[j * p + k] = (lp[j] - lm[j]) / (2.0 * h[k]);
            }
        }
        g
    }
}

pub fn lengths(sol: &cablesense::Solution) -> Vec<f64> {
    sol.cables.iter().map(|c| c.total_m).collect()
}

/// (a) One section, five guides, three passive cables, clamped horizontally along
/// world +x with gravity -z across the rod; unknown tip force y and z (both lateral
/// to the backbone, hence both observable: they bend the rod in two planes that the
/// three cables at 120 degrees resolve).
pub fn problem_a() -> Problem {
    Problem {
        robot: horizontal_five_guide_robot(),
        loads: Loads::default(),
        settings: SolverSettings::default(),
        unknowns: vec![force(0, Axis::Y), force(0, Axis::Z)],
    }
}

/// (b) Two sections, vertical (gravity along the backbone), six cables; unknown
/// lateral forces x and y at the end of both sections.
pub fn problem_b() -> Problem {
    Problem {
        robot: two_section_robot(),
        loads: Loads::default(),
        // Forward tolerance 1e-12, not the default 1e-10: the section-0 forces are
        // weakly observable here, and a forward residual of 1e-10 moves the lengths
        // enough to shift the estimate by ~1e-8 N and the tip by ~1.3e-9 m (proptest
        // regression in proptest-regressions/estimate_roundtrip.txt), over the 1e-9 m
        // the round trip asserts.
        settings: SolverSettings {
            tolerance: 1e-12,
            ..SolverSettings::default()
        },
        unknowns: vec![
            force(0, Axis::X),
            force(0, Axis::Y),
            force(1, Axis::X),
            force(1, Axis::Y),
        ],
    }
}

/// (c) One section, vertical, five guides; unknown tensions of cables 0 and 1
/// (bounds `>= 0`, the default), cable 2 passive; all three cables measured.
pub fn problem_c() -> Problem {
    Problem {
        robot: five_guide_robot(),
        loads: Loads::default(),
        settings: SolverSettings::default(),
        unknowns: vec![tension(0), tension(1)],
    }
}

// ---------------------------------------------------------------------------
// Seeded Gaussian noise: xorshift64* and Box-Muller.

pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }
    /// xorshift64* (Vigna 2016), 53 high bits to a uniform in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        let r = x.wrapping_mul(0x2545_F491_4F6C_DD1D);
        ((r >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    /// Standard normal by Box-Muller (one of the pair).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
    }
}
