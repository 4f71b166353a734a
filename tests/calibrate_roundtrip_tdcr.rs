//! Round trip on a three-segment tendon-driven robot: a recording synthesised by
//! the model with known parameters is calibrated back to them within the reported
//! standard errors.
//!
//! Robot: three 60 mm NiTi segments, four disks each, nine displacement-driven
//! tendons at 4.5 mm (three per segment, 120 degrees apart, segments rotated by 40
//! degrees), driven from servo readings (`ServoModel`, rows warm in sequence).
//! Truth: Young's modulus 55 GPa, tendon stiffness 4000 N, a tilted and shifted
//! capture frame and a marker 8 mm beyond the tip. Start: 60 GPa, 5000 N, identity
//! frame, offset (0, 0, 5 mm). Fitted: the two scene parameters, the capture frame
//! (6) and the marker offset (3): 11 values per seed.
//!
//! Noise: the true tip comes from the true readings; the recording holds the
//! readings rounded to the encoder's resolution (1 um) and the marker with Gaussian
//! capture noise (0.1 mm per coordinate) rounded to the capture resolution (10 um).
//! The rounding of the readings is not in the fit's noise model; it moves the tip by
//! about 25 x 0.29 um = 7 um RMS, 0.07 sigma (0.5 % of the variance).
//!
//! Criterion (issue 10): values inside 2 reported standard errors of the truth. The
//! reported errors scale the covariance by the residual variance factor, so with
//! `d = 3 rows - 11` degrees of freedom a consistent fit puts a value inside 2
//! errors with the Student-t probability `p = P(|t_d| < 2)` (0.9514 for 30 rows,
//! d = 79: slightly below the normal 0.9545). Over `n` values (11 per seed,
//! correlated only within a seed) the fraction inside has binomial spread
//! `sqrt(p (1 - p) / n)`.
//! * `three_segment_round_trip_100_seeds` (`#[ignore]`: run with `--ignored`;
//!   about 3.4 s of CPU a seed in release, so several minutes): 100 seeds, 1100
//!   values. The issue asks for at least 95 %; with p = 0.9514 and a binomial
//!   sigma of 0.65 % a consistent fit misses 95 % with probability about 0.4, so
//!   the assertion is `p - 3 sigma` = 93.2 % and the figure is printed (and
//!   recorded in the README).
//! * `three_segment_round_trip` (always run): 4 seeds, 44 values; asserts the
//!   fraction inside is at least `p - 3 sigma_binomial` = 0.9514 - 3 x 0.0324 =
//!   0.854 (a consistent fit fails this with probability below 1 %).
//!
//! Every seed must converge, and its residual variance factor must lie in 0.5-2.0
//! (d = 79: the chi-square 1st-99.9th percentiles are 0.67-1.49; wider for the
//! rounding).

use cablesense::calibrate::{
    calibrate, CalibrationReport, CalibrationSettings, CalibrationSetup, ColumnMap, FitParam,
    FrameSetup, LmStatus, ParamSpec, Recording, RigidTransform, SceneModel, ServoModel,
};
use cablesense::nalgebra::Vector3;
use cablesense::validation::{set_values, ParamPath};
use cablesense::{Scene, Start};

const NOISE: f64 = 1e-4;
const CAPTURE_RESOLUTION: f64 = 1e-5;
const ENCODER_RESOLUTION: f64 = 1e-6;
const ROWS: usize = 30;
const FITTED: usize = 11;
/// `P(|t_79| < 2)`, Student t with 3 x 30 - 11 = 79 degrees of freedom.
const P_INSIDE: f64 = 0.9514;

fn scene() -> Scene {
    let mut text = String::new();
    for k in 0..3 {
        text += r#"
[[robot.sections]]
length_m = 0.06
shape = { solid = { diameter_m = 1.0e-3 } }
youngs_modulus_pa = 60.0e9
poisson_ratio = 0.3
density_kg_m3 = 6450.0
[robot.sections.guides]
count = 4
first_offset_m = 0.015
spacing_m = 0.015
thickness_m = 0.0
diameter_m = 0.011
mass_kg = 1.0e-3
holes = { radius_m = 0.0045 }
"#;
        let _ = k;
    }
    text += r#"
[robot.tendons]
stiffness_n = 5000.0
pretension_n = 1.0
"#;
    for seg in 0..3 {
        for j in 0..3 {
            text += &format!(
                r#"
[[robot.cables]]
name = "t{}"
routing = {{ radius_m = 0.0045, angle_deg = {} }}
end_section = {seg}
actuation = "displacement"
"#,
                3 * seg + j,
                40.0 * seg as f64 + 120.0 * j as f64
            );
        }
    }
    text += r#"
[loads]
gravity_m_s2 = [0.0, 0.0, -9.81]
[numerics]
guide_mass = "point"
integrator = { rk4 = { steps_per_section = 8 } }
[readings]
scale_m = 1.0
"#;
    Scene::from_toml_str(&text).unwrap()
}

fn paths() -> Vec<ParamPath> {
    vec![
        "robot/sections/*/youngs_modulus_pa".parse().unwrap(),
        "robot/tendons/stiffness_n".parse().unwrap(),
    ]
}

const TRUTH: [f64; 2] = [55e9, 4000.0];

fn true_frame() -> RigidTransform {
    RigidTransform::from_vector(
        &Vector3::new(0.05, -0.03, 0.4),
        &Vector3::new(0.004, -0.002, 0.01),
    )
}

fn true_offset() -> Vector3<f64> {
    Vector3::new(0.0, 0.0, 0.008)
}

/// Readings (m) of the nine tendons: each segment bends towards a direction that
/// turns slowly from row to row (0.5 rad a row, segments at different rates), by
/// up to 1 mm of pull (`q_j = a cos(phi - 120 j deg)`: the tendons on the far side
/// are paid out and may go slack); a smooth sequence like a real recording, so rows
/// warm-start well. `jitter` (m, per reading) is added.
fn readings(rows: usize, jitter: &[[f64; 9]]) -> Vec<[f64; 9]> {
    (0..rows)
        .map(|i| {
            let mut q = [0.0; 9];
            for seg in 0..3 {
                let t = i as f64;
                let phi = t * (0.5 + 0.2 * seg as f64) + seg as f64;
                let a = 1e-3 * (0.6 + 0.4 * (0.3 * t + seg as f64).sin());
                for j in 0..3 {
                    let th = phi - 2.0 * std::f64::consts::PI / 3.0 * j as f64;
                    q[3 * seg + j] = a * th.cos() + jitter[i][3 * seg + j];
                }
            }
            q
        })
        .collect()
}

/// xorshift64* with Box-Muller.
struct Rng(u64);
impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64) / (1u64 << 53) as f64
    }
    fn gauss(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

fn round(x: f64, step: f64) -> f64 {
    (x / step).round() * step
}

/// A recording: true readings (the smooth pattern plus a jitter uniform within one
/// encoder step, different per seed, so that the rounding is not the same bias in
/// every seed), the true markers from them, and the rounded, noisy columns.
fn recording(sc: &Scene, seed: u64) -> Recording {
    let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let jitter: Vec<[f64; 9]> = (0..ROWS)
        .map(|_| std::array::from_fn(|_| (rng.uniform() - 0.5) * ENCODER_RESOLUTION))
        .collect();
    let q_true = readings(ROWS, &jitter);
    let truth = set_values(sc, &paths(), &TRUTH).unwrap();
    let mut ws = truth.tendon_workspace().unwrap();
    let (frame, offset) = (true_frame(), true_offset());
    let columns = ServoModel::reading_columns(sc);
    let mut csv = format!("{},tip_x,tip_y,tip_z\n", columns.join(","));
    for q in &q_true {
        let mut rep = ws.solve_readings(q).unwrap();
        if !rep.status.is_converged() {
            // (the warm chain may fail where a cold solve does not)
            rep = ws.solve_readings_from(q, Start::Cold).unwrap();
        }
        assert!(rep.status.is_converged(), "seed {seed}: {rep:?}");
        let tip = *ws.workspace_mut().solution().tip();
        let m =
            frame.rotation.transpose() * (tip.position + tip.rotation * offset - frame.translation);
        let mut cells: Vec<String> = q
            .iter()
            .map(|v| format!("{:.7}", round(*v, ENCODER_RESOLUTION)))
            .collect();
        for k in 0..3 {
            cells.push(format!(
                "{:.6}",
                round(m[k] + NOISE * rng.gauss(), CAPTURE_RESOLUTION)
            ));
        }
        csv += &cells.join(",");
        csv.push('\n');
    }
    let map = ColumnMap {
        inputs: columns,
        ..ColumnMap::default()
    };
    Recording::parse_str("synthetic.csv", &csv, &map).unwrap()
}

fn fit(sc: &Scene, rec: &Recording) -> CalibrationReport {
    let p = paths();
    let model = SceneModel::new(sc, &p, &rec.input_names, None).unwrap();
    let params: Vec<FitParam> = p
        .iter()
        .zip(model.values())
        .map(|(path, v)| {
            let mut spec = ParamSpec::new(path.as_str());
            spec.min = Some(1.0);
            FitParam::from_spec(&spec, *v)
        })
        .collect();
    let setup = CalibrationSetup {
        model: &model,
        params,
        frame: FrameSetup {
            capture_to_base: RigidTransform::default(),
            marker_offset_m: Vector3::new(0.0, 0.0, 0.005),
            fit_capture_frame: true,
            fit_marker_offset: true,
        },
        train: rec,
        val: None,
        robot_length_m: model.robot_length(),
    };
    let settings = CalibrationSettings {
        capture_noise_m: NOISE,
        ..CalibrationSettings::default()
    };
    calibrate(&setup, &settings, &mut |_| {}).unwrap()
}

/// Values inside 2 reported standard errors, and values checked, over `seeds`.
fn round_trip(seeds: std::ops::Range<u64>) -> (usize, usize) {
    let sc = set_values(&scene(), &paths(), &[60e9, 5000.0]).unwrap();
    let truth: Vec<f64> = TRUTH
        .iter()
        .copied()
        .chain(true_frame().rotation_vector().iter().copied())
        .chain(true_frame().translation.iter().copied())
        .chain(true_offset().iter().copied())
        .collect();
    let (mut inside, mut total) = (0, 0);
    for seed in seeds {
        let rec = recording(&sc, seed);
        let report = fit(&sc, &rec);
        assert_eq!(
            report.status,
            LmStatus::Converged,
            "seed {seed}: {:?}",
            report.warnings
        );
        assert!(report.failed_rows.is_empty(), "seed {seed}");
        assert_eq!(report.params.len(), FITTED);
        let s2 = report.statistics.residual_variance;
        assert!(
            (0.5..2.0).contains(&s2),
            "seed {seed}: variance factor {s2}"
        );
        let mut line = format!("seed {seed:3}: s2 {s2:.2}, z");
        for (p, want) in report.params.iter().zip(&truth) {
            assert!(p.std_error.is_finite() && p.std_error > 0.0, "{p:?}");
            let z = (p.value - want) / p.std_error;
            line += &format!(" {z:+.2}");
            total += 1;
            if z.abs() <= 2.0 {
                inside += 1;
            }
        }
        println!("{line}");
    }
    (inside, total)
}

#[test]
fn three_segment_round_trip() {
    let (inside, total) = round_trip(0..4);
    let frac = inside as f64 / total as f64;
    let sigma = (P_INSIDE * (1.0 - P_INSIDE) / total as f64).sqrt();
    println!(
        "{inside} of {total} inside 2 sigma ({:.1} %; bound {:.1} %)",
        frac * 100.0,
        (P_INSIDE - 3.0 * sigma) * 100.0
    );
    assert!(frac >= P_INSIDE - 3.0 * sigma, "{inside} of {total}");
}

#[test]
#[ignore = "100 seeds: several minutes in release; run with --ignored"]
fn three_segment_round_trip_100_seeds() {
    let (inside, total) = round_trip(0..100);
    let frac = inside as f64 / total as f64;
    let sigma = (P_INSIDE * (1.0 - P_INSIDE) / total as f64).sqrt();
    println!(
        "{inside} of {total} inside 2 sigma ({:.2} %; issue: >= 95 %; binomial bound {:.2} %)",
        frac * 100.0,
        (P_INSIDE - 3.0 * sigma) * 100.0
    );
    assert!(frac >= P_INSIDE - 3.0 * sigma, "{inside} of {total}");
}
