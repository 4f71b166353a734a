//! Actuator readings of a tendon-driven robot: one row per sample, CSV with a header
//! or JSON lines, mapped to the displacement-driven tendons by column name.
//!
//! Columns (CSV header or JSON keys):
//! - one per displacement-driven tendon, named by the cable's `reading` (default: its
//!   name), in the unit `[readings] scale_m` says (metres per unit; `0.001` for mm);
//! - optional time `[readings] time_column` (default `t_s`);
//! - optional `tension_<cable>` (N, >= 0): a load cell on that displacement-driven
//!   tendon (the load-cell measurements of `estimate::TendonLoadEstimator`); a
//!   `tension_` column naming no displacement-driven tendon is an error naming the
//!   line and column (CSV: reported on the header line, the column is then ignored
//!   and the stream goes on; JSON lines: an error for that row);
//! - optional `length_<cable>`: the length change of a passive (measuring) cable
//!   from the reference state (every unknown load at its reference, readings 0),
//!   positive = longer, in the unit `[readings] length_scale_m` says (metres per
//!   unit; default: `scale_m`, the unit of the tendon columns): the encoder
//!   measurements of `estimate::TendonLoadEstimator`. Only cables with
//!   `actuation = "passive"` have one (the parser learns them from
//!   [`ReadingsParser::with_measuring_cables`]; `Scene::readings_parser` does this);
//!   a `length_` column naming no passive cable (an unknown name, or a driven
//!   tendon, whose reading is an input) is an error naming the line and column, as
//!   for `tension_`;
//! - optional measured tip `[readings] measured_tip` (three columns, unit
//!   `measured_scale_m`), carried along for comparison;
//! - anything else (a pattern label, other sensors) is ignored.
//!
//! A missing or empty reading keeps that tendon's last value (before any value: an
//! error for that row). A missing or empty measurement (`tension_`, `length_`) is
//! *not measured in that row* (`NaN` in [`ReadingRow`]): a measurement is never
//! carried from an earlier row, since a stale value would be fitted as if it were
//! new data; a row with no measurement at all is estimated as unobservable. NaN,
//! infinity or text where a number belongs is an error for that row only, naming
//! the line and column; the stream goes on. A UTF-8 byte-order mark and CRLF line
//! ends are accepted. A header without any tendon column is an error, and the
//! parser then waits for the next line that is a valid header.

use super::measure::{finite_cell, LineError};
pub use crate::scene::readings::{ReadingsSpec, MAX_TIME_OFFSET_S};
use crate::scene::Scene;
use crate::tendons::{Actuation, TendonWorkspace};

/// One parsed row.
#[derive(Clone, Debug, PartialEq)]
pub struct ReadingRow {
    /// 1-based line number.
    pub line: usize,
    /// Time stamp (s), if the file has the time column.
    pub t_s: Option<f64>,
    /// Reading per driven tendon (m).
    pub readings_m: Vec<f64>,
    /// Load-cell tension per driven tendon (N), `NaN` where the row has none.
    pub tensions_n: Vec<f64>,
    /// Length change from the reference state per cable of the robot (m, in robot
    /// cable order), `NaN` where the row has no `length_<cable>` value and for every
    /// cable that is not a measuring cable; empty when the parser knows no cables
    /// ([`ReadingsParser::with_measuring_cables`] not called).
    pub length_changes_m: Vec<f64>,
    /// Measured tip (m), if mapped and present.
    pub measured_tip_m: Option<[f64; 3]>,
}

impl ReadingRow {
    /// The length changes in the form `TendonLoadEstimator::tick` takes: `None`
    /// when the parser knows no cables.
    pub fn length_changes(&self) -> Option<&[f64]> {
        (!self.length_changes_m.is_empty()).then_some(&self.length_changes_m[..])
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Col {
    Time,
    Reading(usize),
    Tension(usize),
    Length(usize),
    Tip(usize),
    Ignored,
}

/// Line-by-line parser of a readings stream.
#[derive(Clone, Debug)]
pub struct ReadingsParser {
    columns: Vec<String>,
    cables: Vec<String>,
    measuring: Vec<Option<String>>,
    spec: ReadingsSpec,
    header: Option<Vec<Col>>,
    names: Vec<String>,
    last: Vec<f64>,
    json: Option<bool>,
}

impl ReadingsParser {
    /// `columns[i]` is driven tendon `i`'s reading column, `cables[i]` its cable name
    /// (for `tension_<cable>`). No `length_<cable>` columns: see
    /// [`Self::with_measuring_cables`].
    pub fn new(columns: Vec<String>, cables: Vec<String>, spec: ReadingsSpec) -> Self {
        let n = columns.len();
        Self {
            columns,
            cables,
            measuring: Vec::new(),
            spec,
            header: None,
            names: Vec::new(),
            last: vec![f64::NAN; n],
            json: None,
        }
    }

    /// Read `length_<cable>` columns: `measuring[j]` is robot cable `j`'s name if
    /// it is a passive (measuring) cable, else `None`; rows then carry
    /// [`ReadingRow::length_changes_m`] with one entry per robot cable.
    pub fn with_measuring_cables(mut self, measuring: Vec<Option<String>>) -> Self {
        self.measuring = measuring;
        self
    }

    /// A non-fatal error: even a bad header is not fatal here (the parser waits for
    /// the next valid one).
    fn err(line: usize, field: impl Into<String>, why: impl Into<String>) -> LineError {
        LineError::new(line, field, why)
    }

    fn classify(&self, name: &str) -> Col {
        if name == self.spec.time_column {
            Col::Time
        } else if let Some(i) = self.columns.iter().position(|c| c == name) {
            Col::Reading(i)
        } else if let Some(i) = name
            .strip_prefix("tension_")
            .and_then(|n| self.cables.iter().position(|c| c == n))
        {
            Col::Tension(i)
        } else if let Some(j) = name
            .strip_prefix("length_")
            .and_then(|n| self.measuring.iter().position(|c| c.as_deref() == Some(n)))
        {
            Col::Length(j)
        } else if let Some(i) = self
            .spec
            .measured_tip
            .as_ref()
            .and_then(|t| t.iter().position(|c| c == name))
        {
            Col::Tip(i)
        } else {
            Col::Ignored
        }
    }

    /// The first column named `tension_<x>` with no driven tendon `x`, or
    /// `length_<x>` with no measuring cable `x`.
    fn unknown_measurement_column<'a>(
        &self,
        mut names: impl Iterator<Item = &'a str>,
    ) -> Option<String> {
        names
            .find(|n| {
                (n.starts_with("tension_") || n.starts_with("length_"))
                    && self.classify(n) == Col::Ignored
            })
            .map(str::to_string)
    }

    fn unknown_measurement(&self, line: usize, name: &str) -> LineError {
        let why = if let Some(cable) = name.strip_prefix("tension_") {
            format!(
                "no displacement-driven tendon named `{cable}` for a load cell (tendons: {}); the column is ignored",
                self.cables.join(", ")
            )
        } else {
            let cable = name.trim_start_matches("length_");
            let passive: Vec<&str> = self
                .measuring
                .iter()
                .flatten()
                .map(String::as_str)
                .collect();
            let passive = if passive.is_empty() {
                "none".to_string()
            } else {
                passive.join(", ")
            };
            if self.cables.iter().any(|c| c == cable) {
                format!(
                    "`{cable}` is a displacement-driven tendon, not a passive measuring cable: its reading is an input (passive cables: {passive}); the column is ignored"
                )
            } else {
                format!(
                    "no passive (measuring) cable named `{cable}` (passive cables: {passive}); the column is ignored"
                )
            }
        };
        Self::err(line, name, why)
    }

    /// Parse one line: `Ok(None)` for blank lines, comments and headers.
    pub fn line(&mut self, line_no: usize, text: &str) -> Result<Option<ReadingRow>, LineError> {
        let Some(t) = super::rows::content(text) else {
            return Ok(None);
        };
        let json = *self.json.get_or_insert(t.starts_with('{'));
        if json {
            return self.json_row(line_no, t).map(Some);
        }
        let cells = super::rows::split(t).map_err(|why| Self::err(line_no, "row", why))?;
        let cells: Vec<&str> = cells.iter().map(String::as_str).collect();
        let looks_like_header = cells.iter().any(|c| {
            matches!(self.classify(c), Col::Reading(_) | Col::Time) && c.parse::<f64>().is_err()
        });
        if self.header.is_none() || looks_like_header {
            let cols: Vec<Col> = cells.iter().map(|c| self.classify(c)).collect();
            if !cols.iter().any(|c| matches!(c, Col::Reading(_))) {
                self.header = None;
                return Err(Self::err(
                    line_no,
                    "header",
                    format!(
                        "no tendon column: expected some of {} (waiting for a valid header)",
                        self.columns.join(", ")
                    ),
                ));
            }
            if let Some((a, b, name)) = super::duplicate_column(&cells) {
                self.header = None;
                return Err(Self::err(
                    line_no,
                    "header",
                    format!(
                        "column `{name}` is given twice (columns {a} and {b}; waiting for a valid header)"
                    ),
                ));
            }
            self.names = cells.iter().map(|c| c.to_string()).collect();
            let unknown = self.unknown_measurement_column(cells.iter().copied());
            let restart = self.header.replace(cols).is_some();
            if let Some(name) = unknown {
                return Err(self.unknown_measurement(line_no, &name));
            }
            if restart {
                // a header mid-stream (two recordings joined, a logger restarted):
                // its columns are used from here on, and the line is reported, so no
                // row is silently read differently from the one before
                return Err(Self::err(
                    line_no,
                    "header",
                    "a new header mid-stream: the columns are read from it from here on",
                ));
            }
            return Ok(None);
        }
        let cols = self.header.as_ref().expect("header checked above");
        if cells.len() != cols.len() {
            return Err(Self::err(
                line_no,
                "row",
                format!("{} cells, the header has {}", cells.len(), cols.len()),
            ));
        }
        let items: Vec<(Col, String, Option<String>)> = cols
            .iter()
            .zip(&self.names)
            .zip(&cells)
            .map(|((c, n), v)| (*c, n.clone(), Some(v.to_string())))
            .collect();
        self.row(line_no, items.into_iter()).map(Some)
    }

    fn json_row(&mut self, line: usize, t: &str) -> Result<ReadingRow, LineError> {
        let v: serde_json::Value =
            serde_json::from_str(t).map_err(|e| Self::err(line, "json", e.to_string()))?;
        if !v.is_object() {
            return Err(Self::err(line, "json", "a row must be an object"));
        }
        // `Value` keeps the last of two equal keys: parse again refusing a repeat
        let obj = &crate::files::json::unique_object(t)
            .map_err(|e| Self::err(line, "json", e.to_string()))?;
        if let Some(name) = self.unknown_measurement_column(obj.keys().map(String::as_str)) {
            return Err(self.unknown_measurement(line, &name));
        }
        let items: Vec<(Col, String, Option<String>)> = obj
            .iter()
            .map(|(k, v)| {
                let cell = match v {
                    serde_json::Value::Null => None,
                    serde_json::Value::Number(n) => Some(n.to_string()),
                    serde_json::Value::String(s) => Some(s.clone()),
                    other => Some(other.to_string()),
                };
                (self.classify(k), k.clone(), cell)
            })
            .collect();
        self.row(line, items.into_iter())
    }

    fn row(
        &mut self,
        line: usize,
        items: impl Iterator<Item = (Col, String, Option<String>)>,
    ) -> Result<ReadingRow, LineError> {
        let n = self.columns.len();
        let mut row = ReadingRow {
            line,
            t_s: None,
            readings_m: vec![f64::NAN; n],
            tensions_n: vec![f64::NAN; n],
            length_changes_m: vec![f64::NAN; self.measuring.len()],
            measured_tip_m: None,
        };
        let mut tip = [f64::NAN; 3];
        for (col, name, cell) in items {
            if col == Col::Ignored {
                continue;
            }
            let Some(cell) = cell.filter(|c| !c.is_empty()) else {
                continue;
            };
            let v = finite_cell(line, &name, &cell)?;
            match col {
                Col::Time => row.t_s = Some(v),
                Col::Reading(i) => row.readings_m[i] = v * self.spec.scale_m,
                Col::Tension(i) => {
                    if v < 0.0 {
                        return Err(Self::err(
                            line,
                            name,
                            format!("a tension must be >= 0, got {v}"),
                        ));
                    }
                    row.tensions_n[i] = v
                }
                Col::Length(j) => row.length_changes_m[j] = v * self.spec.length_scale(),
                Col::Tip(i) => tip[i] = v * self.spec.measured_scale_m,
                Col::Ignored => {}
            }
        }
        for i in 0..n {
            if row.readings_m[i].is_nan() {
                if self.last[i].is_nan() {
                    return Err(Self::err(
                        line,
                        self.columns[i].clone(),
                        "missing, and no earlier row gave a value to keep",
                    ));
                }
                row.readings_m[i] = self.last[i];
            }
        }
        self.last.copy_from_slice(&row.readings_m);
        if tip.iter().all(|x| x.is_finite()) {
            row.measured_tip_m = Some(tip);
        }
        Ok(row)
    }
}

impl ReadingsParser {
    /// The rows of a whole readings text that parse, in order; lines that do not
    /// (headers, comments, bad rows) are skipped without a word: for benches, tests
    /// and targets built from shipped recordings, not for user input, whose bad lines
    /// must be reported ([`ReadingsParser::line`]).
    pub fn good_rows(&mut self, text: &str) -> Vec<ReadingRow> {
        text.lines()
            .enumerate()
            .filter_map(|(i, l)| self.line(i + 1, l).ok().flatten())
            .collect()
    }

    /// A parser for readings files of `scene`'s displacement-driven tendons (as
    /// solved by `ws`), with a `length_<cable>` column for each passive (measuring)
    /// cable.
    pub fn from_scene(scene: &Scene, ws: &TendonWorkspace) -> Self {
        let robot = ws.workspace().robot();
        Self::new(
            ws.columns().to_vec(),
            ws.driven()
                .iter()
                .map(|&j| robot.cables()[j].name.clone())
                .collect(),
            scene.readings.clone().unwrap_or_default(),
        )
        .with_measuring_cables(
            robot
                .cables()
                .iter()
                .map(|c| (c.actuation == Actuation::Passive).then(|| c.name.clone()))
                .collect(),
        )
    }
}

impl Scene {
    /// A parser for readings files of this scene: [`ReadingsParser::from_scene`].
    pub fn readings_parser(&self, ws: &TendonWorkspace) -> ReadingsParser {
        ReadingsParser::from_scene(self, ws)
    }

    /// The model's tips (m, base frame) at the rows of a readings text, solved warm in
    /// order; rows that do not parse or whose solve does not converge are skipped, and
    /// at most `limit` tips are returned. The targets of the IK round trips (`reach`
    /// without arguments, the IK bench and tests).
    pub fn model_tips(
        &self,
        readings_text: &str,
        limit: usize,
    ) -> Result<Vec<nalgebra::Vector3<f64>>, crate::error::ModelError> {
        let mut tw = self.tendon_workspace()?;
        let rows = self.readings_parser(&tw).good_rows(readings_text);
        let mut out = Vec::new();
        for r in &rows {
            if out.len() == limit {
                break;
            }
            if tw.solve_readings(&r.readings_m)?.status.is_converged() {
                out.push(tw.tip_position());
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parser() -> ReadingsParser {
        ReadingsParser::new(
            vec!["a_mm".into(), "b_mm".into()],
            vec!["a".into(), "b".into()],
            ReadingsSpec {
                scale_m: 1e-3,
                ..ReadingsSpec::default()
            },
        )
    }

    #[test]
    fn csv_with_bom_crlf_missing_cells_and_bad_rows() {
        let mut p = parser();
        assert_eq!(p.line(1, "\u{feff}t_s,label,a_mm,b_mm\r\n").unwrap(), None);
        let r = p.line(2, "0.5,pull,1.5,-2\r\n").unwrap().unwrap();
        assert_eq!(r.readings_m, vec![1.5e-3, -2e-3]);
        assert_eq!(r.t_s, Some(0.5));
        // missing cell keeps the last value
        let r = p.line(3, "0.6,pull,,-1").unwrap().unwrap();
        assert_eq!(r.readings_m, vec![1.5e-3, -1e-3]);
        let e = p.line(4, "0.7,pull,NaN,1").unwrap_err();
        assert_eq!((e.line, e.field.as_str()), (4, "a_mm"));
        let e = p.line(5, "0.7,pull,1").unwrap_err();
        assert!(e.why.contains("cells"), "{e}");
        // the stream goes on
        assert!(p.line(6, "0.8,x,2,2").unwrap().is_some());
        // a header mid-stream is reported, and its columns are used from then on
        let e = p.line(7, "b_mm,t_s,a_mm").unwrap_err();
        assert_eq!((e.line, e.field.as_str()), (7, "header"));
        let r = p.line(8, "3,0.9,4").unwrap().unwrap();
        assert_eq!(r.readings_m, vec![4e-3, 3e-3]);
    }

    #[test]
    fn json_rows_and_first_missing_value() {
        let mut p = parser();
        let e = p.line(1, r#"{"t_s": 0, "a_mm": 1}"#).unwrap_err();
        assert_eq!(e.field, "b_mm");
        let r = p
            .line(2, r#"{"t_s": 0, "a_mm": 1, "b_mm": 2, "tension_a": 3}"#)
            .unwrap()
            .unwrap();
        assert_eq!(r.tensions_n[0], 3.0);
        assert!(r.tensions_n[1].is_nan());
        // load-cell errors name line, column and value; the stream goes on
        let e = p
            .line(3, r#"{"a_mm": 1, "b_mm": 2, "tension_zz": 3}"#)
            .unwrap_err();
        assert_eq!((e.line, e.field.as_str()), (3, "tension_zz"));
        assert!(e.why.contains("`zz`") && e.why.contains("a, b"), "{e}");
        let e = p
            .line(4, r#"{"a_mm": 1, "b_mm": 2, "tension_b": -0.5}"#)
            .unwrap_err();
        assert_eq!((e.line, e.field.as_str()), (4, "tension_b"));
        assert!(e.why.contains("-0.5"), "{e}");
        let e = p
            .line(5, r#"{"a_mm": 1, "b_mm": 2, "tension_a": "NaN"}"#)
            .unwrap_err();
        assert_eq!((e.line, e.field.as_str()), (5, "tension_a"));
        assert!(p
            .line(6, r#"{"a_mm": 1, "tension_b": 0.5}"#)
            .unwrap()
            .is_some());
    }

    #[test]
    fn csv_load_cell_columns() {
        let mut p = parser();
        // an unknown load cell is reported on the header, which is still used
        let e = p.line(1, "a_mm,b_mm,tension_a,tension_c").unwrap_err();
        assert_eq!((e.line, e.field.as_str()), (1, "tension_c"));
        let r = p.line(2, "1,2,0.75,9").unwrap().unwrap();
        assert_eq!(r.tensions_n[0], 0.75);
        assert!(r.tensions_n[1].is_nan());
        let e = p.line(3, "1,2,-1,0").unwrap_err();
        assert_eq!((e.line, e.field.as_str()), (3, "tension_a"));
        assert!(e.why.contains("-1"), "{e}");
        let e = p.line(4, "1,2,inf,0").unwrap_err();
        assert_eq!((e.line, e.field.as_str()), (4, "tension_a"));
        // empty load cell: no measurement on that row
        let r = p.line(5, "1,2,,0").unwrap().unwrap();
        assert!(r.tensions_n[0].is_nan());
    }

    #[test]
    fn csv_measuring_cable_columns() {
        let mut p = parser().with_measuring_cables(vec![None, None, Some("m".into())]);
        // without `length_scale_m` the tendon unit applies
        assert_eq!(p.line(1, "a_mm,b_mm,length_m").unwrap(), None);
        let r = p.line(2, "1,2,-0.5").unwrap().unwrap();
        assert_eq!(r.length_changes().map(<[f64]>::len), Some(3));
        assert!(r.length_changes_m[..2].iter().all(|v| v.is_nan()));
        assert_eq!(r.length_changes_m[2], -0.5e-3);
        // empty: not measured (not the last value)
        let r = p.line(3, "1,2,").unwrap().unwrap();
        assert!(r.length_changes_m[2].is_nan());
        let e = p.line(4, "a_mm,b_mm,length_a").unwrap_err();
        assert_eq!((e.line, e.field.as_str()), (4, "length_a"));
        assert!(e.why.contains("displacement-driven"), "{e}");
        // a parser that knows no cables: no length changes, `length_` is unknown
        let mut q = ReadingsParser::new(
            vec!["a".into()],
            vec!["a".into()],
            ReadingsSpec {
                length_scale_m: Some(1e-6),
                ..ReadingsSpec::default()
            },
        );
        let e = q.line(1, "a,length_m").unwrap_err();
        assert!(e.why.contains("passive cables: none"), "{e}");
        assert_eq!(q.line(2, "1,5").unwrap().unwrap().length_changes(), None);
    }
}
