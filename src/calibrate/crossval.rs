//! Grouped cross-validation of a calibration: which parameters and effects to free is
//! decided on the training recording alone.
//!
//! The rows are split into groups that a random split would mix: pattern families
//! read from a label column (e.g. FTDCR v4's `pattern_label`: single segments,
//! `pair12`, `pair13`, `pair23`), or contiguous blocks of time when a recording has
//! no labels. Each group in turn is held out: the candidate is calibrated on the
//! other groups ([`super::calibrate`], the same stages as a full calibration) and
//! predicts the held group. A held-out group holds motions its fit never saw, so the
//! figure measures how a model carries to new motions, as a validation recording does,
//! without looking at one.
//!
//! Error per group: the RMSE of the Euclidean tip distance with that group's own mean
//! model-measured offset removed (the FTDCR convention, [`TipErrors::mean_removed`]).
//! Pooled: `sqrt(sum_k n_k rmse_k^2 / sum_k n_k)`, every held-out row once. Rows the
//! model could not solve count in `rows` and are reported in `unsolved`.

use super::fit::{CalibrationSettings, FitParam, FrameSetup, Progress, Split};
use super::model::CalibrationModel;
use super::recording::Recording;
use super::run::{calibrate, CalibrationSetup};
use super::stats::TipErrors;
use super::uncertainty::{fit_model_error, lateral_deflection};
use super::CalibrationError;
use crate::scene::ModelErrorSpec;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Groups of a recording's rows: `group_of[i]` indexes `names` for row `i`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Folds {
    /// Group names, in the order they are held out.
    pub names: Vec<String>,
    /// Group of each row of the recording.
    pub group_of: Vec<usize>,
}

impl Folds {
    /// Groups from row labels: a row belongs to the first family one of whose
    /// substrings its label contains (`families`: name and substrings). A label no
    /// family matches is an error naming the row and the label; a family no row
    /// matches is an error too (an empty fold would hold nothing out).
    pub fn from_labels(
        labels: &[String],
        families: &[(String, Vec<String>)],
    ) -> Result<Self, CalibrationError> {
        let bad = |s: String| Err(CalibrationError::BadInput(s));
        if families.len() < 2 {
            return bad(format!(
                "cross-validation needs at least two groups, got {}",
                families.len()
            ));
        }
        let mut group_of = Vec::with_capacity(labels.len());
        for (i, label) in labels.iter().enumerate() {
            match families
                .iter()
                .position(|(_, subs)| subs.iter().any(|s| label.contains(s.as_str())))
            {
                Some(g) => group_of.push(g),
                None => {
                    return bad(format!(
                        "row {i}: label `{}` matches no group ({})",
                        shorten(label),
                        families
                            .iter()
                            .map(|(n, s)| format!("{n} = {}", s.join("|")))
                            .collect::<Vec<_>>()
                            .join("; ")
                    ))
                }
            }
        }
        for (g, (name, _)) in families.iter().enumerate() {
            if !group_of.contains(&g) {
                return bad(format!("group `{name}` matches no row"));
            }
        }
        Ok(Self {
            names: families.iter().map(|(n, _)| n.clone()).collect(),
            group_of,
        })
    }

    /// `k` contiguous blocks of rows in recording order (sizes differ by at most 1),
    /// for recordings without labels. `k` >= 2 and at most the number of rows.
    pub fn time_blocks(rows: usize, k: usize) -> Result<Self, CalibrationError> {
        if k < 2 || k > rows {
            return Err(CalibrationError::BadInput(format!(
                "cross-validation blocks: {k} blocks for {rows} rows (need 2 <= blocks <= rows)"
            )));
        }
        Ok(Self {
            names: (0..k).map(|b| format!("block{b}")).collect(),
            group_of: (0..rows).map(|i| i * k / rows).collect(),
        })
    }

    /// The rows of `rec` outside (fit) and inside (held) group `g`.
    fn split(&self, rec: &Recording, g: usize) -> (Recording, Recording) {
        let mut fit = rec.clone();
        let mut held = rec.clone();
        fit.rows.clear();
        held.rows.clear();
        for (row, &k) in rec.rows.iter().zip(&self.group_of) {
            if k == g {
                held.rows.push(row.clone());
            } else {
                fit.rows.push(row.clone());
            }
        }
        (fit, held)
    }
}

/// A label for messages: at most 80 characters.
fn shorten(s: &str) -> String {
    if s.chars().count() <= 80 {
        s.to_string()
    } else {
        format!("{}...", s.chars().take(80).collect::<String>())
    }
}

/// One held-out group's figures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeldOut {
    /// Group name.
    pub group: String,
    /// Rows held out.
    pub rows: usize,
    /// Rows fitted.
    pub fit_rows: usize,
    /// Held-out rows the model could not solve (their predictions are the best
    /// iterate the calibration kept; they are in `rows` and in the RMSE).
    pub unsolved: usize,
    /// Held-out tip errors (raw and with this group's mean offset removed).
    pub errors: TipErrors,
    /// Final status of the fit.
    pub status: String,
    /// Fitted scene parameter values, in the order of the candidate's parameters.
    pub values: Vec<f64>,
    /// Each held-out row's model marker (robot base frame, m), in file order.
    #[serde(skip)]
    pub model_m: Vec<Vector3<f64>>,
    /// Each held-out row's error (model - measured, m) with the group's mean
    /// offset removed, in file order.
    #[serde(skip)]
    pub error_m: Vec<Vector3<f64>>,
}

/// A candidate's cross-validation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CrossValidation {
    /// One entry per group, in [`Folds::names`] order.
    pub held_out: Vec<HeldOut>,
    /// Pooled held-out RMSE (m), each group's mean offset removed.
    pub pooled_rmse_m: f64,
}

impl CrossValidation {
    /// Pool per-group RMSEs: `sqrt(sum n_k rmse_k^2 / sum n_k)`.
    pub fn pool(held_out: Vec<HeldOut>) -> Self {
        let (mut sum, mut n) = (0.0, 0usize);
        for h in &held_out {
            let e = &h.errors.mean_removed;
            sum += e.count as f64 * e.rmse_m * e.rmse_m;
            n += e.count;
        }
        let pooled_rmse_m = if n > 0 {
            (sum / n as f64).sqrt()
        } else {
            f64::NAN
        };
        Self {
            held_out,
            pooled_rmse_m,
        }
    }

    /// The model-error term of the predictions' covariance
    /// ([`super::uncertainty`]), fitted to every held-out row of every group, the
    /// deflection measured from the axis through `base` along `axis` (the robot's
    /// base). `None` without held-out rows.
    pub fn model_error(
        &self,
        base: &Vector3<f64>,
        axis: &Vector3<f64>,
        source: &str,
    ) -> Option<ModelErrorSpec> {
        let samples: Vec<(f64, Vector3<f64>)> = self
            .held_out
            .iter()
            .flat_map(|h| h.model_m.iter().zip(&h.error_m))
            .map(|(p, e)| (lateral_deflection(p, base, axis), *e))
            .collect();
        fit_model_error(&samples, source)
    }
}

/// Hold out each group of `folds` in turn: calibrate `model`'s `params` (and the
/// frame) on the other rows of `recording`, predict the held rows. `observer` sees
/// the group index and each calibration's progress.
#[allow(clippy::too_many_arguments)]
pub fn cross_validate<M: CalibrationModel + Clone>(
    model: &M,
    params: &[FitParam],
    frame: FrameSetup,
    recording: &Recording,
    folds: &Folds,
    settings: &CalibrationSettings,
    robot_length_m: f64,
    observer: &mut dyn FnMut(usize, &Progress),
) -> Result<CrossValidation, CalibrationError> {
    if folds.group_of.len() != recording.rows.len() {
        return Err(CalibrationError::BadInput(format!(
            "cross-validation: {} group labels for {} rows of {}",
            folds.group_of.len(),
            recording.rows.len(),
            recording.file
        )));
    }
    let mut held_out = Vec::with_capacity(folds.names.len());
    for (g, name) in folds.names.iter().enumerate() {
        let (fit, held) = folds.split(recording, g);
        let setup = CalibrationSetup {
            model,
            params: params.to_vec(),
            frame,
            train: &fit,
            val: Some(&held),
            robot_length_m,
        };
        let report = calibrate(&setup, settings, &mut |p| observer(g, p))?;
        let errors = report.val.ok_or_else(|| {
            CalibrationError::BadInput(format!("group `{name}`: no held-out prediction"))
        })?;
        let unsolved = report
            .failed_rows
            .iter()
            .filter(|f| f.split == Split::Val)
            .count();
        let val_rows: Vec<_> = report
            .rows
            .iter()
            .filter(|r| r.split == Split::Val)
            .collect();
        let mean = val_rows
            .iter()
            .fold(Vector3::zeros(), |m, r| m + r.error_m())
            / (val_rows.len().max(1) as f64);
        held_out.push(HeldOut {
            model_m: val_rows.iter().map(|r| r.model_base_m).collect(),
            error_m: val_rows.iter().map(|r| r.error_m() - mean).collect(),
            group: name.clone(),
            rows: held.rows.len(),
            fit_rows: fit.rows.len(),
            unsolved,
            errors,
            status: format!("{:?}", report.status),
            values: report.params.iter().map(|p| p.value).collect(),
        });
    }
    Ok(CrossValidation::pool(held_out))
}

/// The label of each row of `recording` from column `column` of its file's text
/// (`text`: the CSV the recording was read from; rows are matched by line).
pub fn row_labels(
    text: &str,
    column: &str,
    recording: &Recording,
) -> Result<Vec<String>, CalibrationError> {
    let bad = |s: String| Err(CalibrationError::BadInput(s));
    let csv = crate::files::rows::CsvText::parse(text, true).map_err(|(line, why)| {
        CalibrationError::BadInput(format!("{} line {line}: {why}", recording.file))
    })?;
    let Some(col) = csv.column(column) else {
        return bad(format!(
            "{}: no column `{}` (columns: {})",
            recording.file,
            shorten(column),
            shorten(&csv.names.join(", "))
        ));
    };
    let mut out = Vec::with_capacity(recording.rows.len());
    for row in &recording.rows {
        let cell = csv
            .rows
            .binary_search_by_key(&row.line, |(line, _)| *line)
            .ok()
            .and_then(|i| csv.rows[i].1.get(col));
        match cell {
            Some(c) => out.push(c.clone()),
            None => {
                return bad(format!(
                    "{} line {}: no cell in column `{column}`",
                    recording.file, row.line
                ))
            }
        }
    }
    Ok(out)
}

/// Parse a family list `name=sub1|sub2;name2=sub3`: each group's name and the
/// substrings a label of that group contains.
pub fn parse_families(s: &str) -> Result<Vec<(String, Vec<String>)>, CalibrationError> {
    let mut out = Vec::new();
    for part in s.split(';').map(str::trim).filter(|p| !p.is_empty()) {
        let Some((name, subs)) = part.split_once('=') else {
            return Err(CalibrationError::BadInput(format!(
                "group `{}`: expected NAME=SUBSTRING|SUBSTRING",
                shorten(part)
            )));
        };
        let subs: Vec<String> = subs
            .split('|')
            .map(|x| x.trim().to_string())
            .filter(|x| !x.is_empty())
            .collect();
        if name.trim().is_empty() || subs.is_empty() {
            return Err(CalibrationError::BadInput(format!(
                "group `{}`: a name and at least one substring are needed",
                shorten(part)
            )));
        }
        out.push((name.trim().to_string(), subs));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fams(s: &str) -> Vec<(String, Vec<String>)> {
        parse_families(s).unwrap()
    }

    #[test]
    fn labels_fall_into_the_first_family_that_matches() {
        let labels: Vec<String> = ["rep1_seg1_dir0", "rep1_pair12_same", "rep2_tendon3_pull"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let f = Folds::from_labels(&labels, &fams("single=seg|tendon; pairs=pair")).unwrap();
        assert_eq!(f.names, ["single", "pairs"]);
        assert_eq!(f.group_of, [0, 1, 0]);
        // an unmatched label names the row and the label
        let e = Folds::from_labels(&labels, &fams("single=seg;pairs=pair")).unwrap_err();
        assert!(e.to_string().contains("row 2") && e.to_string().contains("tendon3"));
        // an empty group is refused
        let e = Folds::from_labels(&labels, &fams("a=seg|tendon;b=pair;c=all3")).unwrap_err();
        assert!(e.to_string().contains("`c`"), "{e}");
        assert!(parse_families("single").is_err() && parse_families("a=").is_err());
    }

    #[test]
    fn time_blocks_are_contiguous_and_balanced() {
        let f = Folds::time_blocks(10, 3).unwrap();
        assert_eq!(f.group_of, [0, 0, 0, 0, 1, 1, 1, 2, 2, 2]);
        assert!(Folds::time_blocks(3, 1).is_err() && Folds::time_blocks(3, 4).is_err());
    }

    #[test]
    fn pooling_weighs_groups_by_rows() {
        let held = |n: usize, rmse: f64| {
            let mut errors = TipErrors::of(&[], &[]);
            errors.mean_removed.count = n;
            errors.mean_removed.rmse_m = rmse;
            HeldOut {
                group: String::new(),
                rows: n,
                fit_rows: 0,
                unsolved: 0,
                errors,
                status: String::new(),
                values: vec![],
                model_m: vec![],
                error_m: vec![],
            }
        };
        let cv = CrossValidation::pool(vec![held(1, 3.0), held(3, 1.0)]);
        assert!((cv.pooled_rmse_m - 3.0f64.sqrt()).abs() < 1e-15);
    }
}
