//! A chain of targets solved one after another (a recording's rows, a path),
//! robust to a row that fails: what `cablesense reach` and
//! `examples/ik_measured_val.rs` run.
//!
//! A warm chain carries each row's end into the next row's start. When a row ends
//! short of its target (a target outside the model's reach, a local minimum, a
//! spent budget), its end can lie far from where the next target's readings are,
//! and the chain then "loses its way": on the measured val tips of FTDCR v4 as
//! targets, the plain warm chain ended up to 126 mm from a target. So:
//!
//! * a row starts from the previous row's end only when that row ended within
//!   [`IkChain::retry_distance_m`] of its target (reached, or an honest
//!   `unreachable` close by); after one that did not, from the readings of the
//!   last row that did (or zero readings when none did yet);
//! * a row that is not reached and ended out of budget, or farther than
//!   [`IkChain::retry_distance_m`] from its target, is solved once more from zero
//!   readings (the reference, where the model's equilibrium is known; the last
//!   reached readings are the start it already had), with the full budget of
//!   [`IkSettings`](super::IkSettings), and the better end is kept: reached before not, then the smaller distance (a multistart of
//!   a local method, as in global optimisation's multistart heuristics; Nocedal &
//!   Wright, ch. 2, on local versus global minimisers).
//!
//! An `unreachable` row within the retry distance is an honest outcome (a target
//! the model cannot reach, seen from its closest tip) and is not retried.

use super::{IkReport, IkStatus, IkTarget, IkWorkspace};
use crate::error::ModelError;

/// Where a chained row's kept solution started.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IkStart {
    /// The previous row's end (it ended within the retry distance).
    Previous,
    /// The readings of the last row that ended within the retry distance.
    LastReached,
    /// Zero readings.
    Zero,
}

impl IkStart {
    /// `previous`, `last_reached` or `zero`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Previous => "previous",
            Self::LastReached => "last_reached",
            Self::Zero => "zero",
        }
    }
}

/// One chained row: the kept report, where it started, and the solves run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkChainRow {
    /// The kept solve's report (its readings are [`IkChain::readings`]).
    pub report: IkReport,
    /// Where the kept solve started.
    pub start: IkStart,
    /// Solves run for the row (1, or 2 with the retry from zero readings).
    pub attempts: usize,
}

/// An inverse solver over a chain of targets (module docs).
pub struct IkChain {
    ik: IkWorkspace,
    /// A row not reached that ended farther than this from its target is retried
    /// from the other starts (m, > 0). Default 5e-4 (0.5 mm: fifty times the
    /// default tolerance, well below the forward model's error on FTDCR v4).
    pub retry_distance_m: f64,
    last_reached: Vec<f64>,
    has_reached: bool,
    previous_reached: bool,
    best_q: Vec<f64>,
    zero: Vec<f64>,
}

impl IkChain {
    /// A chain on `ik`, starting at its current readings.
    pub fn new(ik: IkWorkspace) -> Self {
        let p = ik.readings().len();
        Self {
            ik,
            retry_distance_m: 5e-4,
            last_reached: vec![0.0; p],
            has_reached: false,
            previous_reached: true,
            best_q: vec![0.0; p],
            zero: vec![0.0; p],
        }
    }

    /// The inverse solver (at the last row's kept readings).
    pub fn workspace(&self) -> &IkWorkspace {
        &self.ik
    }

    /// The last row's kept readings (m, `tendon_workspace().driven()` order).
    pub fn readings(&self) -> &[f64] {
        self.ik.readings()
    }

    /// Solve the next row (module docs). Errors: an invalid target, or a start
    /// whose forward solve fails (zero readings, the last resort, always solves on
    /// a valid scene).
    pub fn solve(&mut self, target: &IkTarget) -> Result<IkChainRow, ModelError> {
        target.validate()?;
        let mut start = IkStart::Previous;
        if !self.previous_reached {
            start = if self.has_reached {
                IkStart::LastReached
            } else {
                IkStart::Zero
            };
            self.move_to(start)?;
        }
        let mut best = self.ik.solve(target)?;
        let mut best_start = start;
        self.best_q.copy_from_slice(self.ik.readings());
        let mut attempts = 1;
        // after a reached row the last reached readings are this row's start: the
        // other start is zero readings
        if start != IkStart::Zero && self.needs_retry(&best) {
            self.move_to(IkStart::Zero)?;
            let r = self.ik.solve(target)?;
            attempts += 1;
            if Self::better(&r, &best) {
                best = r;
                best_start = IkStart::Zero;
                self.best_q.copy_from_slice(self.ik.readings());
            }
        }
        if attempts > 1 && self.ik.readings() != &self.best_q[..] {
            // back to the kept solve's readings (one forward solve)
            let q = std::mem::take(&mut self.best_q);
            let r = self.ik.set_readings(&q);
            self.best_q = q;
            r?;
        }
        let good = best.status == IkStatus::Reached || best.distance_m <= self.retry_distance_m;
        if good {
            self.last_reached.copy_from_slice(self.ik.readings());
            self.has_reached = true;
        }
        self.previous_reached = good;
        Ok(IkChainRow {
            report: best,
            start: best_start,
            attempts,
        })
    }

    fn needs_retry(&self, r: &IkReport) -> bool {
        match r.status {
            IkStatus::Reached => false,
            IkStatus::BudgetExhausted => true,
            IkStatus::Unreachable { distance_m, .. } => {
                distance_m > self.retry_distance_m || distance_m.is_nan()
            }
        }
    }

    /// `a` is better than `b`: reached before not, then closer.
    fn better(a: &IkReport, b: &IkReport) -> bool {
        let ra = a.status == IkStatus::Reached;
        let rb = b.status == IkStatus::Reached;
        if ra != rb {
            return ra;
        }
        a.distance_m < b.distance_m
    }

    fn move_to(&mut self, start: IkStart) -> Result<(), ModelError> {
        match start {
            IkStart::Previous => Ok(()),
            IkStart::LastReached => {
                let q = std::mem::take(&mut self.last_reached);
                let r = self.ik.set_readings(&q);
                self.last_reached = q;
                r
            }
            IkStart::Zero => {
                let q = std::mem::take(&mut self.zero);
                let r = self.ik.set_readings(&q);
                self.zero = q;
                r
            }
        }
    }
}
