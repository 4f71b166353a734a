//! Thesis tables 4.1-4.5 (data/thesis): with the fitted values stored in
//! data/thesis/fitted.toml, our model reproduces the thesis's predicted columns,
//! and our error against the observed columns is of the thesis's size.
//!
//! Every number here is recomputed from the scene files, the CSVs and the fitted
//! values; nothing is typed in except the bounds, each with its source.
//! Parameter choices and results: data/thesis/README.md, "Parameter choices".

use cablesense::validation::{
    compare, fit, Comparison, FitProblem, FitSettings, FittedFile, ParamPath, TableData, Target,
    ThesisTable,
};
use cablesense::GuideMass;
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/thesis")
}

fn fitted() -> FittedFile {
    let path = dir().join("fitted.toml");
    assert!(path.is_file(), "{} is missing", path.display());
    FittedFile::load(&path).expect("fitted.toml parses")
}

/// Compare a table with its scene and the stored fit of the thesis's predictions.
fn run(t: ThesisTable) -> (TableData, Comparison) {
    let data = TableData::load(&dir(), t).expect("table and scene load");
    let rec = fitted();
    let rec = rec
        .get(data.spec.scene, Target::Predicted)
        .unwrap_or_else(|| panic!("no predicted fit for {} in fitted.toml", data.spec.scene));
    let scene = rec.apply(&data.scene).expect("fitted values apply");
    let c = compare(&data, &scene).expect("comparison runs");
    assert!(c.all_converged(), "table {t}: a row did not converge");
    (data, c)
}

fn max_point_error_mm(c: &Comparison) -> f64 {
    c.points
        .iter()
        .map(|p| p.max_ours_thesis_m)
        .fold(0.0, f64::max)
        * 1e3
}

fn modulus(t: ThesisTable) -> f64 {
    let data_scene = t.spec().scene;
    fitted()
        .get(data_scene, Target::Predicted)
        .and_then(|r| r.value("robot/sections/*/youngs_modulus_pa"))
        .unwrap_or_else(|| panic!("table {t}: no fitted modulus"))
}

/// Issue bound: one fitted E per table reproduces the predicted tip columns to < 1 mm.
const TIP_BOUND_MM: f64 = 1.0;

#[test]
fn table_4_1_one_modulus_reproduces_the_thesis_predictions() {
    let (_, c) = run(ThesisTable::T41);
    let e = max_point_error_mm(&c);
    println!(
        "4.1: E = {:.3} GPa, max |ours - thesis| = {e:.3} mm",
        modulus(ThesisTable::T41) * 1e-9
    );
    assert!(e < TIP_BOUND_MM, "4.1: {e} mm");
}

#[test]
fn table_4_2_one_modulus_and_a_vertical_pen_scale_force_reproduce_the_thesis_predictions() {
    let (data, c) = run(ThesisTable::T42);
    let e = max_point_error_mm(&c);
    println!(
        "4.2: E = {:.3} GPa, max |ours - thesis| = {e:.3} mm",
        modulus(ThesisTable::T42) * 1e-9
    );
    assert!(e < TIP_BOUND_MM, "4.2: {e} mm");
    // the pen-scale pull of the stored scene is vertical (README, "Parameter choices")
    let f = data.scene.loads.point[1].force_n;
    assert!(
        f[0] == 0.0 && f[2] == 0.0 && f[1] > 0.0,
        "pen-scale direction {f:?}"
    );
}

#[test]
fn table_4_3_average_mass_model_reproduces_the_thesis_predictions() {
    let (data, c) = run(ThesisTable::T43);
    assert_eq!(data.scene.numerics.guide_mass, GuideMass::Average);
    let e = max_point_error_mm(&c);
    println!(
        "4.3: E = {:.3} GPa, max |ours - thesis| = {e:.3} mm",
        modulus(ThesisTable::T43) * 1e-9
    );
    assert!(e < TIP_BOUND_MM, "4.3: {e} mm");
}

/// The 14.9 g the thesis says it used does not reproduce its own predictions: the
/// nominal masses do (README "Parameter choices"). Reported, with the honest bound.
#[test]
fn table_4_3_with_the_measured_14_9_g_does_not_reproduce_the_thesis_predictions() {
    let (_, c) = run(ThesisTable::T43Measured);
    let e = max_point_error_mm(&c);
    println!(
        "4.3m: E = {:.3} GPa, max |ours - thesis| = {e:.3} mm",
        modulus(ThesisTable::T43Measured) * 1e-9
    );
    assert!(
        e > 2.0 * TIP_BOUND_MM,
        "4.3m unexpectedly reproduces the thesis: {e} mm"
    );
}

/// Issue bound: the thesis's predicted cable lengths (table 4.5, average model) to < 0.2 mm.
const LENGTH_BOUND_MM: f64 = 0.2;

#[test]
fn table_4_5_cable_lengths_of_the_average_model() {
    let (_, c) = run(ThesisTable::T45);
    let s = &c.lengths[0];
    let e = s.max_ours_thesis_m * 1e3;
    println!(
        "4.5 avg: refLenPre ours {:.4} cm (thesis 38.72), max |length ours - thesis| = {e:.3} mm",
        s.ours_ref_length_m * 100.0
    );
    assert!(e < LENGTH_BOUND_MM, "4.5 avg: {e} mm");
}

#[test]
fn table_4_5_cable_lengths_of_the_accurate_model() {
    let (data, c) = run(ThesisTable::T45Acc);
    assert_eq!(data.scene.numerics.guide_mass, GuideMass::Accurate);
    let e = c.lengths[0].max_ours_thesis_m * 1e3;
    println!("4.5 acc: max |length ours - thesis| = {e:.3} mm");
    assert!(e < LENGTH_BOUND_MM, "4.5 acc: {e} mm");
}

/// Table 4.4's predicted columns are a copy of 4.3's: modelled (accurate mass),
/// reported against the observed columns only, never fitted to its predicted column.
#[test]
fn table_4_4_accurate_model_is_compared_with_observations_only() {
    let (data, c) = run(ThesisTable::T44);
    assert!(data.spec.predicted_is_copy);
    assert_eq!(data.scene.numerics.guide_mass, GuideMass::Accurate);
    let p = &c.points[0];
    println!(
        "4.4 (accurate): mean err vs observed ours {:.3} % (thesis printed {:.3} %, a copy of 4.3)",
        p.mean_pct_ours_obs, p.thesis_avg_pct
    );
    assert!(p.mean_pct_ours_obs.is_finite());
    let refused = FitProblem::new(
        data.scene.clone(),
        vec![data],
        vec!["robot/sections/*/youngs_modulus_pa".parse().unwrap()],
        Target::Predicted,
    );
    assert!(
        refused.is_err(),
        "fitting 4.4's copied predicted column must be refused"
    );
}

/// Our error against the observed columns, beside the thesis's printed averages.
/// Since our model reproduces the thesis's predictions (above), our mean error must
/// be the thesis's own to within the differences between the two predictions:
/// bound 0.15 percentage points (the < 1 mm agreement is 0.5 % of 19.5 cm at most,
/// and about 0.1 % on average).
#[test]
fn errors_against_observations_match_the_thesis_averages() {
    for t in [ThesisTable::T41, ThesisTable::T42, ThesisTable::T43] {
        let (_, c) = run(t);
        for p in &c.points {
            println!(
                "{t} {}: mean err vs observed ours {:.3} %, thesis printed {:.3} %, thesis recomputed {:.3} %",
                p.label, p.mean_pct_ours_obs, p.thesis_avg_pct, p.mean_pct_thesis_obs
            );
            assert!(
                (p.mean_pct_ours_obs - p.mean_pct_thesis_obs).abs() < 0.15,
                "{t} {}: ours {} % vs thesis {} %",
                p.label,
                p.mean_pct_ours_obs,
                p.mean_pct_thesis_obs
            );
        }
    }
}

/// The stored moduli are least-squares optima of the current model: refitting from
/// them moves them by less than 1e-4 (guards against a stale fitted.toml).
#[test]
fn stored_moduli_are_current_least_squares_optima() {
    for t in [ThesisTable::T41, ThesisTable::T43] {
        let data = TableData::load(&dir(), t).unwrap();
        let rec = fitted();
        let scene = rec
            .get(data.spec.scene, Target::Predicted)
            .unwrap()
            .apply(&data.scene)
            .unwrap();
        let path: ParamPath = "robot/sections/*/youngs_modulus_pa".parse().unwrap();
        let stored = path.value(&scene).unwrap();
        let problem = FitProblem::new(scene, vec![data], vec![path], Target::Predicted).unwrap();
        let report = fit(&problem, &FitSettings::default()).unwrap();
        let rel = (report.values[0] - stored).abs() / stored;
        println!(
            "{t}: stored E {stored:.6e}, refit {:.6e} (rel. change {rel:.1e})",
            report.values[0]
        );
        assert!(
            rel < 1e-4,
            "{t}: stored {stored}, refit {}",
            report.values[0]
        );
    }
}

/// Table 4.5 as an inverse experiment (issue 3). The estimator must invert the
/// model's own deflection at each hung mass back to that mass (1e-6 relative: the
/// forward/estimator tolerances are far tighter), and on the thesis's observed
/// deflections it must return a status for every row with a finite estimate, never a
/// panic or NaN. The observed-data errors themselves are reported by `validate`, not
/// asserted: the model is not tuned to them.
#[test]
fn table_4_5_inverse_experiment_inverts_the_model_and_reports_the_data() {
    use cablesense::validation::table_4_5_inverse;
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/thesis");
    let rows = table_4_5_inverse(&dir).expect("inverse experiment runs");
    assert_eq!(rows.len(), 5, "five loaded rows in table 4.5");
    for r in &rows {
        assert!(r.estimate_kg.is_finite() && r.estimate_kg >= 0.0, "{r:?}");
        assert!(r.model_change_m.is_finite(), "{r:?}");
    }
    // round trip through the model's own deflections
    let scene = cablesense::Scene::load(dir.join("table_4_3.toml")).unwrap();
    let fitted = cablesense::validation::FittedFile::load(&dir.join("fitted.toml")).unwrap();
    let scene = fitted
        .get("table_4_3.toml", cablesense::validation::Target::Predicted)
        .unwrap()
        .apply(&scene)
        .unwrap();
    let mut unloaded = scene.loads.clone();
    unloaded.point.iter_mut().for_each(|p| p.mass_kg = 0.0);
    let robot = scene.build_robot().unwrap();
    let spec = cablesense::estimate::EstimateSpec::new(vec![cablesense::estimate::UnknownSpec {
        kind: cablesense::estimate::UnknownKind::Mass,
        section: Some(0),
        axis: None,
        cable: None,
        name: None,
        min: Some(0.0),
        max: None,
        prior_mean: None,
        prior_sigma: None,
        reference: 0.0,
        initial: 0.0,
    }]);
    let mut est =
        cablesense::estimate::Estimator::new(robot, unloaded, scene.numerics.clone(), spec)
            .unwrap();
    for r in &rows {
        est.set_theta(&[0.0]);
        est.tick(&[r.model_change_m], None);
        let got = est.theta()[0];
        assert!(
            (got - r.truth_kg).abs() <= 1e-6 * r.truth_kg,
            "mass {} kg: estimated {got} kg from the model's own deflection {} m",
            r.truth_kg,
            r.model_change_m
        );
    }
}
