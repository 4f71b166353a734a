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
//! - optional measured tip `[readings] measured_tip` (three columns, unit
//!   `measured_scale_m`), carried along for comparison;
//! - anything else (a pattern label, other sensors) is ignored.
//!
//! A missing or empty reading keeps that tendon's last value (before any value: an
//! error for that row). NaN, infinity or text where a number belongs is an error for
//! that row only, naming the line and column; the stream goes on. A UTF-8 byte-order
//! mark and CRLF line ends are accepted. A header without any tendon column is an
//! error, and the parser then waits for the next line that is a valid header.

use serde::{Deserialize, Serialize};

use super::measure::{finite_cell, LineError};

/// The `[readings]` table of a scene: how to read a readings file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReadingsSpec {
    /// Metres per unit of the tendon columns (default 1: metres; 0.001 for mm).
    pub scale_m: f64,
    /// Time column (s). Default `t_s`.
    pub time_column: String,
    /// Three columns with a measured tip position, shown beside the model's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measured_tip: Option<[String; 3]>,
    /// Metres per unit of `measured_tip` (default 1).
    pub measured_scale_m: f64,
    /// Time offset between the servo log and the measured tip (s, default 0): the
    /// row stamped `t` is solved with the readings linearly interpolated at
    /// `t - time_offset_s` (> 0: the capture lags the log), inside blocks of rows
    /// at most 3 s apart, clamped at a block's ends; needs the time column. See
    /// `calibrate::conditioning`. Calibration path `readings/time_offset_s`.
    pub time_offset_s: f64,
    /// Backlash between each servo and its tendon (m, >= 0, default 0): the tendon
    /// follows the (time-shifted) reading with a play of this width (loading and
    /// unloading differ by it). See `calibrate::conditioning`. Calibration path
    /// `readings/backlash_m`.
    pub backlash_m: f64,
}

impl Default for ReadingsSpec {
    fn default() -> Self {
        Self {
            scale_m: 1.0,
            time_column: "t_s".into(),
            measured_tip: None,
            measured_scale_m: 1.0,
            time_offset_s: 0.0,
            backlash_m: 0.0,
        }
    }
}

impl ReadingsSpec {
    /// Check the numbers.
    pub fn validate(&self) -> Result<(), crate::ModelError> {
        crate::ModelError::positive("readings.scale_m", self.scale_m)?;
        crate::ModelError::positive("readings.measured_scale_m", self.measured_scale_m)?;
        crate::ModelError::finite("readings.time_offset_s", self.time_offset_s)?;
        crate::ModelError::non_negative("readings.backlash_m", self.backlash_m)?;
        Ok(())
    }
}

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
    /// Measured tip (m), if mapped and present.
    pub measured_tip_m: Option<[f64; 3]>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Col {
    Time,
    Reading(usize),
    Tension(usize),
    Tip(usize),
    Ignored,
}

/// Line-by-line parser of a readings stream.
#[derive(Clone, Debug)]
pub struct ReadingsParser {
    columns: Vec<String>,
    cables: Vec<String>,
    spec: ReadingsSpec,
    header: Option<Vec<Col>>,
    names: Vec<String>,
    last: Vec<f64>,
    json: Option<bool>,
}

impl ReadingsParser {
    /// `columns[i]` is driven tendon `i`'s reading column, `cables[i]` its cable name
    /// (for `tension_<cable>`).
    pub fn new(columns: Vec<String>, cables: Vec<String>, spec: ReadingsSpec) -> Self {
        let n = columns.len();
        Self {
            columns,
            cables,
            spec,
            header: None,
            names: Vec::new(),
            last: vec![f64::NAN; n],
            json: None,
        }
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

    /// The first column named `tension_<x>` with no driven tendon `x`.
    fn unknown_tension_column<'a>(
        &self,
        mut names: impl Iterator<Item = &'a str>,
    ) -> Option<String> {
        names
            .find(|n| n.starts_with("tension_") && self.classify(n) == Col::Ignored)
            .map(str::to_string)
    }

    fn unknown_tension(&self, line: usize, name: &str) -> LineError {
        Self::err(
            line,
            name,
            format!(
                "no displacement-driven tendon named `{}` for a load cell (tendons: {}); the column is ignored",
                name.trim_start_matches("tension_"),
                self.cables.join(", ")
            ),
        )
    }

    /// Parse one line: `Ok(None)` for blank lines, comments and headers.
    pub fn line(&mut self, line_no: usize, text: &str) -> Result<Option<ReadingRow>, LineError> {
        let t = text.trim_start_matches('\u{feff}').trim();
        if t.is_empty() || t.starts_with('#') {
            return Ok(None);
        }
        let json = *self.json.get_or_insert(t.starts_with('{'));
        if json {
            return self.json_row(line_no, t).map(Some);
        }
        let cells: Vec<&str> = t.split(',').map(|c| c.trim().trim_matches('"')).collect();
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
            self.names = cells.iter().map(|c| c.to_string()).collect();
            let unknown = self.unknown_tension_column(cells.iter().copied());
            let restart = self.header.replace(cols).is_some();
            if let Some(name) = unknown {
                return Err(self.unknown_tension(line_no, &name));
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
        let obj = v
            .as_object()
            .ok_or_else(|| Self::err(line, "json", "a row must be an object"))?;
        if let Some(name) = self.unknown_tension_column(obj.keys().map(String::as_str)) {
            return Err(self.unknown_tension(line, &name));
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
}
