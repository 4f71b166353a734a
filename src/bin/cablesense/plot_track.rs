//! `track --plot DIR`: the estimated tip path and the last estimated shape.

use crate::stream::SceneEstimator;
use anyhow::Context;
use cablesense::files::svg::{Figure, Item, Marker, Unit, THREE_VIEWS};
use cablesense::nalgebra::Vector3;
use cablesense::Start;
use std::path::Path;

/// Write `dir/track.svg`.
pub fn write(
    dir: &Path,
    scene: &Path,
    est: &mut SceneEstimator,
    tips: Vec<Vector3<f64>>,
) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let n = tips.len();
    let mut fig = Figure::new(
        format!("{}: estimated tip path over {n} samples", scene.display()),
        Unit::Mm,
        &THREE_VIEWS,
    );
    // the shape at the last estimate: the rod models keep their full solution
    if let Some(ws) = est.model().workspace_mut() {
        if !ws.solve(Start::Warm).status.is_converged() {
            eprintln!("note: the last estimated shape did not re-solve; drawing the tip path only");
        } else {
            let sol = ws.solution();
            let robot = ws.robot().clone();
            fig.add_solution(&robot, &sol, "rgb(20,20,20)");
        }
    } else {
        let robot = est.model().robot().clone();
        let mut chain = vec![*robot.base_position()];
        chain.extend(est.model().section_tips().iter().map(|p| p.position));
        fig.items.push(Item::Curve {
            points: chain,
            colour: "rgb(20,20,20)".into(),
            width: 2.0,
            closed: false,
        });
        eprintln!("note: curvature rungs have no backbone samples; drawing base, section ends and the tip path");
    }
    if let Some(first) = tips.first() {
        fig.items.push(Item::Marker {
            at: *first,
            shape: Marker::Dot,
            colour: "rgb(200,40,40)".into(),
            size: 3.0,
        });
    }
    fig.add_path(
        tips,
        "rgb(200,40,40)",
        "estimated tip path (dot: first sample, cross: last)",
    );
    let path = dir.join("track.svg");
    std::fs::write(&path, fig.to_svg()).with_context(|| format!("writing {}", path.display()))?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
