//! Shared test helpers: robot builders, solver settings, independent section
//! properties and one tolerance helper.
#![allow(dead_code)]

use cablesense::nalgebra::{Matrix3, Vector3};
use cablesense::robot::{CableSpec, GuideSpec, HolesSpec, SectionSpec};
use cablesense::{
    CrossSection, Integrator, Loads, Material, PointLoad, Robot, RobotSpec, Solution,
    SolverSettings,
};
use std::f64::consts::PI;

/// `|got - want| <= abs + rel * |want|`; the message names what, index and `s`.
#[derive(Clone, Copy, Debug)]
pub struct Tol {
    pub abs: f64,
    pub rel: f64,
}

impl Tol {
    pub fn abs(abs: f64) -> Self {
        Self { abs, rel: 0.0 }
    }
    pub fn rel(rel: f64) -> Self {
        Self { abs: 0.0, rel }
    }
    pub fn both(abs: f64, rel: f64) -> Self {
        Self { abs, rel }
    }
    /// True when `got` is within tolerance of `want` (for proptest's `prop_assert!`).
    pub fn ok(&self, got: f64, want: f64) -> bool {
        got.is_finite() && (got - want).abs() <= self.abs + self.rel * want.abs()
    }
    #[track_caller]
    pub fn check(&self, what: &str, index: usize, s: f64, got: f64, want: f64) {
        let bound = self.abs + self.rel * want.abs();
        assert!(
            (got - want).abs() <= bound && got.is_finite(),
            "{what}[{index}] at s = {s}: got {got:e}, want {want:e}, |diff| = {:e} > {bound:e}",
            (got - want).abs()
        );
    }
    #[track_caller]
    pub fn check3(&self, what: &str, s: f64, got: &Vector3<f64>, want: &Vector3<f64>) {
        for i in 0..3 {
            self.check(what, i, s, got[i], want[i]);
        }
    }
    #[track_caller]
    pub fn check33(&self, what: &str, s: f64, got: &Matrix3<f64>, want: &Matrix3<f64>) {
        for i in 0..9 {
            self.check(what, i, s, got[i], want[i]);
        }
    }
    /// A failure message like `check`'s, or `None` when within tolerance (proptest).
    pub fn err3(
        &self,
        what: &str,
        s: f64,
        got: &Vector3<f64>,
        want: &Vector3<f64>,
    ) -> Option<String> {
        (0..3).find(|&i| !self.ok(got[i], want[i])).map(|i| {
            format!(
                "{what}[{i}] at s = {s}: got {:e}, want {:e}, |diff| = {:e} > {:e}",
                got[i],
                want[i],
                (got[i] - want[i]).abs(),
                self.abs + self.rel * want[i].abs()
            )
        })
    }
}

pub fn nitinol() -> Material {
    Material {
        youngs_modulus_pa: 62.7e9,
        poisson_ratio: 0.3,
        density_kg_m3: 6800.0,
    }
}

pub fn section(length: f64, diameter: f64) -> SectionSpec {
    SectionSpec {
        length_m: length,
        shape: CrossSection::Solid {
            diameter_m: diameter,
        },
        material: nitinol(),
        shear_coefficient: 1.0,
        precurvature_per_m: [0.0; 3],
        guides: None,
    }
}

pub fn guides(count: usize, first: f64, spacing: f64) -> GuideSpec {
    GuideSpec {
        count,
        first_offset_m: first,
        spacing_m: spacing,
        thickness_m: 3e-3,
        diameter_m: 0.03,
        mass_kg: 2.2e-3,
        holes: HolesSpec {
            radius_m: 0.01,
            angles_deg: vec![90.0, 210.0, 330.0],
        },
        even: Default::default(),
    }
}

/// A robot from sections, no cables, base at the origin along world +z.
pub fn robot_of(sections: Vec<SectionSpec>) -> Robot {
    Robot::new(RobotSpec {
        limits: None,
        base: Default::default(),
        sections,
        cables: vec![],
        tendons: None,
        friction: None,
    })
    .unwrap()
}

/// One plain rod along world +z.
pub fn plain_rod(length: f64, diameter: f64) -> Robot {
    robot_of(vec![section(length, diameter)])
}

/// Single section, five guides, three cables ending on the last disk.
pub fn five_guide_robot() -> Robot {
    let mut s = section(0.39, 1.56e-3);
    s.guides = Some(guides(5, 0.0054, 0.095));
    Robot::new(RobotSpec {
        limits: None,
        base: Default::default(),
        sections: vec![s],
        cables: (0..3)
            .map(|h| CableSpec {
                name: None,
                hole: Some(h),
                end_section: 0,
                ..Default::default()
            })
            .collect(),
        tendons: None,
        friction: None,
    })
    .unwrap()
}

/// Two sections with four guides each (at 0.04, 0.09, 0.14, 0.19 m of each 0.2 m
/// section: with 3 mm disks a guide centred on the section end would stick out of it);
/// cables 0-2 end on section 0, 3-5 on section 1.
pub fn two_section_robot() -> Robot {
    two_section_robot_first_at(0.04)
}

/// [`two_section_robot`] with the first disk of each section at `first` (m).
pub fn two_section_robot_first_at(first: f64) -> Robot {
    let mut a = section(0.2, 1.56e-3);
    a.guides = Some(guides(4, first, 0.05));
    let mut b = section(0.2, 1.2e-3);
    b.guides = Some(guides(4, first, 0.05));
    let mut cables: Vec<CableSpec> = (0..3)
        .map(|h| CableSpec {
            name: None,
            hole: Some(h),
            end_section: 0,
            ..Default::default()
        })
        .collect();
    cables.extend((0..3).map(|h| CableSpec {
        name: None,
        hole: Some(h),
        end_section: 1,
        ..Default::default()
    }));
    Robot::new(RobotSpec {
        limits: None,
        base: Default::default(),
        sections: vec![a, b],
        cables,
        tendons: None,
        friction: None,
    })
    .unwrap()
}

// ---------------------------------------------------------------------------
// Section properties computed here from the material and diameter, independently
// of `cablesense::rod` (thesis eqs. 2.9 and 2.12: D = diag(kGA, kGA, EA),
// C = diag(EI, EI, GJ); G = E / (2 (1 + nu)) for an isotropic solid).

/// Properties of a solid circular section of diameter `d` made of `nitinol()`.
#[derive(Clone, Copy, Debug)]
pub struct Props {
    pub ei: f64,
    pub gj: f64,
    pub ea: f64,
    pub ga: f64,
    /// rho A (kg/m)
    pub lambda: f64,
}

pub fn props(d: f64) -> Props {
    let m = nitinol();
    let e = m.youngs_modulus_pa;
    let g = e / (2.0 * (1.0 + m.poisson_ratio));
    let a = PI * d * d / 4.0;
    let i = PI * d.powi(4) / 64.0;
    Props {
        ei: e * i,
        gj: g * 2.0 * i,
        ea: e * a,
        ga: g * a,
        lambda: m.density_kg_m3 * a,
    }
}

// ---------------------------------------------------------------------------
// Settings and loads.

/// Default settings with fixed-step RK4.
pub fn rk4(steps_per_section: usize) -> SolverSettings {
    SolverSettings {
        integrator: Integrator::Rk4 { steps_per_section },
        ..Default::default()
    }
}

/// Default settings with the adaptive DP5(4) integrator.
pub fn adaptive(tol: f64) -> SolverSettings {
    SolverSettings {
        integrator: Integrator::Adaptive {
            tol,
            max_steps: 100_000,
        },
        ..Default::default()
    }
}

/// A world-frame force and torque at the end of `section`.
pub fn point(section: usize, force: [f64; 3], torque: [f64; 3]) -> PointLoad {
    PointLoad {
        section,
        force_n: force,
        torque_nm: torque,
        ..Default::default()
    }
}

/// No gravity, one world-frame load at the tip of a one-section rod.
pub fn tip_only(force: [f64; 3], torque: [f64; 3]) -> Loads {
    Loads {
        point: vec![point(0, force, torque)],
        ..Loads::none()
    }
}

/// Solve from a cold start and insist on convergence.
#[track_caller]
pub fn solve_ok(robot: &Robot, loads: &Loads, settings: &SolverSettings) -> Solution {
    let sol = cablesense::solve(robot, loads, settings).expect("valid input");
    assert!(
        sol.report.status.is_converged(),
        "solve did not converge: {:?}",
        sol.report
    );
    sol
}

/// Rotation by `angle` (rad) about `axis` (any length), Rodrigues' formula written here.
pub fn axis_angle(axis: [f64; 3], angle: f64) -> Matrix3<f64> {
    let k = Vector3::from(axis).normalize();
    let kx = Matrix3::new(0.0, -k.z, k.y, k.z, 0.0, -k.x, -k.y, k.x, 0.0);
    Matrix3::identity() + kx * angle.sin() + kx * kx * (1.0 - angle.cos())
}

/// Rotation taking the base's local +z (the backbone) to world +x: a horizontal
/// clamp, so that gravity `[0, 0, -9.81]` acts across the rod.
pub fn horizontal() -> Matrix3<f64> {
    axis_angle([0.0, 1.0, 0.0], PI / 2.0)
}

/// `two_section_robot()` but with a different hole pattern on section 1's disks
/// (radius 8 mm at 60/180/300 degrees instead of 10 mm at 90/210/330): cables 3-5 use
/// hole `j - 3` of each disk they pass, so they jog from one pattern to the other
/// between the last disk of section 0 and the first of section 1.
pub fn two_section_robot_mixed_holes() -> Robot {
    let mut spec = two_section_robot().spec().clone();
    let g = spec.sections[1].guides.as_mut().unwrap();
    g.holes = HolesSpec {
        radius_m: 0.008,
        angles_deg: vec![60.0, 180.0, 300.0],
    };
    Robot::new(spec).unwrap()
}

/// The joint sweep's partials `[R_x R_T]` and `[dl/dx dl/dT]`
/// (`Workspace::joint_jacobians`) of a tendon workspace solved at a row, at a point
/// off that equilibrium (the unknowns moved by up to 1e-3, pattern from `seed`),
/// against central differences of step `h = 1e-4` of the shooting residual and the
/// path lengths: residual entries to 1e-5 absolute + 1e-5 relative, length entries
/// to 1e-9 absolute + 1e-5 relative (why these: `tests/tendon_derivatives.rs`).
/// `Err` names the first entry that disagrees.
pub fn joint_partials_against_central_differences(
    tw: &mut cablesense::tendons::TendonWorkspace,
    seed: u64,
) -> Result<(), String> {
    let (h, tol_r, tol_l) = (1e-4, Tol::both(1e-5, 1e-5), Tol::both(1e-9, 1e-5));
    let theta: Vec<f64> = tw.tensions().to_vec();
    let ws = tw.workspace_mut();
    let (n, p, c) = (ws.unknowns(), theta.len(), ws.robot().cables().len());
    let w = n + p;
    // off the equilibrium, so the partials are not only those of a solution
    let x: Vec<f64> = ws
        .unknowns_vector()
        .iter()
        .enumerate()
        .map(|(i, x)| x + 1e-3 * (((seed as usize + 7 * i) % 11) as f64 - 5.0) / 5.0)
        .collect();
    ws.set_theta(&theta);
    let (mut js, mut jm) = (vec![0.0; n * w], vec![0.0; c * w]);
    if !ws.joint_jacobians(&x, &mut js, &mut jm) {
        return Err("the sweep failed".into());
    }
    let (mut rp, mut rm) = (vec![0.0; n], vec![0.0; n]);
    let (mut lp, mut lm) = (vec![0.0; c], vec![0.0; c]);
    for col in 0..w {
        for (sign, r, l) in [(1.0, &mut rp, &mut lp), (-1.0, &mut rm, &mut lm)] {
            let (mut xs, mut th) = (x.clone(), theta.clone());
            if col < n {
                xs[col] += sign * h;
            } else {
                th[col - n] += sign * h;
            }
            ws.set_theta(&th);
            if !ws.adopt_unknowns(&xs, true).is_finite() {
                return Err(format!("the pass failed at column {col}, sign {sign}"));
            }
            r.copy_from_slice(ws.residual_vector());
            ws.cable_lengths_into(l);
        }
        for k in 0..n {
            let (fd, exact) = ((rp[k] - rm[k]) / (2.0 * h), js[k * w + col]);
            if !tol_r.ok(fd, exact) {
                return Err(format!("dr[{k}]/dz[{col}]: exact {exact:e}, fd {fd:e}"));
            }
        }
        for j in 0..c {
            let (fd, exact) = ((lp[j] - lm[j]) / (2.0 * h), jm[j * w + col]);
            if !tol_l.ok(fd, exact) {
                return Err(format!("dl[{j}]/dz[{col}]: exact {exact:e}, fd {fd:e}"));
            }
        }
    }
    Ok(())
}

/// The library's default tolerances (`numerics.tolerance` 1e-10, `[numerics.tendons]
/// tolerance_m` 1e-12 m) on `scene`. Checks against round-off (derivatives against
/// central differences, cold solves against warm ones) need them; the shipped FTDCR
/// v4 scenes solve to 1e-4 and 1e-7 m since session 27 (their accuracy budget: a
/// tenth of the arc coupling's error, `tests/tendon_tolerance.rs`).
pub fn default_tolerances(mut scene: cablesense::Scene) -> cablesense::Scene {
    let d = SolverSettings::default();
    scene.numerics.tolerance = d.tolerance;
    scene.numerics.tendons.tolerance_m = d.tendons.tolerance_m;
    scene
}
