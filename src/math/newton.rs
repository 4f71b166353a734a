//! Pieces of the chord-Newton iteration shared by the shooting solvers
//! (`statics::workspace::newton`, `statics::multiple::newton`); the tendon
//! solver's joint path uses the same sufficient-decrease constant.
//!
//! A fresh Jacobian's step is damped by backtracking on `||r||_2` with Armijo's
//! sufficient-decrease test `||r(x + a dx)|| < (1 - c a) ||r(x)||` (Nocedal &
//! Wright, *Numerical Optimization*, 2nd ed., 2006, sec. 3.1 and 11.2, the merit
//! `||r||` of a Newton step decreasing at rate 1 along it). A reused (chord)
//! Jacobian's full step is kept only if it contracts the residual by
//! [`CHORD_CONTRACTION`] (Kelley, *Solving Nonlinear Equations with Newton's
//! Method*, 2003, sec. 2.3 on the chord method's contraction); at most
//! [`MAX_CHORD_STEPS`] in a row before a fresh Jacobian.

/// A reused (chord) Jacobian's full step must shrink `||r||_2` by this factor.
pub(crate) const CHORD_CONTRACTION: f64 = 0.1;

/// Chord steps allowed per Jacobian before it is refreshed anyway.
pub(crate) const MAX_CHORD_STEPS: usize = 8;

/// Armijo's constant `c` of the sufficient-decrease test.
pub(crate) const ARMIJO_SLOPE: f64 = 1e-4;

/// Halvings of the step a backtracking line search tries (down to `2^-29`).
const MAX_HALVINGS: usize = 30;

/// Backtracking from the full step: `trial(alpha)` evaluates the point `x + alpha
/// dx` and returns its `||r||_2` (`None` if the evaluation failed); the first
/// `alpha` in `1, 1/2, 1/4, ...` ([`MAX_HALVINGS`] trials) whose norm passes
/// Armijo's test against `f0 = ||r(x)||_2` is returned, `None` if none does.
pub(crate) fn backtrack(f0: f64, mut trial: impl FnMut(f64) -> Option<f64>) -> Option<f64> {
    let mut alpha = 1.0;
    for _ in 0..MAX_HALVINGS {
        if trial(alpha).is_some_and(|f| f < (1.0 - ARMIJO_SLOPE * alpha) * f0) {
            return Some(alpha);
        }
        alpha *= 0.5;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `r(x) = x - 1` from `x = 0` with a step four times too long: the full step
    /// and the half step raise or keep `|r|`, the quarter step lands on the root.
    /// A trial that never decreases: `None` after `MAX_HALVINGS` trials.
    #[test]
    fn backtracking_takes_the_first_sufficient_decrease() {
        let mut tried = Vec::new();
        let a = backtrack(1.0, |alpha| {
            tried.push(alpha);
            Some((4.0 * alpha - 1.0f64).abs())
        });
        assert_eq!(a, Some(0.25));
        assert_eq!(tried, [1.0, 0.5, 0.25]);
        let mut n = 0;
        assert_eq!(
            backtrack(1.0, |_| {
                n += 1;
                None
            }),
            None
        );
        assert_eq!(n, MAX_HALVINGS);
    }
}
