//! Profile driver for `benches/continuous.rs` without criterion (issue 11): the warm
//! tension ramp on Till's robot, continuous (`cont`) or as 100 point disks (`disks`),
//! for callgrind and deterministic counts (RHS evaluations, Newton iterations per solve).
//! Each line: solve index, tip (m), Newton iterations, RHS evaluations, Jacobians.
//! `cargo run --release --example till_ramp_profile -- MODE SOLVES [q]`: prints each
//! solve's tip (m) unless `q`, and the counts on stderr.

use cablesense::robot::{CableSpec, GuideSpec, HolesSpec, RobotSpec, SectionSpec};
use cablesense::{
    CrossSection, Integrator, Material, Robot, Scene, SolverSettings, Start, Workspace,
};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map_or("cont", |s| s.as_str()).to_string();
    let reps: usize = args.get(2).map_or(500, |s| s.parse().unwrap());
    let quiet = args.get(3).is_some();
    let scene = Scene::load("data/scenes/till_tendon_robot.toml").expect("shipped scene");
    let (robot, settings) = if mode == "disks" {
        let n = 100usize;
        let h = 0.5 / n as f64;
        let spec = RobotSpec {
            limits: None,
            base: Default::default(),
            sections: vec![SectionSpec {
                length_m: 0.5,
                shape: CrossSection::Solid { diameter_m: 2e-3 },
                material: Material {
                    youngs_modulus_pa: 200e9,
                    poisson_ratio: 0.25,
                    density_kg_m3: 8000.0,
                },
                shear_coefficient: 1.0,
                precurvature_per_m: [0.0; 3],
                guides: Some(GuideSpec {
                    count: n,
                    first_offset_m: h,
                    spacing_m: h,
                    thickness_m: 0.0,
                    diameter_m: 0.04,
                    mass_kg: 0.0,
                    holes: HolesSpec {
                        radius_m: 0.01506,
                        angles_deg: vec![0.0, 90.0, 180.0, 270.0],
                    },
                    even: Default::default(),
                }),
            }],
            cables: (0..4).map(|k| CableSpec::through_hole(k, 0)).collect(),
            tendons: None,
            friction: None,
        };
        let settings = SolverSettings {
            integrator: Integrator::Rk4 {
                steps_per_section: n,
            },
            ..SolverSettings::default()
        };
        (Robot::new(spec).unwrap(), settings)
    } else {
        (scene.build_robot().unwrap(), scene.numerics.clone())
    };
    let mut ws = Workspace::new(robot, scene.loads.clone(), settings).unwrap();
    let ramp: Vec<f64> = (0..=140)
        .chain((0..140).rev())
        .map(|k| 1.0 + 0.1 * k as f64)
        .collect();
    let mut loads = scene.loads.clone();
    let rep = ws.solve(Start::Cold);
    eprintln!("cold: {rep:?}");
    let (mut rhs, mut it, mut jac, mut failed) = (0u64, 0usize, 0u64, 0usize);
    let c0 = ws.rhs_counts();
    for k in 0..reps {
        loads.tensions_n[0] = ramp[k % ramp.len()];
        ws.set_loads(&loads).unwrap();
        let rep = ws.solve(Start::Warm);
        rhs += rep.rhs_evals;
        it += rep.iterations;
        jac += rep.jacobian_evals;
        failed += usize::from(!rep.status.is_converged());
        if !quiet {
            let t = ws.tip_position();
            println!(
                "{k} {:.17e} {:.17e} {:.17e} it {} rhs {} jac {}",
                t.x, t.y, t.z, rep.iterations, rep.rhs_evals, rep.jacobian_evals
            );
        }
    }
    let r = reps as f64;
    let c1 = ws.rhs_counts();
    eprintln!(
        "{mode}: f64 rhs/solve {:.1}, dual rhs/solve {:.1}, gap re-integrations/solve {:.1}",
        (c1.f64_rhs - c0.f64_rhs) as f64 / r,
        (c1.dual_rhs - c0.dual_rhs) as f64 / r,
        (c1.local_iterations - c0.local_iterations) as f64 / r
    );
    eprintln!(
        "{mode}: {reps} warm solves: rhs/solve {:.1}, iterations/solve {:.2}, jacobians/solve {:.3}, failed {failed}",
        rhs as f64 / r,
        it as f64 / r,
        jac as f64 / r
    );
}
