//! The tendon solve's rollback (`TendonWorkspace::set_rollback`, on by default)
//! allocates nothing: a counting `#[global_allocator]` (`tests/alloc_counter`).
//! One test only in this file (the allocator's counts are process-wide).

mod alloc_counter;
use alloc_counter::counted;
use cablesense::Scene;

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
    assert_eq!(restored, 5, "rows after an unreachable one");
    eprintln!("unreachable rows: {bad_allocs} allocations in 6");
    assert_eq!(good_allocs, 0, "{good_allocs} allocations in 60 rows");

    // under a work budget (`numerics.tendons.max_passes`) the unreachable rows end
    // with `budget_exhausted` and allocate nothing either, nor do the rows after them
    // (both take the budget's cold path from the reference when the warm one hands
    // back: its kept Jacobian's buffers are sized at construction)
    ws.set_tendon_settings(cablesense::tendons::TendonSettings {
        max_passes: Some(BUDGET),
        ..*ws.tendon_settings()
    })
    .unwrap();
    let (mut allocs, mut bad_counts, mut exhausted) = (0, Vec::new(), 0);
    for (k, q) in rows[80..140].iter().enumerate() {
        let (n, _) = counted(|| {
            ws.solve_readings(q).unwrap();
        });
        allocs += n;
        if k % 10 == 9 {
            let mut status = None;
            let (n, _) = counted(|| status = Some(ws.solve_readings(&bad).unwrap().status));
            bad_counts.push(n);
            exhausted += usize::from(status == Some(cablesense::SolveStatus::BudgetExhausted));
        }
    }
    eprintln!("budgeted unreachable rows: allocations {bad_counts:?}");
    assert_eq!(exhausted, 6, "unreachable rows ended by the budget");
    assert_eq!(allocs, 0, "{allocs} allocations in 60 budgeted rows");
    assert_eq!(
        bad_counts, [0; 6],
        "allocations in the budgeted unreachable rows"
    );
}

/// Rod evaluations a call may run in the budgeted part of the test.
const BUDGET: usize = 8;
