//! No heap allocation per row after warm-up for the load estimator on a tendon robot
//! (`estimate::TendonLoadEstimator::tick`, STYLE.md "Hot paths for a control loop"):
//! a counting `#[global_allocator]` (`tests/alloc_counter`) counts the
//! allocations this thread makes while counting is on (per thread: the tests of
//! this file may run in parallel). A second test counts the tendon solve's rollback.

mod alloc_counter;
use alloc_counter::counted;
use cablesense::estimate::EstimateStatus;
use cablesense::files::load_cells;
use cablesense::Scene;

/// The 40 rows of the shipped demo recording, parsed beforehand; the first 10 warm
/// up (first-row buffers, the first fresh sensitivity sweeps), the other 30 are
/// counted: zero allocations.
#[test]
fn tendon_load_tick_does_not_allocate_after_warm_up() {
    let sc = Scene::load("data/load_cells/tdcr_load_cells.toml").unwrap();
    let mut est = load_cells::estimator(&sc).unwrap();
    let mut p = load_cells::parser(&sc, &mut est);
    let text = std::fs::read_to_string("data/load_cells/tdcr_load_cells.csv").unwrap();
    let rows: Vec<_> = text
        .lines()
        .enumerate()
        .filter_map(|(i, l)| p.line(i + 1, l).unwrap())
        .collect();
    assert_eq!(rows.len(), 40);
    for r in &rows[..10] {
        est.tick(&r.readings_m, &r.tensions_n, None).unwrap();
    }
    let mut statuses = Vec::with_capacity(30);
    let (n, bytes) = counted(|| {
        for r in &rows[10..] {
            statuses.push(est.tick(&r.readings_m, &r.tensions_n, None).unwrap());
        }
    });
    assert!(
        statuses.iter().all(|s| *s == EstimateStatus::Converged),
        "{statuses:?}"
    );
    assert_eq!(n, 0, "{n} allocations ({bytes} bytes) in 30 rows");
}

/// The rollback (`TendonWorkspace::set_rollback`, on by default) adds no allocation:
/// on the FTDCR v4 val rows, after 20 warm-up rows, 60 warm rows with an
/// unreachable row after every 10th allocate nothing, the rows that restore the
/// kept state included. (The unreachable rows themselves are counted apart: the
/// nested fallback they end in is not yet allocation-free.)
#[test]
fn tendon_rollback_does_not_allocate() {
    let scene = Scene::load("data/scenes/ftdcr_v4.toml").unwrap();
    let mut ws = scene.tendon_workspace().unwrap();
    assert!(ws.rollback());
    let mut p = scene.readings_parser(&ws);
    let text = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .enumerate()
        .filter_map(|(i, l)| p.line(i + 1, l).unwrap())
        .map(|r| r.readings_m)
        .collect();
    let bad = [0.05, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    for q in &rows[..20] {
        ws.solve_readings(q).unwrap();
    }
    let (mut good_allocs, mut bad_allocs, mut restored) = (0, 0, 0);
    for (k, q) in rows[20..80].iter().enumerate() {
        let pending = ws.rollback_pending();
        let (n, _) = counted(|| {
            assert!(ws.solve_readings(q).unwrap().status.is_converged());
        });
        good_allocs += n;
        restored += usize::from(pending);
        if k % 10 == 9 {
            let (n, _) = counted(|| {
                assert!(!ws.solve_readings(&bad).unwrap().status.is_converged());
            });
            bad_allocs += n;
            assert!(ws.rollback_pending());
        }
    }
    assert_eq!(restored, 6);
    eprintln!("unreachable rows: {bad_allocs} allocations in 6");
    assert_eq!(good_allocs, 0, "{good_allocs} allocations in 60 rows");
}
