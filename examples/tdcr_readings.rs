//! Solve the shipped FTDCR v4 scene from its validation recording and print the
//! model tip beside the measured one (no calibration: the scene's starting values).
//!
//! `cargo run --release --example tdcr_readings [SCENE] [READINGS] [ROWS]`
use cablesense::Scene;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let scene_path = args.get(1).map_or("data/scenes/ftdcr_v4.toml", |s| s);
    let data = args.get(2).map_or("data/hardware/ftdcr_v4/val.csv", |s| s);
    let rows: usize = args.get(3).map_or(Ok(usize::MAX), |s| s.parse())?;
    let scene = Scene::load(scene_path)?;
    let t0 = Instant::now();
    let mut ws = scene.tendon_workspace()?;
    println!("reference solve + setup: {:?}", t0.elapsed());
    let mut parser = scene.readings_parser(&ws);
    let text = std::fs::read_to_string(data)?;
    let mut n = 0;
    let mut times = Vec::new();
    for (i, line) in text.lines().enumerate() {
        match parser.line(i + 1, line) {
            Ok(Some(row)) => {
                let t = Instant::now();
                let rep = ws.solve_readings(&row.readings_m)?;
                times.push(t.elapsed().as_secs_f64());
                let tip = ws.tip_position();
                let m = row.measured_tip_m.unwrap_or([f64::NAN; 3]);
                println!(
                    "line {:4} {:?} it {} fw {} slack {} tip [{:7.2} {:7.2} {:7.2}] mm measured [{:7.2} {:7.2} {:7.2}] T {:?}",
                    row.line,
                    rep.status,
                    rep.iterations,
                    rep.forward_solves,
                    rep.slack,
                    tip.x * 1e3,
                    tip.y * 1e3,
                    tip.z * 1e3,
                    m[0] * 1e3,
                    m[1] * 1e3,
                    m[2] * 1e3,
                    ws.tensions().iter().map(|t| (t * 100.0).round() / 100.0).collect::<Vec<_>>()
                );
                n += 1;
                if n >= rows {
                    break;
                }
            }
            Ok(None) => {}
            Err(e) => println!("{e}"),
        }
    }
    times.sort_by(f64::total_cmp);
    if !times.is_empty() {
        println!(
            "{} rows, median {:.1} us, p95 {:.1} us, max {:.1} us",
            times.len(),
            times[times.len() / 2] * 1e6,
            times[times.len() * 95 / 100] * 1e6,
            times[times.len() - 1] * 1e6
        );
    }
    Ok(())
}
