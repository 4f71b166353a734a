//! No heap allocation per row after warm-up for the load estimator on a tendon robot
//! (`estimate::TendonLoadEstimator::tick`, STYLE.md "Hot paths for a control loop"):
//! a counting `#[global_allocator]` (`tests/alloc_counter`) counts the
//! allocations this thread makes while counting is on. One test only in this file
//! (the allocator is process-wide).

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
