//! Conditioning of servo readings before the tendon solve: a time offset between the
//! servo log and the motion capture, and a backlash (play) between a servo and its
//! tendon. Both are `[readings]` settings of a scene ([`crate::scene::ReadingsSpec`]
//! `time_offset_s`, `backlash_m`), so they are ordinary calibration parameters
//! (`readings/time_offset_s`, `readings/backlash_m`) and `track` applies them too.
//!
//! Why: the residuals of the FTDCR v4 calibration (`data/calibration/ftdcr_v4_residuals.md`)
//! depend on the direction of motion: the model tip is ahead of the measured one
//! while the tendons are pulled (radial error +5.3 mm) and about right while they are
//! released (-0.4 mm), and a first-order time shift of the model tip removes part of it.
//!
//! **Time offset** `dt` (s): the row stamped `t` is solved with the readings
//! linearly interpolated at `t - dt` (`dt > 0`: the capture lags the servo log).
//! Interpolation stays inside a *block* of rows: consecutive rows with increasing
//! time stamps no more than [`MAX_GAP_S`] apart. A time before the block's first row
//! or after its last row is clamped to that row (no extrapolation, nothing read
//! across a gap). Offline ([`InputTimeline`]) every row of the recording is
//! available; in a stream ([`ReadingsHistory`]) only past rows are, so a negative
//! offset (readings from the future) is clamped to the newest row there.
//!
//! **Backlash** `b` (m, >= 0): the displacement that reaches the tendon follows the
//! (time-shifted) reading `x` with a play of width `b` (the play operator of
//! hysteresis models, e.g. Brokate & Sprekels, *Hysteresis and Phase Transitions*,
//! 1996, sec. 2.3): `y_k = clamp(y_{k-1}, x_k - b/2, x_k + b/2)`, started at
//! `y_0 = x_0`, one per tendon, evaluated at the rows (a sampled play: the motion
//! between two rows is taken as monotone). The play state carries over gaps (the
//! servos hold their positions). Loading and unloading then differ by `b`.
//!
//! With `dt = 0` and `b = 0` the readings pass unchanged.

use crate::error::ModelError;
use crate::scene::ReadingsSpec;
use std::collections::VecDeque;

/// Largest time step (s) between two rows that are interpolated between; a larger
/// gap (or a time stamp that does not increase) starts a new block.
pub const MAX_GAP_S: f64 = 3.0;

/// The conditioning settings of a scene's `[readings]` table.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Conditioning {
    /// Time offset (s): readings are taken at `t - time_offset_s`.
    pub time_offset_s: f64,
    /// Play width per tendon (m, >= 0).
    pub backlash_m: f64,
}

impl Conditioning {
    /// The settings of a `[readings]` table (none: identity).
    pub fn from_spec(spec: Option<&ReadingsSpec>) -> Self {
        spec.map_or_else(Self::default, |r| Self {
            time_offset_s: r.time_offset_s,
            backlash_m: r.backlash_m,
        })
    }
    /// Readings pass unchanged.
    pub fn is_identity(&self) -> bool {
        self.time_offset_s == 0.0 && self.backlash_m == 0.0
    }
}

fn lerp(t0: f64, x0: f64, t1: f64, x1: f64, t: f64) -> f64 {
    let f = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
    x0 + (x1 - x0) * f
}

/// One step of the play operator of width `b`.
fn play(y: f64, x: f64, b: f64) -> f64 {
    y.clamp(x - 0.5 * b, x + 0.5 * b)
}

/// Is `t1` the next row of the block ending at `t0`?
fn same_block(t0: f64, t1: f64) -> bool {
    t1 > t0 && t1 - t0 <= MAX_GAP_S
}

/// The inputs of a whole recording over time, for reading them at shifted times
/// offline (see the module docs). Built by [`super::Recording`] when it is read.
#[derive(Clone, Debug, PartialEq)]
pub struct InputTimeline {
    /// File, for errors.
    file: String,
    /// Name of the time column (looked for, if absent), for errors.
    time_column: String,
    /// Time stamp per row (s), if the recording has a time column; in time order.
    t: Option<Vec<f64>>,
    /// Inputs per row (recording units), row-major, in time order.
    inputs: Vec<f64>,
    width: usize,
    /// Per row in time order: first row of its block, and one past its last.
    block: Vec<(usize, usize)>,
    /// Position in time order of each row of the file (`None`: the file's order
    /// is the time order, or there are no time stamps).
    rank: Option<Vec<usize>>,
}

impl InputTimeline {
    /// A timeline of `inputs` (one `Vec` per row, all the same length), stamped
    /// `t` when given (one per row).
    /// `time_column` names the time column in errors. With time stamps, the rows
    /// are taken in time order whatever their order in the file (a stable sort:
    /// rows with equal stamps keep their file order), so a shuffled copy of a
    /// recording is conditioned exactly as the original; results come back in
    /// file order.
    pub fn new(
        file: impl Into<String>,
        time_column: impl Into<String>,
        t: Option<Vec<f64>>,
        inputs: &[Vec<f64>],
    ) -> Self {
        let n = inputs.len();
        let width = inputs.first().map_or(0, Vec::len);
        let mut rank = None;
        let mut sorted_inputs: Option<Vec<Vec<f64>>> = None;
        let t = t.map(|t| {
            let mut order: Vec<usize> = (0..t.len()).collect();
            order.sort_by(|&a, &b| t[a].total_cmp(&t[b]));
            if order.iter().enumerate().all(|(k, &i)| k == i) {
                return t;
            }
            let mut r = vec![0; t.len()];
            for (k, &i) in order.iter().enumerate() {
                r[i] = k;
            }
            rank = Some(r);
            sorted_inputs = Some(order.iter().map(|&i| inputs[i].clone()).collect());
            order.iter().map(|&i| t[i]).collect()
        });
        let inputs = sorted_inputs.as_deref().unwrap_or(inputs);
        let mut block = vec![(0, n); n];
        if let Some(t) = &t {
            let mut start = 0;
            for i in 1..=n {
                if i == n || !same_block(t[i - 1], t[i]) {
                    block[start..i].fill((start, i));
                    start = i;
                }
            }
        }
        Self {
            file: file.into(),
            time_column: time_column.into(),
            t,
            inputs: inputs.iter().flatten().copied().collect(),
            width,
            block,
            rank,
        }
    }

    /// Rows.
    pub fn len(&self) -> usize {
        self.block.len()
    }
    /// No rows.
    pub fn is_empty(&self) -> bool {
        self.block.is_empty()
    }
    /// Does the recording have time stamps?
    pub fn has_time(&self) -> bool {
        self.t.is_some()
    }
    /// File name.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// Input `c` of row `i` times `scale`.
    fn at(&self, i: usize, c: usize, scale: f64) -> f64 {
        self.inputs[i * self.width + c] * scale
    }

    /// Inputs `columns` (times `scale`) of every row, conditioned by `cond`:
    /// row-major, `columns.len()` per row. Errors when `cond` shifts time and the
    /// recording has no time stamps (naming the time column looked for).
    pub fn conditioned(
        &self,
        cond: &Conditioning,
        columns: &[usize],
        scale: f64,
    ) -> Result<Vec<f64>, ModelError> {
        let m = columns.len();
        let mut out = Vec::with_capacity(self.len() * m);
        match (&self.t, cond.time_offset_s != 0.0) {
            (None, true) => {
                return Err(ModelError::Invalid {
                    field: "readings.time_offset_s".into(),
                    why: format!(
                        "a time offset of {} s needs time stamps, and {} has no time column `{}`",
                        cond.time_offset_s, self.file, self.time_column
                    ),
                })
            }
            (Some(t), true) => {
                for i in 0..self.len() {
                    let (s, e) = self.block[i];
                    let tau = t[i] - cond.time_offset_s;
                    // rows j, j + 1 of the block with t_j <= tau < t_{j+1} (clamped)
                    let j = s + t[s..e].partition_point(|&tj| tj <= tau);
                    for &c in columns {
                        out.push(if j == s {
                            self.at(s, c, scale)
                        } else if j == e {
                            self.at(e - 1, c, scale)
                        } else {
                            lerp(
                                t[j - 1],
                                self.at(j - 1, c, scale),
                                t[j],
                                self.at(j, c, scale),
                                tau,
                            )
                        });
                    }
                }
            }
            (_, false) => {
                for i in 0..self.len() {
                    out.extend(columns.iter().map(|&c| self.at(i, c, scale)));
                }
            }
        }
        if cond.backlash_m != 0.0 {
            for c in 0..m {
                let mut y = out[c];
                for i in 0..self.len() {
                    y = play(y, out[i * m + c], cond.backlash_m);
                    out[i * m + c] = y;
                }
            }
        }
        // back to the file's order
        Ok(match &self.rank {
            Some(rank) => rank
                .iter()
                .flat_map(|&k| out[k * m..(k + 1) * m].iter().copied())
                .collect(),
            None => out,
        })
    }
}

/// The per-stream state of conditioning (see the module docs): the rows of the
/// current block back to `t - time_offset_s`, and the play state. Small: a
/// `Clone` of it is a rollback point.
#[derive(Clone, Debug, PartialEq)]
pub struct ReadingsHistory {
    cond: Conditioning,
    /// Recent rows of the current block (time, readings in m), oldest first.
    past: VecDeque<(f64, Vec<f64>)>,
    /// Play output per tendon (m), `None` before the first row.
    play: Option<Vec<f64>>,
    out: Vec<f64>,
}

impl ReadingsHistory {
    /// An empty history for `cond`.
    pub fn new(cond: Conditioning) -> Self {
        Self {
            cond,
            past: VecDeque::new(),
            play: None,
            out: Vec::new(),
        }
    }
    /// The settings.
    pub fn conditioning(&self) -> &Conditioning {
        &self.cond
    }

    /// Take the row stamped `t_s` with `readings_m` (m) and return the conditioned
    /// readings. A time offset needs a time stamp (an error naming
    /// `time_column` otherwise; the history is then unchanged).
    pub fn push(
        &mut self,
        t_s: Option<f64>,
        readings_m: &[f64],
        time_column: &str,
    ) -> Result<&[f64], ModelError> {
        self.out.clear();
        if self.cond.time_offset_s == 0.0 {
            self.out.extend_from_slice(readings_m);
        } else {
            let t = t_s.ok_or_else(|| ModelError::Invalid {
                field: "readings.time_offset_s".into(),
                why: format!(
                    "a time offset of {} s needs time stamps, and this row has no time column `{time_column}`",
                    self.cond.time_offset_s
                ),
            })?;
            if self.past.back().is_some_and(|(t0, _)| !same_block(*t0, t)) {
                self.past.clear();
            }
            self.past.push_back((t, readings_m.to_vec()));
            let tau = t - self.cond.time_offset_s;
            // keep one row at or before tau (and what follows)
            while self.past.len() > 1 && self.past[1].0 <= tau {
                self.past.pop_front();
            }
            let j = self.past.partition_point(|(tj, _)| *tj <= tau);
            let (s, e) = (0, self.past.len());
            for c in 0..readings_m.len() {
                self.out.push(if j == s {
                    self.past[s].1[c]
                } else if j == e {
                    self.past[e - 1].1[c]
                } else {
                    let (a, b) = (&self.past[j - 1], &self.past[j]);
                    lerp(a.0, a.1[c], b.0, b.1[c], tau)
                });
            }
        }
        if self.cond.backlash_m != 0.0 {
            let b = self.cond.backlash_m;
            let y = self.play.get_or_insert_with(|| self.out.clone());
            for (y, x) in y.iter_mut().zip(self.out.iter_mut()) {
                *y = play(*y, *x, b);
                *x = *y;
            }
        }
        Ok(&self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows() -> (Vec<f64>, Vec<Vec<f64>>) {
        // two blocks: a gap of 5 s after t = 1.5
        let t = vec![0.0, 0.5, 1.0, 1.5, 6.5, 7.0, 7.4];
        let x = t.iter().map(|t| vec![t * 2.0, -t]).collect();
        (t, x)
    }

    #[test]
    fn offline_interpolates_inside_blocks_and_clamps() {
        let (t, x) = rows();
        let tl = InputTimeline::new("f", "t_s", Some(t.clone()), &x);
        let cond = Conditioning {
            time_offset_s: 0.2,
            backlash_m: 0.0,
        };
        let out = tl.conditioned(&cond, &[0, 1], 1.0).unwrap();
        // row 1 (t 0.5) reads t 0.3; row 0 and the first row after the gap clamp
        assert!((out[2] - 0.6).abs() < 1e-12 && (out[3] + 0.3).abs() < 1e-12);
        assert_eq!((out[0], out[8]), (0.0, 13.0));
        // negative offset: reads ahead, clamped at the block's last row
        let cond = Conditioning {
            time_offset_s: -0.3,
            ..cond
        };
        let out = tl.conditioned(&cond, &[0], 1.0).unwrap();
        assert!((out[2] - 2.6).abs() < 1e-12);
        assert_eq!((out[3], out[6]), (3.0, 14.8));
        let e = InputTimeline::new("f", "stamp", None, &x)
            .conditioned(&cond, &[0], 1.0)
            .unwrap_err();
        assert!(e.to_string().contains("`stamp`"), "{e}");
    }

    #[test]
    fn a_shuffled_recording_is_conditioned_as_the_original() {
        let (t, x) = rows();
        // a fixed permutation of the rows (file order no longer time order)
        let perm: Vec<usize> = (0..t.len()).map(|k| (k * 5 + 3) % t.len()).collect();
        let mut seen = perm.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..t.len()).collect::<Vec<_>>());
        let ts: Vec<f64> = perm.iter().map(|&i| t[i]).collect();
        let xs: Vec<Vec<f64>> = perm.iter().map(|&i| x[i].clone()).collect();
        for (dt, b) in [(0.0, 0.0), (0.2, 0.0), (0.3, 0.5), (0.0, 0.8), (-0.3, 0.2)] {
            let cond = Conditioning {
                time_offset_s: dt,
                backlash_m: b,
            };
            let orig = InputTimeline::new("f", "t_s", Some(t.clone()), &x)
                .conditioned(&cond, &[0, 1], 1.0)
                .unwrap();
            let shuf = InputTimeline::new("f", "t_s", Some(ts.clone()), &xs)
                .conditioned(&cond, &[0, 1], 1.0)
                .unwrap();
            for (k, &i) in perm.iter().enumerate() {
                assert_eq!(
                    shuf[2 * k..2 * k + 2],
                    orig[2 * i..2 * i + 2],
                    "dt {dt} b {b} row {i}"
                );
            }
        }
    }

    #[test]
    fn stream_matches_offline_for_past_offsets() {
        let (t, x) = rows();
        for (dt, b) in [(0.0, 0.0), (0.2, 0.0), (0.7, 0.0), (0.3, 0.5), (0.0, 0.8)] {
            let cond = Conditioning {
                time_offset_s: dt,
                backlash_m: b,
            };
            let off = InputTimeline::new("f", "t_s", Some(t.clone()), &x)
                .conditioned(&cond, &[0, 1], 1.0)
                .unwrap();
            let mut h = ReadingsHistory::new(cond);
            for (i, (ti, xi)) in t.iter().zip(&x).enumerate() {
                let y = h.push(Some(*ti), xi, "t_s").unwrap();
                assert_eq!(y, &off[2 * i..2 * i + 2], "dt {dt} b {b} row {i}");
            }
        }
    }

    #[test]
    fn play_follows_with_a_lag_of_half_the_width() {
        let t: Vec<f64> = (0..5).map(f64::from).collect();
        let x: Vec<Vec<f64>> = [0.0, 1.0, 2.0, 1.0, 0.0].iter().map(|v| vec![*v]).collect();
        let cond = Conditioning {
            time_offset_s: 0.0,
            backlash_m: 1.0,
        };
        let y = InputTimeline::new("f", "t_s", Some(t), &x)
            .conditioned(&cond, &[0], 1.0)
            .unwrap();
        assert_eq!(y, vec![0.0, 0.5, 1.5, 1.5, 0.5]);
    }
}
