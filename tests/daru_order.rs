//! The one-segment robot of `data/hardware/daru/` (a raster over three cable
//! commands, no header, no time column) and the row order of a calibration:
//!
//! * the chain of rows a calibration solves ([`chain_order`], [`RowOrder::Auto`]
//!   without time stamps) visits the same rows in the same order for a shuffled
//!   copy of the rows;
//! * a calibration of a shuffled copy of the training rows gives the same
//!   held-out RMSE (within 1 %, the target) as the file order.

use cablesense::calibrate::{
    calibrate, chain_order, CalibrationSettings, CalibrationSetup, ColumnMap, FitParam, FrameSetup,
    Recording, RowOrder, SceneModel,
};
use cablesense::validation::ParamPath;
use cablesense::Scene;

const DIR: &str = env!("CARGO_MANIFEST_DIR");

fn scene() -> Scene {
    Scene::load(format!("{DIR}/data/scenes/daru.toml")).unwrap()
}

fn recording(sc: &Scene) -> Recording {
    let spec = sc.calibration.clone().unwrap();
    Recording::load(
        format!("{DIR}/data/hardware/daru/Dataset-Actions-Positions.txt"),
        &ColumnMap::from_spec(&spec),
    )
    .unwrap()
}

/// A fixed permutation (a linear congruential shuffle, no dependency).
fn shuffled(rec: &Recording, seed: u64) -> Recording {
    let mut out = rec.clone();
    let mut s = seed;
    for i in (1..out.rows.len()).rev() {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let j = (s >> 33) as usize % (i + 1);
        out.rows.swap(i, j);
    }
    out
}

#[test]
fn headerless_file_reads_with_the_scenes_column_names() {
    let sc = scene();
    let rec = recording(&sc);
    assert_eq!(rec.rows.len(), 30_250);
    assert_eq!(rec.input_names, ["l1", "l2", "l3"]);
    // first line `0,0,1,-43.06682,-144.2242,276.5916` is data, in mm
    assert_eq!(rec.rows[0].line, 1);
    assert_eq!(rec.rows[0].inputs, [0.0, 0.0, 1.0]);
    assert!((rec.rows[0].marker_m.x + 0.04306682).abs() < 1e-12);
}

#[test]
fn the_row_chain_does_not_depend_on_the_order_of_the_rows() {
    let sc = scene();
    let rec = recording(&sc).every(7);
    let shuf = shuffled(&rec, 46);
    let key = |r: &Recording, order: Vec<usize>| -> Vec<usize> {
        order.into_iter().map(|i| r.rows[i].line).collect()
    };
    let a = key(&rec, chain_order(&rec.rows));
    let b = key(&shuf, chain_order(&shuf.rows));
    assert_eq!(a.len(), rec.rows.len());
    assert_eq!(a, b, "the chain of a shuffled copy visits other rows");
    // the chain starts at the row nearest to zero commands (the straight robot)
    let norm = |x: &[f64]| x.iter().map(|v| v * v).sum::<f64>();
    let first = &rec.rows.iter().find(|r| r.line == a[0]).unwrap().inputs;
    let least = rec
        .rows
        .iter()
        .map(|r| norm(&r.inputs))
        .fold(f64::INFINITY, f64::min);
    assert_eq!(norm(first), least);
}

#[test]
fn calibration_of_shuffled_training_rows_gives_the_same_held_out_error() {
    let sc = scene();
    let all = recording(&sc);
    let (train, val) = all.split_rows(0..24_200);
    // a small fit: every 100th training row, three iterations, every 25th held-out row
    let train = train.every(100);
    let val = val.every(25);
    let spec = sc.calibration.clone().unwrap();
    let paths: Vec<ParamPath> = spec
        .params
        .iter()
        .map(|p| p.path.parse().unwrap())
        .collect();
    let fit = |rows: &Recording| {
        let model = SceneModel::new(&sc, &paths, &rows.input_names, None).unwrap();
        let params: Vec<FitParam> = spec
            .params
            .iter()
            .zip(model.values())
            .map(|(p, v)| FitParam::from_spec(p, *v))
            .collect();
        let setup = CalibrationSetup {
            model: &model,
            params,
            frame: FrameSetup::from_spec(&spec),
            train: rows,
            val: Some(&val),
            robot_length_m: model.robot_length(),
        };
        let settings = CalibrationSettings {
            max_iterations: 3,
            row_order: RowOrder::Auto,
            ..CalibrationSettings::from_spec(&spec, 2)
        };
        calibrate(&setup, &settings, &mut |_| {}).unwrap()
    };
    let a = fit(&train);
    let b = fit(&shuffled(&train, 7));
    assert!(a.failed_rows.is_empty(), "{:?}", a.failed_rows);
    let (ra, rb) = (
        a.val.unwrap().mean_removed.rmse_m,
        b.val.unwrap().mean_removed.rmse_m,
    );
    assert!(
        (ra - rb).abs() <= 0.01 * ra,
        "held-out RMSE {:.4} mm (file order) against {:.4} mm (shuffled)",
        ra * 1e3,
        rb * 1e3
    );
}
