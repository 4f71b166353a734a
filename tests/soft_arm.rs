//! A soft arm hanging under its own weight solves cold with the default numerics
//! (issue 46). The arm: 0.36 m in three tapered sections (diameters 24, 18 and 12 mm),
//! E = 3e5 Pa, density 1100 kg/m^3 (a silicone-like elastomer), three straight
//! continuous tendons at 35 % of the tip radius, the base pointing down, 0.2 N on one
//! tendon. Counting its weight at full |g| made its load intensity 90 rad and sent the
//! cold solve into a branch-checked continuation that ran out of steps
//! (`max_iterations`, residual 6.6); along the axis of a hanging rod, weight pulls it
//! straight, so only the across-the-axis part (and a compressive axial part) counts
//! (`statics/intensity.rs`, `bending_gravity`).
//!
//! Asserted: the default solve converges; its tip equals the solve without the branch
//! guard (the plain Newton from the straight rod, which converged before the change
//! too) within 1e-9 m; the arm bends towards the pulled tendon by a few mm (a
//! physical equilibrium, not the straight rod); the intensity counts the weight only
//! where it can bend the rod (lying the same arm horizontal raises it above 10 rad;
//! hanging, the weight's share is zero and only the tendon's remains).

use cablesense::{Loads, Scene, SolverSettings, Start, Workspace};

const ARM: &str = r#"
description = "soft tapered arm hanging under its own weight"

[robot.base]
axis = [1.0, 0.0, 0.0]
angle_deg = 180.0

[[robot.sections]]
length_m = 0.12
shape = { solid = { diameter_m = 0.024 } }
youngs_modulus_pa = 3.0e5
poisson_ratio = 0.45
density_kg_m3 = 1100.0

[[robot.sections]]
length_m = 0.12
shape = { solid = { diameter_m = 0.018 } }
youngs_modulus_pa = 3.0e5
poisson_ratio = 0.45
density_kg_m3 = 1100.0

[[robot.sections]]
length_m = 0.12
shape = { solid = { diameter_m = 0.012 } }
youngs_modulus_pa = 3.0e5
poisson_ratio = 0.45
density_kg_m3 = 1100.0

[[robot.cables]]
name = "a"
routing = "continuous"
path = { straight = { radius_m = 0.0042, angle_deg = 0.0 } }
end_section = 2

[[robot.cables]]
name = "b"
routing = "continuous"
path = { straight = { radius_m = 0.0042, angle_deg = 120.0 } }
end_section = 2

[[robot.cables]]
name = "c"
routing = "continuous"
path = { straight = { radius_m = 0.0042, angle_deg = 240.0 } }
end_section = 2

[loads]
gravity_m_s2 = [0.0, 0.0, -9.81]
tensions_n = [0.2, 0.0, 0.0]
"#;

fn solve(scene: &Scene, settings: SolverSettings) -> (bool, cablesense::nalgebra::Vector3<f64>) {
    let robot = scene.build_robot().unwrap();
    let mut ws = Workspace::new(robot, scene.loads.clone(), settings).unwrap();
    let rep = ws.solve(Start::Cold);
    (rep.status.is_converged(), ws.tip_position())
}

#[test]
fn a_soft_arm_hanging_under_its_weight_solves_cold_with_the_defaults() {
    let scene = Scene::from_toml_str(ARM).unwrap();
    let (ok, tip) = solve(&scene, SolverSettings::default());
    assert!(ok, "default solve did not converge: tip {tip:?}");
    let unguarded = SolverSettings {
        branch_guard: false,
        ..SolverSettings::default()
    };
    let (ok_plain, tip_plain) = solve(&scene, unguarded);
    assert!(ok_plain);
    assert!((tip - tip_plain).norm() < 1e-9, "{tip:?} vs {tip_plain:?}");
    // hanging: the tip is near (0, 0, -0.36), bent a few mm towards the pulled tendon
    assert!((tip.z + 0.36).abs() < 2e-3, "{tip:?}");
    assert!(
        tip.x.hypot(tip.y) > 2e-3 && tip.x.hypot(tip.y) < 0.05,
        "{tip:?}"
    );
}

#[test]
fn weight_counts_in_the_intensity_only_where_it_can_bend_the_rod() {
    let scene = Scene::from_toml_str(ARM).unwrap();
    let robot = scene.build_robot().unwrap();
    let intensity = |loads: Loads| {
        Workspace::new(robot.clone(), loads, SolverSettings::default())
            .unwrap()
            .load_intensity()
    };
    let hanging = intensity(scene.loads.clone());
    let mut no_weight = scene.loads.clone();
    no_weight.gravity_m_s2 = [0.0, 0.0, 0.0];
    let tendon_only = intensity(no_weight);
    assert!(tendon_only > 0.0);
    assert!(
        (hanging - tendon_only).abs() < 1e-12,
        "{hanging} {tendon_only}"
    );
    let mut lying = scene.loads.clone();
    lying.gravity_m_s2 = [9.81, 0.0, 0.0];
    assert!(intensity(lying) > 10.0 + tendon_only);
    // upright (weight compressing the rod): counted in full, as across the axis
    let mut upright = scene.loads.clone();
    upright.gravity_m_s2 = [0.0, 0.0, 9.81];
    let (up, side) = (intensity(upright), {
        let mut l = scene.loads.clone();
        l.gravity_m_s2 = [0.0, 9.81, 0.0];
        intensity(l)
    });
    assert!((up - side).abs() < 1e-9 * side, "{up} {side}");
}
