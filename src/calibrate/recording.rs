//! Recordings: rows of model inputs (tensions, forces, ...) and the measured marker
//! position, read from CSV (header line, or column names given by
//! [`ColumnMap::header`] for a file without one; a UTF-8 BOM and CRLF line ends are
//! tolerated; `#` lines and blank lines are skipped) or JSON lines (one object per
//! line, keys = column names). Every error names the file, the line (1-based) and
//! the column.

use super::conditioning::InputTimeline;
use super::CalibrationError;
use crate::scene::calibration::{CalibrationSpec, LengthUnit};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::ops::Range;
use std::path::Path;
use std::sync::Arc;

/// Which columns of a recording are read, and how.
#[derive(Clone, Debug, PartialEq)]
pub struct ColumnMap {
    /// Marker position columns x, y, z.
    pub marker_columns: [String; 3],
    /// Unit of the marker columns.
    pub unit: LengthUnit,
    /// Time column (s); `None` = `t_s` if present, else no time.
    pub time_column: Option<String>,
    /// Input columns; empty = every column named `tension_*`, `force_*` or `mass_*`.
    pub inputs: Vec<String>,
    /// Column names of a CSV file without a header line (its first line is data);
    /// empty = the first line is the header. Not used for JSON lines.
    pub header: Vec<String>,
}

impl Default for ColumnMap {
    fn default() -> Self {
        Self::from_spec(&CalibrationSpec::default())
    }
}

impl ColumnMap {
    /// The column map of a scene's `[calibration]` table.
    pub fn from_spec(spec: &CalibrationSpec) -> Self {
        Self {
            marker_columns: spec.marker_columns.clone(),
            unit: spec.unit,
            time_column: spec.time_column.clone(),
            inputs: spec.inputs.clone(),
            header: spec.header.clone(),
        }
    }
}

/// Is `name` an input column when the map lists none (`tension_*`, `force_*`, `mass_*`)?
pub fn is_default_input(name: &str) -> bool {
    ["tension_", "force_", "mass_"]
        .iter()
        .any(|p| name.starts_with(p))
}

/// One row of a recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RecordingRow {
    /// Line in the file (1-based).
    pub line: usize,
    /// Time stamp (s), if the recording has a time column.
    pub t_s: Option<f64>,
    /// Measured marker position in the capture frame (m).
    pub marker_m: Vector3<f64>,
    /// Input values, ordered like [`Recording::input_names`] (units as named: N, kg).
    pub inputs: Vec<f64>,
    /// The whole recording's inputs over time and this row's place in it (set when
    /// a recording is read), for models that read inputs at a shifted time or
    /// through a play ([`super::conditioning`]); a row taken out of its recording
    /// keeps it. `None` for rows built by hand. Not serialized.
    #[serde(skip)]
    pub history: Option<RowHistory>,
}

/// Where a row sits in its recording's [`InputTimeline`].
#[derive(Clone, Debug)]
pub struct RowHistory {
    /// The recording's inputs over time (shared by its rows).
    pub timeline: Arc<InputTimeline>,
    /// This row's index in it.
    pub index: usize,
}

impl PartialEq for RowHistory {
    /// Same timeline (by identity) and index.
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.timeline, &other.timeline) && self.index == other.index
    }
}

/// A parsed recording.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// File name used in errors and reports.
    pub file: String,
    /// Names of the input columns.
    pub input_names: Vec<String>,
    /// The marker columns as read.
    pub marker_columns: [String; 3],
    /// Unit the marker columns were read in (values are stored in m).
    pub unit: LengthUnit,
    /// The rows, in file order.
    pub rows: Vec<RecordingRow>,
}

fn cell_err(file: &str, line: usize, column: String, why: String) -> CalibrationError {
    CalibrationError::Recording {
        file: file.into(),
        line,
        column,
        why,
    }
}

/// Split one CSV line into cells (double quotes group, `""` is a quote).
fn number(file: &str, line: usize, column: &str, cell: &str) -> Result<f64, CalibrationError> {
    if cell.is_empty() {
        return Err(cell_err(file, line, column.into(), "empty cell".into()));
    }
    let v: f64 = cell.parse().map_err(|_| {
        cell_err(
            file,
            line,
            column.into(),
            format!("`{}` is not a number", crate::files::shorten(cell)),
        )
    })?;
    if !v.is_finite() {
        return Err(cell_err(
            file,
            line,
            column.into(),
            format!("`{cell}` is not finite (NaN or infinite)"),
        ));
    }
    Ok(v)
}

/// Resolved column layout: indices (CSV) or keys (JSON) of what is read.
struct Layout {
    marker: [String; 3],
    time: Option<String>,
    inputs: Vec<String>,
}

impl Layout {
    fn new(
        file: &str,
        header_line: usize,
        header: &[String],
        map: &ColumnMap,
    ) -> Result<Self, CalibrationError> {
        if let Some((a, b, name)) = crate::files::duplicate_column(header) {
            return Err(cell_err(
                file,
                header_line,
                name,
                format!("column given twice (columns {a} and {b})"),
            ));
        }
        let need = |c: &str| -> Result<String, CalibrationError> {
            if header.iter().any(|h| h == c) {
                Ok(c.to_string())
            } else {
                Err(CalibrationError::MissingColumn {
                    file: file.into(),
                    line: header_line,
                    column: c.into(),
                    available: header.join(", "),
                })
            }
        };
        let marker = [
            need(&map.marker_columns[0])?,
            need(&map.marker_columns[1])?,
            need(&map.marker_columns[2])?,
        ];
        let time = match &map.time_column {
            Some(t) => Some(need(t)?),
            None => header.iter().find(|h| *h == "t_s").cloned(),
        };
        let inputs = if map.inputs.is_empty() {
            header
                .iter()
                .filter(|h| is_default_input(h))
                .cloned()
                .collect()
        } else {
            map.inputs
                .iter()
                .map(|c| need(c))
                .collect::<Result<_, _>>()?
        };
        Ok(Self {
            marker,
            time,
            inputs,
        })
    }

    fn row(
        &self,
        file: &str,
        line: usize,
        unit: LengthUnit,
        get: &dyn Fn(&str) -> Option<String>,
    ) -> Result<RecordingRow, CalibrationError> {
        let read = |c: &str| -> Result<f64, CalibrationError> {
            let cell = get(c)
                .ok_or_else(|| cell_err(file, line, c.into(), "missing in this row".into()))?;
            number(file, line, c, &cell)
        };
        let mut marker = Vector3::zeros();
        for (k, c) in self.marker.iter().enumerate() {
            marker[k] = read(c)? * unit.to_m();
        }
        let t_s = match &self.time {
            Some(c) => Some(read(c)?),
            None => None,
        };
        let inputs = self
            .inputs
            .iter()
            .map(|c| read(c))
            .collect::<Result<_, _>>()?;
        Ok(RecordingRow {
            line,
            t_s,
            marker_m: marker,
            inputs,
            history: None,
        })
    }
}

impl Recording {
    /// Read a recording file (CSV, or JSON lines when the first data line starts with `{`).
    pub fn load(path: impl AsRef<Path>, map: &ColumnMap) -> Result<Self, CalibrationError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| CalibrationError::Io {
            path: path.display().to_string(),
            why: e.to_string(),
        })?;
        Self::parse_str(&path.display().to_string(), &text, map)
    }

    /// Parse recording text; `file` names it in errors.
    pub fn parse_str(file: &str, text: &str, map: &ColumnMap) -> Result<Self, CalibrationError> {
        let lines = crate::files::rows::data_lines(text);
        let mut layout: Option<Layout> = None;
        let mut rows = Vec::new();
        let mut json: Option<bool> = None;
        let mut header: Vec<String> = Vec::new();
        for (line, l) in lines {
            let is_json = *json.get_or_insert_with(|| l.trim_start().starts_with('{'));
            if is_json {
                // (a key given twice is refused, not read as its last value)
                let obj = crate::files::json::unique_object(l)
                    .map_err(|e| cell_err(file, line, "-".into(), format!("bad JSON: {e}")))?;
                let lay = match &layout {
                    Some(l) => l,
                    None => {
                        header = obj.keys().cloned().collect();
                        layout.insert(Layout::new(file, line, &header, map)?)
                    }
                };
                let get = |c: &str| -> Option<String> {
                    obj.get(c).map(|v| match v {
                        serde_json::Value::Number(n) => n.to_string(),
                        serde_json::Value::String(s) => s.clone(),
                        serde_json::Value::Null => String::new(),
                        other => other.to_string(),
                    })
                };
                rows.push(lay.row(file, line, map.unit, &get)?);
            } else {
                let cells = crate::files::rows::split(l)
                    .map_err(|why| cell_err(file, line, "-".into(), why))?;
                if layout.is_none() && !map.header.is_empty() {
                    // headerless: the names come from the map, this line is data
                    header = map.header.clone();
                    layout = Some(Layout::new(file, line, &header, map)?);
                }
                let Some(lay) = &layout else {
                    header = cells;
                    layout = Some(Layout::new(file, line, &header, map)?);
                    continue;
                };
                if cells.len() > header.len() {
                    // a shifted row would be fitted as if it were right: refuse it (a
                    // short row names the first missing column below)
                    return Err(cell_err(
                        file,
                        line,
                        "-".into(),
                        format!(
                            "{} cells where the header has {}",
                            cells.len(),
                            header.len()
                        ),
                    ));
                }
                let get = |c: &str| -> Option<String> {
                    header
                        .iter()
                        .position(|h| h == c)
                        .and_then(|i| cells.get(i).cloned())
                };
                rows.push(lay.row(file, line, map.unit, &get)?);
            }
        }
        let Some(layout) = layout else {
            return Err(cell_err(
                file,
                1,
                "-".into(),
                "no header and no rows".into(),
            ));
        };
        if rows.is_empty() {
            return Err(cell_err(file, 1, "-".into(), "no data rows".into()));
        }
        let times: Option<Vec<f64>> = rows.iter().map(|r| r.t_s).collect();
        let inputs: Vec<Vec<f64>> = rows.iter().map(|r| r.inputs.clone()).collect();
        let time_column = layout
            .time
            .clone()
            .or_else(|| map.time_column.clone())
            .unwrap_or_else(|| "t_s".into());
        let timeline = Arc::new(InputTimeline::new(file, time_column, times, &inputs));
        for (index, r) in rows.iter_mut().enumerate() {
            r.history = Some(RowHistory {
                timeline: timeline.clone(),
                index,
            });
        }
        Ok(Self {
            file: file.into(),
            input_names: layout.inputs,
            marker_columns: layout.marker,
            unit: map.unit,
            rows,
        })
    }

    /// Index of an input column.
    pub fn input(&self, name: &str) -> Option<usize> {
        self.input_names.iter().position(|n| n == name)
    }

    /// Rows `range` (0-based, clamped) and the rest (in file order), as two recordings.
    pub fn split_rows(&self, range: Range<usize>) -> (Self, Self) {
        let (lo, hi) = (
            range.start.min(self.rows.len()),
            range.end.min(self.rows.len()),
        );
        let mut inside = self.clone();
        let mut rest = self.clone();
        inside.rows = self.rows[lo..hi.max(lo)].to_vec();
        rest.rows = self.rows[..lo]
            .iter()
            .chain(&self.rows[hi.max(lo)..])
            .cloned()
            .collect();
        (inside, rest)
    }
}

impl Recording {
    /// Every `n`-th row (rows 0, n, 2n, ...; `n` >= 1), e.g. to fit on fewer rows.
    /// The rows keep their place in the whole recording, so readings at shifted
    /// times are still interpolated between neighbouring rows of the file.
    pub fn every(&self, n: usize) -> Self {
        let mut out = self.clone();
        out.rows = self.rows.iter().step_by(n.max(1)).cloned().collect();
        out
    }
}

/// Parse a row range `A..B` (0-based data rows, end exclusive; `A..` = to the end).
pub fn parse_row_range(s: &str) -> Result<Range<usize>, String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("row range `{s}`: expected A..B"))?;
    let a: usize = if a.trim().is_empty() {
        0
    } else {
        a.trim()
            .parse()
            .map_err(|_| format!("row range `{s}`: `{a}` is not a row index"))?
    };
    let b: usize = if b.trim().is_empty() {
        usize::MAX
    } else {
        b.trim()
            .parse()
            .map_err(|_| format!("row range `{s}`: `{b}` is not a row index"))?
    };
    if b <= a {
        return Err(format!("row range `{s}` is empty"));
    }
    Ok(a..b)
}
