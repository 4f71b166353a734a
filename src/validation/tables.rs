//! The thesis tables as validation cases: which CSV columns hold loads, observed
//! and predicted tip points and cable lengths, which scene models the experiment,
//! and the thesis's reference length and printed averages.
//!
//! Provenance, OCR repairs and column meanings: `data/thesis/README.md`.

use super::ValidationError;
use crate::files::demo::DataSource;
use crate::files::Scene;
use crate::loads::Loads;
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// A validation case: one thesis table modelled by one scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ThesisTable {
    /// `4.1`: experiment 1a, mass at the end of section 1.
    T41,
    /// `4.2`: experiment 1b, mass on section 1 and pen-scale pull at the tip.
    T42,
    /// `4.3`: experiment 2, average mass model, tip positions.
    T43,
    /// `4.3m`: table 4.3 with the measured 14.9 g instead of the nominal masses.
    T43Measured,
    /// `4.4`: experiment 2, accurate mass model (its predicted columns are a copy of 4.3).
    T44,
    /// `4.5`: cable lengths, average mass model.
    T45,
    /// `4.5acc`: cable lengths, accurate mass model.
    T45Acc,
}

impl ThesisTable {
    /// Every case, in print order.
    pub const ALL: [Self; 7] = [
        Self::T41,
        Self::T42,
        Self::T43,
        Self::T43Measured,
        Self::T44,
        Self::T45,
        Self::T45Acc,
    ];

    /// Short name used on the command line and in `fitted.toml` (`4.1`, ..., `4.5acc`).
    pub fn name(self) -> &'static str {
        self.spec().name
    }

    /// The static description of the case.
    pub fn spec(self) -> &'static TableSpec {
        match self {
            Self::T41 => &T41,
            Self::T42 => &T42,
            Self::T43 => &T43,
            Self::T43Measured => &T43M,
            Self::T44 => &T44,
            Self::T45 => &T45,
            Self::T45Acc => &T45ACC,
        }
    }
}

impl FromStr for ThesisTable {
    type Err = ValidationError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim().trim_start_matches("table").trim_start_matches('_');
        let t = t.replace('_', ".");
        Self::ALL
            .into_iter()
            .find(|x| x.name().eq_ignore_ascii_case(&t))
            .ok_or_else(|| ValidationError::UnknownTable(s.into()))
    }
}

impl fmt::Display for ThesisTable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// How one CSV column turns into a load of the row's scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RowLoad {
    /// Hanging calibrated mass: `loads.point[point].mass_kg` = column (g -> kg).
    Mass {
        /// Index into the scene's `loads.point`.
        point: usize,
        /// Column (grams).
        column: &'static str,
    },
    /// Pen-scale reading `w` (g, signed; negative = pulling against gravity, README
    /// "Column definitions"): `loads.point[point].force_n = -w |g| d`, where `d` is
    /// the unit vector of the scene's own `force_n` there (the direction of an upward
    /// pull; vertical in the shipped scene, tiltable by calibrating its components).
    PenScale {
        /// Index into the scene's `loads.point`.
        point: usize,
        /// Column (grams).
        column: &'static str,
    },
}

impl RowLoad {
    /// The CSV column.
    pub fn column(&self) -> &'static str {
        match *self {
            Self::Mass { column, .. } | Self::PenScale { column, .. } => column,
        }
    }
}

/// A tracked point (a section end) with its observed and predicted columns (cm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointSpec {
    /// Label for reports (`s1`, `tip`).
    pub label: &'static str,
    /// Section whose end the point is.
    pub section: usize,
    /// Observed `[x, y]` columns.
    pub observed: [&'static str; 2],
    /// Thesis-predicted `[x, y]` columns.
    pub predicted: [&'static str; 2],
    /// Printed error column (%).
    pub thesis_err_pct: &'static str,
    /// Printed average error (%), README "Printed averages".
    pub thesis_avg_pct: f64,
}

/// A cable whose length the thesis predicted (table 4.5).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LengthSpec {
    /// Label for reports.
    pub label: &'static str,
    /// Index into the scene's `robot.cables`.
    pub cable: usize,
    /// Observed change of length (cm) from the unloaded first row.
    pub observed_delta: &'static str,
    /// Thesis model length (cm).
    pub predicted_length: &'static str,
    /// Thesis model change of length (cm).
    pub predicted_delta: &'static str,
    /// Printed mean of `del dif` = observed - predicted delta over the loaded rows (m).
    pub thesis_avg_del_dif_m: f64,
}

/// Static description of a validation case.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableSpec {
    /// Short name (`4.1`).
    pub name: &'static str,
    /// Thesis caption.
    pub title: &'static str,
    /// CSV file in the data directory.
    pub csv: &'static str,
    /// Scene file in the data directory.
    pub scene: &'static str,
    /// Load columns, applied in order to the scene's loads template.
    pub loads: &'static [RowLoad],
    /// Tracked points.
    pub points: &'static [PointSpec],
    /// Tracked cable lengths.
    pub lengths: &'static [LengthSpec],
    /// Reference length of the thesis's error percentage (m): 19.5 cm per section in
    /// 4.1/4.2, 39 cm in 4.3/4.4 (README "Column definitions").
    pub ref_length_m: f64,
    /// The predicted columns are a copy of another table's (4.4): never a target.
    pub predicted_is_copy: bool,
}

const TIP_MASS: &[RowLoad] = &[RowLoad::Mass {
    point: 0,
    column: "tip_mass_g",
}];

const EXP1_POINTS: [PointSpec; 2] = [
    PointSpec {
        label: "s1",
        section: 0,
        observed: ["obs_s1_x_cm", "obs_s1_y_cm"],
        predicted: ["pred_s1_x_cm", "pred_s1_y_cm"],
        thesis_err_pct: "err_s1_pct",
        thesis_avg_pct: f64::NAN,
    },
    PointSpec {
        label: "s2",
        section: 1,
        observed: ["obs_s2_x_cm", "obs_s2_y_cm"],
        predicted: ["pred_s2_x_cm", "pred_s2_y_cm"],
        thesis_err_pct: "err_s2_pct",
        thesis_avg_pct: f64::NAN,
    },
];

const fn exp1_points(avg1: f64, avg2: f64) -> [PointSpec; 2] {
    let [mut a, mut b] = EXP1_POINTS;
    a.thesis_avg_pct = avg1;
    b.thesis_avg_pct = avg2;
    [a, b]
}

const P41: [PointSpec; 2] = exp1_points(0.919, 1.33);
const P42: [PointSpec; 2] = exp1_points(0.93, 3.36);

const TIP43: &[PointSpec] = &[PointSpec {
    label: "tip",
    section: 0,
    observed: ["obs_x_cm", "obs_y_cm"],
    predicted: ["pred_x_cm", "pred_y_cm"],
    thesis_err_pct: "err_pct",
    thesis_avg_pct: 1.269,
}];

const T41: TableSpec = TableSpec {
    name: "4.1",
    title: "Observed and predicted results for experiment 1a",
    csv: "table_4_1.csv",
    scene: "table_4_1.toml",
    loads: TIP_MASS,
    points: &P41,
    lengths: &[],
    ref_length_m: 0.195,
    predicted_is_copy: false,
};

const T42: TableSpec = TableSpec {
    name: "4.2",
    title: "Predicted and observed results of experiment 1 b",
    csv: "table_4_2.csv",
    scene: "table_4_2.toml",
    loads: &[
        RowLoad::Mass {
            point: 0,
            column: "s1_mass_g",
        },
        RowLoad::PenScale {
            point: 1,
            column: "s2_mass_g",
        },
    ],
    points: &P42,
    lengths: &[],
    ref_length_m: 0.195,
    predicted_is_copy: false,
};

const T43: TableSpec = TableSpec {
    name: "4.3",
    title: "Predicted and observed results of average mass model",
    csv: "table_4_3.csv",
    scene: "table_4_3.toml",
    loads: TIP_MASS,
    points: TIP43,
    lengths: &[],
    ref_length_m: 0.39,
    predicted_is_copy: false,
};

const T43M: TableSpec = TableSpec {
    name: "4.3m",
    title: "Table 4.3 with the measured 14.9 g rod + guides",
    scene: "table_4_3_measured_mass.toml",
    ..T43
};

const T44: TableSpec = TableSpec {
    name: "4.4",
    title: "Predicted and observed results of accurate mass model",
    csv: "table_4_4.csv",
    scene: "table_4_4.toml",
    predicted_is_copy: true,
    ..T43
};

const T45: TableSpec = TableSpec {
    name: "4.5",
    title: "Predicted and observed deflection readings (average mass model)",
    csv: "table_4_5.csv",
    scene: "table_4_3.toml",
    loads: TIP_MASS,
    points: &[],
    lengths: &[LengthSpec {
        label: "cable",
        cable: 0,
        observed_delta: "obs_delta_cm",
        predicted_length: "avg_pred_len_cm",
        predicted_delta: "avg_pred_delta_cm",
        thesis_avg_del_dif_m: 0.0819e-2,
    }],
    ref_length_m: 0.39,
    predicted_is_copy: false,
};

const T45ACC: TableSpec = TableSpec {
    name: "4.5acc",
    title: "Predicted and observed deflection readings (accurate mass model)",
    scene: "table_4_4.toml",
    lengths: &[LengthSpec {
        label: "cable",
        cable: 0,
        observed_delta: "obs_delta_cm",
        predicted_length: "acc_pred_len_cm",
        predicted_delta: "acc_pred_delta_cm",
        thesis_avg_del_dif_m: 0.111e-2,
    }],
    ..T45
};

/// A case with its CSV columns (SI) and its scene, read from the data directory.
#[derive(Clone, Debug)]
pub struct TableData {
    /// What the case is.
    pub spec: &'static TableSpec,
    /// Which case.
    pub table: ThesisTable,
    /// The scene as stored (fitted values not applied).
    pub scene: Scene,
    /// Scene file.
    pub scene_path: PathBuf,
    /// CSV file.
    pub csv_path: PathBuf,
    /// Number of rows.
    pub rows: usize,
    /// Per [`TableSpec::loads`] entry, the row values (kg).
    pub load_values: Vec<Vec<f64>>,
    /// Per point, observed `[x, y]` per row (m).
    pub observed: Vec<Vec<[f64; 2]>>,
    /// Per point, thesis-predicted `[x, y]` per row (m).
    pub predicted: Vec<Vec<[f64; 2]>>,
    /// Per point, the printed error per row (%).
    pub thesis_err_pct: Vec<Vec<f64>>,
    /// Per length, observed change from row 0 (m).
    pub observed_delta: Vec<Vec<f64>>,
    /// Per length, thesis-predicted length (m).
    pub predicted_length: Vec<Vec<f64>>,
    /// Per length, thesis-predicted change (m).
    pub predicted_delta: Vec<Vec<f64>>,
}

impl TableData {
    /// Read the CSV and scene of `table` from `dir` (normally `data/thesis`).
    pub fn load(dir: &Path, table: ThesisTable) -> Result<Self, ValidationError> {
        Self::load_from(&DataSource::Dir(dir.to_path_buf()), table)
    }

    /// Read the CSV and scene of `table` from a directory on disk or the embedded
    /// copy of `data/thesis` ([`DataSource::THESIS`]).
    pub fn load_from(src: &DataSource, table: ThesisTable) -> Result<Self, ValidationError> {
        let spec = table.spec();
        let csv_path = PathBuf::from(src.file(spec.csv)?.display());
        let scene_path = PathBuf::from(src.file(spec.scene)?.display());
        let t = src.table(spec.csv)?;
        let scene = src.scene(spec.scene)?;
        let path = csv_path.display().to_string();
        let col = |name: &str| {
            t.col_si(name).map_err(|e| match e {
                crate::files::thesis::TableError::NoColumn { column, .. } => {
                    crate::files::thesis::TableError::NoColumn {
                        path: path.clone(),
                        column,
                    }
                }
                other => other,
            })
        };
        let pair = |c: [&str; 2]| -> Result<Vec<[f64; 2]>, ValidationError> {
            let (x, y) = (col(c[0])?, col(c[1])?);
            Ok(x.into_iter().zip(y).map(|(x, y)| [x, y]).collect())
        };
        let data = Self {
            spec,
            table,
            rows: t.rows.len(),
            load_values: spec
                .loads
                .iter()
                .map(|l| col(l.column()))
                .collect::<Result<_, _>>()?,
            observed: spec
                .points
                .iter()
                .map(|p| pair(p.observed))
                .collect::<Result<_, _>>()?,
            predicted: spec
                .points
                .iter()
                .map(|p| pair(p.predicted))
                .collect::<Result<_, _>>()?,
            thesis_err_pct: spec
                .points
                .iter()
                .map(|p| col(p.thesis_err_pct))
                .collect::<Result<_, _>>()?,
            observed_delta: spec
                .lengths
                .iter()
                .map(|l| col(l.observed_delta))
                .collect::<Result<_, _>>()?,
            predicted_length: spec
                .lengths
                .iter()
                .map(|l| col(l.predicted_length))
                .collect::<Result<_, _>>()?,
            predicted_delta: spec
                .lengths
                .iter()
                .map(|l| col(l.predicted_delta))
                .collect::<Result<_, _>>()?,
            scene,
            scene_path,
            csv_path,
        };
        // check the load template once, with the stored scene
        for r in 0..data.rows {
            data.row_loads(&data.scene, r)?;
        }
        Ok(data)
    }

    /// The loads of row `row`: the scene's loads with the row's values written in.
    pub fn row_loads(&self, scene: &Scene, row: usize) -> Result<Loads, ValidationError> {
        let mut loads = scene.loads.clone();
        let g = nalgebra::Vector3::from(loads.gravity_m_s2).norm();
        for (l, values) in self.spec.loads.iter().zip(&self.load_values) {
            let w = values[row];
            match *l {
                RowLoad::Mass { point, .. } => {
                    let p = loads
                        .point
                        .get_mut(point)
                        .ok_or_else(|| self.missing(point, "a hanging mass"))?;
                    p.mass_kg = w;
                }
                RowLoad::PenScale { point, .. } => {
                    let p = loads
                        .point
                        .get_mut(point)
                        .ok_or_else(|| self.missing(point, "the pen-scale pull"))?;
                    let d = nalgebra::Vector3::from(p.force_n);
                    let n = d.norm();
                    if !(n > 0.0 && n.is_finite()) {
                        return Err(self.missing(
                            point,
                            "its force_n gives the direction of an upward pen-scale pull and must be non-zero",
                        ));
                    }
                    p.force_n = (d * (-w * g / n)).into();
                }
            }
        }
        Ok(loads)
    }

    fn missing(&self, point: usize, why: &str) -> ValidationError {
        ValidationError::MissingPointLoad {
            table: self.table.name().into(),
            point,
            why: why.into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_and_every_case_loads() {
        for t in ThesisTable::ALL {
            assert_eq!(t.name().parse::<ThesisTable>().unwrap(), t);
        }
        assert_eq!(
            "table_4_5acc".parse::<ThesisTable>().unwrap(),
            ThesisTable::T45Acc
        );
        assert!("4.6".parse::<ThesisTable>().is_err());
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/thesis");
        for t in ThesisTable::ALL {
            let d = TableData::load(&dir, t).unwrap();
            assert_eq!(
                d.rows,
                if t == ThesisTable::T41 {
                    5
                } else if t == ThesisTable::T42 {
                    10
                } else {
                    6
                }
            );
        }
    }

    #[test]
    fn pen_scale_reading_becomes_an_upward_force() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/thesis");
        let d = TableData::load(&dir, ThesisTable::T42).unwrap();
        // last row: 103 g on section 1, pen scale -33.76 g (thesis 4.6.6: 1.01 N and 0.3311 N)
        let loads = d.row_loads(&d.scene, 9).unwrap();
        assert!((loads.point[0].mass_kg - 0.103).abs() < 1e-12);
        let f = loads.point[1].force_n;
        assert!(
            (f[1] - 0.03376 * 9.80665).abs() < 1e-12 && f[0] == 0.0 && f[2] == 0.0,
            "{f:?}"
        );
        let loads = d.row_loads(&d.scene, 0).unwrap();
        assert_eq!(loads.point[1].force_n, [0.0, 0.0, 0.0]);
    }
}
