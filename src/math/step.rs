//! Step-size control of a natural-parameter continuation with a tangent predictor
//! and a Newton corrector, shared by the single-shooting and the multiple-shooting
//! solvers (`statics::workspace::continuation`, `statics::multiple::continuation`).
//!
//! A step `h` in the load scale is accepted when the corrector moved the unknowns by
//! at most [`CORRECTOR_RATIO`] of the predictor's own move (on a smooth branch the
//! ratio is `O(h)` for a first-order predictor, `O(h^2)` for a second-order one;
//! `O(1)` after a jump to another branch). The next step scales `h` so that the
//! ratio would land at 0.8 of the limit, within `[h/4, max_growth h]`; after a
//! rejection at most `h/2`. Allgower & Georg, *Introduction to Numerical
//! Continuation Methods* (2003), ch. 6 (steplength adaptation from the corrector's
//! contraction).

/// Largest corrector move over predictor move of an accepted step.
pub(crate) const CORRECTOR_RATIO: f64 = 0.5;

/// The ratio a step is sized to reach, as a fraction of [`CORRECTOR_RATIO`].
const TARGET_FRACTION: f64 = 0.8;

/// Smallest growth factor (a step shrinks to at most a quarter).
const MIN_GROWTH: f64 = 0.25;

/// Largest growth factor after a rejected step.
const REJECTED_GROWTH: f64 = 0.5;

/// A continuation's step rule (see the module docs).
#[derive(Clone, Copy, Debug)]
pub(crate) struct StepRule {
    /// Largest growth factor of an accepted step.
    pub max_growth: f64,
}

impl StepRule {
    /// Does a corrector `ratio` (move over predicted move) accept the step?
    pub fn accepts(&self, ratio: f64) -> bool {
        ratio <= CORRECTOR_RATIO
    }

    /// Factor for the next step after a step with corrector `ratio`, the ratio
    /// growing like `h^(1/order)` (`order` 1: linear, 0.5: quadratic).
    pub fn growth(&self, ratio: f64, order: f64) -> f64 {
        let base = TARGET_FRACTION * CORRECTOR_RATIO / ratio;
        let g = if order == 1.0 { base } else { base.powf(order) };
        g.clamp(MIN_GROWTH, self.max_growth)
    }

    /// Factor for the retry after a rejected step whose ratio gave `growth`.
    pub fn after_rejection(growth: f64) -> f64 {
        growth.min(REJECTED_GROWTH)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ratio at the target keeps the step; a failed corrector (infinite ratio)
    /// shrinks it to a quarter; a tiny ratio grows it to the cap; a rejection at
    /// most halves it.
    #[test]
    fn the_rule_sizes_steps_from_the_ratio() {
        let r = StepRule { max_growth: 2.0 };
        assert_eq!(r.growth(0.4, 1.0), 1.0);
        assert_eq!(r.growth(f64::INFINITY, 1.0), 0.25);
        assert_eq!(r.growth(1e-6, 1.0), 2.0);
        assert_eq!(r.growth(0.1, 0.5), 2.0);
        assert!(r.accepts(0.5) && !r.accepts(0.5000001));
        assert_eq!(StepRule::after_rejection(2.0), 0.5);
        assert_eq!(StepRule::after_rejection(0.25), 0.25);
    }
}
