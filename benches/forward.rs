//! Forward-statics benches: one `benchmark_group` per operation.
//!
//! * `forward_warm`: the control-loop tick. One section (0.39 m Nitinol rod), five guides,
//!   three passive cables, gravity across the rod; each iteration moves the tip force to
//!   the next of three nearby values (a cycle whose steps are pairwise non-parallel) and
//!   measures `set_loads` + `solve(Start::Warm)` + `cable_lengths_into`. Parameterised
//!   over integrator x guide-mass model. (Until run T6 the bench alternated between two
//!   values; the warm solve's load-path predictor extrapolates an alternation A, B, A
//!   exactly to the solution at A, so that bench had stopped measuring a Newton solve:
//!   2.3 us against 9.4 us in T5.)
//!   Issue target: <= 20 us (RK4, the default settings).
//! * `forward_cold_tensioned`: two sections, six cables, two of them tensioned,
//!   `solve(Start::Cold)` + `cable_lengths_into` every iteration; also the shipped scene
//!   `data/scenes/demo_two_section.toml`. Issue target: <= 500 us.
//! * `forward_rod_model`: Cosserat vs Kirchhoff rod, warm, otherwise as `forward_warm`.
//! * `forward_cold_branch_checked`: the shipped track demo (`data/scenes/track_demo.toml`,
//!   RK4 32, point guide mass) with one cable at `T r L/EI` = 5 and 7.5, cold: above load
//!   intensity 3 the branch guard answers by a checked continuation (no target; the cost
//!   of staying on the branch far past doubling back).
//!
//! Inputs are fixed (no randomness); robots, loads and workspaces are built and
//! checked to converge outside the timed closures. A solve that does not converge
//! during timing is counted and reported on stderr, since its time would be
//! meaningless. Results log: `benches/README.md`.

use cablesense::robot::{CableSpec, GuideSpec, HolesSpec, SectionSpec};
use cablesense::{
    CrossSection, GuideMass, Integrator, Loads, Material, PointLoad, Robot, RobotSpec, RodModel,
    Scene, SolverSettings, Start, Workspace,
};
use criterion::{criterion_group, criterion_main, BenchmarkGroup, BenchmarkId, Criterion};
use std::hint::black_box;
use std::time::Duration;

/// Gravity across the rod: the backbone runs along world +z, gravity along -y.
const GRAVITY_ACROSS: [f64; 3] = [0.0, -9.81, 0.0];

/// The three tip forces (N, world) the warm bench cycles through: every step is
/// 0.5 mN along two axes (as the earlier two-value alternation), and no step is
/// parallel to the one before it, so the load-path predictor never applies.
const TIP_FORCES: [[f64; 3]; 3] = [
    [0.02, 0.0, 0.0],
    [0.0205, 0.0005, 0.0],
    [0.0205, 0.0, 0.0005],
];

fn nitinol() -> Material {
    Material {
        youngs_modulus_pa: 62.7e9,
        poisson_ratio: 0.3,
        density_kg_m3: 6800.0,
    }
}

fn section(length: f64, guides: GuideSpec) -> SectionSpec {
    SectionSpec {
        length_m: length,
        shape: CrossSection::Solid {
            diameter_m: 1.56e-3,
        },
        material: nitinol(),
        shear_coefficient: 1.0,
        precurvature_per_m: [0.0; 3],
        guides: Some(guides),
    }
}

/// Guide disks: 3.01 mm thick, 2.2 g, holes on a 1 cm radius at 90/210/330 deg.
fn guides(count: usize, first: f64, spacing: f64) -> GuideSpec {
    GuideSpec {
        count,
        first_offset_m: first,
        spacing_m: spacing,
        thickness_m: 3.01e-3,
        diameter_m: 0.028,
        mass_kg: 2.2e-3,
        holes: HolesSpec {
            radius_m: 0.01,
            angles_deg: vec![90.0, 210.0, 330.0],
        },
        even: Default::default(),
    }
}

fn cable(hole: usize, end_section: usize) -> CableSpec {
    CableSpec {
        name: None,
        hole: Some(hole),
        end_section,
        ..Default::default()
    }
}

/// One 0.39 m section, five guides, three cables ending on the last disk.
fn single_section_robot() -> Robot {
    Robot::new(RobotSpec {
        limits: None,
        base: Default::default(),
        sections: vec![section(0.39, guides(5, 0.0054, 0.095))],
        cables: (0..3).map(|h| cable(h, 0)).collect(),
        tendons: None,
        friction: None,
    })
    .expect("valid single-section robot")
}

/// Two 0.195 m sections with four guides each; cables 0-2 end on section 0, 3-5 on 1.
fn two_section_robot() -> Robot {
    let s = || section(0.195, guides(4, 0.045, 0.045));
    Robot::new(RobotSpec {
        limits: None,
        base: Default::default(),
        sections: vec![s(), s()],
        cables: (0..6).map(|j| cable(j % 3, j / 3)).collect(),
        tendons: None,
        friction: None,
    })
    .expect("valid two-section robot")
}

/// Gravity across the rod, three passive cables, tip force `TIP_FORCES[k]`.
fn warm_loads(k: usize) -> Loads {
    Loads {
        gravity_m_s2: GRAVITY_ACROSS,
        point: vec![PointLoad {
            section: 0,
            force_n: TIP_FORCES[k],
            ..Default::default()
        }],
        tensions_n: vec![0.0; 3],
    }
}

/// Gravity across the rod, one tensioned cable per section.
fn tensioned_loads() -> Loads {
    Loads {
        gravity_m_s2: GRAVITY_ACROSS,
        point: Vec::new(),
        tensions_n: vec![1.5, 0.0, 0.0, 0.0, 0.8, 0.0],
    }
}

fn settings(integrator: Integrator, guide_mass: GuideMass, rod_model: RodModel) -> SolverSettings {
    SolverSettings {
        integrator,
        guide_mass,
        rod_model,
        ..Default::default()
    }
}

fn rk4(steps_per_section: usize) -> Integrator {
    Integrator::Rk4 { steps_per_section }
}

fn adaptive(tol: f64) -> Integrator {
    Integrator::Adaptive {
        tol,
        max_steps: 100_000,
    }
}

/// Criterion settings sized so the whole bench takes about two minutes.
fn configure(group: &mut BenchmarkGroup<'_, criterion::measurement::WallTime>, measure_s: f64) {
    group
        .sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs_f64(measure_s));
}

/// Build a workspace for the warm bench and converge each of its loads once.
fn warm_workspace(robot: &Robot, s: SolverSettings, label: &str) -> Workspace {
    let mut ws = Workspace::new(robot.clone(), warm_loads(0), s).expect("valid workspace");
    for k in [0, 1, 2, 0] {
        ws.set_loads(&warm_loads(k)).expect("valid loads");
        let rep = ws.solve(Start::Warm);
        assert!(
            rep.status.is_converged(),
            "{label}: setup solve with tip force {:?} did not converge: {rep:?}",
            TIP_FORCES[k]
        );
    }
    ws
}

/// Time `set_loads` + warm `solve` + `cable_lengths_into`, cycling the tip force.
fn bench_warm(
    group: &mut BenchmarkGroup<'_, criterion::measurement::WallTime>,
    label: String,
    id: BenchmarkId,
    robot: &Robot,
    s: SolverSettings,
) {
    let mut ws = warm_workspace(robot, s, &label);
    let loads = [warm_loads(0), warm_loads(1), warm_loads(2)];
    let mut lengths = vec![0.0; robot.cables().len()];
    let mut k = 0usize;
    let mut not_converged = 0u64;
    group.bench_function(id, |b| {
        b.iter(|| {
            k = (k + 1) % loads.len();
            ws.set_loads(black_box(&loads[k])).expect("valid loads");
            let rep = ws.solve(Start::Warm);
            not_converged += u64::from(!rep.status.is_converged());
            ws.cable_lengths_into(&mut lengths);
            black_box(&lengths);
        })
    });
    if not_converged > 0 {
        eprintln!("WARNING {label}: {not_converged} timed solves did not converge");
    }
}

fn forward_warm(c: &mut Criterion) {
    let robot = single_section_robot();
    let mut group = c.benchmark_group("forward_warm");
    configure(&mut group, 2.0);
    let integrators = [
        ("rk4_8", rk4(8)),
        ("rk4_16", rk4(16)),
        ("rk4_24", rk4(24)),
        ("rk4_48", rk4(48)),
        ("adaptive_1e-6", adaptive(1e-6)),
        ("adaptive_1e-9", adaptive(1e-9)),
    ];
    let masses = [
        ("average", GuideMass::Average),
        ("point", GuideMass::Point),
        ("accurate", GuideMass::Accurate),
    ];
    for (mname, mass) in masses {
        for (iname, integrator) in integrators {
            let s = settings(integrator, mass, RodModel::Cosserat);
            let label = format!("forward_warm/{mname}/{iname}");
            bench_warm(&mut group, label, BenchmarkId::new(mname, iname), &robot, s);
        }
    }
    group.finish();
}

/// Time cold `solve` + `cable_lengths_into` on a fixed workspace.
fn bench_cold(
    group: &mut BenchmarkGroup<'_, criterion::measurement::WallTime>,
    id: &str,
    robot: Robot,
    loads: Loads,
    s: SolverSettings,
) {
    let mut lengths = vec![0.0; robot.cables().len()];
    let mut ws = Workspace::new(robot, loads, s).expect("valid workspace");
    let rep = ws.solve(Start::Cold);
    assert!(rep.status.is_converged(), "{id}: setup cold solve: {rep:?}");
    let mut not_converged = 0u64;
    group.bench_function(id, |b| {
        b.iter(|| {
            let rep = ws.solve(black_box(Start::Cold));
            not_converged += u64::from(!rep.status.is_converged());
            ws.cable_lengths_into(&mut lengths);
            black_box(&lengths);
        })
    });
    if not_converged > 0 {
        eprintln!("WARNING {id}: {not_converged} timed solves did not converge");
    }
}

fn forward_cold_tensioned(c: &mut Criterion) {
    let mut group = c.benchmark_group("forward_cold_tensioned");
    configure(&mut group, 4.0);
    bench_cold(
        &mut group,
        "two_section_rk4_24",
        two_section_robot(),
        tensioned_loads(),
        SolverSettings::default(),
    );
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/scenes/demo_two_section.toml"
    );
    let scene = Scene::load(path).expect("shipped demo scene loads");
    let robot = scene.build_robot().expect("demo scene robot");
    bench_cold(
        &mut group,
        "demo_two_section_scene",
        robot,
        scene.loads,
        scene.numerics,
    );
    group.finish();
}

fn forward_cold_branch_checked(c: &mut Criterion) {
    let mut group = c.benchmark_group("forward_cold_branch_checked");
    configure(&mut group, 6.0);
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/scenes/track_demo.toml");
    let scene = Scene::load(path).expect("shipped track demo loads");
    let robot = scene.build_robot().expect("track demo robot");
    let (l, ei) = (robot.length(), robot.sections()[0].stiffness.bend_twist.x);
    let r = robot.cables()[0].base_hole.norm();
    for (name, angle) in [
        ("track_demo_tension_5", 5.0),
        ("track_demo_tension_7_5", 7.5),
    ] {
        let mut loads = scene.loads.clone();
        loads.tensions_n = vec![angle * ei / (r * l)];
        let s = SolverSettings {
            guide_mass: GuideMass::Point,
            integrator: Integrator::Rk4 {
                steps_per_section: 32,
            },
            ..SolverSettings::default()
        };
        bench_cold(&mut group, name, robot.clone(), loads, s);
    }
    group.finish();
}

fn forward_rod_model(c: &mut Criterion) {
    let robot = single_section_robot();
    let mut group = c.benchmark_group("forward_rod_model");
    configure(&mut group, 2.0);
    for (name, model) in [
        ("cosserat", RodModel::Cosserat),
        ("kirchhoff", RodModel::Kirchhoff),
    ] {
        let s = settings(Integrator::default(), GuideMass::default(), model);
        let label = format!("forward_rod_model/{name}");
        bench_warm(
            &mut group,
            label,
            BenchmarkId::from_parameter(name),
            &robot,
            s,
        );
    }
    group.finish();
}

criterion_group!(
    benches,
    forward_warm,
    forward_cold_tensioned,
    forward_rod_model,
    forward_cold_branch_checked
);
criterion_main!(benches);
