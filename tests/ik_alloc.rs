//! What a warm inverse-kinematics tick allocates: a counting `#[global_allocator]`
//! (`tests/alloc_counter`). Nothing: the step's QP is solved by the active-set
//! method of `command::ik` (clarabel 0.11's `solve` allocates once per call, a map
//! of its timers, and is only the fallback; at 4a5f184, clarabel on every step,
//! this count was 186 in the same 40 ticks). One test only in this file (the
//! allocator's counts are process-wide).

mod alloc_counter;
use alloc_counter::counted;
use cablesense::command::{IkSettings, IkStatus, IkTarget, IkWorkspace};
use cablesense::Scene;

/// On the calibrated FTDCR v4, targets = the model's tips at consecutive val rows:
/// after 10 warm-up ticks, 40 warm ticks (each from the previous tick's readings)
/// allocate nothing, no step falls back to clarabel, and every tick is reached (val
/// row 19 ended 14 um away as `unreachable` before the taut/slack boundary was
/// treated as a kink, `tests/ik_boundary.rs`).
#[test]
fn warm_ik_tick_allocates_nothing() {
    let scene = Scene::load("data/calibration/ftdcr_v4_calibrated.toml").unwrap();
    let text = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").unwrap();
    let targets: Vec<IkTarget> = scene
        .model_tips(&text, 50)
        .unwrap()
        .into_iter()
        .map(IkTarget::position)
        .collect();
    let mut ik = IkWorkspace::from_scene(&scene, IkSettings::default()).unwrap();
    for t in &targets[..10] {
        ik.solve(t).unwrap();
    }
    // the counter sees an allocation (a zero count below is not a dead counter)
    let (probe, _) = counted(|| {
        std::hint::black_box(vec![1u8; 16]);
    });
    assert!(probe >= 1, "the counting allocator counted {probe}");
    let (mut allocs, mut qps, mut fallbacks) = (0, 0, 0);
    let mut reached = 0;
    for t in &targets[10..] {
        let mut r = None;
        let (n, _) = counted(|| r = Some(ik.solve(t).unwrap()));
        let r = r.unwrap();
        allocs += n;
        qps += r.qp_solves;
        fallbacks += r.qp_fallbacks;
        reached += usize::from(r.status == IkStatus::Reached);
        if r.status != IkStatus::Reached {
            eprintln!("not reached: {r:?}");
        }
    }
    eprintln!("40 warm ticks: {allocs} allocations, {qps} QP solves ({fallbacks} by clarabel), {reached} reached");
    assert_eq!(fallbacks, 0, "steps solved by clarabel");
    assert_eq!(allocs, 0, "allocations in 40 warm ticks");
    assert_eq!(reached, 40, "{reached} of 40 reached");
}
