//! Shared helpers of the calibration tests: a small two-section robot driven by
//! three cable tensions, and recordings synthesised by the tension model with known
//! parameters, capture frame and marker offset.
#![allow(dead_code)]

use cablesense::calibrate::{
    CalibrationModel, ColumnMap, LengthUnit, Recording, RecordingRow, RigidTransform, TensionModel,
};
use cablesense::nalgebra::Vector3;
use cablesense::validation::ParamPath;
use cablesense::Scene;

/// Two 0.1 m Nitinol sections, two disks each, cables `a`, `b` ending on section 0
/// and `c` on section 1; vertical (base along +z), gravity along -z; fast numerics.
pub const SCENE: &str = r#"
[[robot.sections]]
length_m = 0.1
shape = { solid = { diameter_m = 1.5e-3 } }
youngs_modulus_pa = 60e9
poisson_ratio = 0.3
density_kg_m3 = 6500.0
[robot.sections.guides]
count = 2
first_offset_m = 0.045
spacing_m = 0.05
thickness_m = 3e-3
diameter_m = 0.02
mass_kg = 1e-3
holes = { radius_m = 0.008, angles_deg = [90.0, 210.0, 330.0] }

[[robot.sections]]
length_m = 0.1
shape = { solid = { diameter_m = 1.5e-3 } }
youngs_modulus_pa = 60e9
poisson_ratio = 0.3
density_kg_m3 = 6500.0
[robot.sections.guides]
count = 2
first_offset_m = 0.045
spacing_m = 0.05
thickness_m = 3e-3
diameter_m = 0.02
mass_kg = 1e-3
holes = { radius_m = 0.008, angles_deg = [90.0, 210.0, 330.0] }

[[robot.cables]]
name = "a"
hole = 0
end_section = 0
[[robot.cables]]
name = "b"
hole = 1
end_section = 0
[[robot.cables]]
name = "c"
hole = 2
end_section = 1

[loads]
gravity_m_s2 = [0.0, 0.0, -9.81]

[numerics]
rod_model = "cosserat"
guide_mass = "none"
integrator = { rk4 = { steps_per_section = 4 } }
"#;

pub fn scene() -> Scene {
    Scene::from_toml_str(SCENE).unwrap()
}

pub fn path(s: &str) -> ParamPath {
    s.parse().unwrap()
}

/// Small deterministic generator (xorshift64*), uniform and Gaussian draws.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64) / (1u64 << 53) as f64
    }
    pub fn gauss(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// The truth of a synthetic recording.
pub struct Truth {
    /// Scene parameter values.
    pub values: Vec<f64>,
    /// Capture frame to base.
    pub frame: RigidTransform,
    /// Marker offset in the tip frame (m).
    pub offset: Vector3<f64>,
}

pub fn truth() -> Truth {
    Truth {
        values: vec![52e9, 68e9],
        frame: RigidTransform::from_vector(
            &Vector3::new(0.2, -0.1, 0.4),
            &Vector3::new(0.03, -0.01, 0.15),
        ),
        offset: Vector3::new(1.5e-3, -1e-3, 6e-3),
    }
}

/// Tension rows (N) on cables a, b, c: a path through the tension space.
pub fn tensions(rows: usize) -> Vec<[f64; 3]> {
    (0..rows)
        .map(|i| {
            let p = i as f64 / rows as f64 * 2.0 * std::f64::consts::PI;
            [
                7.0 * (1.0 + p.sin()).max(0.0),
                7.0 * (1.0 + (p + 2.1).sin()).max(0.0),
                5.0 * (1.0 + (2.0 * p + 4.2).sin()).max(0.0),
            ]
        })
        .collect()
}

/// A CSV recording (`t_s`, tension columns, marker in `unit` in the capture frame)
/// synthesised with `params` = `truth.values` and Gaussian capture noise `noise_m`.
pub fn synthesise(
    params: &[ParamPath],
    truth: &Truth,
    rows: usize,
    noise_m: f64,
    seed: u64,
    unit: LengthUnit,
) -> String {
    let sc = scene();
    let names: Vec<String> = ["tension_a", "tension_b", "tension_c"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let mut m = TensionModel::new(&sc, params, &names, None).unwrap();
    m.set_params(&truth.values).unwrap();
    let mut rng = Rng::new(seed);
    let mut csv = String::from("t_s,tension_a,tension_b,tension_c,tip_x,tip_y,tip_z\n");
    for (i, t) in tensions(rows).iter().enumerate() {
        let row = RecordingRow {
            line: i + 2,
            t_s: Some(i as f64 * 0.1),
            marker_m: Vector3::zeros(),
            inputs: t.to_vec(),
            history: None,
        };
        let pose = m.predict(&row).unwrap();
        let base = pose.position + pose.rotation * truth.offset;
        let mut cap = truth.frame.rotation.transpose() * (base - truth.frame.translation);
        for k in 0..3 {
            cap[k] += noise_m * rng.gauss();
        }
        let k = 1.0 / unit.to_m();
        csv.push_str(&format!(
            "{},{},{},{},{},{},{}\n",
            i as f64 * 0.1,
            t[0],
            t[1],
            t[2],
            cap.x * k,
            cap.y * k,
            cap.z * k
        ));
    }
    csv
}

pub fn map(unit: LengthUnit) -> ColumnMap {
    ColumnMap {
        unit,
        ..ColumnMap::default()
    }
}

pub fn parse(name: &str, text: &str, unit: LengthUnit) -> Recording {
    Recording::parse_str(name, text, &map(unit)).unwrap()
}
