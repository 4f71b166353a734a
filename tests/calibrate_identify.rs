//! `calibrate --identify`: the servo-to-tendon mapping and per-segment angle offsets
//! read off a single-tendon pull recording.

use cablesense::calibrate::{identify, IdentifyError, IdentifySettings};
use cablesense::Scene;

const DIR: &str = env!("CARGO_MANIFEST_DIR");

fn ftdcr() -> Scene {
    Scene::load(format!("{DIR}/data/scenes/ftdcr_v4.toml")).unwrap()
}

fn pull_csv() -> String {
    std::fs::read_to_string(format!("{DIR}/data/hardware/ftdcr_v4/tendon_pull.csv")).unwrap()
}

#[test]
fn shipped_pull_recording() {
    let scene = ftdcr();
    let r = identify(
        &scene,
        "tendon_pull.csv",
        &pull_csv(),
        &IdentifySettings::default(),
    )
    .unwrap();
    for s in &r.servos {
        println!(
            "{:<12} rows {:>2} lin angle {:>7.1} gain {:>5.1} r2 {:.3} | rms mm {:?} | ang {:?} | seg {} cable {} misfit {:.1} next {:?}",
            s.column,
            s.rows,
            s.linear.angle_rad.to_degrees(),
            s.linear.gain,
            s.linear.r2,
            s.rms_m.iter().map(|x| (x * 1e4).round() / 10.0).collect::<Vec<_>>(),
            s.angle_deg.iter().map(|x| x.round()).collect::<Vec<_>>(),
            s.segment,
            s.cable,
            s.angle_misfit_deg,
            s.next_best
        );
    }
    for s in &r.segments {
        println!("{s:?}");
    }
    println!("swaps {:?} cost {}", r.swaps, r.cost);
    println!("{}", r.toml_snippet(&scene).unwrap());
    // the proposal is the mapping the scene already has (from the labels upstream)
    assert!(r.mapping_matches(&scene), "{:?}", r.readings);
    // grouping and order are supported: swapping two segments costs more
    assert!(r.swaps.iter().all(|s| s.margin > 5.0), "{:?}", r.swaps);
    // offsets: the scene's angles (upstream seg_offsets) agree with the tip to 2 deg
    for s in &r.segments {
        assert!(s.offset_deg.abs() < 2.0, "{s:?}");
    }
    // the snippet parses back as cables with the same readings
    let snippet = r.toml_snippet(&scene).unwrap();
    let v: toml::Value = toml::from_str(&snippet).unwrap();
    let cables = v["robot"]["cables"].as_array().unwrap();
    assert_eq!(cables.len(), 9);
    assert_eq!(cables[0]["reading"].as_str(), Some("servo_4_mm"));
}

/// A pull recording made by the model: servo `perm[j]` drives cable `j`, and every
/// tendon sits `offset_deg` further round than the scene says.
fn synthetic(perm: &[usize; 9], offset_deg: f64) -> String {
    let mut truth = ftdcr();
    for (j, c) in truth.robot.cables.iter_mut().enumerate() {
        c.reading = Some(format!("servo_{}_mm", perm[j]));
        c.routing.as_mut().unwrap().angle_deg += offset_deg;
    }
    let offset =
        cablesense::nalgebra::Vector3::from(truth.calibration.as_ref().unwrap().marker_offset_m);
    let mut ws = truth.tendon_workspace().unwrap();
    let mut csv = String::from("timestamp,pattern_label");
    for s in 1..=9 {
        csv += &format!(",servo_{s}_mm");
    }
    csv += ",tip_x,tip_y,tip_z\n";
    let mut t = 0.0;
    for s in 1..=9 {
        let j = perm.iter().position(|&p| p == s).unwrap();
        for k in 0..6 {
            let q = 0.5e-3 * k as f64;
            let mut r = vec![-10e-3; 9];
            r[j] = q;
            let rep = ws.solve_readings(&r).unwrap();
            assert!(rep.status.is_converged());
            let sol = ws.workspace_mut().solution();
            let p = sol.tip().position + sol.tip().rotation * offset;
            csv += &format!("{t},pull_{s}");
            for (c, _) in (1..=9).enumerate() {
                let cable = perm.iter().position(|&p| p == c + 1).unwrap();
                csv += &format!(",{}", r[cable] * 1e3);
            }
            csv += &format!(",{},{},{}\n", p.x * 1e3, p.y * 1e3, p.z * 1e3);
            t += 0.5;
        }
    }
    csv
}

#[test]
fn synthetic_permuted_mapping_and_offset_are_identified_back() {
    let scene = ftdcr();
    let perm = [7, 2, 9, 4, 1, 6, 3, 8, 5];
    let csv = synthetic(&perm, 20.0);
    let r = identify(&scene, "synthetic.csv", &csv, &IdentifySettings::default()).unwrap();
    for (j, want) in perm.iter().enumerate() {
        assert_eq!(
            r.readings[j].as_deref(),
            Some(format!("servo_{want}_mm").as_str()),
            "cable {j}: {:?}",
            r.readings
        );
    }
    for s in &r.segments {
        println!("{s:?}");
        assert!((s.offset_deg - 20.0).abs() < 1.0, "{s:?}");
    }
    // the model explains its own data: every servo's path within 0.1 mm
    for s in &r.servos {
        assert!(s.rms_m[s.segment] < 1e-4, "{}: {:?}", s.column, s.rms_m);
    }
    assert!(!r.mapping_matches(&scene));
}

#[test]
fn bad_files_give_clear_errors() {
    let scene = ftdcr();
    let csv = pull_csv();
    let s = IdentifySettings::default();
    let e = identify(
        &scene,
        "f.csv",
        &csv.replacen("pattern_label", "label", 1),
        &s,
    )
    .unwrap_err();
    assert!(
        matches!(e, IdentifyError::MissingColumn { ref column, .. } if column == "pattern_label"),
        "{e}"
    );
    assert!(
        e.to_string()
            .starts_with("f.csv:1: no column `pattern_label`"),
        "{e}"
    );
    let e = identify(&scene, "f.csv", &csv.replacen("tip_y", "y", 1), &s).unwrap_err();
    assert!(e.to_string().contains("no column `tip_y` (tip y)"), "{e}");
    // three idle rows: every servo constant
    let mut idle = csv.clone();
    for k in 0..3 {
        idle += &format!("{k},idle,-10,-10,-10,-10,-10,-10,-10,-10,-10,0,0,188\n");
    }
    let e = identify(&scene, "f.csv", &idle, &s).unwrap_err();
    assert!(
        matches!(e, IdentifyError::PullsNothing { ref pattern, line: 136, rows: 3, .. } if pattern == "idle"),
        "{e}"
    );
    println!("{e}");
    let mut bad = csv.clone();
    bad += "1,rep1_tendon8_id7_pull,-9.99,x,-9.99,-9.99,-9.99,-9.99,-9.99,-9.99,0.1,1,2,3\n";
    let e = identify(&scene, "f.csv", &bad, &s).unwrap_err();
    assert!(
        e.to_string()
            .contains("f.csv:136: column `servo_3_mm`: `x` is not a number"),
        "{e}"
    );
}
