//! Large-load benches (multiple shooting, `statics::multiple`).
//!
//! * `reach_cold`: the thesis's Nitinol rod (0.39 m, 1.56 mm), Kirchhoff, no gravity,
//!   a planar tip force of `P L^2/EI` = 100 and 1000 across the rod; `solve(Start::Cold)`
//!   every iteration (the load continuation from rest). Issue target at 1000: <= 20 ms.
//! * `reach_warm`: the same rod at 1000, alternating the force by 0.1 %, warm.
//!
//! Inputs are fixed; workspaces are built and checked to converge outside the timed
//! closures. Results log: `benches/README.md`.

use cablesense::robot::SectionSpec;
use cablesense::{
    CrossSection, Loads, Material, PointLoad, Robot, RobotSpec, RodModel, SolverSettings, Start,
    Workspace,
};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use std::time::Duration;

const L: f64 = 0.39;
const D: f64 = 1.56e-3;

fn rod() -> Robot {
    Robot::new(RobotSpec {
        limits: None,
        base: Default::default(),
        sections: vec![SectionSpec {
            length_m: L,
            shape: CrossSection::Solid { diameter_m: D },
            material: Material {
                youngs_modulus_pa: 62.7e9,
                poisson_ratio: 0.3,
                density_kg_m3: 6800.0,
            },
            shear_coefficient: 1.0,
            precurvature_per_m: [0.0; 3],
            guides: None,
        }],
        cables: vec![],
        tendons: None,
        friction: None,
    })
    .expect("valid rod")
}

fn tip_load(robot: &Robot, a: f64) -> Loads {
    let ei = robot.sections()[0].stiffness.bend_twist.x;
    Loads {
        point: vec![PointLoad {
            section: 0,
            force_n: [0.0, -a * ei / (L * L), 0.0],
            ..Default::default()
        }],
        ..Loads::none()
    }
}

fn settings() -> SolverSettings {
    SolverSettings {
        rod_model: RodModel::Kirchhoff,
        ..SolverSettings::default()
    }
}

fn reach_cold(c: &mut Criterion) {
    let mut g = c.benchmark_group("reach_cold");
    g.measurement_time(Duration::from_secs(5)).sample_size(20);
    let robot = rod();
    for a in [100.0, 1000.0] {
        let mut ws = Workspace::new(robot.clone(), tip_load(&robot, a), settings()).unwrap();
        assert!(ws.solve(Start::Cold).status.is_converged());
        g.bench_with_input(BenchmarkId::from_parameter(a), &a, |b, _| {
            b.iter(|| black_box(ws.solve(Start::Cold)))
        });
    }
    g.finish();
}

fn reach_warm(c: &mut Criterion) {
    let mut g = c.benchmark_group("reach_warm");
    g.measurement_time(Duration::from_secs(5));
    let robot = rod();
    let loads = [tip_load(&robot, 1000.0), tip_load(&robot, 1001.0)];
    let mut ws = Workspace::new(robot.clone(), loads[0].clone(), settings()).unwrap();
    assert!(ws.solve(Start::Cold).status.is_converged());
    let mut k = 0;
    g.bench_function("1000", |b| {
        b.iter(|| {
            k ^= 1;
            ws.set_loads(&loads[k]).unwrap();
            black_box(ws.solve(Start::Warm))
        })
    });
    g.finish();
}

criterion_group!(benches, reach_cold, reach_warm);
criterion_main!(benches);
