//! Val row 19 of the FTDCR v4 round trip (the model's tip at the recorded readings)
//! from the warm chain's start (rows 0..18, as `tests/ik_alloc.rs` runs them) and
//! from the same readings set afresh: the status and work of each.
//!
//! `cargo run --release --example ik_row19`
use cablesense::command::{IkSettings, IkTarget, IkWorkspace};
use cablesense::Scene;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scene = Scene::load("data/calibration/ftdcr_v4_calibrated.toml")?;
    let text = std::fs::read_to_string("data/hardware/ftdcr_v4/val.csv")?;
    let targets: Vec<IkTarget> = scene
        .model_tips(&text, 20)?
        .into_iter()
        .map(IkTarget::position)
        .collect();
    let mut ik = IkWorkspace::from_scene(&scene, IkSettings::default())?;
    for t in &targets[..19] {
        ik.solve(t)?;
    }
    let start = ik.readings().to_vec();
    println!("start readings (m): {start:?}");
    println!("target: {:?}", targets[19].position_m.as_slice());
    println!("chain: {:?}", ik.solve(&targets[19])?);
    let mut fresh = IkWorkspace::from_scene(&scene, IkSettings::default())?;
    fresh.set_readings(&start)?;
    println!("fresh: {:?}", fresh.solve(&targets[19])?);
    Ok(())
}
