//! No heap allocation per row after warm-up for the load estimator on a tendon robot
//! (`estimate::TendonLoadEstimator::tick`, STYLE.md "Hot paths for a control loop"):
//! a counting `#[global_allocator]` (as in `tests/estimate_alloc.rs`) counts the
//! allocations this thread makes while counting is on. One test only in this file
//! (the allocator is process-wide).

use cablesense::estimate::EstimateStatus;
use cablesense::files::load_cells;
use cablesense::Scene;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);
static BYTES: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    // const-initialised, no destructor: reading it never allocates
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

fn record(bytes: usize) {
    if COUNTING.try_with(Cell::get).unwrap_or(false) {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        BYTES.fetch_add(bytes, Ordering::Relaxed);
    }
}

// SAFETY: every call is forwarded unchanged to `System`; counting has no effect on
// the returned memory.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        record(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        record(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        record(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Run `f` with counting on; `(allocations, bytes)` it made on this thread.
fn counted(f: impl FnOnce()) -> (usize, usize) {
    let (a0, b0) = (
        ALLOCATIONS.load(Ordering::Relaxed),
        BYTES.load(Ordering::Relaxed),
    );
    COUNTING.with(|c| c.set(true));
    f();
    COUNTING.with(|c| c.set(false));
    (
        ALLOCATIONS.load(Ordering::Relaxed) - a0,
        BYTES.load(Ordering::Relaxed) - b0,
    )
}

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
