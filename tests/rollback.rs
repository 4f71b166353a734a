//! Rollback in the library (`TendonWorkspace::set_rollback`, on by default): a solve
//! that does not converge is not the next solve's warm start. The FTDCR v4 val rows
//! solved warm with and without a deliberately unreachable row between them give
//! bit-identical results on every good row (the same test runs through the C ABI in
//! `capi/tests/rollback.rs` and through Python in `python/tests`).

use cablesense::statics::Start;
use cablesense::tendons::TendonWorkspace;
use cablesense::Scene;

/// One tendon pulled in 50 mm, the other eight held: the backbone cannot take it
/// up (the FTDCR's tendons are antagonistic), so the solve does not converge.
pub const UNREACHABLE: [f64; 9] = [0.05, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];

/// The val rows of the shipped FTDCR v4 scene, readings in m in the workspace's order.
pub fn val_rows() -> (Scene, Vec<Vec<f64>>) {
    let scene = Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
    let ws = scene.tendon_workspace().expect("workspace");
    let mut p = scene.readings_parser(&ws);
    let text = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv").expect("shipped data");
    let rows = text
        .lines()
        .enumerate()
        .filter_map(|(i, l)| p.line(i + 1, l).ok().flatten())
        .map(|r| r.readings_m)
        .collect();
    (scene, rows)
}

/// What a row gives a caller, as bits: status, tip, tensions, iterations.
pub fn outcome(ws: &TendonWorkspace) -> (String, Vec<u64>, usize) {
    let mut bits: Vec<u64> = ws.tip_position().iter().map(|v| v.to_bits()).collect();
    bits.extend(ws.tensions().iter().map(|v| v.to_bits()));
    let r = ws.report();
    (format!("{:?}", r.status), bits, r.iterations)
}

/// Solve `rows` warm; after row `bad_after` (if any) solve [`UNREACHABLE`] too.
fn run(
    scene: &Scene,
    rows: &[Vec<f64>],
    bad_after: Option<usize>,
    rollback: bool,
) -> Vec<(String, Vec<u64>, usize)> {
    let mut ws = scene.tendon_workspace().expect("workspace");
    ws.set_rollback(rollback);
    let mut out = Vec::with_capacity(rows.len());
    for (i, q) in rows.iter().enumerate() {
        ws.solve_readings(q).expect("valid readings");
        out.push(outcome(&ws));
        if bad_after == Some(i) {
            let rep = ws.solve_readings(&UNREACHABLE).expect("valid readings");
            assert!(!rep.status.is_converged(), "the bad row converged: {rep:?}");
            assert_eq!(ws.rollback_pending(), rollback);
        }
    }
    out
}

#[test]
fn a_failed_row_leaves_the_following_rows_bit_identical() {
    let (scene, rows) = val_rows();
    assert!(rows.len() > 400, "{} val rows", rows.len());
    let clean = run(&scene, &rows, None, true);
    let converged = clean.iter().filter(|o| o.0 == "Converged").count();
    // three unreachable rows: early, middle, late
    for bad in [5, rows.len() / 2, rows.len() - 3] {
        let faulty = run(&scene, &rows, Some(bad), true);
        for (i, (a, b)) in clean.iter().zip(&faulty).enumerate() {
            assert_eq!(a, b, "row {i} differs after the bad row at {bad}");
        }
    }
    // the rows after a failed one differ without the rollback (what the test
    // guards against; 417 of 443 converged there before the rollback)
    let poisoned = run(&scene, &rows, Some(5), false);
    let differ = clean
        .iter()
        .zip(&poisoned)
        .skip(6)
        .filter(|(a, b)| a != b)
        .count();
    assert!(differ > 0, "no row differs without the rollback");
    eprintln!(
        "{} val rows, {converged} converged; without the rollback {differ} rows after the bad one differ",
        rows.len()
    );
}

/// A cold solve after a failed one starts from the same state too, and the
/// failed attempt stays readable until the next solve.
#[test]
fn the_failed_attempt_is_readable_until_the_next_solve() {
    let (scene, rows) = val_rows();
    let mut ws = scene.tendon_workspace().expect("workspace");
    let mut clean = scene.tendon_workspace().expect("workspace");
    for q in &rows[..10] {
        ws.solve_readings(q).unwrap();
        clean.solve_readings(q).unwrap();
    }
    let good_tip = ws.tip_position();
    let rep = ws.solve_readings(&UNREACHABLE).unwrap();
    assert!(!rep.status.is_converged());
    assert_eq!(ws.report(), &rep);
    assert_ne!(
        ws.tip_position(),
        good_tip,
        "the failed attempt is readable"
    );
    ws.apply_rollback();
    assert!(!ws.rollback_pending());
    assert_eq!(ws.tip_position(), good_tip, "rolled back");
    let a = ws.solve_readings_from(&rows[10], Start::Cold).unwrap();
    let b = clean.solve_readings_from(&rows[10], Start::Cold).unwrap();
    assert_eq!(a, b);
    assert_eq!(ws.tip_position(), clean.tip_position());
}

/// What the rollback's copy costs per row: the 443 val rows solved warm with the
/// rollback on and off, alternated (`cargo test --release --test integration
/// rollback_cost -- --ignored --nocapture`; figures in docs/control-loop.md).
#[test]
#[ignore]
fn rollback_cost() {
    let (scene, rows) = val_rows();
    let mut on = scene.tendon_workspace().expect("workspace");
    let mut off = scene
        .tendon_workspace()
        .expect("workspace")
        .without_rollback();
    let (mut t_on, mut t_off) = (Vec::new(), Vec::new());
    for _ in 0..6 {
        for (ws, t) in [(&mut on, &mut t_on), (&mut off, &mut t_off)] {
            let t0 = std::time::Instant::now();
            for q in &rows {
                ws.solve_readings(q).expect("valid readings");
            }
            t.push(t0.elapsed().as_secs_f64() / rows.len() as f64 * 1e6);
        }
    }
    // the copy alone: restore the kept state after an unreachable row, 50 times
    let mut copy = Vec::new();
    for _ in 0..50 {
        on.solve_readings(&UNREACHABLE).expect("valid readings");
        let t0 = std::time::Instant::now();
        on.apply_rollback();
        copy.push(t0.elapsed().as_secs_f64() * 1e6);
    }
    copy.sort_by(f64::total_cmp);
    eprintln!(
        "one copy of the warm state: median {:.1} us, min {:.1} us",
        copy[25], copy[0]
    );
    t_on.sort_by(f64::total_cmp);
    t_off.sort_by(f64::total_cmp);
    eprintln!(
        "us per warm row, median of 6 passes over {} rows: rollback on {:.1}, off {:.1} (on {t_on:.1?}, off {t_off:.1?})",
        rows.len(),
        t_on[3],
        t_off[3]
    );
}
