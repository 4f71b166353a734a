//! Encoder streams: cable length changes per sample, as CSV or JSON lines.
//!
//! CSV: a header naming the columns: optional `t_s`, then one column per cable,
//! named like the scene's cables (changes in metres), optionally `sigma_<cable>`
//! columns (metres). An empty cell means "this cable is missing in this sample".
//! JSON lines: `{"t_s": 0.1, "changes_m": [1e-4, null, 2e-4], "sigma_m": [...]}`;
//! `null` is missing. A malformed or non-finite value is an error for that line
//! only (naming the line and the field); the stream goes on.
//!
//! Lines may end in CRLF, and the first may start with a UTF-8 byte-order mark
//! (both are ignored on any line). A CSV header that does not name the columns is
//! reported once and **stops the stream**: the error is [`LineError::fatal`], and
//! every later non-blank line gets a short fatal error pointing back at it (a caller
//! that keeps reading sees no sample from rows whose columns are unknown; the
//! command-line tools stop at the first fatal error and exit with status 1).

use serde::Deserialize;
use thiserror::Error;

/// One encoder sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// 1-based line number in the input.
    pub line: usize,
    /// Time stamp (s), if the stream has one.
    pub t_s: Option<f64>,
    /// Length change per cable (m); `NaN` = missing.
    pub changes_m: Vec<f64>,
    /// Noise per cable (m), if given; `NaN` = default.
    pub sigma_m: Option<Vec<f64>>,
}

/// A bad line (the stream continues after it).
#[derive(Clone, Debug, PartialEq, Error)]
#[error("line {line}: {field}: {why}")]
pub struct LineError {
    /// 1-based line number.
    pub line: usize,
    /// Column or JSON key.
    pub field: String,
    /// What is wrong, quoting the value.
    pub why: String,
    /// The stream cannot go on (a bad CSV header): stop reading.
    pub fatal: bool,
}

impl LineError {
    /// An error of one line; the stream goes on.
    pub fn new(line: usize, field: impl Into<String>, why: impl Into<String>) -> Self {
        Self {
            line,
            field: field.into(),
            why: why.into(),
            fatal: false,
        }
    }
}

/// A cell (CSV) or value (JSON) of column `field` that must be a finite number.
pub fn finite_cell(line: usize, field: &str, cell: &str) -> Result<f64, LineError> {
    let v: f64 = cell.parse().map_err(|_| {
        LineError::new(
            line,
            field,
            format!("`{}` is not a number", super::shorten(cell)),
        )
    })?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(LineError::new(
            line,
            field,
            format!("`{}` is not finite", super::shorten(cell)),
        ))
    }
}

/// Input format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Comma-separated with a header line.
    Csv,
    /// One JSON object per line.
    JsonLines,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Col {
    Time,
    Change(usize),
    Sigma(usize),
}

/// Parses a stream line by line.
#[derive(Clone, Debug)]
pub struct StreamParser {
    cables: Vec<String>,
    format: Option<Format>,
    columns: Option<Vec<Col>>,
    /// Line of the bad header that stopped the stream.
    stopped_at: Option<usize>,
}

impl StreamParser {
    /// A parser for a robot with these cable names; `format = None` detects it from
    /// the first non-empty line (`{` means JSON lines).
    pub fn new(cables: Vec<String>, format: Option<Format>) -> Self {
        Self {
            cables,
            format,
            columns: None,
            stopped_at: None,
        }
    }

    /// The line of the bad CSV header that stopped the stream, if any.
    pub fn stopped_at(&self) -> Option<usize> {
        self.stopped_at
    }

    /// Parse one line. `Ok(None)` for blank, comment (`#`) and CSV header lines.
    pub fn line(&mut self, line_no: usize, text: &str) -> Result<Option<Sample>, LineError> {
        let Some(t) = super::rows::content(text) else {
            return Ok(None);
        };
        if let Some(at) = self.stopped_at {
            return Err(LineError {
                fatal: true,
                ..Self::err(
                    line_no,
                    "stream",
                    format!("not read: the stream stopped at the bad header of line {at}"),
                )
            });
        }
        let format = *self.format.get_or_insert(if t.starts_with('{') {
            Format::JsonLines
        } else {
            Format::Csv
        });
        match format {
            Format::JsonLines => self.json(line_no, t).map(Some),
            Format::Csv => self.csv(line_no, t),
        }
    }

    fn err(line: usize, field: impl Into<String>, why: impl Into<String>) -> LineError {
        LineError::new(line, field, why)
    }

    /// A fatal header error: the stream stops here.
    fn header_err(&mut self, line: usize, field: String, why: String) -> LineError {
        self.stopped_at = Some(line);
        LineError {
            fatal: true,
            ..Self::err(line, field, why)
        }
    }

    fn csv(&mut self, line: usize, t: &str) -> Result<Option<Sample>, LineError> {
        let cells = super::rows::split(t).map_err(|why| Self::err(line, "row", why))?;
        let cells: Vec<&str> = cells.iter().map(String::as_str).collect();
        let Some(cols) = &self.columns else {
            if let Some((a, b, name)) = super::duplicate_column(&cells) {
                let why = format!(
                    "column `{name}` is given twice (columns {a} and {b}); the stream stops here"
                );
                return Err(self.header_err(line, "header".into(), why));
            }
            let mut cols = Vec::with_capacity(cells.len());
            for c in &cells {
                let col = if *c == "t_s" || *c == "t" {
                    Col::Time
                } else if let Some(j) = self.cables.iter().position(|n| n == c) {
                    Col::Change(j)
                } else if let Some(j) = c
                    .strip_prefix("sigma_")
                    .and_then(|n| self.cables.iter().position(|x| x == n))
                {
                    Col::Sigma(j)
                } else {
                    let why = format!(
                        "not t_s, a cable name ({}) or sigma_<cable>; the stream stops here",
                        self.cables.join(", ")
                    );
                    return Err(self.header_err(line, format!("header `{c}`"), why));
                };
                cols.push(col);
            }
            if !cols.iter().any(|c| matches!(c, Col::Change(_))) {
                let why = "no cable column; the stream stops here".to_string();
                return Err(self.header_err(line, "header".into(), why));
            }
            self.columns = Some(cols);
            return Ok(None);
        };
        if cells.len() != cols.len() {
            return Err(Self::err(
                line,
                "row",
                format!("{} cells, header has {}", cells.len(), cols.len()),
            ));
        }
        let n = self.cables.len();
        let mut s = Sample {
            line,
            t_s: None,
            changes_m: vec![f64::NAN; n],
            sigma_m: None,
        };
        for (cell, col) in cells.iter().zip(cols) {
            let name = match col {
                Col::Time => "t_s".to_string(),
                Col::Change(j) => self.cables[*j].clone(),
                Col::Sigma(j) => format!("sigma_{}", self.cables[*j]),
            };
            if cell.is_empty() {
                if *col == Col::Time {
                    return Err(Self::err(line, name, "empty time stamp"));
                }
                continue;
            }
            let v = finite_cell(line, &name, cell)?;
            match col {
                Col::Time => s.t_s = Some(v),
                Col::Change(j) => s.changes_m[*j] = v,
                Col::Sigma(j) => {
                    if v <= 0.0 {
                        return Err(Self::err(line, name, format!("noise must be > 0, got {v}")));
                    }
                    s.sigma_m.get_or_insert_with(|| vec![f64::NAN; n])[*j] = v;
                }
            }
        }
        Ok(Some(s))
    }

    fn json(&self, line: usize, t: &str) -> Result<Sample, LineError> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Row {
            #[serde(default)]
            t_s: Option<f64>,
            changes_m: Vec<Option<f64>>,
            #[serde(default)]
            sigma_m: Option<Vec<Option<f64>>>,
        }
        let row: Row =
            serde_json::from_str(t).map_err(|e| Self::err(line, "json", e.to_string()))?;
        let n = self.cables.len();
        if row.changes_m.len() != n {
            return Err(Self::err(
                line,
                "changes_m",
                format!("{} values for {} cables", row.changes_m.len(), n),
            ));
        }
        if let Some(t) = row.t_s {
            if !t.is_finite() {
                return Err(Self::err(line, "t_s", format!("{t} is not finite")));
            }
        }
        let sigma = match row.sigma_m {
            Some(v) if v.len() != n => {
                return Err(Self::err(
                    line,
                    "sigma_m",
                    format!("{} values for {} cables", v.len(), n),
                ));
            }
            Some(v) => {
                let mut out = vec![f64::NAN; n];
                for (j, s) in v.iter().enumerate() {
                    if let Some(s) = s {
                        if !(s.is_finite() && *s > 0.0) {
                            return Err(Self::err(
                                line,
                                format!("sigma_m[{j}]"),
                                format!("noise must be finite and > 0, got {s}"),
                            ));
                        }
                        out[j] = *s;
                    }
                }
                Some(out)
            }
            None => None,
        };
        Ok(Sample {
            line,
            t_s: row.t_s,
            changes_m: row
                .changes_m
                .iter()
                .map(|v| v.unwrap_or(f64::NAN))
                .collect(),
            sigma_m: sigma,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parser() -> StreamParser {
        StreamParser::new(vec!["a".into(), "b".into()], None)
    }

    #[test]
    fn csv_with_missing_cell_and_bad_lines() {
        let mut p = parser();
        assert_eq!(p.line(1, "t_s,a,b").unwrap(), None);
        let s = p.line(2, "0.1,1e-4,").unwrap().unwrap();
        assert_eq!(s.changes_m[0], 1e-4);
        assert!(s.changes_m[1].is_nan());
        let e = p.line(3, "0.2,abc,1").unwrap_err();
        assert_eq!((e.line, e.field.as_str()), (3, "a"));
        assert!(e.to_string().contains("`abc`"));
        let e = p.line(4, "0.3,NaN,1").unwrap_err();
        assert!(e.to_string().contains("not finite"), "{e}");
        assert!(p.line(5, "0.4,1e-4,2e-4").unwrap().is_some());
    }

    /// A UTF-8 byte-order mark and CRLF endings (as `str::lines` leaves them when
    /// the text is split on `\n` only) are accepted.
    #[test]
    fn bom_and_crlf() {
        let mut p = parser();
        assert_eq!(p.line(1, "\u{feff}t_s,a,b\r").unwrap(), None);
        let s = p.line(2, "0.1,1e-4,2e-4\r").unwrap().unwrap();
        assert_eq!(s.changes_m, vec![1e-4, 2e-4]);
        let mut p = parser();
        let s = p
            .line(1, "\u{feff}{\"changes_m\": [1e-4, 2e-4]}\r")
            .unwrap()
            .unwrap();
        assert_eq!(s.changes_m, vec![1e-4, 2e-4]);
    }

    /// A bad header is reported once as fatal; later rows are not read as headers.
    #[test]
    fn bad_header_stops_the_stream() {
        let mut p = parser();
        let e = p.line(1, "t_s,a,zz").unwrap_err();
        assert!(e.fatal && e.field == "header `zz`", "{e}");
        assert_eq!(p.stopped_at(), Some(1));
        assert_eq!(p.line(2, "").unwrap(), None);
        let e = p.line(3, "0.1,1e-4,2e-4").unwrap_err();
        assert!(e.fatal && e.field == "stream", "{e}");
        assert!(!e.to_string().contains("header `0.1`"), "{e}");
        // a valid header later does not restart it
        assert!(p.line(4, "t_s,a,b").unwrap_err().fatal);
    }

    #[test]
    fn json_lines() {
        let mut p = parser();
        let s = p
            .line(1, r#"{"t_s": 1.0, "changes_m": [null, 2e-4]}"#)
            .unwrap()
            .unwrap();
        assert!(s.changes_m[0].is_nan());
        let e = p.line(2, r#"{"changes_m": [1.0]}"#).unwrap_err();
        assert_eq!(e.field, "changes_m");
        let e = p
            .line(3, r#"{"changes_m": [1.0, 2.0], "oops": 1}"#)
            .unwrap_err();
        assert!(e.why.contains("oops"), "{e}");
    }
}
