//! The nose's horizontal position in the estimate's local frame (x and y
//! level, z up, the origin where the estimate started), the water's
//! current, and how far the model's speed is off: the model's predicted
//! velocity of the nose through the water, turned into the world by the
//! estimated attitude and scaled by the estimated speed factor, plus the
//! estimated current, integrated every period (dead reckoning), and
//! corrected by position fixes and velocities over ground. One Kalman
//! filter of five states: x, y, the current's x and y, and the model's
//! speed error `k` (the water-relative velocity is `(1 + k)` times the
//! model's):
//!
//! - **Prediction.** `p += ((1 + k) v + c) dt`; the position's variance
//!   grows by the model's fast speed error ([`SPEED_ERROR`] of the speed,
//!   correlated over about a second: within a gait period the model and
//!   the body disagree), and through the uncertainty of the current (at
//!   first [`CURRENT_SIGMA`]) and of `k` (at first [`SCALE_SIGMA`]); the
//!   current and `k` may change slowly ([`CURRENT_WALK`],
//!   [`SCALE_WALK`]). Without fixes both stay what they were estimated
//!   (0 at first).
//! - **Why `k`.** The model's speed is off by a few per cent on the
//!   built-in robot (3.7 % slow at full gait) and by more on a real one.
//!   Swimming straight, a speed error and a current along the heading
//!   move the robot alike, and no fix tells them apart; a filter without
//!   `k` takes the speed error for current. Once the heading changes (a
//!   turn onto a path, a leg switch) the two differ: the speed error turns
//!   with the robot, the current does not, and the filter separates them.
//! - **Fixes.** A fix of standard deviation `σ` corrects the position and,
//!   through their covariance, the current and `k`: a position that keeps
//!   drifting from the dead-reckoned one is the water moving the robot, or
//!   the model's speed.
//! - **Latency.** A fix is stamped with the time it was measured (its
//!   arrival less the sensor's configured latency). Its innovation is taken
//!   against the estimate of that time, kept for [`HISTORY`] periods, with
//!   the covariance of that time; the correction then moves the present
//!   (by the corrected position, current and `k` since) and the kept past
//!   alike. A fix older than the kept history is left out and counted.
//!   The covariance of the fix's time is the present one moved back
//!   without taking out the process noise added since: with a latency of
//!   a few tenths of a second, slightly over-confident.
//! - **Velocities over ground** (a DVL): less the model's scaled velocity
//!   through the water at their time, they observe the current (with the
//!   model's fast speed error added to theirs), and through the
//!   covariance `k` and the position.
//! - **Outliers.** A fix farther than [`GATE`] standard deviations (of
//!   the estimate and the fix together) is left out and counted; after
//!   [`GATE_FIXES`] such fixes in a row (fixes and velocities counted
//!   apart) the estimate, not the sensor, is taken to be wrong, and the
//!   next one is believed whole.
//! - **Health** ([`PositionHealth`]): whether fixes arrive, from the age of
//!   the last one taken: fixed, stale after `[autopilot] fix-stale`, lost
//!   after `fix-lost`; dead reckoning alone without a position sensor.
//!
//! Nothing here allocates after [`Plane::new`] (the matrices are on the
//! stack).

use anguilla_ipc::PositionHealth;
use anguilla_protocol::time::Nanos;
use nalgebra::{Matrix2, SMatrix, SVector};

/// Periods of past positions kept for a late fix (at 160 Hz, 6.4 s).
pub const HISTORY: usize = 1024;
/// The fraction of the speed by which the model's velocity through the
/// water is wrong from moment to moment (its standard deviation,
/// correlated over [`SPEED_CORRELATION`]); what lasts is `k`'s.
pub const SPEED_ERROR: f64 = 0.1;
/// How long the model's fast speed error lasts (s).
pub const SPEED_CORRELATION: f64 = 1.0;
/// The current's standard deviation before any fix (m/s, per axis): the
/// currents a robot of this size swims in.
pub const CURRENT_SIGMA: f64 = 0.1;
/// How fast the current may change (m/s per √s, a random walk): 0.05 m/s
/// in 100 s, as the robot swims through eddies and a channel's shear.
/// Slower, a current learnt wrong (in a sharp turn, where the model is
/// worst) is unlearnt over minutes: on the built-in robot's path
/// benchmark, 0.002 left it 0.024 m/s off after 60 s where 0.005 leaves
/// 0.004 (docs/autopilot.md, "Following a path").
pub const CURRENT_WALK: f64 = 0.005;
/// The standard deviation of the model's lasting speed error `k` before
/// any fix (a fraction of the speed).
pub const SCALE_SIGMA: f64 = 0.1;
/// How fast `k` may change (per √s, a random walk): 0.01 in 100 s, as
/// the gait or the body's trim changes.
pub const SCALE_WALK: f64 = 0.001;
/// Standard deviations beyond which a fix is an outlier.
pub const GATE: f64 = 5.0;
/// Outlying fixes in a row after which the next one is believed whole.
pub const GATE_FIXES: u32 = 3;

/// The states: x, y (m), the current's x, y (m/s), `k`.
type Cov = SMatrix<f64, 5, 5>;
type State = SVector<f64, 5>;
const CX: usize = 2;
const CY: usize = 3;
const K: usize = 4;

/// The transition of `t` seconds (negative: back) in which the model's
/// velocity moved the nose by `d` (m, world; before the scale).
fn transition(t: f64, d: (f64, f64)) -> Cov {
    let mut f = Cov::identity();
    f[(0, CX)] = t;
    f[(1, CY)] = t;
    f[(0, K)] = d.0;
    f[(1, K)] = d.1;
    f
}

/// The covariance moved `t` seconds on (negative: back), the model's
/// velocity moving the nose by `d` meanwhile, without process noise.
fn shifted(p: &Cov, t: f64, d: (f64, f64)) -> Cov {
    let f = transition(t, d);
    f * p * f.transpose()
}

/// One period kept: its time, the position, the model's velocity through
/// the water (unscaled), and the model's displacement since the start
/// (its velocity integrated, unscaled).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Kept {
    t: Nanos,
    x: f64,
    y: f64,
    vx: f64,
    vy: f64,
    dx: f64,
    dy: f64,
}

const ORIGIN: Kept = Kept {
    t: Nanos::ZERO,
    x: 0.0,
    y: 0.0,
    vx: 0.0,
    vy: 0.0,
    dx: 0.0,
    dy: 0.0,
};

/// When a fix is stale and when lost (s since the last one taken).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixTimes {
    /// Older than this: stale.
    pub stale: f64,
    /// Older than this: lost.
    pub lost: f64,
}

/// The position, current and speed-error estimate.
#[derive(Debug, Clone)]
pub struct Plane {
    x: f64,
    y: f64,
    cx: f64,
    cy: f64,
    k: f64,
    /// The model's displacement since the start (m, unscaled).
    dx: f64,
    dy: f64,
    cov: Cov,
    /// The last [`HISTORY`] periods, a ring.
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

/// The covariance before any fix: the position known (the origin), the
/// current and `k` not.
fn initial() -> Cov {
    Cov::from_diagonal(&State::new(
        0.0,
        0.0,
        CURRENT_SIGMA * CURRENT_SIGMA,
        CURRENT_SIGMA * CURRENT_SIGMA,
        SCALE_SIGMA * SCALE_SIGMA,
    ))
}

impl Plane {
    /// At the origin, certain of it, the current and the model's speed
    /// error unknown; `times` when a position sensor gives fixes.
    pub fn new(times: Option<FixTimes>) -> Self {
        Self {
            x: 0.0,
            y: 0.0,
            cx: 0.0,
            cy: 0.0,
            k: 0.0,
            dx: 0.0,
            dy: 0.0,
            cov: initial(),
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

    /// One period of `dt` s ending at `now`, at the model's world
    /// velocity through the water `vx`, `vy` (m/s, before the estimated
    /// scale); non-finite velocities count as 0.
    pub fn propagate(&mut self, now: Nanos, vx: f64, vy: f64, dt: f64) {
        let f = |v: f64| if v.is_finite() { v } else { 0.0 };
        let (vx, vy, dt) = (f(vx), f(vy), f(dt).max(0.0));
        let s = 1.0 + self.k;
        self.x += (s * vx + self.cx) * dt;
        self.y += (s * vy + self.cy) * dt;
        self.dx += vx * dt;
        self.dy += vy * dt;
        let speed_error = SPEED_ERROR * vx.hypot(vy);
        let mut c = shifted(&self.cov, dt, (vx * dt, vy * dt));
        let white = speed_error * speed_error * SPEED_CORRELATION * dt;
        c[(0, 0)] += white;
        c[(1, 1)] += white;
        c[(CX, CX)] += CURRENT_WALK * CURRENT_WALK * dt;
        c[(CY, CY)] += CURRENT_WALK * CURRENT_WALK * dt;
        c[(K, K)] += SCALE_WALK * SCALE_WALK * dt;
        self.cov = c;
        self.now = now;
        self.history[self.next] = Kept {
            t: now,
            x: self.x,
            y: self.y,
            vx,
            vy,
            dx: self.dx,
            dy: self.dy,
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
            dx: self.dx,
            dy: self.dy,
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

    /// How long ago `then` was (s), and the model's displacement since
    /// (m, unscaled).
    fn since(&self, then: &Kept) -> (f64, (f64, f64)) {
        let ago = self.now.saturating_sub(then.t).as_nanos() as f64 * 1e-9;
        (ago, (self.dx - then.dx, self.dy - then.dy))
    }

    /// The Kalman update at `then` of an innovation `e` observed through
    /// `h` with noise `r` (per axis), from the covariance `p` of that
    /// time; returns the covariance of that time after it. Moves the
    /// estimate, the present and the kept past.
    fn update(
        &mut self,
        then: &Kept,
        p: &Cov,
        h: &SMatrix<f64, 2, 5>,
        e: (f64, f64),
        r: f64,
    ) -> Cov {
        let s = h * p * h.transpose() + Matrix2::identity() * r;
        let Some(si) = s.try_inverse() else {
            return *p;
        };
        let gain = p * h.transpose() * si;
        let d = gain * nalgebra::Vector2::new(e.0, e.1);
        if !(d.iter().all(|v| v.is_finite()) && gain.iter().all(|v| v.is_finite())) {
            return *p;
        }
        self.shift(then, d[0], d[1], d[CX], d[CY], d[K]);
        let ikh = Cov::identity() - gain * h;
        // Joseph's form: symmetric and positive whatever the rounding.
        ikh * p * ikh.transpose() + gain * (Matrix2::identity() * r) * gain.transpose()
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
        let r = sigma * sigma;
        if !r.is_finite() {
            // A σ whose square overflows (a forged 1e200) would make the
            // estimate NaN for good.
            self.rejected += 1;
            return false;
        }
        let (ago, d) = self.since(&then);
        let p = shifted(&self.cov, -ago, (-d.0, -d.1));
        let spread = 0.5 * (p[(0, 0)] + p[(1, 1)]);
        let outlier = ex.hypot(ey) > GATE * (spread + r).sqrt();
        if self.fixes == 0 {
            // The first fix: where the estimate started (its origin) is
            // where the sensor's frame says the robot was then, and the
            // drift before it is not the current's; taken whole, the
            // current and the speed error untouched.
            self.shift(&then, ex, ey, 0.0, 0.0, 0.0);
            let mut c = p;
            for i in [0, 1] {
                for j in 0..5 {
                    c[(i, j)] = 0.0;
                    c[(j, i)] = 0.0;
                }
                c[(i, i)] = r;
            }
            return self.taken_fix(at, ago, d, &c);
        }
        let Some(whole) = Self::gate(&mut self.gated_fix, &mut self.rejected, outlier) else {
            return false;
        };
        let after = if whole {
            // The estimate was wrong: the fix is believed whole, the
            // current is unknown again (and so is its drift since); the
            // speed error stays what it was learnt.
            let (cx, cy) = (self.cx, self.cy);
            self.shift(&then, ex, ey, -cx, -cy, 0.0);
            let mut c = initial();
            c[(0, 0)] = r;
            c[(1, 1)] = r;
            c[(K, K)] = p[(K, K)];
            c
        } else {
            let mut h = SMatrix::<f64, 2, 5>::zeros();
            h[(0, 0)] = 1.0;
            h[(1, 1)] = 1.0;
            self.update(&then, &p, &h, (ex, ey), r)
        };
        self.taken_fix(at, ago, d, &after)
    }

    /// A fix measured at `at`, `ago` s back, the model's displacement `d`
    /// since, taken: `after` its time's covariance.
    fn taken_fix(&mut self, at: Nanos, ago: f64, d: (f64, f64), after: &Cov) -> bool {
        self.cov = shifted(after, ago, d);
        self.fixes = self.fixes.saturating_add(1);
        self.last_fix = Some(self.last_fix.map_or(at, |l| l.max(at)));
        true
    }

    /// Takes a velocity over ground measured at `at`: `vx`, `vy` (m/s,
    /// local frame) with standard deviation `sigma` (m/s per axis, > 0).
    /// Less the model's scaled velocity through the water then, it
    /// observes the current. Returns whether it was taken (as
    /// [`Plane::fix`]).
    pub fn velocity(&mut self, at: Nanos, vx: f64, vy: f64, sigma: f64) -> bool {
        if !(vx.is_finite() && vy.is_finite() && sigma.is_finite() && sigma > 0.0) {
            self.rejected += 1;
            return false;
        }
        let Some(then) = self.at(at) else {
            self.rejected += 1;
            return false;
        };
        let s = 1.0 + self.k;
        let (ex, ey) = (vx - s * then.vx - self.cx, vy - s * then.vy - self.cy);
        let (ago, d) = self.since(&then);
        let p = shifted(&self.cov, -ago, (-d.0, -d.1));
        let mut h = SMatrix::<f64, 2, 5>::zeros();
        h[(0, CX)] = 1.0;
        h[(1, CY)] = 1.0;
        h[(0, K)] = then.vx;
        h[(1, K)] = then.vy;
        // What it observes is the current plus the model's speed, whose
        // fast error adds to the sensor's.
        let model = SPEED_ERROR * then.vx.hypot(then.vy);
        let r = sigma * sigma + model * model;
        if !r.is_finite() {
            self.rejected += 1;
            return false;
        }
        let hph = h * p * h.transpose();
        let spread = 0.5 * (hph[(0, 0)] + hph[(1, 1)]);
        let outlier = ex.hypot(ey) > GATE * (spread + r).sqrt();
        let Some(whole) = Self::gate(&mut self.gated_velocity, &mut self.rejected, outlier) else {
            return false;
        };
        let after = if whole {
            // The current was wrong: the velocity's is believed whole.
            self.shift(&then, 0.0, 0.0, ex, ey, 0.0);
            let mut c = p;
            for i in [CX, CY] {
                for j in 0..5 {
                    c[(i, j)] = 0.0;
                    c[(j, i)] = 0.0;
                }
                c[(i, i)] = r;
            }
            c
        } else {
            self.update(&then, &p, &h, (ex, ey), r)
        };
        self.cov = shifted(&after, ago, d);
        self.velocities = self.velocities.saturating_add(1);
        true
    }

    /// Moves the estimate, the present and the kept past by a correction
    /// at `then`: `dx`, `dy` of position, `dcx`, `dcy` of current and `dk`
    /// of the speed error, the whole track (before `then` too) moved as
    /// the model has it: by the current over the time since `then`, and by
    /// `dk` times the model's displacement since.
    fn shift(&mut self, then: &Kept, dx: f64, dy: f64, dcx: f64, dcy: f64, dk: f64) {
        let since = |t: Nanos| (t.as_nanos() as f64 - then.t.as_nanos() as f64) * 1e-9;
        self.cx += dcx;
        self.cy += dcy;
        self.k += dk;
        let t = since(self.now);
        self.x += dx + dcx * t + dk * (self.dx - then.dx);
        self.y += dy + dcy * t + dk * (self.dy - then.dy);
        for h in self.history.iter_mut() {
            let t = since(h.t);
            h.x += dx + dcx * t + dk * (h.dx - then.dx);
            h.y += dy + dcy * t + dk * (h.dy - then.dy);
        }
    }

    /// x, y (m).
    pub fn position(&self) -> (f64, f64) {
        (self.x, self.y)
    }

    /// The position's standard deviation (m, per axis: the root mean
    /// square of x's and y's).
    pub fn sigma(&self) -> f64 {
        (0.5 * (self.cov[(0, 0)] + self.cov[(1, 1)]))
            .max(0.0)
            .sqrt()
    }

    /// The water's estimated velocity over ground, x and y (m/s).
    pub fn current(&self) -> (f64, f64) {
        (self.cx, self.cy)
    }

    /// The current's standard deviation (m/s, per axis, as
    /// [`Plane::sigma`]).
    pub fn current_sigma(&self) -> f64 {
        (0.5 * (self.cov[(CX, CX)] + self.cov[(CY, CY)]))
            .max(0.0)
            .sqrt()
    }

    /// The factor by which the model's speed through the water is
    /// multiplied, `1 + k` (1 until fixes or velocities tell).
    pub fn speed_scale(&self) -> f64 {
        1.0 + self.k
    }

    /// The standard deviation of [`Plane::speed_scale`].
    pub fn speed_scale_sigma(&self) -> f64 {
        self.cov[(K, K)].max(0.0).sqrt()
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

    /// With a position sensor, placed at the origin by a first fix (σ
    /// 1 cm).
    fn placed() -> Plane {
        let mut p = Plane::new(Some(TIMES));
        assert!(p.fix(ms(0), 0.0, 0.0, 0.01));
        p
    }

    /// The first fix places the estimate in the sensor's frame: taken
    /// whole however far (the drift before the estimate began, or
    /// another origin), the current and the speed error untouched; the
    /// next one is gated.
    #[test]
    fn the_first_fix_places_the_estimate() {
        let mut p = Plane::new(Some(TIMES));
        for k in 1..=200 {
            p.propagate(ms(10 * k), 0.5, 0.0, DT);
        }
        assert!(p.fix(ms(2000), 40.0, -3.0, 0.2));
        assert!((p.position().0 - 40.0).abs() < 1e-9 && (p.position().1 + 3.0).abs() < 1e-9);
        assert_eq!((p.current(), p.speed_scale()), ((0.0, 0.0), 1.0));
        assert!((p.sigma() - 0.2).abs() < 1e-9, "{}", p.sigma());
        assert!((p.current_sigma() - CURRENT_SIGMA).abs() < 1e-3);
        assert!(!p.fix(ms(2000), 0.0, 0.0, 0.2), "the next is gated");
        assert_eq!((p.fixes(), p.rejected()), (1, 1));
    }

    #[test]
    fn dead_reckoning_drifts_with_its_uncertainty_and_a_fix_pulls_it_back() {
        let mut p = placed();
        // The model says 0.5 m/s along x; the truth is 0.4 m/s (a current
        // against it). 20 s.
        for k in 1..=2000 {
            p.propagate(ms(10 * k), 0.5, 0.0, DT);
        }
        let (x, _) = p.position();
        assert!((x - 10.0).abs() < 1e-9, "{x}");
        // The unknown current's 0.1 m/s for 20 s (2 m a side) and, along
        // x, the model's unknown speed error's 10 % of 10 m (1 m): the
        // root mean square of √(4 + 1) and √4, and a little more.
        let sigma = p.sigma();
        let expected = (0.5f64 * (5.0 + 4.0)).sqrt();
        assert!((expected..expected + 0.05).contains(&sigma), "{sigma}");
        // A fix of the truth (8 m) measured now, σ 0.5 m: 2 m off is
        // within the gate, and pulls by P / (P + R), P about 5 m².
        assert!(p.fix(ms(20_000), 8.0, 0.0, 0.5));
        let (x, _) = p.position();
        let pulled = 10.0 - x;
        assert!(
            (2.0 * 5.0 / 5.25..2.0 * 5.3 / 5.55).contains(&pulled),
            "{x}"
        );
        assert!(p.sigma() < 0.5, "{}", p.sigma());
        // The position was behind all along: the current is against x.
        assert!(p.current().0 < -0.05, "{:?}", p.current());
        assert_eq!((p.fixes(), p.rejected()), (2, 0));
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
        // Across the heading the current is known well; along it, as well
        // as the model's speed: swimming straight, a speed error and a
        // current along the heading move the robot alike.
        assert!(p.current_sigma() < 0.03, "{}", p.current_sigma());
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

    /// The model's speed 5 % slow, a current of (−0.05, 0.08) m/s: a
    /// straight swim along x cannot tell the speed error from the
    /// current along x, and takes most of it for current; a turn onto y
    /// halfway tells them apart: the current within 0.01 m/s and the
    /// speed's factor within 0.02 of 1.05.
    #[test]
    fn a_turn_tells_the_models_speed_error_from_the_current() {
        let (cx, cy, scale) = (-0.05, 0.08, 1.05);
        let run = |turn: bool| {
            let mut p = Plane::new(Some(TIMES));
            let mut noise = 0.61_f64;
            let mut next = || {
                noise = (noise * 9301.0 + 0.49297).fract();
                0.05 * (2.0 * noise - 1.0) * 1.7
            };
            let (mut tx, mut ty) = (0.0, 0.0);
            for k in 1..=6000u64 {
                let (vx, vy) = if turn && k > 3000 {
                    (0.0, 0.3)
                } else {
                    (0.3, 0.0)
                };
                tx += (scale * vx + cx) * DT;
                ty += (scale * vy + cy) * DT;
                p.propagate(ms(10 * k), vx, vy, DT);
                if k % 50 == 0 {
                    assert!(p.fix(ms(10 * k), tx + next(), ty + next(), 0.05));
                }
            }
            let (ex, ey) = p.current();
            (ex - cx, ey - cy, p.speed_scale())
        };
        let (ex, ey, s) = run(true);
        assert!(ex.abs() < 0.01 && ey.abs() < 0.01, "{ex} {ey}");
        eprintln!("turned: current off by ({ex}, {ey}), speed factor {s}");
        assert!((s - scale).abs() < 0.02, "{s}");
        // Straight: the speed error (0.015 m/s along x) split between
        // the two by their priors, not told apart; together they are
        // what moved the robot.
        let (ex, ey, s) = run(false);
        eprintln!("straight: current off by ({ex}, {ey}), speed factor {s}");
        assert!(ex > 0.005 && ey.abs() < 0.01, "{ex} {ey}");
        assert!((ex + (s - 1.0) * 0.3 - 0.015).abs() < 0.003, "{ex} {s}");
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

    /// A forged σ whose square overflows (finite, but 1e200) is refused
    /// and counted, for a fix and a velocity alike: the estimate stays
    /// finite and takes the next good one.
    #[test]
    fn a_sigma_too_large_to_square_is_refused() {
        let mut p = Plane::new(Some(TIMES));
        for k in 1..=100 {
            p.propagate(ms(10 * k), 0.3, 0.0, DT);
        }
        assert!(!p.fix(ms(1000), 0.3, 0.0, 1e200));
        assert!(!p.velocity(ms(1000), 0.3, 0.0, 1e200));
        assert_eq!((p.fixes(), p.velocities(), p.rejected()), (0, 0, 2));
        assert!(p.fix(ms(1000), 0.3, 0.0, 0.1));
        assert!(p.velocity(ms(1000), 0.3, 0.0, 0.01));
        let (x, y) = p.position();
        assert!(x.is_finite() && y.is_finite() && p.sigma().is_finite());
        assert!(p.current_sigma().is_finite() && p.speed_scale().is_finite());
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
        let mut p = placed();
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
        let mut p = placed();
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
