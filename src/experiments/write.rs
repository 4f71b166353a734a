//! CSV files of the experiments (`pareto.csv`, `stability.csv`), to any writer.

use super::front;
use super::pareto::ParetoRow;
use super::stability::{PointKind, StabilityPoint};
use std::io::Write;

/// `pareto.csv`: one line per row, with whether the row is on its scene's Pareto front
/// of (warm solve time, tip error) and of (warm solve time, cable error).
pub fn pareto_csv(mut f: impl Write, rows: &[ParetoRow]) -> std::io::Result<()> {
    writeln!(
        f,
        "scene,rung,family,loads_converged,loads_total,tip_err_m,cable_err_m,cold_solve_s,warm_solve_s,estimator_tick_s,estimate_err_n,observed_rms_err_m,on_tip_front,on_cable_front"
    )?;
    let mut by_scene: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    by_scene.dedup();
    for s in by_scene {
        let sub: Vec<&ParetoRow> = rows.iter().filter(|r| r.scene == s).collect();
        let ft = front(
            &sub.iter()
                .map(|r| (r.warm_s, r.tip_err))
                .collect::<Vec<_>>(),
        );
        let fc = front(
            &sub.iter()
                .map(|r| (r.warm_s, r.cable_err))
                .collect::<Vec<_>>(),
        );
        for (i, r) in sub.iter().enumerate() {
            writeln!(
                f,
                "{},{},{},{},{},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{},{}",
                r.scene,
                r.rung.label(),
                r.rung.family(),
                r.loads_converged,
                r.loads_total,
                r.tip_err,
                r.cable_err,
                r.cold_s,
                r.warm_s,
                r.tick_s,
                r.est_err,
                r.obs_err,
                ft.contains(&i),
                fc.contains(&i)
            )?;
        }
    }
    f.flush()
}

/// `stability.csv`: one line per map point.
pub fn stability_csv(mut f: impl Write, points: &[StabilityPoint]) -> std::io::Result<()> {
    writeln!(
        f,
        "kind,method,start,direction,magnitude_nondim,status,outcome,iterations,residual,error,error_unit,time_s"
    )?;
    for p in points {
        writeln!(
            f,
            "{},{},{},{},{},{},{:?},{},{:e},{:e},{},{:e}",
            p.kind.as_str(),
            p.method,
            p.start.as_str(),
            p.dir.short(),
            p.magnitude,
            p.status,
            p.outcome,
            p.iterations,
            p.residual,
            p.error,
            if p.kind == PointKind::Forward {
                "m (tip)"
            } else {
                "EI/L^2 (force)"
            },
            p.time_s
        )?;
    }
    f.flush()
}
