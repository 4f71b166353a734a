//! Writes `data/calibration/train.csv` and `val.csv`: recordings of the calibration
//! demo robot (`data/calibration/demo.toml`) driven by three cable tensions.
//!
//! Truth: section moduli 52 and 68 GPa (the scene says 60 and 60), capture frame
//! `x_base = R x_capture + t` with rotation vector (0.2, -0.1, 0.4) rad and
//! t = (30, -10, 150) mm, marker (1.5, -1, 6) mm from the tip in the tip frame,
//! Gaussian capture noise 0.1 mm (seeded xorshift + Box-Muller: reproducible),
//! marker columns in mm. Train: 60 rows of one tension pattern; val: 30 rows of
//! another. Run: `cargo run --release --example make_calibration_demo`.

use cablesense::calibrate::{CalibrationModel, RecordingRow, RigidTransform, TensionModel};
use cablesense::nalgebra::Vector3;
use cablesense::Scene;
use std::fmt::Write as _;

struct Rng(u64);
impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn gauss(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

fn main() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/calibration");
    let scene = Scene::load(dir.join("demo.toml")).expect("demo scene");
    let params: Vec<_> = [
        "robot/sections/0/youngs_modulus_pa",
        "robot/sections/1/youngs_modulus_pa",
    ]
    .iter()
    .map(|p| p.parse().unwrap())
    .collect();
    let names: Vec<String> = ["tension_a", "tension_b", "tension_c"]
        .map(String::from)
        .to_vec();
    let mut model = TensionModel::new(&scene, &params, &names, None).expect("model");
    model.set_params(&[52e9, 68e9]).expect("truth");
    let frame = RigidTransform::from_vector(
        &Vector3::new(0.2, -0.1, 0.4),
        &Vector3::new(0.03, -0.01, 0.15),
    );
    let offset = Vector3::new(1.5e-3, -1e-3, 6e-3);
    let mut rng = Rng(0x5eed_ca11_b4a7_e001);
    for (file, rows, phase, freq) in [("train.csv", 60, 0.0, 1.0), ("val.csv", 30, 0.7, 2.0)] {
        let mut csv = String::from("t_s,tension_a,tension_b,tension_c,tip_x,tip_y,tip_z\n");
        for i in 0..rows {
            let p = i as f64 / rows as f64 * 2.0 * std::f64::consts::PI;
            let t = [
                7.0 * (1.0 + (freq * p + phase).sin()),
                7.0 * (1.0 + (p + 2.1 + phase).sin()),
                5.0 * (1.0 + (2.0 * p + 4.2).sin()),
            ];
            let row = RecordingRow {
                line: i + 2,
                t_s: Some(i as f64 * 0.5),
                marker_m: Vector3::zeros(),
                inputs: t.to_vec(),
                history: None,
            };
            let pose = model.predict(&row).expect("truth solves");
            let base = pose.position + pose.rotation * offset;
            let mut cap = frame.rotation.transpose() * (base - frame.translation);
            for k in 0..3 {
                cap[k] += 1e-4 * rng.gauss();
            }
            let _ = writeln!(
                csv,
                "{:.1},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
                i as f64 * 0.5,
                t[0],
                t[1],
                t[2],
                cap.x * 1e3,
                cap.y * 1e3,
                cap.z * 1e3
            );
        }
        std::fs::write(dir.join(file), csv).expect("write");
        println!("wrote {}", dir.join(file).display());
    }
}
