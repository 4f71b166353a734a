//! The model ladder against the full Cosserat reference: where each rung is exact,
//! how fast each discretisation converges, and what the automatic choice picks.
//!
//! Tolerances, each with its source:
//! * CC under a pure bending moment: the Cosserat solution is the same arc (n = 0 gives
//!   v = e3, m constant in the body frame, thesis eqs. 2.9-2.12), so only round-off
//!   and the reference's own error remain: 1e-9 m.
//! * Kirchhoff vs Cosserat: they differ by shear and extension only; with tip force P
//!   the Timoshenko shear deflection is P L / (k G A) and the extension P L / (E A)
//!   (Timoshenko & Gere, *Mechanics of Materials*, shear deflection of a cantilever).
//! * RK4 is 4th order: error ratio 2^4 = 16 per halving of the step (band 10..24).
//! * PCC (midpoint curvature per piece) is 2nd order: ratio 4 per halving (band 3..5.5).
//! * Adaptive DP5(4) with local error control: global error roughly proportional to
//!   tol (Hairer, Norsett & Wanner, *Solving ODEs I*, II.4); band 10..1000 per 100x.

use cablesense::ladder::{choose, AutoSettings, CcSettings, PccSettings, Rung};
use cablesense::nalgebra::Vector3;
use cablesense::{GuideMass, Integrator, Loads, PointLoad, RodModel, Scene, SolverSettings, Start};

fn scene(path: &str) -> Scene {
    Scene::load(path).expect("shipped scene")
}

/// Two sections of different diameters, rotated base, disks and passive cables.
/// Both sections use the same hole radius (each disk's own hole is used by every
/// rung; a common radius keeps this scene simple).
fn two_section_scene(extra_loads: &str) -> Scene {
    let text = format!(
        r#"
[robot.base]
position_m = [0.01, -0.02, 0.03]
axis = [0.3, 1.0, 0.2]
angle_deg = 70.0

[[robot.sections]]
length_m = 0.2
shape = {{ solid = {{ diameter_m = 1.56e-3 }} }}
youngs_modulus_pa = 62.7e9
poisson_ratio = 0.3
density_kg_m3 = 6800.0
[robot.sections.guides]
count = 4
first_offset_m = 0.04
spacing_m = 0.05
thickness_m = 2e-3
diameter_m = 0.02
mass_kg = 1e-3
holes = {{ radius_m = 0.008 }}

[[robot.sections]]
length_m = 0.15
shape = {{ solid = {{ diameter_m = 1.2e-3 }} }}
youngs_modulus_pa = 62.7e9
poisson_ratio = 0.3
density_kg_m3 = 6800.0
[robot.sections.guides]
count = 3
first_offset_m = 0.04
spacing_m = 0.05
thickness_m = 2e-3
diameter_m = 0.02
mass_kg = 1e-3
holes = {{ radius_m = 0.008 }}

[[robot.cables]]
hole = 0
end_section = 0
[[robot.cables]]
hole = 1
end_section = 1
[[robot.cables]]
hole = 2
end_section = 1

[loads]
gravity_m_s2 = [0.0, 0.0, 0.0]
{extra_loads}
"#
    );
    Scene::from_toml_str(&text).expect("valid test scene")
}

fn reference_settings() -> SolverSettings {
    Rung::reference()
        .solver_settings()
        .cloned()
        .expect("the reference is a rod rung")
}

fn rod(model: RodModel, guide_mass: GuideMass, integrator: Integrator) -> Rung {
    Rung::Rod(SolverSettings {
        rod_model: model,
        guide_mass,
        integrator,
        ..SolverSettings::default()
    })
}

/// Solve `rung` and return (tip, cable lengths), asserting convergence.
fn run(rung: &Rung, scene: &Scene, loads: &Loads) -> (Vector3<f64>, Vec<f64>) {
    let robot = scene.build_robot().unwrap();
    let mut m = rung.build(&robot).unwrap();
    let rep = m.solve(loads, Start::Cold).unwrap();
    assert!(rep.status.is_converged(), "{}: {rep:?}", rung.label());
    let mut l = vec![0.0; robot.cables().len()];
    m.cable_lengths_into(&mut l);
    (m.tip_position(), l)
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn cc_is_exact_for_pure_bending_moments_without_gravity() {
    // torques perpendicular to the bending plane: the base tangent is R0 e3, the
    // torque is along R0 e1 (body x at the base), at the tip and at the section joint
    let sc = two_section_scene(
        r#"
[[loads.point]]
section = 1
torque_nm = [0.0, 0.0, 0.0]
[[loads.point]]
section = 0
torque_nm = [0.0, 0.0, 0.0]
"#,
    );
    let robot = sc.build_robot().unwrap();
    let x = robot.base_rotation().column(0).into_owned();
    let mut loads = sc.loads.clone();
    loads.point[0].torque_nm = (x * 0.02).into();
    loads.point[1].torque_nm = (x * -0.005).into();
    let reference = Rung::Rod(reference_settings());
    let mut cc = Rung::ConstantCurvature(CcSettings::default())
        .build(&robot)
        .unwrap();
    cc.solve(&loads, Start::Cold).unwrap();
    let mut r = reference.build(&robot).unwrap();
    assert!(r.solve(&loads, Start::Cold).unwrap().status.is_converged());
    let (a, b) = (cc.output(), r.output());
    // the tip moved well away from straight, so the check is not vacuous
    let straight = robot.base_position() + robot.base_rotation().column(2) * 0.35;
    assert!((b.tip().unwrap().position - straight).norm() > 0.03);
    for (k, (p, q)) in a.section_tips.iter().zip(&b.section_tips).enumerate() {
        let d = (p.position - q.position).norm();
        assert!(d < 1e-9, "section {k} end: |CC - Cosserat| = {d:e} m");
        assert!((p.rotation - q.rotation).norm() < 1e-8);
    }
    for (g, (p, q)) in a.guides.iter().zip(&b.guides).enumerate() {
        assert!((p.position - q.position).norm() < 1e-9, "guide {g}");
    }
    let d = max_diff(&a.cable_lengths, &b.cable_lengths);
    assert!(d < 1e-9, "cable lengths differ by {d:e} m");
}

#[test]
fn kirchhoff_differs_from_cosserat_by_the_shear_and_extension_estimate() {
    // cantilever, tip force across the rod; small load: the difference is the
    // Timoshenko shear deflection P L / (k G A) plus the extension
    let text = r#"
[[robot.sections]]
length_m = 0.3
shape = { solid = { diameter_m = 1.56e-3 } }
youngs_modulus_pa = 62.7e9
poisson_ratio = 0.3
density_kg_m3 = 6800.0
[loads]
gravity_m_s2 = [0.0, 0.0, 0.0]
"#;
    let sc = Scene::from_toml_str(text).unwrap();
    let robot = sc.build_robot().unwrap();
    let s = &robot.sections()[0].stiffness;
    let (ga, ea, l) = (s.shear_stretch.x, s.shear_stretch.z, 0.3);
    let ei = s.bend_twist.x;
    for &nondim in &[0.01, 1.0, 5.0] {
        let p = nondim * ei / (l * l);
        let mut loads = sc.loads.clone();
        loads.point.push(PointLoad {
            section: 0,
            force_n: [p, 0.0, 0.0],
            ..Default::default()
        });
        let fine = Integrator::Adaptive {
            tol: 1e-12,
            max_steps: 100_000,
        };
        let (tk, _) = run(
            &rod(RodModel::Kirchhoff, GuideMass::None, fine),
            &sc,
            &loads,
        );
        let (tc, _) = run(&rod(RodModel::Cosserat, GuideMass::None, fine), &sc, &loads);
        let estimate = p * l / ga + p * l / ea;
        let d = (tk - tc).norm();
        assert!(
            d <= 1.5 * estimate,
            "PL^2/EI = {nondim}: |K - C| = {d:e} > 1.5 x {estimate:e}"
        );
        if nondim < 0.1 {
            // small deflection: the shear term is the whole difference
            let shear = p * l / ga;
            assert!(
                (d - shear).abs() < 0.02 * shear,
                "small load: {d:e} vs P L / (G A) = {shear:e}"
            );
        }
    }
}

#[test]
fn rk4_error_falls_at_fourth_order() {
    // thesis experiment 2 (5 disks, 83 g tip mass: a large deflection)
    let sc = scene("data/thesis/table_4_3.toml");
    let mut refs = reference_settings();
    refs.guide_mass = GuideMass::Accurate;
    let (t_ref, _) = run(&Rung::Rod(refs), &sc, &sc.loads);
    let errs: Vec<f64> = [8, 16, 32, 64]
        .iter()
        .map(|&n| {
            let rung = rod(
                RodModel::Cosserat,
                GuideMass::Accurate,
                Integrator::Rk4 {
                    steps_per_section: n,
                },
            );
            (run(&rung, &sc, &sc.loads).0 - t_ref).norm()
        })
        .collect();
    for w in errs.windows(2) {
        let ratio = w[0] / w[1];
        assert!(
            (10.0..24.0).contains(&ratio),
            "RK4 error ratio per halving {ratio:.2} outside 10..24: {errs:?}"
        );
    }
}

#[test]
fn adaptive_error_scales_with_tol() {
    let sc = scene("data/thesis/table_4_3.toml");
    let mut refs = reference_settings();
    refs.integrator = Integrator::Adaptive {
        tol: 1e-13,
        max_steps: 1_000_000,
    };
    let (t_ref, _) = run(&Rung::Rod(refs), &sc, &sc.loads);
    let errs: Vec<f64> = [1e-6, 1e-8, 1e-10]
        .iter()
        .map(|&tol| {
            let rung = rod(
                RodModel::Cosserat,
                GuideMass::Accurate,
                Integrator::Adaptive {
                    tol,
                    max_steps: 100_000,
                },
            );
            let e = (run(&rung, &sc, &sc.loads).0 - t_ref).norm();
            assert!(e < 10.0 * tol * 0.39, "tol {tol:e}: error {e:e}");
            e
        })
        .collect();
    for w in errs.windows(2) {
        let ratio = w[0] / w[1];
        assert!(
            (10.0..1000.0).contains(&ratio),
            "adaptive error ratio per 100x tol {ratio:.1}: {errs:?}"
        );
    }
}

#[test]
fn pcc_converges_to_kirchhoff_at_second_order() {
    // thesis experiment 1a: bare rod, own weight and 43 g at the joint
    let sc = scene("data/thesis/table_4_1.toml");
    let mut k = reference_settings();
    k.rod_model = RodModel::Kirchhoff;
    let (t_ref, _) = run(&Rung::Rod(k), &sc, &sc.loads);
    let errs: Vec<f64> = [4, 8, 16, 32]
        .iter()
        .map(|&n| {
            let rung = Rung::PiecewiseConstantCurvature(PccSettings {
                pieces_per_section: n,
                guide_mass: GuideMass::None,
                ..PccSettings::default()
            });
            (run(&rung, &sc, &sc.loads).0 - t_ref).norm()
        })
        .collect();
    for w in errs.windows(2) {
        let ratio = w[0] / w[1];
        assert!(
            (3.0..5.5).contains(&ratio),
            "PCC error ratio per halving {ratio:.2} outside 3..5.5: {errs:?}"
        );
    }
}

#[test]
fn every_rung_agrees_with_the_reference_on_the_demo_scene_to_its_model_error() {
    // the demo: two sections, tensioned cables, payload, gravity across the rod
    let sc = scene("data/scenes/demo_two_section.toml");
    let (t_ref, l_ref) = run(&Rung::reference(), &sc, &sc.loads);
    let cases: [(Rung, f64); 4] = [
        // CC ignores the rod's weight: centimetres
        (Rung::ConstantCurvature(CcSettings::default()), 0.2),
        // PCC 16 with the same (accurate) mass model: O(h^2) discretisation
        (
            Rung::PiecewiseConstantCurvature(PccSettings {
                pieces_per_section: 16,
                guide_mass: GuideMass::Accurate,
                ..PccSettings::default()
            }),
            1e-4,
        ),
        // Kirchhoff: shear and extension only (cable tension / EA ~ 1e-5)
        (
            rod(
                RodModel::Kirchhoff,
                GuideMass::Accurate,
                Integrator::Rk4 {
                    steps_per_section: 32,
                },
            ),
            2e-5,
        ),
        (
            rod(
                RodModel::Cosserat,
                GuideMass::Accurate,
                Integrator::Rk4 {
                    steps_per_section: 32,
                },
            ),
            1e-7,
        ),
    ];
    for (rung, tol) in cases {
        let (t, l) = run(&rung, &sc, &sc.loads);
        let d = (t - t_ref).norm();
        assert!(d < tol, "{}: tip {d:e} m > {tol:e}", rung.label());
        assert!(max_diff(&l, &l_ref) < tol, "{}: cables", rung.label());
    }
}

#[test]
fn auto_picks_constant_curvature_for_pure_moments_without_gravity() {
    // (a) a pure tip moment, passive cables: CC is exact
    let sc = two_section_scene(
        r#"
[[loads.point]]
section = 1
torque_nm = [0.0, 0.0, 0.0]
"#,
    );
    let robot = sc.build_robot().unwrap();
    let mut loads = sc.loads.clone();
    loads.point[0].torque_nm = (robot.base_rotation().column(1) * 0.003)
        .into_owned()
        .into();
    let settings = AutoSettings::default();
    let ladder = cablesense::ladder::auto_ladder(&robot);
    let choice = choose(&robot, &loads, &settings, &ladder).unwrap();
    assert_eq!(choice.rung.family(), "cc", "{:#?}", choice.picked_report());
    let cc = &choice.candidates[0];
    assert!(cc.tip_error_m < 1e-9 && cc.cable_error_m < 1e-9, "{cc:?}");

    // (b) cable moments only: 20 disks, 0.1 N on one cable, no gravity
    let text = r#"
[[robot.sections]]
length_m = 0.2
shape = { solid = { diameter_m = 1.0e-3 } }
youngs_modulus_pa = 62.7e9
poisson_ratio = 0.3
density_kg_m3 = 6800.0
[robot.sections.guides]
count = 20
first_offset_m = 0.0095
spacing_m = 0.01
thickness_m = 1e-3
diameter_m = 0.02
mass_kg = 0.0
holes = { radius_m = 0.005 }
[[robot.cables]]
hole = 0
end_section = 0
[[robot.cables]]
hole = 1
end_section = 0
[loads]
gravity_m_s2 = [0.0, 0.0, 0.0]
tensions_n = [0.1, 0.0]
"#;
    let sc = Scene::from_toml_str(text).unwrap();
    let robot = sc.build_robot().unwrap();
    let choice = choose(
        &robot,
        &sc.loads,
        &settings,
        &cablesense::ladder::auto_ladder(&robot),
    )
    .unwrap();
    assert_eq!(choice.rung.family(), "cc", "{:#?}", choice.candidates[0]);
}

#[test]
fn auto_picks_a_rod_rung_for_the_thesis_rods_under_their_own_weight() {
    for path in ["data/thesis/table_4_1.toml", "data/thesis/table_4_3.toml"] {
        let sc = scene(path);
        let robot = sc.build_robot().unwrap();
        let choice = choose(
            &robot,
            &sc.loads,
            &AutoSettings::default(),
            &cablesense::ladder::auto_ladder(&robot),
        )
        .unwrap();
        assert!(!choice.fallback, "{path}: nothing met the targets");
        let fam = choice.rung.family();
        assert!(
            fam == "kirchhoff" || fam == "cosserat",
            "{path}: picked {}",
            choice.rung.label()
        );
        // CC ignores gravity: rejected on its tip error
        assert!(choice.candidates[0].tip_error_m > 1e-3, "{path}");
        let picked = choice.picked_report().unwrap();
        assert!(picked.tip_error_m <= 1e-4 && picked.cable_error_m <= 1e-6);
    }
}

#[test]
fn bad_settings_are_errors_not_panics() {
    let sc = scene("data/thesis/table_4_1.toml");
    let robot = sc.build_robot().unwrap();
    let bad = Rung::PiecewiseConstantCurvature(PccSettings {
        pieces_per_section: 0,
        ..PccSettings::default()
    });
    assert!(bad.build(&robot).is_err());
    let bad = Rung::ConstantCurvature(CcSettings {
        tolerance: f64::NAN,
        ..CcSettings::default()
    });
    assert!(bad.build(&robot).is_err());
    let settings = AutoSettings {
        tip_tolerance_m: -1.0,
        ..AutoSettings::default()
    };
    assert!(choose(&robot, &sc.loads, &settings, &[Rung::reference()]).is_err());
    assert!(choose(&robot, &sc.loads, &AutoSettings::default(), &[]).is_err());
    // loads that do not fit the robot
    let mut loads = sc.loads.clone();
    loads.point[0].section = 7;
    let mut m = Rung::ConstantCurvature(CcSettings::default())
        .build(&robot)
        .unwrap();
    assert!(m.solve(&loads, Start::Cold).is_err());
}

#[test]
fn pcc_and_cc_survive_absurd_loads_without_nan_or_panic() {
    let sc = scene("data/thesis/table_4_3.toml");
    let robot = sc.build_robot().unwrap();
    let mut loads = sc.loads.clone();
    let mut beyond = sc.loads.clone();
    // 1e3 kg on the thesis rod: a weight of 9.8 kN, absurd but below its axial
    // stiffness EA (1.2e5 N); 1e6 kg reaches EA, which load validation refuses
    // (an axial strain of -1, no physical state), naming the mass
    loads.point[0].mass_kg = 1e3;
    beyond.point[0].mass_kg = 1e6;
    for rung in [
        Rung::ConstantCurvature(CcSettings::default()),
        Rung::PiecewiseConstantCurvature(PccSettings::default()),
    ] {
        let mut m = rung.build(&robot).unwrap();
        let rep = m.solve(&loads, Start::Cold).unwrap();
        if rep.status.is_converged() {
            assert!(m.tip_position().iter().all(|x| x.is_finite()));
        }
        let e = m.solve(&beyond, Start::Cold).unwrap_err().to_string();
        assert!(e.contains("loads.point[0].mass_kg = 1000000"), "{e}");
    }
}
