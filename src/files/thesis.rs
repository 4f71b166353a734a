//! Reader for the thesis reference tables in `data/thesis/*.csv` (units in the
//! column names: `_cm`, `_g`, `_pct`). Conversion to SI happens in the callers'
//! accessors ([`Table::col_si`]), never in the model.

use std::path::Path;
use thiserror::Error;

/// A numeric CSV table with a header row.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// Column names.
    pub columns: Vec<String>,
    /// Rows of numbers.
    pub rows: Vec<Vec<f64>>,
}

/// Why a table could not be read.
#[derive(Debug, Error)]
pub enum TableError {
    /// I/O.
    #[error("cannot read {path}: {cause}")]
    Io {
        /// File.
        path: String,
        /// Cause (part of the message, so not also a `source()`).
        cause: std::io::Error,
    },
    /// A cell is not a number, or a row has the wrong width.
    #[error("{path}:{line}: {why}")]
    Parse {
        /// File.
        path: String,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        why: String,
    },
    /// A requested column is absent.
    #[error("{path}: no column `{column}`")]
    NoColumn {
        /// File.
        path: String,
        /// Column.
        column: String,
    },
}

impl Table {
    /// Parse CSV text (comma-separated, one header line, `#` comment lines skipped).
    pub fn parse(text: &str, path: &str) -> Result<Self, TableError> {
        let csv =
            super::rows::CsvText::parse(text, true).map_err(|(line, why)| TableError::Parse {
                path: path.into(),
                line,
                why,
            })?;
        let columns = csv.names;
        let mut rows = Vec::new();
        for (line, cells) in &csv.rows {
            if cells.len() != columns.len() {
                return Err(TableError::Parse {
                    path: path.into(),
                    line: *line,
                    why: format!("{} cells, header has {}", cells.len(), columns.len()),
                });
            }
            let row = cells
                .iter()
                .zip(&columns)
                .map(|(c, name)| {
                    c.parse::<f64>().map_err(|_| TableError::Parse {
                        path: path.into(),
                        line: *line,
                        why: format!("column `{name}`: `{}` is not a number", super::shorten(c)),
                    })
                })
                .collect::<Result<Vec<f64>, _>>()?;
            rows.push(row);
        }
        Ok(Self { columns, rows })
    }

    /// Read a CSV file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, TableError> {
        let p = path.as_ref();
        let text = std::fs::read_to_string(p).map_err(|cause| TableError::Io {
            path: p.display().to_string(),
            cause,
        })?;
        Self::parse(&text, &p.display().to_string())
    }

    /// A column as printed.
    pub fn col(&self, name: &str) -> Result<Vec<f64>, TableError> {
        let k =
            self.columns
                .iter()
                .position(|c| c == name)
                .ok_or_else(|| TableError::NoColumn {
                    path: String::new(),
                    column: name.into(),
                })?;
        Ok(self.rows.iter().map(|r| r[k]).collect())
    }

    /// A column converted to SI from the unit suffix of its name
    /// (`_cm` -> m, `_mm` -> m, `_g` -> kg; anything else unchanged).
    pub fn col_si(&self, name: &str) -> Result<Vec<f64>, TableError> {
        let k = if name.ends_with("_cm") {
            1e-2
        } else if name.ends_with("_mm") || name.ends_with("_g") {
            1e-3
        } else {
            1.0
        };
        Ok(self.col(name)?.into_iter().map(|v| v * k).collect())
    }
}
