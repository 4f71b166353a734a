//! Bodies of the fuzz targets, shared by `fuzz/fuzz_targets/*.rs` (through
//! `#[path = "shared.rs"] mod shared;`) and by the main crate's
//! `tests/fuzz_regressions.rs`, which replays `fuzz/seeds/` and `fuzz/regressions/`
//! through exactly these checks under an ordinary `cargo test`.
//!
//! Only `cablesense` and its own dependencies (`serde_json`) are used here, so the file
//! compiles in both crates. That is also why [`ForwardInput`] is decoded from bytes by
//! a fixed layout ([`ForwardInput::from_bytes`]) rather than by `#[derive(Arbitrary)]`:
//! the main crate does not depend on `arbitrary`, and a replayed crasher must decode to
//! the same typed input in both places. The fuzz target's `Arbitrary` impl delegates
//! to `from_bytes`.
//!
//! What counts as a bug: a panic (including the assertions below), a hang, or a
//! `Converged` status whose tip, samples or cable lengths are not finite. Rejected
//! input (`Err`) and non-convergence statuses are fine.

// Each fuzz target includes this whole file but calls only its own entry point.
#![allow(dead_code)]

use cablesense::robot::{BaseSpec, CableSpec, GuideSpec, HolesSpec, SectionSpec};
use cablesense::{
    CableCoupling, CrossSection, Frame, GuideMass, Integrator, Loads, Material, PointLoad, Robot,
    RobotSpec, RodModel, Scene, SolveStatus, SolverSettings, Start, Workspace,
};

/// Solves are skipped for scenes larger than this (parsing and validation still run):
/// the fuzzer looks for crashes, not for slow but legitimate big robots.
const MAX_SECTIONS: usize = 6;
/// See [`MAX_SECTIONS`].
const MAX_GUIDES: usize = 24;
/// See [`MAX_SECTIONS`].
const MAX_CABLES: usize = 12;
/// Budget caps applied to a scene's numerics before solving.
const MAX_ITERATIONS: usize = 6;
/// See [`MAX_ITERATIONS`].
const MAX_CONTINUATION_STEPS: usize = 4;
/// See [`MAX_ITERATIONS`].
const MAX_RK4_STEPS: usize = 32;
/// See [`MAX_ITERATIONS`].
const MAX_ADAPTIVE_STEPS: usize = 1500;
/// See [`MAX_ITERATIONS`].
const MIN_ADAPTIVE_TOL: f64 = 1e-8;

/// `scene_toml` target: UTF-8 text -> TOML scene -> validate -> small-budget solve.
pub fn scene_toml(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(scene) = Scene::from_toml_str(text) else {
        return;
    };
    if scene.validate().is_err() {
        return;
    }
    // A valid scene written by the library must read back as the same scene.
    let written = scene.to_toml_string();
    let back = Scene::from_toml_str(&written)
        .unwrap_or_else(|e| panic!("to_toml_string output does not parse: {e}\n{written}"));
    assert_eq!(back, scene, "TOML round trip changed the scene:\n{written}");
    check_scene(&scene);
}

/// `scene_json` target: UTF-8 text -> JSON scene -> validate -> small-budget solve.
pub fn scene_json(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(scene) = Scene::from_json_str(text) else {
        return;
    };
    if scene.validate().is_err() {
        return;
    }
    let written = serde_json::to_string(&scene).expect("a valid scene serializes to JSON");
    let back = Scene::from_json_str(&written)
        .unwrap_or_else(|e| panic!("JSON output does not parse: {e}\n{written}"));
    assert_eq!(back, scene, "JSON round trip changed the scene:\n{written}");
    check_scene(&scene);
}

/// `forward_solve` target on raw bytes (what the regression test replays).
pub fn forward_solve(data: &[u8]) {
    check_forward(&ForwardInput::from_solve_bytes(data));
}

/// A validated scene: build the robot, cap the budget, solve cold, check the result.
fn check_scene(scene: &Scene) {
    let robot = scene
        .build_robot()
        .expect("Scene::validate passed, so build_robot must succeed");
    if robot.sections().len() > MAX_SECTIONS
        || robot.guides().len() > MAX_GUIDES
        || robot.cables().len() > MAX_CABLES
    {
        return;
    }
    let settings = capped(&scene.numerics);
    let Ok(mut ws) = Workspace::new(robot, scene.loads.clone(), settings) else {
        return;
    };
    ws.solve(Start::Cold);
    check_workspace(&mut ws, "scene cold");
}

/// The scene's numerics with iteration and step budgets capped so one run is fast.
fn capped(s: &SolverSettings) -> SolverSettings {
    let integrator = match s.integrator {
        Integrator::Rk4 { steps_per_section } => Integrator::Rk4 {
            steps_per_section: steps_per_section.min(MAX_RK4_STEPS),
        },
        Integrator::Adaptive { tol, max_steps } => Integrator::Adaptive {
            tol: tol.max(MIN_ADAPTIVE_TOL),
            max_steps: max_steps.min(MAX_ADAPTIVE_STEPS),
        },
    };
    SolverSettings {
        integrator,
        max_iterations: s.max_iterations.min(MAX_ITERATIONS),
        max_continuation_steps: s.max_continuation_steps.min(MAX_CONTINUATION_STEPS),
        ..s.clone()
    }
}

/// The invariants of a solve that reported `Converged`: everything finite, residual
/// within tolerance, and the in-place and allocating outputs agree.
fn check_workspace(ws: &mut Workspace, what: &str) {
    let report = *ws.report();
    let n_cables = ws.robot().cables().len();
    let mut lengths = vec![f64::NAN; n_cables];
    ws.cable_lengths_into(&mut lengths);
    let tip = ws.tip_position();
    let sol = ws.solution();
    // the tolerance a solve uses is the settings' raised to the residual's round-off
    // floor, never lower, and never anything but that (docs/scene-format.md, `[numerics]`), except
    // under the condensed coupling, whose measured settle noise may raise it further
    // (`statics/workspace/noise.rs`)
    let floor = ws.residual_floor();
    let base = ws.settings().tolerance.max(floor);
    let condensed = ws.settings().cable_coupling == CableCoupling::Condensed;
    assert!(
        report.tolerance.to_bits() == base.to_bits() || (condensed && report.tolerance > base),
        "{what}: report {report:?}, settings {}, floor {floor}",
        ws.settings().tolerance
    );
    let tolerance = report.tolerance;
    // a status is a function of the state handed back: converged exactly when its
    // residual is within the solve's tolerance, unless the branch guard gave a verdict
    // (`Unstable`, or a checked continuation that did not reach full load)
    // (the checked continuation runs above load intensity 3, `CERTIFY_INTENSITY`)
    // (an infinite floor, loads near the range of f64, certifies nothing: `NonFinite`)
    let verdict = report.status == SolveStatus::Unstable
        || (ws.settings().branch_guard && ws.load_intensity() > 3.0)
        || (tolerance == f64::INFINITY && report.status == SolveStatus::NonFinite);
    assert!(
        report.status.is_converged() || report.residual > tolerance || verdict,
        "{what}: {report:?} although residual <= tolerance {tolerance}"
    );
    if !report.status.is_converged() {
        return;
    }
    let ctx = || format!("{what}: Converged but {report:?}");
    assert!(
        report.residual <= tolerance,
        "{}: residual {} > tolerance {tolerance}",
        ctx(),
        report.residual
    );
    assert!(
        tip.iter().all(|x| x.is_finite()),
        "{}: tip_position {tip:?}",
        ctx()
    );
    assert!(
        lengths.iter().all(|x| x.is_finite()),
        "{}: cable_lengths_into {lengths:?}",
        ctx()
    );
    let t = sol.tip();
    assert!(
        t.position.iter().all(|x| x.is_finite()) && t.rotation.iter().all(|x| x.is_finite()),
        "{}: solution tip {t:?}",
        ctx()
    );
    assert_eq!(sol.cables.len(), n_cables, "{}", ctx());
    for c in &sol.cables {
        assert!(
            c.total_m.is_finite() && c.segments_m.iter().all(|x| x.is_finite()),
            "{}: cable {c:?}",
            ctx()
        );
    }
    for s in &sol.samples {
        let finite = s.s.is_finite()
            && s.r.iter().all(|x| x.is_finite())
            && s.rotation.iter().all(|x| x.is_finite())
            && s.n.iter().all(|x| x.is_finite())
            && s.m.iter().all(|x| x.is_finite());
        assert!(finite, "{}: sample {s:?}", ctx());
    }
    assert!(
        sol.base_force.iter().all(|x| x.is_finite())
            && sol.base_moment.iter().all(|x| x.is_finite()),
        "{}: base wrench {:?} {:?}",
        ctx(),
        sol.base_force,
        sol.base_moment
    );
}

/// Newton iteration limit of `forward_solve` inputs (1..=this).
const FORWARD_MAX_ITERATIONS: u8 = 5;
/// Continuation-step limit of `forward_solve` inputs (0..=this).
const FORWARD_MAX_CONTINUATION_STEPS: u8 = 3;

/// Bytes consumed by [`ForwardInput::from_bytes`]; shorter input is zero-padded,
/// longer input ignored past this length.
pub const FORWARD_INPUT_BYTES: usize = 2 * 48 + 8;

/// Bytes of a `forward_solve` input: a [`ForwardInput`], then one byte choosing the
/// cable coupling (`numerics.cable_coupling`: condensed, arc, exact; byte mod 3) and
/// the arc coupling's rounds (`numerics.arc_rounds`: 3, 1 or 2 by byte / 3 mod 3).
/// The byte is past [`FORWARD_INPUT_BYTES`], so the inputs of the other targets that embed a
/// `ForwardInput` keep their layout, and the corpora written before it (104 bytes,
/// the extra byte read as zero) replay with the default coupling, as they ran.
pub const FORWARD_SOLVE_BYTES: usize = FORWARD_INPUT_BYTES + 1;

/// Typed input of the `forward_solve` target: every number already mapped into a
/// physically bounded range, so an `Err` from the library means a real rejection
/// rather than garbage in.
#[derive(Clone, Debug)]
pub struct ForwardInput {
    /// Sections (1 or 2), each: length (m), rod diameter (m), guide count (0..=5).
    pub sections: Vec<(f64, f64, usize)>,
    /// Young's modulus (Pa), Poisson's ratio, density (kg/m^3).
    pub material: (f64, f64, f64),
    /// Guide disk mass (kg) and hole radius (m).
    pub guide: (f64, f64),
    /// Precurvature of every section (1/m).
    pub precurvature: [f64; 3],
    /// Base rotation axis and angle (deg).
    pub base: ([f64; 3], f64),
    /// Gravity (m/s^2).
    pub gravity: [f64; 3],
    /// Tip force (N), torque (N m), frame, payload (kg).
    pub tip: ([f64; 3], [f64; 3], Frame, f64),
    /// Cable tensions (N), three cables per section; values <= 0 become passive.
    pub tensions: [f64; 6],
    /// Solver settings.
    pub settings: SolverSettings,
    /// Tip-force change (N) for a second, warm-started solve.
    pub perturbation: [f64; 3],
}

/// Reads the fixed layout: `u16` little-endian fractions, then `u8` choices (also
/// used by `shared_estimate.rs`). Past the end of the data it reads zeros.
pub(crate) struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    /// A reader of `data` starting at byte `pos`.
    pub(crate) fn new(data: &'a [u8], pos: usize) -> Self {
        Self { data, pos }
    }
    pub(crate) fn byte(&mut self) -> u8 {
        let b = self.data.get(self.pos).copied().unwrap_or(0);
        self.pos += 1;
        b
    }
    /// A fraction in [0, 1].
    pub(crate) fn unit(&mut self) -> f64 {
        let lo = self.byte();
        let hi = self.byte();
        f64::from(u16::from_le_bytes([lo, hi])) / f64::from(u16::MAX)
    }
    pub(crate) fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    pub(crate) fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.unit()).exp()
    }
    pub(crate) fn vec3(&mut self, half: f64) -> [f64; 3] {
        [0, 1, 2].map(|_| self.range(-half, half))
    }
    pub(crate) fn choice(&mut self, n: u8) -> u8 {
        self.byte() % n
    }
}

impl ForwardInput {
    /// Decode a `forward_solve` input ([`FORWARD_SOLVE_BYTES`]): [`Self::from_bytes`]
    /// and the cable coupling.
    pub fn from_solve_bytes(data: &[u8]) -> Self {
        let mut input = Self::from_bytes(data);
        let b = Reader::new(data, FORWARD_INPUT_BYTES).byte();
        input.settings.cable_coupling = match b % 3 {
            0 => CableCoupling::Condensed,
            1 => CableCoupling::Arc,
            _ => CableCoupling::Exact,
        };
        // the arc coupling's rounds (`numerics.arc_rounds`; read only under `arc`):
        // from the same byte, so that the corpora written before it (bytes 0-2) keep
        // their coupling and the default 3 rounds
        input.settings.arc_rounds = [3, 1, 2][usize::from(b / 3 % 3)];
        input
    }

    /// Decode (see [`FORWARD_INPUT_BYTES`]). Every byte string is a valid input.
    pub fn from_bytes(data: &[u8]) -> Self {
        let data = &data[..data.len().min(FORWARD_INPUT_BYTES)];
        // 48 u16 fractions first (96 bytes), then 8 u8 choices.
        let mut f = Reader { data, pos: 0 };
        let mut c = Reader { data, pos: 96 };
        let two = c.choice(2) == 1;
        let mut sections = Vec::new();
        for k in 0..2 {
            let length = f.range(0.05, 0.5);
            let diameter = f.range(0.5e-3, 3e-3);
            let guides = (f.unit() * 5.999) as usize;
            if k == 0 || two {
                sections.push((length, diameter, guides));
            }
        }
        let material = (
            f.log_range(20e9, 200e9),
            f.range(0.0, 0.49),
            f.range(1000.0, 9000.0),
        );
        let guide = (f.range(0.0, 5e-3), f.range(0.0, 0.014));
        let precurvature = f.vec3(5.0);
        let base = (f.vec3(1.0), f.range(-180.0, 180.0));
        let gravity = f.vec3(10.0);
        let frame = if c.choice(2) == 1 {
            Frame::Body
        } else {
            Frame::World
        };
        let tip = (f.vec3(0.3), f.vec3(0.03), frame, f.range(0.0, 0.05));
        let tensions = [0; 6].map(|_| f.range(-2.0, 4.0).max(0.0));
        let integrator = if c.choice(4) == 0 {
            Integrator::Adaptive {
                tol: f.log_range(1e-8, 1e-4),
                max_steps: 200 + (f.unit() * 1000.0) as usize,
            }
        } else {
            Integrator::Rk4 {
                steps_per_section: 1 + (f.unit() * 31.0) as usize,
            }
        };
        // Settings added to the library later keep their defaults until fuzzed here.
        #[allow(clippy::needless_update)]
        let settings = SolverSettings {
            rod_model: if c.choice(2) == 1 {
                RodModel::Kirchhoff
            } else {
                RodModel::Cosserat
            },
            guide_mass: match c.choice(4) {
                0 => GuideMass::None,
                1 => GuideMass::Average,
                2 => GuideMass::Accurate,
                _ => GuideMass::Point,
            },
            integrator,
            max_iterations: 1 + usize::from(c.choice(FORWARD_MAX_ITERATIONS)),
            tolerance: f.log_range(1e-12, 1e-6),
            continuation: c.choice(2) == 1,
            max_continuation_steps: usize::from(c.choice(FORWARD_MAX_CONTINUATION_STEPS + 1)),
            ..SolverSettings::default()
        };
        let perturbation = f.vec3(0.02);
        Self {
            sections,
            material,
            guide,
            precurvature,
            base,
            gravity,
            tip,
            tensions,
            settings,
            perturbation,
        }
    }

    /// The robot, or `None` when the library rejects it.
    pub fn robot(&self) -> Option<Robot> {
        let (e, nu, rho) = self.material;
        let sections = self
            .sections
            .iter()
            .map(|&(length, diameter, count)| SectionSpec {
                length_m: length,
                shape: CrossSection::Solid {
                    diameter_m: diameter,
                },
                material: Material {
                    youngs_modulus_pa: e,
                    poisson_ratio: nu,
                    density_kg_m3: rho,
                },
                shear_coefficient: 1.0,
                precurvature_per_m: self.precurvature,
                guides: (count > 0).then(|| GuideSpec {
                    count,
                    first_offset_m: length / (count as f64 + 1.0),
                    spacing_m: length / (count as f64 + 1.0),
                    thickness_m: 3.01e-3,
                    diameter_m: 0.028,
                    mass_kg: self.guide.0,
                    holes: HolesSpec {
                        radius_m: self.guide.1,
                        angles_deg: vec![90.0, 210.0, 330.0],
                    },
                    even: Default::default(),
                }),
            })
            .collect::<Vec<_>>();
        let cables = (0..sections.len())
            .filter(|&k| sections[k].guides.is_some())
            .flat_map(|k| {
                (0..3).map(move |hole| CableSpec {
                    name: None,
                    hole: Some(hole),
                    end_section: k,
                    ..Default::default()
                })
            })
            .collect();
        Robot::new(RobotSpec {
            limits: None,
            base: BaseSpec {
                position_m: [0.0; 3],
                axis: self.base.0,
                angle_deg: self.base.1,
            },
            sections,
            cables,
            tendons: None,
            friction: None,
        })
        .ok()
    }

    /// The loads on `robot`, with the tip force shifted by `df`.
    pub fn loads(&self, robot: &Robot, df: [f64; 3]) -> Loads {
        let (force, torque, frame, mass) = self.tip;
        Loads {
            gravity_m_s2: self.gravity,
            point: vec![PointLoad {
                section: robot.sections().len() - 1,
                force_n: [0, 1, 2].map(|i| force[i] + df[i]),
                torque_nm: torque,
                frame,
                mass_kg: mass,
            }],
            tensions_n: self.tensions[..robot.cables().len()].to_vec(),
        }
    }
}

/// `forward_solve` target: build, solve cold, check; if converged, perturb the tip
/// force, solve warm, check, and re-solve warm at the same loads.
pub fn check_forward(input: &ForwardInput) {
    let Some(robot) = input.robot() else {
        return;
    };
    let loads = input.loads(&robot, [0.0; 3]);
    let Ok(mut ws) = Workspace::new(robot.clone(), loads, input.settings.clone()) else {
        return;
    };
    ws.solve(Start::Cold);
    check_workspace(&mut ws, "forward cold");
    if !ws.report().status.is_converged() {
        return;
    }
    let perturbed = input.loads(&robot, input.perturbation);
    ws.set_loads(&perturbed)
        .expect("loads differing only in tip force stay valid");
    ws.solve(Start::Warm);
    check_workspace(&mut ws, "forward warm after perturbation");
    if ws.report().status.is_converged() {
        // Re-solving a converged point must stay converged.
        let again = ws.solve(Start::Warm);
        assert!(
            again.status.is_converged(),
            "warm re-solve of a converged point: {again:?}"
        );
        check_workspace(&mut ws, "forward warm re-solve");
    }
}
