//! The nose's horizontal position in the estimate's local frame (x and y
//! level, z up, the origin where the estimate started): the model's
//! predicted velocity of the nose, turned into the world by the estimated
//! attitude, integrated every period (dead reckoning), and corrected by
//! position fixes (a Kalman update per fix, the same gain on x and y).
//!
//! - **Uncertainty.** The standard deviation starts at 0 (the origin is
//!   where the estimate started) and grows while dead-reckoned by
//!   [`SPEED_ERROR`] of the speed plus [`DRIFT`]: a model's speed error
//!   and an unknown current make a position error that grows with time,
//!   not with its square root. A fix of standard deviation `σ` then pulls
//!   the estimate by `K = P / (P + σ²)` and leaves `P (1 − K)`.
//! - **Latency.** A fix is stamped with the time it was measured (its
//!   arrival less the sensor's configured latency). Its innovation is taken
//!   against the estimate of that time, kept for [`HISTORY`] periods, and
//!   the correction moves the present and the kept past alike.
//! - **Outliers.** A fix farther than [`GATE`] standard deviations (of
//!   the estimate and the fix together) is left out and counted; after
//!   [`GATE_FIXES`] such fixes in a row the estimate, not the sensor, is
//!   taken to be wrong, and the next one is believed whole.
//!
//! Nothing here allocates after [`Plane::new`].

use anguilla_protocol::time::Nanos;

/// Periods of past positions kept for a late fix (at 160 Hz, 6.4 s).
pub const HISTORY: usize = 1024;
/// The fraction of the speed by which the dead-reckoned position's
/// standard deviation grows (the model's speed is this good).
pub const SPEED_ERROR: f64 = 0.1;
/// What the standard deviation grows by at rest (m/s): an unknown current.
pub const DRIFT: f64 = 0.05;
/// Standard deviations beyond which a fix is an outlier.
pub const GATE: f64 = 5.0;
/// Outlying fixes in a row after which the next one is believed whole.
pub const GATE_FIXES: u32 = 3;

/// The position estimate.
#[derive(Debug, Clone)]
pub struct Plane {
    x: f64,
    y: f64,
    sigma: f64,
    /// `(time, x, y)` of the last [`HISTORY`] periods, a ring.
    history: Box<[(Nanos, f64, f64)]>,
    next: usize,
    len: usize,
    fixes: u32,
    rejected: u32,
    gated: u32,
}

impl Default for Plane {
    fn default() -> Self {
        Self::new()
    }
}

impl Plane {
    /// At the origin, certain of it.
    pub fn new() -> Self {
        Self {
            x: 0.0,
            y: 0.0,
            sigma: 0.0,
            history: vec![(Nanos::ZERO, 0.0, 0.0); HISTORY].into_boxed_slice(),
            next: 0,
            len: 0,
            fixes: 0,
            rejected: 0,
            gated: 0,
        }
    }

    /// One period of `dt` s ending at `now`, at the world velocity
    /// `vx`, `vy` (m/s); non-finite velocities count as 0.
    pub fn propagate(&mut self, now: Nanos, vx: f64, vy: f64, dt: f64) {
        let f = |v: f64| if v.is_finite() { v } else { 0.0 };
        let (vx, vy) = (f(vx), f(vy));
        self.x += vx * dt;
        self.y += vy * dt;
        self.sigma += (SPEED_ERROR * vx.hypot(vy) + DRIFT) * dt.max(0.0);
        self.remember(now);
    }

    fn remember(&mut self, now: Nanos) {
        self.history[self.next] = (now, self.x, self.y);
        self.next = (self.next + 1) % HISTORY;
        self.len = (self.len + 1).min(HISTORY);
    }

    /// The kept estimate nearest before `at` (the oldest kept if `at` is
    /// older still; the present if nothing is kept).
    fn at(&self, at: Nanos) -> (f64, f64) {
        let mut best = (self.x, self.y);
        for k in 1..=self.len {
            let (t, x, y) = self.history[(self.next + HISTORY - k) % HISTORY];
            best = (x, y);
            if t <= at {
                break;
            }
        }
        best
    }

    /// Takes a fix measured at `at`: `x`, `y` (m, local frame) with
    /// standard deviation `sigma` (m, > 0). Returns whether it was taken
    /// (an outlier is not, nor a fix with a value that is not finite).
    pub fn fix(&mut self, at: Nanos, x: f64, y: f64, sigma: f64) -> bool {
        if !(x.is_finite() && y.is_finite() && sigma.is_finite() && sigma > 0.0) {
            self.rejected += 1;
            return false;
        }
        let (hx, hy) = self.at(at);
        let (ex, ey) = (x - hx, y - hy);
        let p = self.sigma * self.sigma;
        let r = sigma * sigma;
        let outlier = ex.hypot(ey) > GATE * (p + r).sqrt();
        let k = if !outlier {
            self.gated = 0;
            p / (p + r)
        } else if self.gated < GATE_FIXES {
            self.gated += 1;
            self.rejected += 1;
            return false;
        } else {
            // The estimate was wrong: the fix is believed whole.
            self.gated = 0;
            1.0
        };
        let (dx, dy) = (k * ex, k * ey);
        self.x += dx;
        self.y += dy;
        for h in self.history.iter_mut() {
            h.1 += dx;
            h.2 += dy;
        }
        self.sigma = if k >= 1.0 {
            sigma
        } else {
            (p * (1.0 - k)).sqrt()
        };
        self.fixes = self.fixes.saturating_add(1);
        true
    }

    /// x, y (m).
    pub fn position(&self) -> (f64, f64) {
        (self.x, self.y)
    }

    /// The position's standard deviation (m).
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// Fixes taken.
    pub fn fixes(&self) -> u32 {
        self.fixes
    }

    /// Fixes left out (outliers, values not finite).
    pub fn rejected(&self) -> u32 {
        self.rejected
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.01;

    fn ms(k: u64) -> Nanos {
        Nanos::from_millis(k)
    }

    #[test]
    fn dead_reckoning_drifts_with_its_uncertainty_and_a_fix_pulls_it_back() {
        let mut p = Plane::new();
        // The model says 0.5 m/s along x; the truth is 0.4 m/s (a current
        // against it). 20 s.
        for k in 1..=2000 {
            p.propagate(ms(10 * k), 0.5, 0.0, DT);
        }
        let (x, _) = p.position();
        assert!((x - 10.0).abs() < 1e-9, "{x}");
        let sigma = p.sigma();
        // 20 s at 0.1 · 0.5 + 0.05 m/s
        assert!((sigma - 2.0).abs() < 1e-9, "{sigma}");
        // A fix of the truth (8 m) measured now, σ 0.5 m: 2 m off is
        // within the gate, and pulls by P / (P + R) = 4 / 4.25.
        assert!(p.fix(ms(20_000), 8.0, 0.0, 0.5));
        let (x, _) = p.position();
        assert!((x - (10.0 - 2.0 * 4.0 / 4.25)).abs() < 1e-9, "{x}");
        assert!(p.sigma() < 0.5, "{}", p.sigma());
        assert_eq!((p.fixes(), p.rejected()), (1, 0));
    }

    #[test]
    fn a_late_fix_is_compared_with_the_estimate_of_its_time() {
        let mut p = Plane::new();
        for k in 1..=300 {
            p.propagate(ms(10 * k), 1.0, 0.0, DT);
        }
        // At 3 s the estimate is at 3 m; a fix measured at 2 s says 2 m:
        // exactly where the estimate was then, so nothing moves.
        assert!(p.fix(ms(2000), 2.0, 0.0, 0.1));
        assert!((p.position().0 - 3.0).abs() < 1e-9, "{:?}", p.position());
        // A fix measured at 1 s says 1.5 m (0.5 m ahead of the estimate
        // then): the present moves by the gain times 0.5 m.
        let s = p.sigma();
        let k = s * s / (s * s + 0.01);
        assert!(p.fix(ms(1000), 1.5, 0.0, 0.1));
        assert!((p.position().0 - (3.0 + 0.5 * k)).abs() < 1e-9);
    }

    #[test]
    fn an_outlier_is_left_out_until_it_lasts() {
        let mut p = Plane::new();
        for k in 1..=100 {
            p.propagate(ms(10 * k), 0.0, 0.0, DT);
        }
        // σ 0.05 m after 1 s at rest; a fix 50 m away is no fix.
        for n in 1..=GATE_FIXES {
            assert!(!p.fix(ms(1000), 50.0, 0.0, 0.5), "fix {n}");
            assert_eq!(p.position(), (0.0, 0.0));
        }
        assert!(!p.fix(ms(1000), f64::NAN, 0.0, 0.5));
        assert_eq!(p.rejected(), GATE_FIXES + 1);
        // One more: the estimate was wrong.
        assert!(p.fix(ms(1000), 50.0, 1.0, 0.5));
        assert_eq!(p.position(), (50.0, 1.0));
        assert_eq!(p.sigma(), 0.5);
    }
}
