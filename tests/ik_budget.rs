//! The cost of inverse-kinematics calls over long warm chains on the calibrated
//! FTDCR v4 (`command::ik`, module docs "Budget"): with
//! `IkSettings::max_solve_passes` set to 128, every forward solve of a call stays
//! within it, also where
//! the readings have drifted into the co-contraction that makes forward solves
//! hard.

use cablesense::command::{IkSettings, IkStatus, IkTarget, IkWorkspace};
use cablesense::Scene;

/// The budget measured on the FTDCR v4 (`command::ik` module docs, "Budget").
const BUDGET: usize = 128;

fn setup() -> (Scene, Vec<IkTarget>) {
    super::ftdcr_targets(usize::MAX)
}

/// IK on `scene` with [`BUDGET`] passes a forward solve: the workspace, the budget
/// and the call's `max_forward_solves`.
fn budgeted(scene: &Scene) -> (IkWorkspace, usize, usize) {
    let settings = IkSettings {
        max_solve_passes: Some(BUDGET),
        ..IkSettings::default()
    };
    let solves = settings.max_forward_solves;
    (
        IkWorkspace::from_scene(scene, settings).unwrap(),
        BUDGET,
        solves,
    )
}

/// Val rows 171-185 warm from the co-contracted readings a 20-walk chain had
/// reached at row 170 (`examples/ik_tick_profile.rs 20`, walk 16; printed to 1e-9
/// m; sum 24.0 mm, tensions 0.7-9.3 N). On that chain, without a budget, the
/// next tick's trial solves took 313-973 passes, 4 077 in the call (4.8 s). Every
/// forward solve now stops at its budget (`peak_passes`: under the cap-only policy
/// a solve is the unbudgeted one up to the cap, so a peak at the cap is a solve
/// that ran longer before).
#[test]
fn co_contracted_start_stays_within_budget() {
    let (scene, targets) = setup();
    let (mut ik, budget, solves) = budgeted(&scene);
    let q_mm = [
        4.019590, 2.209607, 0.012514, 3.142521, 3.109778, 0.707683, 5.281516, 2.290426, 3.264487,
    ];
    let q: Vec<f64> = q_mm.iter().map(|v| v * 1e-3).collect();
    ik.set_readings(&q).unwrap();
    let (mut peak, mut capped, mut reached) = (0usize, 0, 0);
    for t in &targets[171..=185] {
        let r = ik.solve(t).unwrap();
        let sum: f64 = ik.readings().iter().sum::<f64>() * 1e3;
        eprintln!(
            "{} {:.2e} m, sum q {sum:.3} mm, passes {} (peak {})",
            r.status.name(),
            r.distance_m,
            r.passes,
            r.peak_passes
        );
        assert!(
            r.peak_passes <= budget && r.passes <= solves * budget,
            "{r:?}"
        );
        peak = peak.max(r.peak_passes);
        capped += usize::from(r.peak_passes == budget);
        reached += usize::from(r.status == IkStatus::Reached);
    }
    eprintln!(
        "15 ticks: peak {peak} passes, {capped} calls with a solve at the cap, {reached} reached"
    );
}

/// Four walks over the val rows (forward, back, forward, back: 1 768 warm
/// ticks): no forward solve exceeds `max_solve_passes`, a call's passes stay
/// within `max_forward_solves` times that, and the calls end reached.
#[test]
fn long_warm_chain_stays_within_budget() {
    let (scene, targets) = setup();
    let (mut ik, budget, solves) = budgeted(&scene);
    let n = targets.len();
    let (mut ticks, mut reached, mut peak, mut total) = (0, 0, 0usize, 0usize);
    let mut per_call = Vec::new();
    for walk in 0..4 {
        for j in 0..n - 1 {
            let k = if walk % 2 == 0 { j } else { n - 1 - j };
            let r = ik.solve(&targets[k]).unwrap();
            assert!(
                r.peak_passes <= budget && r.passes <= solves * budget,
                "walk {walk} row {k}: {r:?}"
            );
            ticks += 1;
            reached += usize::from(r.status == IkStatus::Reached);
            peak = peak.max(r.peak_passes);
            total += r.passes;
            per_call.push(r.passes);
        }
    }
    per_call.sort_unstable();
    eprintln!(
        "{ticks} ticks, {reached} reached; passes per call p50 {} p99 {} max {}, mean {:.2}; peak of one solve {peak}",
        per_call[ticks / 2],
        per_call[ticks * 99 / 100],
        per_call[ticks - 1],
        total as f64 / ticks as f64
    );
    assert!(
        reached * 1000 >= ticks * 995,
        "{reached} of {ticks} reached"
    );
}

/// The budget is validated like the other settings.
#[test]
fn solve_pass_budget_is_validated() {
    let (scene, _) = setup();
    for v in [0, 100_001] {
        let bad = IkSettings {
            max_solve_passes: Some(v),
            ..IkSettings::default()
        };
        let e = IkWorkspace::from_scene(&scene, bad)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("ik.max_solve_passes"), "{e}");
    }
}
