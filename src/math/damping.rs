//! Levenberg-Marquardt damping: the one place where a damped Gauss-Newton solver
//! decides how its damping `mu` follows the gain ratio
//! `rho = (actual decrease) / (decrease predicted by the quadratic model)` of a
//! trial step, and when it gives up.
//!
//! Two update rules, each the one its solvers were tuned with (their results are
//! unchanged by sharing this code):
//!
//! * [`DampingRule::Nielsen`] (Nielsen 1999; Madsen, Nielsen & Tingleff, "Methods for
//!   Non-Linear Least Squares Problems", 2004, eq. 3.16 and algorithm 3.16): accepted,
//!   `mu *= max(1/3, 1 - (2 rho - 1)^3)` and `nu = 2`; rejected, `mu *= nu`,
//!   `nu *= 2`; gives up when `mu` is not finite or `nu > 1e15`. Calibration uses it
//!   (`calibrate::lm`): few, expensive steps from far away.
//! * [`DampingRule::Ratio`] (the trust-region thresholds of Moré 1978 and Nocedal &
//!   Wright algorithm 4.1 applied to `mu`): accepted, `mu /= 3` (not below 1e-12)
//!   when `rho > 0.75`, `mu *= 2` when `rho < 0.25`; rejected, `mu = max(4 mu, 1e-6)`;
//!   gives up when `mu > 1e12`. The estimators use it (`estimate`): warm samples
//!   close to the answer, where a damping that falls fast after a good step matters.
//!
//! A solver that adds a rule adds a variant here, not a copy of the arithmetic.

/// How the damping follows the gain ratio (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DampingRule {
    /// Nielsen's continuous update.
    Nielsen,
    /// Trust-ratio thresholds 0.25 / 0.75.
    Ratio,
}

/// The damping state of one Levenberg-Marquardt run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Damping {
    rule: DampingRule,
    mu: f64,
    nu: f64,
}

impl Damping {
    /// Start at `mu` (dimensionless: relative to the solver's scaling of the
    /// normal matrix).
    pub fn new(rule: DampingRule, mu: f64) -> Self {
        Self { rule, mu, nu: 2.0 }
    }

    /// The current damping.
    #[inline]
    pub fn mu(&self) -> f64 {
        self.mu
    }

    /// Restart at `mu` (between samples: damping never carries over).
    pub fn reset(&mut self, mu: f64) {
        self.mu = mu;
        self.nu = 2.0;
    }

    /// A trial step with gain ratio `rho` was accepted.
    pub fn accepted(&mut self, rho: f64) {
        match self.rule {
            DampingRule::Nielsen => {
                self.mu *= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                self.nu = 2.0;
            }
            DampingRule::Ratio => {
                if rho > 0.75 {
                    self.mu = (self.mu / 3.0).max(1e-12);
                } else if rho < 0.25 {
                    self.mu *= 2.0;
                }
            }
        }
    }

    /// A trial step was rejected (or could not be computed): raise the damping.
    /// `false` when the rule gives up (no damping produced a decrease).
    #[must_use]
    pub fn rejected(&mut self) -> bool {
        match self.rule {
            DampingRule::Nielsen => {
                self.mu *= self.nu;
                self.nu *= 2.0;
                self.mu.is_finite() && self.nu <= 1e15
            }
            DampingRule::Ratio => {
                self.mu = (self.mu * 4.0).max(1e-6);
                self.mu <= 1e12
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nielsen: a perfect step (rho = 1) divides by 3, rho = 0.5 keeps `mu`, a
    /// rejection multiplies by 2, 4, 8, ... and the run gives up once `nu` passes
    /// 1e15 or `mu` overflows (from 1e-3: `mu = 1e-3 2^(k(k+1)/2)` after `k`
    /// rejections, infinite at the 45th); an acceptance resets `nu`.
    #[test]
    fn nielsen_follows_madsen_nielsen_tingleff() {
        let mut d = Damping::new(DampingRule::Nielsen, 1e-3);
        d.accepted(1.0);
        assert!((d.mu() - 1e-3 / 3.0).abs() < 1e-18);
        d.accepted(0.5);
        assert!((d.mu() - 1e-3 / 3.0).abs() < 1e-18);
        assert!(d.rejected() && d.rejected());
        assert!((d.mu() - 8e-3 / 3.0).abs() < 1e-15);
        d.accepted(0.5);
        assert!(d.rejected());
        assert!((d.mu() - 16e-3 / 3.0).abs() < 1e-15);
        let mut n = 0;
        let mut d = Damping::new(DampingRule::Nielsen, 1e-3);
        while d.rejected() {
            n += 1;
        }
        assert_eq!(n, 44);
    }

    /// Ratio: the thresholds, the floor and the ceiling (from 1e-6, 4^29 more is
    /// 2.9e11, 4^30 more 1.2e12: the 31st rejection gives up).
    #[test]
    fn ratio_follows_the_trust_thresholds() {
        let mut d = Damping::new(DampingRule::Ratio, 1e-3);
        d.accepted(0.9);
        assert_eq!(d.mu(), 1e-3 / 3.0);
        d.accepted(0.5);
        assert_eq!(d.mu(), 1e-3 / 3.0);
        d.accepted(0.1);
        assert_eq!(d.mu(), 2e-3 / 3.0);
        d.reset(1e-13);
        d.accepted(1.0);
        assert_eq!(d.mu(), 1e-12);
        d.reset(0.0);
        assert!(d.rejected());
        assert_eq!(d.mu(), 1e-6);
        let mut n = 1;
        while d.rejected() {
            n += 1;
        }
        assert_eq!(n, 30);
        assert!(d.mu() > 1e12);
    }
}
