//! No heap allocation per sample after warm-up (STYLE.md, "Hot paths for a control
//! loop"): a counting `#[global_allocator]` wraps the system allocator and counts
//! allocations (and bytes) made by this thread while counting is switched on.
//!
//! One test only in this file: the allocator is process-wide and cargo runs the
//! tests of a file on parallel threads. The on/off flag is thread-local as well,
//! so the harness's own threads are never counted.

mod common;
mod estimate_common;

mod alloc_counter;
use alloc_counter::counted;
use cablesense::estimate::{EstimateSpec, EstimateStatus, Method};
use estimate_common::*;

const WARM_UP: usize = 5;
const TICKS: usize = 100;

/// Single section, five guides, three passive cables, horizontal under gravity,
/// unknown tip force y, z (problem (a)). For Levenberg-Marquardt and Gauss-Newton,
/// with reused sensitivities (the default) and fresh ones every iteration (so that
/// the dual-number sensitivity sweep runs inside the counted ticks too): after 5
/// warm-up ticks, 100 ticks with varying measured changes (slowly varying tip
/// force up to 0.05 N; every 7th tick with cable 1 missing, every 5th with
/// per-cable sigma) allocate 0 times and 0 bytes. Afterwards every counted tick
/// must have converged to the true loads (1e-8 N + 1e-6 relative, as the round
/// trip), so the counted ticks did real work.
#[test]
fn ticks_do_not_allocate_after_warm_up() {
    // the counter sees allocations (a vector of 10 bytes: one allocation)
    let seen = counted(|| {
        std::hint::black_box(vec![1u8; 10]);
    });
    assert_eq!(seen, (1, 10), "counting allocator self-check");

    let pb = problem_a();
    let reference = pb.reference_lengths();
    let samples: Vec<(Vec<f64>, Vec<f64>)> = (0..WARM_UP + TICKS)
        .map(|i| {
            let t = i as f64;
            let theta = vec![0.05 * (t / 10.0).sin(), 0.04 * (t / 7.0).cos()];
            let (mut changes, _) = pb.measure(&theta, &reference).expect("forward");
            if i % 7 == 3 {
                changes[1] = f64::NAN;
            }
            (theta, changes)
        })
        .collect();
    let sigma = [1e-5, 2e-5, 1.5e-5];
    for method in [Method::LevenbergMarquardt, Method::GaussNewton] {
        for reuse in [true, false] {
            let mut est = pb.estimator(EstimateSpec {
                reuse_jacobian: reuse,
                ..pb.spec(method)
            });
            let mut status = [EstimateStatus::NoData; TICKS];
            let mut values = [[0.0; 2]; TICKS];
            for (_, changes) in &samples[..WARM_UP] {
                est.tick(changes, None);
            }
            let (count, bytes) = counted(|| {
                for (i, (_, changes)) in samples[WARM_UP..].iter().enumerate() {
                    let s = (i % 5 == 0).then_some(&sigma[..]);
                    status[i] = est.tick(changes, s);
                    values[i].copy_from_slice(est.theta());
                }
            });
            assert_eq!(
                (count, bytes),
                (0, 0),
                "{method:?} reuse_jacobian = {reuse}: {count} allocations, {bytes} bytes in {TICKS} ticks"
            );
            for i in 0..TICKS {
                let what = format!("{method:?} reuse {reuse} tick {i}");
                assert_eq!(status[i], EstimateStatus::Converged, "{what}");
                Tol::both(1e-8, 1e-6).check(&what, &values[i], &samples[WARM_UP + i].0);
            }
        }
    }
}
