//! Identification of a tendon robot's servo-to-tendon mapping from a single-tendon
//! pull recording (`tendon_pull.csv`): which segment each servo drives and at which
//! angle, and each segment's angle offset.
//!
//! Method:
//! 1. Rows are grouped into patterns by their pattern label (consecutive rows with the
//!    same label, a suffix such as `_hold` stripped). A pattern's pulled servo is the
//!    servo column that reads highest in it (pulled = positive; the others are paid
//!    out to slack); a pattern whose pulled servo spans less than
//!    [`IdentifySettings::min_pull_m`] pulls nothing (an error).
//! 2. Per servo, the rows where every other servo reads at least
//!    [`IdentifySettings::slack_gap_m`] below it (the others slack) are its evidence.
//!    Model-free response: least squares of the lateral tip (base frame, plane
//!    perpendicular to the robot axis `z`) on the pull `q`, `p = a + b q`; the rest
//!    pose is `a`, the direction `atan2(b_y, b_x)`, the gain `|b|` (mm of tip per mm
//!    of pull) and `R^2` the share of lateral variance along the line.
//! 3. Model response: per segment, the scene's first tendon of that segment is pulled
//!    through the library ([`crate::tendons::TendonWorkspace`]) over a grid of pulls
//!    with the other tendons at the recording's slack reading. With the robot's axis
//!    along gravity (an upright robot, as the FTDCR) and the other tendons slack, the
//!    response of a tendon at hole angle `alpha` is the response at `alpha = 0`
//!    rotated by `alpha` about the axis (symmetry), so one grid per segment serves
//!    every angle. For each servo and segment the model's tip path at the servo's
//!    pulls is fitted to the measured one by a rotation `phi` about the axis and a
//!    translation (2D Procrustes, closed form: `phi = atan2(sum p x m, sum p . m)`
//!    over centred points, Umeyama 1991 without scale); the RMS residual says how
//!    well that segment explains the servo, and `alpha + phi` is the servo's hole
//!    angle if it drives that segment.
//! 4. Assignment: servos are split into the segments (as many as each segment has
//!    tendons) and, within a segment, onto its tendons' relative angles with a common
//!    offset `beta`, minimising `sum (rms_s / model_error)^2 + sum (dangle_s /
//!    angle_sigma)^2` (exhaustive over subsets by dynamic programming, and over the
//!    slot permutations). Ambiguity is reported as the cost increase when two
//!    segments' servo groups are swapped, and per servo as the next-best segment's
//!    residual.
//!
//! Units: SI inside (m, rad); the recording's columns are converted with the scene's
//! `[readings] scale_m` (servos) and `[calibration] unit` (tip).

use crate::files::Scene;
use crate::tendons::Actuation;
use nalgebra::{Matrix3, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Settings of [`identify`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IdentifySettings {
    /// Column holding the pattern label (default `pattern_label`).
    pub pattern_column: String,
    /// Servo columns are those whose name starts with this (default `servo_`).
    pub servo_prefix: String,
    /// Tip columns x, y, z; default: the scene's `[calibration] marker_columns`
    /// (else `tip_x, tip_y, tip_z`).
    pub tip_columns: Option<[String; 3]>,
    /// Label suffixes stripped before grouping (default `["_hold"]`: the hold row
    /// after a pull belongs to that pull).
    pub merge_suffixes: Vec<String>,
    /// Smallest range of the pulled servo in a pattern (m, default 0.5e-3).
    pub min_pull_m: f64,
    /// A row counts for a servo when every other servo reads at least this much
    /// below it (m, default 2e-3): the others are slack.
    pub slack_gap_m: f64,
    /// Pull grid step of the model response (m, default 0.25e-3).
    pub grid_step_m: f64,
    /// Scale of the model's tip-path error in the assignment cost (m, default 2e-3).
    pub model_error_m: f64,
    /// Scale of a servo's angle misfit to its segment's pattern (degrees, default 10).
    pub angle_sigma_deg: f64,
}

impl Default for IdentifySettings {
    fn default() -> Self {
        Self {
            pattern_column: "pattern_label".into(),
            servo_prefix: "servo_".into(),
            tip_columns: None,
            merge_suffixes: vec!["_hold".into()],
            min_pull_m: 0.5e-3,
            slack_gap_m: 2e-3,
            grid_step_m: 0.25e-3,
            model_error_m: 2e-3,
            angle_sigma_deg: 10.0,
        }
    }
}

/// Why an identification could not run.
#[derive(Debug, Error)]
pub enum IdentifyError {
    /// The header lacks a column.
    #[error("{file}:{line}: no column `{column}` ({what}); columns: {available}")]
    MissingColumn {
        /// File.
        file: String,
        /// Header line.
        line: usize,
        /// Column.
        column: String,
        /// What it is for.
        what: String,
        /// Columns present.
        available: String,
    },
    /// A cell is not a number or a row is short.
    #[error("{file}:{line}: column `{column}`: {why}")]
    BadCell {
        /// File.
        file: String,
        /// Line (1-based).
        line: usize,
        /// Column.
        column: String,
        /// What is wrong.
        why: String,
    },
    /// No servo moves in a pattern.
    #[error(
        "{file}:{line}: pattern `{pattern}` ({rows} rows from this line) pulls nothing: the highest-reading servo spans \
         {range_mm:.3} mm (`{servo}`), below the {min_mm} mm of a pull"
    )]
    PullsNothing {
        /// File.
        file: String,
        /// First line of the pattern.
        line: usize,
        /// Pattern label.
        pattern: String,
        /// Its rows.
        rows: usize,
        /// Servo with the largest range.
        servo: String,
        /// That range (mm).
        range_mm: f64,
        /// The threshold (mm).
        min_mm: f64,
    },
    /// Recording and scene do not fit together (counts, missing pulls, geometry).
    #[error("{file}: {why}")]
    Mismatch {
        /// File.
        file: String,
        /// What is wrong.
        why: String,
    },
    /// A file could not be read.
    #[error("{path}: {why}")]
    Io {
        /// Path.
        path: String,
        /// Cause.
        why: String,
    },
    /// The scene's model could not be built or solved.
    #[error("model: {0}")]
    Model(String),
}

/// One row of a pull recording (SI).
#[derive(Clone, Debug, PartialEq)]
pub struct PullRow {
    /// Line (1-based).
    pub line: usize,
    /// Pattern label as written.
    pub label: String,
    /// Servo readings (m), ordered like [`PullRecording::servos`].
    pub servo_m: Vec<f64>,
    /// Tip in the capture frame (m).
    pub tip_m: Vector3<f64>,
}

/// A pull recording.
#[derive(Clone, Debug, PartialEq)]
pub struct PullRecording {
    /// File name for messages.
    pub file: String,
    /// Servo column names.
    pub servos: Vec<String>,
    /// Rows.
    pub rows: Vec<PullRow>,
}

/// One pattern: consecutive rows with the same label key, and its pulled servo.
#[derive(Clone, Debug, PartialEq)]
pub struct Pattern {
    /// Label key (suffixes stripped).
    pub label: String,
    /// Row indices.
    pub rows: std::ops::Range<usize>,
    /// Index of the pulled servo.
    pub servo: usize,
    /// Range of the pulled servo (m).
    pub range_m: f64,
    /// Highest reading of the pulled servo minus the next-highest servo's (m): how
    /// clearly it is the pulled one.
    pub runner_up_gap_m: f64,
}

impl PullRecording {
    /// Parse CSV text (header line; BOM, CRLF, `#` and blank lines tolerated).
    /// Servo readings are multiplied by `servo_scale_m`, tips by `tip_scale_m`.
    pub fn parse_str(
        file: &str,
        text: &str,
        settings: &IdentifySettings,
        tip_columns: &[String; 3],
        servo_scale_m: f64,
        tip_scale_m: f64,
    ) -> Result<Self, IdentifyError> {
        let csv = crate::files::rows::CsvText::parse(text, true).map_err(|(line, why)| {
            IdentifyError::BadCell {
                file: file.into(),
                line,
                column: "-".into(),
                why,
            }
        })?;
        let (hline, names) = (csv.header_line, &csv.names);
        let available = names.join(", ");
        let find = |c: &str, what: &str| {
            names
                .iter()
                .position(|n| n == c)
                .ok_or_else(|| IdentifyError::MissingColumn {
                    file: file.into(),
                    line: hline,
                    column: c.into(),
                    what: what.into(),
                    available: available.clone(),
                })
        };
        let pat = find(&settings.pattern_column, "the pattern label of each row")?;
        let tips = [
            find(&tip_columns[0], "tip x")?,
            find(&tip_columns[1], "tip y")?,
            find(&tip_columns[2], "tip z")?,
        ];
        let servo_idx: Vec<usize> = (0..names.len())
            .filter(|&i| names[i].starts_with(&settings.servo_prefix))
            .collect();
        if servo_idx.is_empty() {
            return Err(IdentifyError::MissingColumn {
                file: file.into(),
                line: hline,
                column: format!("{}*", settings.servo_prefix),
                what: "servo readings".into(),
                available,
            });
        }
        let mut rows = Vec::new();
        for (line, cells) in &csv.rows {
            let line = *line;
            if cells.len() > names.len() {
                // a shifted row would be read as if it were right (as in
                // `Recording`: a short row names its first missing column below)
                return Err(IdentifyError::BadCell {
                    file: file.into(),
                    line,
                    column: "-".into(),
                    why: format!("{} cells where the header has {}", cells.len(), names.len()),
                });
            }
            let num = |i: usize, scale: f64| -> Result<f64, IdentifyError> {
                let bad = |why: String| IdentifyError::BadCell {
                    file: file.into(),
                    line,
                    column: names[i].clone(),
                    why,
                };
                let c = cells
                    .get(i)
                    .ok_or_else(|| bad("missing (short row)".into()))?;
                let v: f64 = c
                    .parse()
                    .map_err(|_| bad(format!("`{}` is not a number", crate::files::shorten(c))))?;
                if !v.is_finite() {
                    return Err(bad(format!("`{c}` is not finite")));
                }
                Ok(v * scale)
            };
            let label = cells.get(pat).cloned().unwrap_or_default();
            if label.is_empty() {
                return Err(IdentifyError::BadCell {
                    file: file.into(),
                    line,
                    column: names[pat].clone(),
                    why: "empty pattern label".into(),
                });
            }
            rows.push(PullRow {
                line,
                label,
                servo_m: servo_idx
                    .iter()
                    .map(|&i| num(i, servo_scale_m))
                    .collect::<Result<_, _>>()?,
                tip_m: Vector3::new(
                    num(tips[0], tip_scale_m)?,
                    num(tips[1], tip_scale_m)?,
                    num(tips[2], tip_scale_m)?,
                ),
            });
        }
        Ok(Self {
            file: file.into(),
            servos: servo_idx.iter().map(|&i| names[i].clone()).collect(),
            rows,
        })
    }

    /// The patterns and their pulled servos.
    pub fn patterns(&self, settings: &IdentifySettings) -> Result<Vec<Pattern>, IdentifyError> {
        let key = |l: &str| {
            let mut k = l.to_string();
            for s in &settings.merge_suffixes {
                if let Some(x) = k.strip_suffix(s.as_str()) {
                    k = x.to_string();
                }
            }
            k
        };
        let mut out = Vec::new();
        let mut start = 0;
        while start < self.rows.len() {
            let k = key(&self.rows[start].label);
            let mut end = start + 1;
            while end < self.rows.len() && key(&self.rows[end].label) == k {
                end += 1;
            }
            let rows = &self.rows[start..end];
            // (servo, highest reading, range): the pulled servo reads highest
            let mut stats: Vec<(usize, f64, f64)> = (0..self.servos.len())
                .map(|s| {
                    let (lo, hi) = rows
                        .iter()
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |a, r| {
                            (a.0.min(r.servo_m[s]), a.1.max(r.servo_m[s]))
                        });
                    (s, hi, hi - lo)
                })
                .collect();
            stats.sort_by(|a, b| b.1.total_cmp(&a.1));
            let (servo, top, range) = stats[0];
            if range < settings.min_pull_m {
                return Err(IdentifyError::PullsNothing {
                    file: self.file.clone(),
                    line: rows[0].line,
                    pattern: k,
                    rows: rows.len(),
                    servo: self.servos[servo].clone(),
                    range_mm: range * 1e3,
                    min_mm: settings.min_pull_m * 1e3,
                });
            }
            out.push(Pattern {
                label: k,
                rows: start..end,
                servo,
                range_m: range,
                runner_up_gap_m: stats.get(1).map_or(f64::INFINITY, |r| top - r.1),
            });
            start = end;
        }
        Ok(out)
    }
}

/// Per servo: its evidence rows (pull `q` in m, tip in the base frame in m).
#[derive(Clone, Debug, PartialEq)]
pub struct ServoRows {
    /// Pulls (m).
    pub q: Vec<f64>,
    /// Tips (m, base frame).
    pub tip: Vec<Vector3<f64>>,
    /// Lines of the rows.
    pub lines: Vec<usize>,
    /// Labels of the patterns pulling it.
    pub labels: Vec<String>,
    /// Median reading of the other (slack) servos over these rows (m; 0 when the
    /// recording has no other servo).
    pub slack_m: f64,
}

/// Model-free response of one servo (step 2 of the method).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinearResponse {
    /// Direction of the tip's lateral motion per pull (rad, from base `+x` to `+y`).
    pub angle_rad: f64,
    /// Lateral tip motion per pull (m/m).
    pub gain: f64,
    /// Share of the lateral variance explained by the line (-).
    pub r2: f64,
}

/// Least squares `p = a + b q` of the lateral tip on the pull.
pub fn linear_response(rows: &ServoRows) -> LinearResponse {
    let n = rows.q.len() as f64;
    let qm = rows.q.iter().sum::<f64>() / n;
    let pm: Vector2<f64> = rows.tip.iter().map(|t| t.xy()).sum::<Vector2<f64>>() / n;
    let (mut sqq, mut sqp, mut spp) = (0.0, Vector2::zeros(), 0.0);
    for (q, t) in rows.q.iter().zip(&rows.tip) {
        let dq = q - qm;
        let dp = t.xy() - pm;
        sqq += dq * dq;
        sqp += dp * dq;
        spp += dp.norm_squared();
    }
    let b = if sqq > 0.0 {
        sqp / sqq
    } else {
        Vector2::zeros()
    };
    let explained = b.norm_squared() * sqq;
    LinearResponse {
        angle_rad: b.y.atan2(b.x),
        gain: b.norm(),
        r2: if spp > 0.0 { explained / spp } else { 0.0 },
    }
}

/// Group the evidence rows per servo (the rows where the others are slack), in the
/// base frame `x_base = R x_capture + t`.
pub fn servo_rows(
    rec: &PullRecording,
    patterns: &[Pattern],
    settings: &IdentifySettings,
    rotation: &Matrix3<f64>,
    translation: &Vector3<f64>,
) -> Result<Vec<ServoRows>, IdentifyError> {
    let mut out: Vec<ServoRows> = (0..rec.servos.len())
        .map(|_| ServoRows {
            q: Vec::new(),
            tip: Vec::new(),
            lines: Vec::new(),
            labels: Vec::new(),
            slack_m: f64::NAN,
        })
        .collect();
    let mut slack: Vec<Vec<f64>> = vec![Vec::new(); rec.servos.len()];
    for p in patterns {
        let o = &mut out[p.servo];
        if !o.labels.contains(&p.label) {
            o.labels.push(p.label.clone());
        }
        for r in &rec.rows[p.rows.clone()] {
            let q = r.servo_m[p.servo];
            let others = r
                .servo_m
                .iter()
                .enumerate()
                .filter(|(s, _)| *s != p.servo)
                .map(|(_, v)| *v);
            if others.clone().all(|v| v <= q - settings.slack_gap_m) {
                o.q.push(q);
                o.tip.push(rotation * r.tip_m + translation);
                o.lines.push(r.line);
                slack[p.servo].extend(others);
            }
        }
    }
    for (s, o) in out.iter_mut().enumerate() {
        if o.q.len() < 3 {
            return Err(IdentifyError::Mismatch {
                file: rec.file.clone(),
                why: format!(
                    "servo `{}` has {} rows with the other servos slack (at least {} mm below it); \
                     at least 3 are needed (patterns pulling it: [{}])",
                    rec.servos[s],
                    o.q.len(),
                    settings.slack_gap_m * 1e3,
                    o.labels.join(", ")
                ),
            });
        }
        slack[s].sort_by(f64::total_cmp);
        // a recording with one servo has no other (slack) servo to take the level
        // from (it indexed an empty list here): level 0, the rest reading
        o.slack_m = slack[s].get(slack[s].len() / 2).copied().unwrap_or(0.0);
    }
    Ok(out)
}

/// The scene's segments: per section with displacement-driven tendons ending on it,
/// the cable indices, reading columns and hole angles (rad).
#[derive(Clone, Debug, PartialEq)]
pub struct SceneSegment {
    /// Section index.
    pub section: usize,
    /// Cable indices of its driven tendons, scene order.
    pub cables: Vec<usize>,
    /// Their hole angles (rad).
    pub angles: Vec<f64>,
}

/// Segments of `scene` (every driven tendon needs a `routing` angle).
pub fn scene_segments(scene: &Scene) -> Result<Vec<SceneSegment>, IdentifyError> {
    let mut segs: Vec<SceneSegment> = Vec::new();
    for (j, c) in scene.robot.cables.iter().enumerate() {
        if c.actuation != Actuation::Displacement {
            continue;
        }
        if c.continuous {
            // (a straight path has an angle, but the proposed snippet edits `routing`
            // tables only, and no recording of such a robot has checked the rest)
            return Err(IdentifyError::Mismatch {
                file: "scene".into(),
                why: format!(
                    "cable {j} is continuously routed (`routing = \"continuous\"`): identify maps servos onto disk-routed tendons' hole angles only"
                ),
            });
        }
        let angle = c
            .routing
            .as_ref()
            .ok_or_else(|| IdentifyError::Mismatch {
                file: "scene".into(),
                why: format!(
                    "cable {j} has no `routing` (identify needs each driven tendon's hole angle)"
                ),
            })?
            .angle_deg
            .to_radians();
        match segs.iter_mut().find(|s| s.section == c.end_section) {
            Some(s) => {
                s.cables.push(j);
                s.angles.push(angle);
            }
            None => segs.push(SceneSegment {
                section: c.end_section,
                cables: vec![j],
                angles: vec![angle],
            }),
        }
    }
    segs.sort_by_key(|s| s.section);
    if segs.is_empty() {
        return Err(IdentifyError::Mismatch {
            file: "scene".into(),
            why: "no displacement-driven tendons to identify".into(),
        });
    }
    Ok(segs)
}

/// Wrap an angle to `(-pi, pi]`.
pub fn wrap(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let r = a.rem_euclid(t);
    if r > std::f64::consts::PI {
        r - t
    } else {
        r
    }
}
