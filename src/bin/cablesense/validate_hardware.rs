//! `cablesense validate`'s hardware part: the stored FTDCR v4 and daru calibrations
//! on their held-out rows beside the published models and the model ladder's rungs.

use std::path::Path;

/// The hardware benchmark: the stored FTDCR v4 calibration on val.csv (and its train
/// rows) beside the published model. Returns whether every check passed.
pub fn print_hardware(svg: Option<&Path>) -> anyhow::Result<bool> {
    use cablesense::calibrate::{ErrorStats, TipErrors};
    use cablesense::validation::{shipped_hardware_benchmark, HardwareSettings};
    let settings = HardwareSettings::default();
    let b = shipped_hardware_benchmark(&settings)?;
    let len = b.robot_length_m;
    println!();
    println!("Hardware benchmark: FTDCR v4 (data/hardware/ftdcr_v4), stored calibration data/calibration/ftdcr_v4_calibrated.toml");
    println!(
        "  tip from the servo readings alone, base frame; robot length {:.1} mm; stored fit: {:?} after {} LM iterations",
        len * 1e3,
        b.stored.status,
        b.stored.iterations
    );
    println!(
        "  {:<46} {:>6} {:>9} {:>9} {:>9} {:>9} {:>8}",
        "split, metric", "rows", "RMSE mm", "median", "p95", "max", "RMSE %L"
    );
    let line = |name: &str, e: &ErrorStats| {
        println!(
            "  {:<46} {:>6} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>8.2}",
            name,
            e.count,
            e.rmse_m * 1e3,
            e.median_m * 1e3,
            e.p95_m * 1e3,
            e.max_m * 1e3,
            e.rmse_m / len * 100.0
        )
    };
    let split = |name: &str, e: &TipErrors| {
        line(&format!("{name}, raw"), &e.raw);
        line(&format!("{name}, mean offset removed"), &e.mean_removed);
    };
    split("val (held out)", &b.val);
    if let Some(t) = &b.track {
        split("val, track chain (warm, as `track`)", &t.errors);
    }
    if let Some(t) = &b.train {
        split(
            &format!("train (fit rows, 1 in {})", settings.train_stride),
            t,
        );
    }
    let p = b.published;
    println!(
        "  {:<46} {:>6} {:>9.2} {:>9} {:>9} {:>9} {:>8.2}",
        "published model, val, offset rm.",
        443,
        p.val_rmse_m * 1e3,
        "-",
        "-",
        "-",
        p.val_rmse_m / p.robot_length_m * 100.0
    );
    println!(
        "  {:<46} {:>6} {:>9.2} {:>9} {:>9} {:>9} {:>8.2}",
        "published model, train, offset rm.",
        1620,
        p.train_rmse_m * 1e3,
        "-",
        "-",
        "-",
        p.train_rmse_m / p.robot_length_m * 100.0
    );
    println!(
        "  (train rows here are every 5th of the 1620 rows the calibration fitted, so in-sample; the published train figure is over all 1620)"
    );
    let stored = b.stored.val.mean_removed.rmse_m;
    println!(
        "  checks: every row solved: {} ({} failed); val RMSE {:.3} mm reproduces the stored {:.3} mm within {:.0} %: {}; below the published {:.1} mm: {}",
        yes(b.failed_rows.is_empty()),
        b.failed_rows.len(),
        b.val.mean_removed.rmse_m * 1e3,
        stored * 1e3,
        settings.stored_tolerance * 100.0,
        yes(b.reproduces_stored()),
        p.val_rmse_m * 1e3,
        yes(b.beats_published())
    );
    if let Some(t) = &b.track {
        println!(
            "  track chain on val: {} rows, {} not converged, {:.2} ms a row; RMSE {:.3} mm against the calibrated solve's {:.3} mm (within {:.0} %: {})",
            t.rows,
            t.not_converged,
            t.mean_row_s * 1e3,
            t.errors.mean_removed.rmse_m * 1e3,
            b.val.mean_removed.rmse_m * 1e3,
            settings.track_tolerance * 100.0,
            yes(b.track_agrees())
        );
    }
    for f in b.failed_rows.iter().take(5) {
        println!("  failed: {f}");
    }
    println!("  stored report: data/calibration/ftdcr_v4_report.svg");
    if let Some(path) = svg {
        cablesense::calibrate::write_report_svg(
            path,
            &b.as_report(),
            &cablesense::calibrate::SvgOptions {
                title: "FTDCR v4: stored calibration, recomputed (validate)".into(),
                input: None,
            },
        )?;
        println!("  figure: {}", path.display());
    }
    Ok(b.passed())
}

/// One robot's Cosserat-against-CC comparison (every held-out row counted).
pub fn print_rungs(c: &cablesense::validation::RungComparison, target: f64) {
    use cablesense::validation::RangeCheck;
    let len = c.robot_length_m;
    println!();
    println!(
        "  {}: held out {} rows, Cosserat solved {} / {}{}",
        c.robot,
        c.val_rows,
        c.val_solved,
        c.val_rows,
        if c.substituted.is_empty() {
            String::new()
        } else {
            format!(
                "; {} unsolved rows scored with the CC rung's prediction (counted, not dropped)",
                c.substituted.len()
            )
        }
    );
    println!(
        "  {:<40} {:>12} {:>10} {:>8} {:>12}",
        "model, held out", "RMSE mm", "raw mm", "%L", "p95 mm"
    );
    let line = |name: &str, e: &cablesense::calibrate::TipErrors| {
        println!(
            "  {:<40} {:>12.3} {:>10.3} {:>8.2} {:>12.3}",
            name,
            e.mean_removed.rmse_m * 1e3,
            e.raw.rmse_m * 1e3,
            e.mean_removed.rmse_m / len * 100.0,
            e.mean_removed.p95_m * 1e3
        )
    };
    line("Cosserat (stored calibration)", &c.cosserat);
    line("CC rung (fitted here, train rows)", &c.cc);
    println!(
        "  ratio Cosserat / CC: {:.3} (mean offset removed), {:.3} (raw); target <= {target}: {}",
        c.ratio(),
        c.ratio_raw(),
        yes(c.ratio() <= target)
    );
    println!(
        "  CC rung fit: {} train rows, {}, train RMSE {:.3} mm; {:.1} s (Cosserat held-out rows {:.1} s)",
        c.cc_train_rows,
        c.cc_status,
        c.cc_train.mean_removed.rmse_m * 1e3,
        c.seconds.1,
        c.seconds.0
    );
    let values = |title: &str, v: &[RangeCheck]| {
        println!("  {title}:");
        for r in v {
            let range = format!(
                "[{}, {}]",
                r.min.map_or("-".into(), |m| format!("{m:.4e}")),
                r.max.map_or("-".into(), |m| format!("{m:.4e}"))
            );
            println!(
                "    {:<42} {:>13.6e} {:>11} range {:<26} {}",
                r.name,
                r.value,
                r.std_error
                    .filter(|s| s.is_finite())
                    .map_or("".into(), |s| format!("+-{s:.2e}")),
                range,
                if r.inside() {
                    ""
                } else {
                    "ON/OUTSIDE ITS RANGE"
                }
            );
        }
    };
    match &c.coverage_90 {
        Some(cov) => println!(
            "  90 % regions (model-error term of the stored calibration, from cross-validation on train rows; parameter and reading terms not included): {} / {} held-out rows inside ({:.1} %; a calibrated model covers 85-95 %: {})",
            cov.inside,
            cov.total,
            cov.fraction() * 100.0,
            yes((0.85..=0.95).contains(&cov.fraction()))
        ),
        None => println!("  90 % regions: the stored calibration has no [calibration.model_error] term (run `cablesense crossval`)"),
    }
    values("Cosserat fitted values (stored)", &c.cosserat_values);
    values("CC rung fitted values", &c.cc_values);
    for s in c.substituted.iter().take(5) {
        println!("    scored with the CC rung (Cosserat solve failed): {s}");
    }
}

fn yes(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "NO"
    }
}
