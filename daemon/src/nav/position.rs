//! The nose's horizontal position in the estimate's local frame (x and y
//! level, z up, the origin where the estimate started), and the water's
//! current: the model's predicted velocity of the nose through the water,
//! turned into the world by the estimated attitude, plus the estimated
//! current, integrated every period (dead reckoning), and corrected by
//! position fixes. Per axis a Kalman filter of two states, position and
//! current, the same covariance for x and y:
//!
//! - **Prediction.** `p += (v + c) dt`; the position's variance grows by
//!   the model's speed error ([`SPEED_ERROR`] of the speed, correlated
//!   over about a second) and, through the current's own uncertainty
//!   (at first [`CURRENT_SIGMA`]), linearly with time; the current may
//!   change slowly ([`CURRENT_WALK`]). Without fixes the current stays
//!   what it was estimated (0 at first) and the standard deviation grows
//!   by about [`CURRENT_SIGMA`] a second.
//! - **Fixes.** A fix of standard deviation `σ` corrects the position and,
//!   through their covariance, the current: a position that keeps drifting
//!   from the dead-reckoned one is the water moving the robot.
//! - **Latency.** A fix is stamped with the time it was measured (its
//!   arrival less the sensor's configured latency). Its innovation is taken
//!   against the estimate of that time, kept for [`HISTORY`] periods, with
//!   the covariance of that time; the correction then moves the present
//!   (by the corrected position and the corrected current since) and the
//!   kept past alike. A fix older than the kept history is left out and
//!   counted. The covariance of the fix's time is the present one moved
//!   back without taking out the process noise added since: with a
//!   latency of a few tenths of a second, slightly over-confident.
//! - **Velocities over ground** (a DVL): less the model's velocity through
//!   the water at their time, they observe the current directly (with the
//!   model's speed error added to theirs), and through the covariance the
//!   position.
//! - **Outliers.** A fix farther than [`GATE`] standard deviations (of
//!   the estimate and the fix together) is left out and counted; after
//!   [`GATE_FIXES`] such fixes in a row (fixes and velocities counted
//!   apart) the estimate, not the sensor, is taken to be wrong, and the
//!   next one is believed whole.
//! - **Health** ([`PositionHealth`]): whether fixes arrive, from the age of
//!   the last one taken: fixed, stale after `[autopilot] fix-stale`, lost
//!   after `fix-lost`; dead reckoning alone without a position sensor.
//!
//! Nothing here allocates after [`Plane::new`].

use anguilla_ipc::PositionHealth;
use anguilla_protocol::time::Nanos;

/// Periods of past positions kept for a late fix (at 160 Hz, 6.4 s).
pub const HISTORY: usize = 1024;
/// The fraction of the speed by which the model's velocity through the
/// water is wrong (its standard deviation, correlated over
/// [`SPEED_CORRELATION`]).
pub const SPEED_ERROR: f64 = 0.1;
/// How long the model's speed error lasts (s).
pub const SPEED_CORRELATION: f64 = 1.0;
/// The current's standard deviation before any fix (m/s, per axis): the
/// currents a robot of this size swims in.
pub const CURRENT_SIGMA: f64 = 0.1;
/// How fast the current may change (m/s per √s, a random walk): 0.02 m/s
/// in 100 s.
pub const CURRENT_WALK: f64 = 0.002;
/// Standard deviations beyond which a fix is an outlier.
pub const GATE: f64 = 5.0;
/// Outlying fixes in a row after which the next one is believed whole.
pub const GATE_FIXES: u32 = 3;

/// One axis's covariance of (position, current); x and y share it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Cov {
    pp: f64,
    pc: f64,
    cc: f64,
}

impl Cov {
    /// Moved `t` seconds on (negative: back), without process noise.
    fn shifted(self, t: f64) -> Self {
        Self {
            pp: self.pp + 2.0 * t * self.pc + t * t * self.cc,
            pc: self.pc + t * self.cc,
            cc: self.cc,
        }
    }
}

/// One period kept: its time, the position, and the model's velocity
/// through the water.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Kept {
    t: Nanos,
    x: f64,
    y: f64,
    vx: f64,
    vy: f64,
}

const ORIGIN: Kept = Kept {
    t: Nanos::ZERO,
    x: 0.0,
    y: 0.0,
    vx: 0.0,
    vy: 0.0,
};

/// When a fix is stale and when lost (s since the last one taken).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixTimes {
    /// Older than this: stale.
    pub stale: f64,
    /// Older than this: lost.
    pub lost: f64,
}

/// The position and current estimate.
#[derive(Debug, Clone)]
pub struct Plane {
    x: f64,
    y: f64,
    cx: f64,
    cy: f64,
    cov: Cov,
    /// `(time, x, y)` of the last [`HISTORY`] periods, a ring, with the
    /// model's velocity through the water then.
    history: Box<[Kept]>,
    next: usize,
    len: usize,
    now: Nanos,
    fixes: u32,
    velocities: u32,
    rejected: u32,
    gated_fix: u32,
    gated_velocity: u32,
    last_fix: Option<Nanos>,
    /// With a position sensor: when a fix is stale and lost.
    times: Option<FixTimes>,
}

impl Default for Plane {
    fn default() -> Self {
        Self::new(None)
    }
}

impl Plane {
    /// At the origin, certain of it, the current unknown; `times` when a
    /// position sensor gives fixes.
    pub fn new(times: Option<FixTimes>) -> Self {
        Self {
            x: 0.0,
            y: 0.0,
            cx: 0.0,
            cy: 0.0,
            cov: Cov {
                pp: 0.0,
                pc: 0.0,
                cc: CURRENT_SIGMA * CURRENT_SIGMA,
            },
            history: vec![ORIGIN; HISTORY].into_boxed_slice(),
            next: 0,
            len: 0,
            now: Nanos::ZERO,
            fixes: 0,
            velocities: 0,
            rejected: 0,
            gated_fix: 0,
            gated_velocity: 0,
            last_fix: None,
            times,
        }
    }

    /// One period of `dt` s ending at `now`, at the world velocity
    /// through the water `vx`, `vy` (m/s); non-finite velocities count as
    /// 0.
    pub fn propagate(&mut self, now: Nanos, vx: f64, vy: f64, dt: f64) {
        let f = |v: f64| if v.is_finite() { v } else { 0.0 };
        let (vx, vy, dt) = (f(vx), f(vy), f(dt).max(0.0));
        self.x += (vx + self.cx) * dt;
        self.y += (vy + self.cy) * dt;
        let speed_error = SPEED_ERROR * vx.hypot(vy);
        let mut c = self.cov.shifted(dt);
        c.pp += speed_error * speed_error * SPEED_CORRELATION * dt;
        c.cc += CURRENT_WALK * CURRENT_WALK * dt;
        self.cov = c;
        self.now = now;
        self.history[self.next] = Kept {
            t: now,
            x: self.x,
            y: self.y,
            vx,
            vy,
        };
        self.next = (self.next + 1) % HISTORY;
        self.len = (self.len + 1).min(HISTORY);
    }

    /// The kept period nearest before `at` (the first kept if `at` is
    /// before the estimate started; the present, at rest, if nothing is
    /// kept); `None` if `at` is older than the whole kept history (a fix
    /// later than [`HISTORY`] periods cannot be placed).
    fn at(&self, at: Nanos) -> Option<Kept> {
        let mut best = Kept {
            t: self.now,
            x: self.x,
            y: self.y,
            ..ORIGIN
        };
        for k in 1..=self.len {
            best = self.history[(self.next + HISTORY - k) % HISTORY];
            if best.t <= at {
                return Some(best);
            }
        }
        (self.len < HISTORY).then_some(best)
    }

    /// Whether an innovation is taken, counting outliers in a row in
    /// `gated` (each kind of observation its own): `Some(false)` within the
    /// gate, `Some(true)` believed whole after [`GATE_FIXES`] outliers in a
    /// row, `None` left out.
    fn gate(gated: &mut u32, rejected: &mut u32, outlier: bool) -> Option<bool> {
        if !outlier {
            *gated = 0;
            Some(false)
        } else if *gated < GATE_FIXES {
            *gated += 1;
            *rejected += 1;
            None
        } else {
            *gated = 0;
            Some(true)
        }
    }

    /// Takes a fix measured at `at`: `x`, `y` (m, local frame) with
    /// standard deviation `sigma` (m, > 0). Returns whether it was taken
    /// (an outlier is not, nor a fix with a value that is not finite).
    pub fn fix(&mut self, at: Nanos, x: f64, y: f64, sigma: f64) -> bool {
        if !(x.is_finite() && y.is_finite() && sigma.is_finite() && sigma > 0.0) {
            self.rejected += 1;
            return false;
        }
        let Some(then) = self.at(at) else {
            self.rejected += 1;
            return false;
        };
        let (ex, ey) = (x - then.x, y - then.y);
        // The covariance of the estimate's time: `ago` before the present.
        let ago = self.now.saturating_sub(then.t).as_nanos() as f64 * 1e-9;
        let p = self.cov.shifted(-ago);
        let r = sigma * sigma;
        let outlier = ex.hypot(ey) > GATE * (p.pp + r).sqrt();
        let Some(whole) = Self::gate(&mut self.gated_fix, &mut self.rejected, outlier) else {
            return false;
        };
        let then = then.t;
        let after = if whole {
            // The estimate was wrong: the fix is believed whole, the
            // current is unknown again (and so is its drift since).
            let (cx, cy) = (self.cx, self.cy);
            self.cx = 0.0;
            self.cy = 0.0;
            self.shift(then, ex, ey, -cx, -cy);
            Cov {
                pp: r,
                pc: 0.0,
                cc: CURRENT_SIGMA * CURRENT_SIGMA,
            }
        } else {
            let s = p.pp + r;
            let (kp, kc) = (p.pp / s, p.pc / s);
            self.cx += kc * ex;
            self.cy += kc * ey;
            self.shift(then, kp * ex, kp * ey, kc * ex, kc * ey);
            Cov {
                pp: (1.0 - kp) * p.pp,
                pc: (1.0 - kp) * p.pc,
                cc: p.cc - kc * p.pc,
            }
        };
        self.cov = after.shifted(ago);
        self.fixes = self.fixes.saturating_add(1);
        self.last_fix = Some(self.last_fix.map_or(at, |l| l.max(at)));
        true
    }

    /// Takes a velocity over ground measured at `at`: `vx`, `vy` (m/s,
    /// local frame) with standard deviation `sigma` (m/s per axis, > 0).
    /// Less the model's velocity through the water then, it observes the
    /// current. Returns whether it was taken (as [`Plane::fix`]).
    pub fn velocity(&mut self, at: Nanos, vx: f64, vy: f64, sigma: f64) -> bool {
        if !(vx.is_finite() && vy.is_finite() && sigma.is_finite() && sigma > 0.0) {
            self.rejected += 1;
            return false;
        }
        let Some(then) = self.at(at) else {
            self.rejected += 1;
            return false;
        };
        let (ex, ey) = (vx - then.vx - self.cx, vy - then.vy - self.cy);
        let ago = self.now.saturating_sub(then.t).as_nanos() as f64 * 1e-9;
        let p = self.cov.shifted(-ago);
        // What it observes is the current plus the model's speed error.
        let model = SPEED_ERROR * then.vx.hypot(then.vy);
        let r = sigma * sigma + model * model;
        let outlier = ex.hypot(ey) > GATE * (p.cc + r).sqrt();
        let Some(whole) = Self::gate(&mut self.gated_velocity, &mut self.rejected, outlier) else {
            return false;
        };
        let after = if whole {
            // The current was wrong: the velocity's is believed whole.
            self.cx += ex;
            self.cy += ey;
            self.shift(then.t, 0.0, 0.0, ex, ey);
            Cov {
                pc: 0.0,
                cc: r,
                ..p
            }
        } else {
            let s = p.cc + r;
            let (kp, kc) = (p.pc / s, p.cc / s);
            self.cx += kc * ex;
            self.cy += kc * ey;
            self.shift(then.t, kp * ex, kp * ey, kc * ex, kc * ey);
            Cov {
                pp: p.pp - kp * p.pc,
                pc: p.pc - kp * p.cc,
                cc: p.cc - kc * p.cc,
            }
        };
        self.cov = after.shifted(ago);
        self.velocities = self.velocities.saturating_add(1);
        true
    }

    /// Moves the present and the kept past by a correction at `then`:
    /// `dx`, `dy` of position, and `dcx`, `dcy` of current, the whole
    /// track (before `then` too) moved as the constant-current model has it.
    fn shift(&mut self, then: Nanos, dx: f64, dy: f64, dcx: f64, dcy: f64) {
        let since = |t: Nanos| (t.as_nanos() as f64 - then.as_nanos() as f64) * 1e-9;
        let t = since(self.now);
        self.x += dx + dcx * t;
        self.y += dy + dcy * t;
        for h in self.history.iter_mut() {
            let t = since(h.t);
            h.x += dx + dcx * t;
            h.y += dy + dcy * t;
        }
    }

    /// x, y (m).
    pub fn position(&self) -> (f64, f64) {
        (self.x, self.y)
    }

    /// The position's standard deviation (m, per axis).
    pub fn sigma(&self) -> f64 {
        self.cov.pp.max(0.0).sqrt()
    }

    /// The water's estimated velocity over ground, x and y (m/s).
    pub fn current(&self) -> (f64, f64) {
        (self.cx, self.cy)
    }

    /// The current's standard deviation (m/s, per axis).
    pub fn current_sigma(&self) -> f64 {
        self.cov.cc.max(0.0).sqrt()
    }

    /// Fixes taken.
    pub fn fixes(&self) -> u32 {
        self.fixes
    }

    /// Velocities over ground taken.
    pub fn velocities(&self) -> u32 {
        self.velocities
    }

    /// Fixes and velocities left out (outliers, values not finite).
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// How long ago the last fix taken was measured (s), at the last
    /// period; `None` before the first.
    pub fn fix_age(&self) -> Option<f64> {
        self.last_fix
            .map(|l| self.now.saturating_sub(l).as_nanos() as f64 * 1e-9)
    }

    /// Whether fixes arrive.
    pub fn health(&self) -> PositionHealth {
        let Some(times) = self.times else {
            return PositionHealth::DeadReckoning;
        };
        match self.fix_age() {
            None => PositionHealth::Waiting,
            Some(a) if a > times.lost => PositionHealth::Lost,
            Some(a) if a > times.stale => PositionHealth::Stale,
            Some(_) => PositionHealth::Fixed,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.01;

    fn ms(k: u64) -> Nanos {
        Nanos::from_millis(k)
    }

    const TIMES: FixTimes = FixTimes {
        stale: 5.0,
        lost: 20.0,
    };

    #[test]
    fn dead_reckoning_drifts_with_its_uncertainty_and_a_fix_pulls_it_back() {
        let mut p = Plane::new(Some(TIMES));
        // The model says 0.5 m/s along x; the truth is 0.4 m/s (a current
        // against it). 20 s.
        for k in 1..=2000 {
            p.propagate(ms(10 * k), 0.5, 0.0, DT);
        }
        let (x, _) = p.position();
        assert!((x - 10.0).abs() < 1e-9, "{x}");
        // The unknown current's 0.1 m/s for 20 s, and a little more.
        let sigma = p.sigma();
        assert!((2.0..2.1).contains(&sigma), "{sigma}");
        // A fix of the truth (8 m) measured now, σ 0.5 m: 2 m off is
        // within the gate, and pulls by P / (P + R).
        let pp = sigma * sigma;
        assert!(p.fix(ms(20_000), 8.0, 0.0, 0.5));
        let (x, _) = p.position();
        assert!((x - (10.0 - 2.0 * pp / (pp + 0.25))).abs() < 1e-9, "{x}");
        assert!(p.sigma() < 0.5, "{}", p.sigma());
        // The position was behind all along: the current is against x.
        assert!(p.current().0 < -0.05, "{:?}", p.current());
        assert_eq!((p.fixes(), p.rejected()), (1, 0));
    }

    /// The robot swims 0.3 m/s along x (as the model says) through a
    /// current of (−0.05, 0.08) m/s it does not know; fixes of the truth
    /// at 1 Hz, σ 0.3 m, 0.3 s late, with a deterministic noise: after
    /// 60 s the current is known within 0.02 m/s and the position within
    /// two of its σ.
    #[test]
    fn fixes_that_keep_drifting_are_the_current() {
        let mut p = Plane::new(Some(TIMES));
        let (cx, cy) = (-0.05, 0.08);
        let mut truth = Vec::new();
        let mut noise = 0.37_f64;
        let mut next = || {
            noise = (noise * 9301.0 + 0.49297).fract();
            0.3 * (2.0 * noise - 1.0) * 1.7
        };
        for k in 1..=6000u64 {
            let t = k as f64 * DT;
            truth.push(((0.3 + cx) * t, cy * t));
            p.propagate(ms(10 * k), 0.3, 0.0, DT);
            // A fix measured 0.3 s ago arrives each second.
            if k % 100 == 0 && k > 30 {
                let (tx, ty) = truth[k as usize - 31];
                assert!(p.fix(ms(10 * (k - 30)), tx + next(), ty + next(), 0.3));
            }
        }
        let (ex, ey) = p.current();
        assert!(
            (ex - cx).abs() < 0.02 && (ey - cy).abs() < 0.02,
            "{ex} {ey}"
        );
        assert!(p.current_sigma() < 0.02, "{}", p.current_sigma());
        let (x, y) = p.position();
        let (tx, ty) = truth[5999];
        let err = (x - tx).hypot(y - ty);
        assert!(
            err < 2.0 * std::f64::consts::SQRT_2 * p.sigma(),
            "{err} {}",
            p.sigma()
        );
        assert_eq!(p.health(), PositionHealth::Fixed);
    }

    /// A DVL alone (5 Hz, σ 0.01 m/s) learns a current of (0.05, −0.1)
    /// m/s the model does not know within 0.02 m/s in 20 s, and the
    /// dead-reckoned position then drifts by far less than without it.
    #[test]
    fn velocities_over_ground_are_the_current_without_a_fix() {
        let (cx, cy) = (0.05, -0.1);
        let run = |dvl: bool| {
            let mut p = Plane::new(None);
            for k in 1..=6000u64 {
                p.propagate(ms(10 * k), 0.3, 0.0, DT);
                if dvl && k % 20 == 0 {
                    assert!(p.velocity(ms(10 * k), 0.3 + cx, cy, 0.01), "at {k}");
                }
                if k == 2000 && dvl {
                    let (ex, ey) = p.current();
                    assert!(
                        (ex - cx).abs() < 0.02 && (ey - cy).abs() < 0.02,
                        "{ex} {ey}"
                    );
                }
            }
            let (x, y) = p.position();
            (x - (0.3 + cx) * 60.0).hypot(y - cy * 60.0)
        };
        let (with, without) = (run(true), run(false));
        assert!(
            with < 0.5 && without > 5.0,
            "{with} m with, {without} m without"
        );
    }

    #[test]
    fn a_late_fix_is_compared_with_the_estimate_of_its_time() {
        let mut p = Plane::new(Some(TIMES));
        for k in 1..=300 {
            p.propagate(ms(10 * k), 1.0, 0.0, DT);
        }
        // At 3 s the estimate is at 3 m; a fix measured at 2 s says 2 m:
        // exactly where the estimate was then, so nothing moves.
        assert!(p.fix(ms(2000), 2.0, 0.0, 0.1));
        assert!((p.position().0 - 3.0).abs() < 1e-9, "{:?}", p.position());
        assert!(p.current().0.abs() < 1e-9, "{:?}", p.current());
        // A fix measured at 1 s says 1.5 m (0.5 m ahead of the estimate
        // then), the one of 2 s said 2 m: the robot covered less than the
        // model says between them, and the water is against it. The
        // present moves by less than the innovation.
        assert!(p.fix(ms(1000), 1.5, 0.0, 0.1));
        let moved = p.position().0 - 3.0;
        assert!(moved.abs() < 0.5, "{moved}");
        assert!(p.current().0 < -0.01, "{:?}", p.current());
    }

    /// A fix measured before the kept history cannot be placed: left out
    /// and counted, the estimate untouched.
    #[test]
    fn a_fix_older_than_the_history_is_left_out() {
        let mut p = Plane::new(Some(TIMES));
        for k in 1..=(HISTORY as u64 + 100) {
            p.propagate(ms(10 * k), 0.1, 0.0, DT);
        }
        let before = p.position();
        assert!(!p.fix(ms(10), 0.0, 0.0, 0.3));
        assert!(!p.velocity(ms(10), 0.0, 0.0, 0.01));
        assert_eq!((p.position(), p.rejected()), (before, 2));
        assert!(p.fix(ms(10 * HISTORY as u64), p.position().0, 0.0, 0.3));
    }

    /// Fixes and velocities count their outliers apart: a DVL within its
    /// gate does not stop three outlying fixes in a row from making the
    /// fourth believed.
    #[test]
    fn outliers_in_a_row_are_counted_per_kind() {
        let mut p = Plane::new(Some(TIMES));
        for k in 1..=100 {
            p.propagate(ms(10 * k), 0.0, 0.0, DT);
        }
        for _ in 0..GATE_FIXES {
            assert!(!p.fix(ms(1000), 50.0, 0.0, 0.5));
            assert!(p.velocity(ms(1000), 0.0, 0.0, 0.01));
        }
        assert!(p.fix(ms(1000), 50.0, 0.0, 0.5));
        assert_eq!(p.position().0, 50.0);
    }

    #[test]
    fn an_outlier_is_left_out_until_it_lasts() {
        let mut p = Plane::new(Some(TIMES));
        for k in 1..=100 {
            p.propagate(ms(10 * k), 0.0, 0.0, DT);
        }
        // σ 0.1 m after 1 s at rest; a fix 50 m away is no fix.
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
        assert_eq!(p.current(), (0.0, 0.0));
        assert_eq!(p.current_sigma(), CURRENT_SIGMA);
    }

    /// The health follows the last fix's age: waiting, fixed, stale,
    /// lost, fixed again; without a position sensor, dead reckoning.
    #[test]
    fn the_health_is_the_age_of_the_last_fix() {
        let mut p = Plane::new(Some(TIMES));
        let mut now = 0;
        let mut run = |p: &mut Plane, s: u64| {
            for _ in 0..s * 100 {
                now += 10;
                p.propagate(ms(now), 0.2, 0.0, DT);
            }
            now
        };
        run(&mut p, 2);
        assert_eq!(p.health(), PositionHealth::Waiting);
        assert_eq!(p.fix_age(), None);
        let t = run(&mut p, 1);
        assert!(p.fix(ms(t), p.position().0, 0.0, 0.3));
        assert_eq!(p.health(), PositionHealth::Fixed);
        run(&mut p, 5);
        assert_eq!(p.health(), PositionHealth::Fixed, "{:?}", p.fix_age());
        run(&mut p, 1);
        assert_eq!(p.health(), PositionHealth::Stale, "{:?}", p.fix_age());
        let sigma_stale = p.sigma();
        run(&mut p, 15);
        assert_eq!(p.health(), PositionHealth::Lost, "{:?}", p.fix_age());
        assert!(p.sigma() > sigma_stale, "the uncertainty grows while lost");
        // A fresh fix makes it fixed again.
        let t = run(&mut p, 0);
        assert!(p.fix(ms(t - 100), p.position().0, 0.0, 0.3));
        assert_eq!(p.health(), PositionHealth::Fixed);
        // A late one, measured before the last one taken, is taken but
        // does not make the position fresh.
        run(&mut p, 6);
        assert_eq!(p.health(), PositionHealth::Stale, "{:?}", p.fix_age());
        assert!(p.fix(ms(t - 200), p.position().0, 0.0, 0.3));
        assert_eq!(p.health(), PositionHealth::Stale, "{:?}", p.fix_age());
        assert_eq!(Plane::new(None).health(), PositionHealth::DeadReckoning);
    }
}
