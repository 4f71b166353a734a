//! Continuous tendon routing (Rucker & Webster 2011) on Till's example tendon robot
//! (`data/scenes/till_tendon_robot.toml`: 0.5 m steel rod, four straight continuous
//! tendons, 15 N on the first, gravity; 16 RK4 steps).
//!
//! * `till_warm_ramp`: a warm solve per step of a tension ramp on the first tendon,
//!   1 -> 15 -> 1 N in steps of 0.1 N (the control-loop case; `set_loads` keeps the
//!   structure, no allocation). Issue 11 target: <= 50 us.
//! * `till_cold`: one cold solve at 15 N. Issue 11 target: <= 300 us.
//! * `till_disks_100_warm_ramp`: the same ramp on Till's robot emulated with 100
//!   massless point disks (holes at the tendons' 15.06 mm, straight chords between
//!   disks, thesis 3.8.1; one RK4 step per disk spacing, the condensed coupling), the
//!   model `tests/continuous_routing.rs` checks against the continuous one.
//!   Issue 11 target: <= 60 us.
//!
//! Solves that do not converge during timing are counted on stderr.

use cablesense::robot::{CableSpec, GuideSpec, HolesSpec, RobotSpec, SectionSpec};
use cablesense::{
    CrossSection, Integrator, Material, Robot, Scene, SolverSettings, Start, Workspace,
};
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::Duration;

fn benches(c: &mut Criterion) {
    let scene = Scene::load("data/scenes/till_tendon_robot.toml").expect("shipped scene");
    let robot = scene.build_robot().expect("robot");
    let mut ws = Workspace::new(robot, scene.loads.clone(), scene.numerics.clone()).expect("ws");
    let ramp: Vec<f64> = (0..=140)
        .chain((0..140).rev())
        .map(|k| 1.0 + 0.1 * k as f64)
        .collect();
    let mut loads = scene.loads.clone();
    let mut disks = Workspace::new(
        till_with_disks(100),
        scene.loads.clone(),
        SolverSettings {
            integrator: Integrator::Rk4 {
                steps_per_section: 100,
            },
            ..SolverSettings::default()
        },
    )
    .expect("ws");
    let mut g = c.benchmark_group("continuous");
    g.measurement_time(Duration::from_secs(10)).sample_size(30);
    let (mut k, mut failed) = (0usize, 0usize);
    ws.solve(Start::Cold);
    g.bench_function("till_warm_ramp", |b| {
        b.iter(|| {
            loads.tensions_n[0] = ramp[k % ramp.len()];
            ws.set_loads(&loads).expect("same structure");
            failed += usize::from(!ws.solve(black_box(Start::Warm)).status.is_converged());
            k += 1;
        })
    });
    ws.set_loads(&scene.loads).expect("loads");
    g.bench_function("till_cold", |b| {
        b.iter(|| {
            failed += usize::from(!ws.solve(black_box(Start::Cold)).status.is_converged());
        })
    });
    let mut k = 0usize;
    loads.clone_from(&scene.loads);
    disks.solve(Start::Cold);
    g.bench_function("till_disks_100_warm_ramp", |b| {
        b.iter(|| {
            loads.tensions_n[0] = ramp[k % ramp.len()];
            disks.set_loads(&loads).expect("same structure");
            failed += usize::from(!disks.solve(black_box(Start::Warm)).status.is_converged());
            k += 1;
        })
    });
    g.finish();
    if failed > 0 {
        eprintln!("continuous benches: {failed} solves did not converge");
    }
}

/// Till's rod (0.5 m steel, r = 1 mm) with `n` massless, zero-thickness disks at
/// spacing `L/n` carrying the four tendons through holes at 15.06 mm (as in
/// `tests/continuous_routing.rs`).
fn till_with_disks(n: usize) -> Robot {
    let h = 0.5 / n as f64;
    Robot::new(RobotSpec {
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
    })
    .expect("robot")
}

criterion_group!(continuous, benches);
criterion_main!(continuous);
