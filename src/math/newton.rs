//! The chord-Newton driver shared by the shooting solvers
//! (`statics::workspace::newton`, `statics::multiple::newton`): [`chord_newton`]
//! over a [`ChordNewton`] problem. The tendon solver's paths, whose iterations
//! differ (module docs of `tendons::solve::joint` and `nested`), share its
//! constants and the halving schedule ([`halve`]).
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

/// A factorisation whose reciprocal condition estimate is at most this is singular
/// to working precision.
pub(crate) const MIN_RCOND: f64 = 1e-14;

/// Halvings of the step a backtracking line search tries (down to `2^-29`).
const MAX_HALVINGS: usize = 30;

/// The first `alpha` in `1, 1/2, 1/4, ...` (`trials` of them) that `accept`s,
/// `None` if none does.
pub(crate) fn halve(trials: usize, mut accept: impl FnMut(f64) -> bool) -> Option<f64> {
    let mut alpha = 1.0;
    for _ in 0..trials {
        if accept(alpha) {
            return Some(alpha);
        }
        alpha *= 0.5;
    }
    None
}

/// Backtracking from the full step: `trial(alpha)` evaluates the point `x + alpha
/// dx` and returns its `||r||_2` (`None` if the evaluation failed); the first
/// `alpha` ([`MAX_HALVINGS`] halvings) whose norm passes Armijo's test against
/// `f0 = ||r(x)||_2` is returned, `None` if none does.
pub(crate) fn backtrack(f0: f64, mut trial: impl FnMut(f64) -> Option<f64>) -> Option<f64> {
    halve(MAX_HALVINGS, |alpha| {
        trial(alpha).is_some_and(|f| f < (1.0 - ARMIJO_SLOPE * alpha) * f0)
    })
}

/// What a problem's convergence test found at the current point.
pub(crate) enum Test {
    /// Converged: the driver stops.
    Converged,
    /// The point was evaluated again (e.g. with tighter inner solves): test again.
    Recheck,
    /// That evaluation failed.
    Failed,
    /// Not converged: take a step.
    Step,
}

/// How [`chord_newton`] ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum End {
    /// The convergence test passed.
    Converged,
    /// An evaluation failed (the test's own or the Jacobian's).
    Failed,
    /// A fresh Jacobian was due with `max_jacobians` of them spent.
    MaxJacobians,
    /// The Jacobian's factorisation is singular to working precision ([`MIN_RCOND`]).
    Singular,
    /// No step length passed the line search; the current point is re-evaluated.
    Stalled,
}

/// A nonlinear system `r(x) = 0` as the driver sees it: the problem owns `x`, the
/// residual, the step `dx`, a trial point and the factorised Jacobian (which may
/// outlive one call: a warm start reuses it as a chord Jacobian).
pub(crate) trait ChordNewton {
    /// The convergence test at the current point.
    fn test(&mut self) -> Test;
    /// Whether a factorised Jacobian (fresh or from an earlier point) is at hand:
    /// the driver sets it after a factorisation and clears it to force a fresh one.
    fn jacobian_ok(&mut self) -> &mut bool;
    /// Before each step, after the test (e.g. the inner solves' tolerance).
    fn prepare(&mut self) {}
    /// Evaluate the Jacobian at the current point; `false` if that failed.
    fn jacobian(&mut self) -> bool;
    /// Factorise it: its reciprocal condition estimate, `None` if singular.
    fn factor(&mut self) -> Option<f64>;
    /// The step `dx` at the current point (`fresh`: with the Jacobian just made).
    fn step(&mut self, fresh: bool);
    /// `||r||_2` at the current point.
    fn norm(&self) -> f64;
    /// Evaluate the trial point `x + alpha dx`: its `||r||_2`, `None` if it failed.
    fn trial(&mut self, alpha: f64) -> Option<f64>;
    /// The last trial point (reached by `alpha dx`) becomes the current one.
    fn accept(&mut self, alpha: f64, fresh: bool);
    /// After a failed line search: evaluate the current point again.
    fn restore(&mut self);
    /// Line search of a fresh Jacobian's step from `||r|| = f0`: the step length
    /// taken, `None` if none passes. Default: Armijo backtracking ([`backtrack`]).
    fn search(&mut self, f0: f64) -> Option<f64> {
        backtrack(f0, |alpha| self.trial(alpha))
    }
    /// Whether a chord step's full step, `||r||` from `f0` to `f`, is kept.
    /// Default: contraction by [`CHORD_CONTRACTION`].
    fn chord_keeps(&self, f: f64, f0: f64) -> bool {
        f < CHORD_CONTRACTION * f0
    }
}

/// How a [`chord_newton`] run ended, with its counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Outcome {
    pub end: End,
    /// Steps tried (fresh and chord).
    pub iterations: usize,
    /// Fresh Jacobians made.
    pub jacobians: usize,
}

/// Chord Newton from the problem's current (evaluated) point until its test
/// passes, with at most `max_jacobians` fresh Jacobians: a reused Jacobian's full
/// step is kept if [`ChordNewton::chord_keeps`] it, else the Jacobian is dropped; a
/// fresh one's step gets [`ChordNewton::search`], and a damped step (`alpha < 1`,
/// far from the solution, where the Jacobian changes quickly) drops it too.
/// Allocation-free; monomorphised per problem.
pub(crate) fn chord_newton(p: &mut impl ChordNewton, max_jacobians: usize) -> Outcome {
    let (mut iterations, mut jacobians, mut chord_steps) = (0, 0, 0);
    let end = loop {
        match p.test() {
            Test::Converged => break End::Converged,
            Test::Failed => break End::Failed,
            Test::Recheck => continue,
            Test::Step => {}
        }
        if chord_steps >= MAX_CHORD_STEPS {
            *p.jacobian_ok() = false;
        }
        p.prepare();
        let fresh = !*p.jacobian_ok();
        if fresh && jacobians >= max_jacobians {
            break End::MaxJacobians;
        }
        iterations += 1;
        if fresh {
            jacobians += 1;
            chord_steps = 0;
            if !p.jacobian() {
                break End::Failed;
            }
            match p.factor() {
                Some(rc) if rc > MIN_RCOND => *p.jacobian_ok() = true,
                _ => break End::Singular,
            }
        }
        p.step(fresh);
        let f0 = p.norm();
        if !fresh {
            chord_steps += 1;
            if p.trial(1.0).is_some_and(|f| p.chord_keeps(f, f0)) {
                p.accept(1.0, false);
            } else {
                *p.jacobian_ok() = false;
            }
            continue;
        }
        let Some(alpha) = p.search(f0) else {
            p.restore();
            *p.jacobian_ok() = false;
            break End::Stalled;
        };
        p.accept(alpha, true);
        if alpha < 1.0 {
            *p.jacobian_ok() = false;
        }
    };
    Outcome {
        end,
        iterations,
        jacobians,
    }
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
    /// `r(x) = x^2 - 2` with the Jacobian `2 x` kept from where it was made.
    struct Square {
        x: f64,
        trial_x: f64,
        dx: f64,
        jac: f64,
        jac_ok: bool,
        /// `true` for a fresh step, `false` for a chord one, in order.
        steps: Vec<bool>,
    }

    impl ChordNewton for Square {
        fn test(&mut self) -> Test {
            if (self.x * self.x - 2.0).abs() < 1e-12 {
                Test::Converged
            } else {
                Test::Step
            }
        }
        fn jacobian_ok(&mut self) -> &mut bool {
            &mut self.jac_ok
        }
        fn jacobian(&mut self) -> bool {
            self.jac = 2.0 * self.x;
            true
        }
        fn factor(&mut self) -> Option<f64> {
            (self.jac != 0.0).then_some(1.0)
        }
        fn step(&mut self, fresh: bool) {
            self.steps.push(fresh);
            self.dx = -(self.x * self.x - 2.0) / self.jac;
        }
        fn norm(&self) -> f64 {
            (self.x * self.x - 2.0).abs()
        }
        fn trial(&mut self, alpha: f64) -> Option<f64> {
            self.trial_x = self.x + alpha * self.dx;
            Some((self.trial_x * self.trial_x - 2.0).abs())
        }
        fn accept(&mut self, _alpha: f64, _fresh: bool) {
            self.x = self.trial_x;
        }
        fn restore(&mut self) {}
    }

    /// From `x = 1`: a fresh step (to 1.5), a chord step with the Jacobian of
    /// `x = 1` that contracts `|r|` only 2.3x (dropped, not taken), then fresh steps
    /// whose chord successors contract by more than 10x near the root. From `x = 0`
    /// the Jacobian is singular; with no fresh Jacobian allowed, `MaxJacobians`.
    #[test]
    fn chord_newton_reuses_a_contracting_jacobian_only() {
        let mut p = Square {
            x: 1.0,
            trial_x: 0.0,
            dx: 0.0,
            jac: 0.0,
            jac_ok: false,
            steps: Vec::new(),
        };
        let out = chord_newton(&mut p, 10);
        assert_eq!(out.end, End::Converged);
        assert!((p.x - 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(&p.steps[..3], [true, false, true]);
        assert_eq!(out.iterations, p.steps.len());
        assert_eq!(out.jacobians, p.steps.iter().filter(|f| **f).count());
        assert!(out.jacobians < out.iterations);
        p.x = 0.0;
        p.jac_ok = false;
        assert_eq!(chord_newton(&mut p, 10).end, End::Singular);
        p.x = 1.0;
        assert_eq!(chord_newton(&mut p, 0).end, End::MaxJacobians);
    }
}
