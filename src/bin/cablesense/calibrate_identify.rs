//! `cablesense calibrate --identify PULL.csv [SCENE]`: the servo-to-tendon mapping
//! and per-segment angle offsets proposed from a single-tendon pull recording
//! (`cablesense::calibrate::identify`); this file only prints.

use cablesense::calibrate::{identify, IdentifyResult, IdentifySettings};
use cablesense::files::demo::DataRef;
use cablesense::Scene;
use std::path::Path;
use std::process::ExitCode;

/// Default scene: the embedded FTDCR v4.
const DEFAULT_SCENE: &str = "demo:scenes/ftdcr_v4.toml";

/// Run the identification of `file` against `scene` (default the FTDCR v4).
pub fn run(file: &Path, scene: Option<&Path>) -> anyhow::Result<ExitCode> {
    let scene_ref = DataRef::parse(scene.unwrap_or(Path::new(DEFAULT_SCENE)))?;
    let scene = scene_ref.scene()?;
    let data = DataRef::parse(file)?;
    let text = data.read()?;
    let r = identify(&scene, &data.display(), &text, &IdentifySettings::default())?;
    print(&r, &scene, &scene_ref.display());
    println!("{}", r.toml_snippet(&scene)?);
    Ok(ExitCode::SUCCESS)
}

fn print(r: &IdentifyResult, scene: &Scene, scene_name: &str) {
    println!("identify: {} against the model of {scene_name}", r.file);
    println!(
        "  per servo: measured response (lateral tip per mm of pull, direction in the base xy plane), \
         and the RMS of the model's tip path per segment after the best rotation about the axis"
    );
    let segs: Vec<String> = r
        .segments
        .iter()
        .map(|s| format!("seg{} mm", s.section))
        .collect();
    println!(
        "  {:<12} {:>4} {:>8} {:>7} {:>5} | {} | {:>7} {:>6} {:>9} {:>10}",
        "servo",
        "rows",
        "dir deg",
        "mm/mm",
        "R^2",
        segs.iter()
            .map(|s| format!("{s:>9}"))
            .collect::<Vec<_>>()
            .join(" "),
        "segment",
        "cable",
        "angle deg",
        "misfit deg"
    );
    for s in &r.servos {
        let name = scene.robot.cables[s.cable]
            .name
            .clone()
            .unwrap_or_else(|| s.cable.to_string());
        println!(
            "  {:<12} {:>4} {:>8.1} {:>7.2} {:>5.2} | {} | {:>7} {:>6} {:>9.1} {:>10.1}{}",
            s.column,
            s.rows,
            s.linear.angle_rad.to_degrees(),
            s.linear.gain,
            s.linear.r2,
            s.rms_m
                .iter()
                .map(|x| format!("{:>9.2}", x * 1e3))
                .collect::<Vec<_>>()
                .join(" "),
            r.segments[s.segment].section,
            name,
            s.angle_deg[s.segment].rem_euclid(360.0),
            s.angle_misfit_deg,
            match s.next_best {
                Some((i, ratio)) if ratio < 1.0 => format!(
                    "  (segment {} fits its path better alone: {:.0} % of the RMS; placed by the others)",
                    r.segments[i].section,
                    ratio * 100.0
                ),
                Some((i, ratio)) if ratio < 1.2 => format!(
                    "  (ambiguous with segment {}: RMS ratio {:.2})",
                    r.segments[i].section, ratio
                ),
                _ => String::new(),
            }
        );
    }
    println!(
        "  per segment: proposed angle of its first tendon, the scene's, and the offset to add"
    );
    for s in &r.segments {
        println!(
            "    section {}: servos [{}], first tendon at {:.1} deg (scene {:.1} deg), offset {:+.1} deg",
            s.section,
            s.servos
                .iter()
                .map(|&v| r.servos[v].column.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            s.first_angle_deg.rem_euclid(360.0),
            s.scene_first_angle_deg.rem_euclid(360.0),
            s.offset_deg
        );
    }
    for w in &r.swaps {
        println!(
            "  swapping the servo groups of sections {} and {} costs {:+.1} (cost units: (RMS / 2 mm)^2 + (misfit / 10 deg)^2){}",
            r.segments[w.segments.0].section,
            r.segments[w.segments.1].section,
            w.margin,
            if w.margin < 4.0 { "  AMBIGUOUS" } else { "" }
        );
    }
    println!(
        "  total cost {:.1}; the proposal {} the scene's mapping",
        r.cost,
        if r.mapping_matches(scene) {
            "equals"
        } else {
            "differs from"
        }
    );
    println!("  note: equally spaced tendons of one segment can be relabelled cyclically at the same cost; the relabelling closest to the scene's angles is shown");
    println!("\n# proposed [[robot.cables]] (paste over the scene's cables)");
}
