//! Heading and depth hold (docs/autopilot.md).
//!
//! The autopilot replaces the operator's turn curvature (K_c3) while a
//! heading is held, and the pitch curvature (K_c2) while a depth is held;
//! amplitude and frequency stay the operator's. Each period:
//!
//! - **heading**: a turn rate `r = Kψ e + Kψi ∫e` from the heading error `e`
//!   (wrapped to ±180°), at most `max-turn-rate`, integrated only while
//!   not saturated (anti-windup);
//! - **depth**: a dive rate `w = Kd e + Kdi ∫e` from the depth error, at most
//!   `U sin(max-dive-angle)`, flown at the pitch `θ = −asin(w / U)`: a
//!   ballasted body at the model's curvature for it plus `Kθ` times the
//!   pitch error, an unballasted one at the nose-down rate `q = Kθ (θ̂ − θ)`;
//! - **model-based feed-forward**: the model says how fast the body turns
//!   and pitches per unit curvature at speed `U` ([`Gains`], measured once at
//!   start-up by running the model itself on the configured gait), so the
//!   curvature is the wanted rate divided by `gain · U`, `U` being the
//!   model's predicted forward speed (low-passed over a second). The
//!   curvature then goes through the same trapezoidal profile as an
//!   operator's, within `gait.max-turn` and `gait.max-pitch`.

use anguilla_ipc::{HOLD_DEPTH_TOLERANCE, HOLD_HEADING_TOLERANCE, Hold, HoldState, SURFACE_DEPTH};
use anguilla_model::{
    GaitParams, HeadState, Model, ModelError, ParametricGait, Workspace, step_dyn as step,
};
use nalgebra::Vector3;

use crate::config::Config;
use crate::nav::{Estimate, Prediction};

/// The speed below which the feed-forward stops growing (m/s): a body
/// barely swimming cannot turn, and asking for more curvature is useless.
pub const MIN_SPEED: f64 = 0.05;
/// The largest pitch curvature the ballasted body's depth law asks for
/// (1/m, within `gait.max-pitch`): beyond about this, the body's answer is
/// no longer the table's (at full amplitude and 1 Hz, 1/m dives slower
/// than 0.5 and rolls the head by 60°).
pub const DIVE_LAW_CURVATURE: f64 = 0.5;
/// The curvature of the calibration runs (1/m).
pub const CALIBRATION_CURVATURE: f64 = 0.5;
/// Time constant of the speed's low-pass (s).
pub const SPEED_TAU: f64 = 1.0;

/// How the body answers its curvatures, per unit curvature and unit speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains {
    /// Turn rate (rad/s, left positive) per operator turn curvature (1/m)
    /// per forward speed (m/s).
    pub turn: f64,
    /// Nose-down pitch rate (rad/s) per pitch curvature (1/m) per forward
    /// speed (m/s).
    pub pitch: f64,
    /// A ballasted body only: the nose-down pitch (rad) it settles at per
    /// pitch curvature (1/m) — its weight rights it, so a curvature holds
    /// an angle instead of turning it on.
    pub pitch_angle: Option<f64>,
    /// The calibration's forward speed (m/s).
    pub speed: f64,
    /// A ballasted body only: how fast it dives per pitch curvature over
    /// the gaits it swims ([`DiveTable`]).
    pub dive: Option<DiveTable>,
}

/// Amplitudes of the dive table's rows.
pub const DIVE_AMPLITUDES: [f64; 5] = [0.2, 0.4, 0.6, 0.8, 1.0];
/// Frequencies (Hz) of the dive table's columns, those up to
/// `gait.max-frequency` measured (the others repeat the last).
pub const DIVE_FREQUENCIES: [f64; 4] = [0.5, 1.0, 1.5, 2.0];
/// The pitch curvature of the dive table's runs (1/m): small, where the
/// answer is still about linear.
pub const DIVE_CURVATURE: f64 = 0.2;

/// The pitch authority of a ballasted body: its steady dive rate (m/s,
/// positive down) per pitch curvature (1/m, positive diving), measured by
/// running the model on a grid of amplitudes and frequencies.
///
/// It is not one number times the speed: the body's weight rights it
/// against the curvature's pitching moment, which grows with the square of
/// the beat's speed, so a fast gait dives by pitching nose down while a
/// slow one barely pitches, and its bent body's thrust then drives it the
/// other way (the built-in robot at 1 Hz: +0.47 m/s per 1/m at full
/// amplitude, −0.04 at 0.6, −0.03 at 0.3; at 0.5 Hz negative at every
/// amplitude). A law with one fixed sign climbed through the surface at
/// amplitude 0.3 (issue 46).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiveTable {
    /// `rate[amplitude][frequency]` (m/s per 1/m) at [`DIVE_AMPLITUDES`]
    /// and [`DIVE_FREQUENCIES`].
    pub rate: [[f64; DIVE_FREQUENCIES.len()]; DIVE_AMPLITUDES.len()],
}

impl DiveTable {
    /// The dive rate per pitch curvature (m/s per 1/m) at `amplitude`
    /// (0–1) and `frequency` (Hz): bilinear between the grid's points,
    /// falling linearly to 0 below the lowest amplitude, the nearest
    /// column beyond the frequencies.
    pub fn at(&self, amplitude: f64, frequency: f64) -> f64 {
        let (a, fa) = bracket(&DIVE_AMPLITUDES, amplitude);
        let (f, ff) = bracket(&DIVE_FREQUENCIES, frequency);
        let row = |i: usize| self.rate[i][f] * (1.0 - ff) + self.rate[i][f + 1] * ff;
        let r = row(a) * (1.0 - fa) + row(a + 1) * fa;
        if amplitude < DIVE_AMPLITUDES[0] {
            row(0) * (amplitude / DIVE_AMPLITUDES[0]).max(0.0)
        } else {
            r
        }
    }
}

/// The interval of sorted `grid` holding `x` and the fraction into it
/// (clamped to the ends).
fn bracket(grid: &[f64], x: f64) -> (usize, f64) {
    let n = grid.len();
    let i = grid[..n - 1]
        .iter()
        .rposition(|&g| g <= x)
        .unwrap_or(0)
        .min(n - 2);
    let t = ((x - grid[i]) / (grid[i + 1] - grid[i])).clamp(0.0, 1.0);
    (i, t)
}

/// How far about the gait swum [`authority_uncertain`] looks: amplitude
/// (fraction) and frequency (Hz).
pub const AUTHORITY_NEIGHBOURHOOD: [f64; 2] = [0.1, 0.25];

/// Whether the dive table's authority changes sign within
/// [`AUTHORITY_NEIGHBOURHOOD`] of `amplitude` and `frequency`: there the
/// table cannot say which way a curvature drives the body (the built-in
/// robot at amplitude 0.6, 1 Hz: −0.030 m/s per 1/m, +0.032 at 0.8), and
/// a body that swims a little otherwise than the model goes the wrong way.
pub fn authority_uncertain(table: &DiveTable, amplitude: f64, frequency: f64) -> bool {
    let [da, df] = AUTHORITY_NEIGHBOURHOOD;
    let a = table.at(amplitude, frequency);
    [
        (amplitude - da, frequency),
        (amplitude + da, frequency),
        (amplitude, frequency - df),
        (amplitude, frequency + df),
    ]
    .into_iter()
    .any(|(x, f)| table.at(x.clamp(0.0, 1.0), f.max(0.0)) * a <= 0.0)
}

/// The curvature of the ballasted body's static pitch calibration (1/m):
/// small, where its answer is still linear.
pub const PITCH_ANGLE_CURVATURE: f64 = 0.25;

/// Runs the model on `cfg`'s gait (full amplitude, at 1 Hz or the highest
/// frequency allowed): four periods straight to reach speed, then a small
/// turn, or pitch, curvature; one period for it to take hold, and the
/// body's rates averaged over the next (whole periods, so the undulation
/// cancels). The rates are taken in the head's own axes: the model rolls
/// under a pitch curvature (the paper's spiral), and the gain wanted is the
/// one about the body's axes, whatever its roll.
pub fn calibrate(cfg: &Config, model: &Model) -> Result<Gains, ModelError> {
    let f = cfg.gait.max_frequency.min(1.0);
    let k = CALIBRATION_CURVATURE;
    // Mean body rates, forward speed, body elevation (nose up) and dive
    // rate over `measure` periods after `settle` periods of the
    // curvatures, at `amplitude` and `frequency`.
    let run_at = |amplitude: f64,
                  frequency: f64,
                  kc3: f64,
                  kc2: f64,
                  settle: usize,
                  measure: usize|
     -> Result<(Vector3<f64>, f64, f64, f64), ModelError> {
        let period = 1.0 / frequency;
        let poly = cfg.gait.amplitude_polynomial;
        let mut params = GaitParams {
            wavelength: cfg.gait.wavelength,
            period,
            amplitude: [
                poly[0] * amplitude,
                poly[1] * amplitude,
                poly[2] * amplitude,
            ],
            phase: 0.0,
            kc3: 0.0,
            kc2: 0.0,
        };
        let mut gait = ParametricGait::new(params, 0.05)?;
        let mut ws = Workspace::new(model);
        let mut head = HeadState::launch(0.0);
        let per = (period / model.dt()).round() as usize;
        for _ in 0..4 * per {
            step(model, &mut ws, &mut gait, &mut head)?;
        }
        params.kc3 = kc3;
        params.kc2 = kc2;
        gait.set_target(&params)?;
        for _ in 0..settle * per {
            step(model, &mut ws, &mut gait, &mut head)?;
        }
        let (mut rates, mut speed, mut elevation) = (Vector3::zeros(), 0.0, 0.0);
        let n = measure * per;
        let (z0, t0) = (head.position.z, head.t);
        for _ in 0..n {
            let r = step(model, &mut ws, &mut gait, &mut head)?;
            let p = Prediction::of(&head, ws.shape());
            rates += p.rates;
            speed += r.forward_speed;
            let f = head.orientation * anguilla_model::forward_axes(p.forward);
            elevation += f.z.atan2(f.x.hypot(f.y));
        }
        let dive = -(head.position.z - z0) / (head.t - t0).max(model.dt());
        let n = n as f64;
        Ok((rates / n, speed / n, elevation / n, dive))
    };
    let run = |kc3: f64, kc2: f64, settle: usize, measure: usize| {
        run_at(1.0, f, kc3, kc2, settle, measure)
    };
    // The operator's turn is positive left; the gait's K_c3 is its
    // opposite (control.rs). Sensor axes: z up (a left turn is +z), y left
    // (nose down is +y).
    let (turn, u_turn, _, _) = run(-k, 0.0, 1, 1)?;
    let (pitch, u_pitch, _, _) = run(0.0, k, 1, 1)?;
    let floor = |g: f64| if g.abs() < 1e-3 { 1e-3 } else { g };
    let pitch_angle = if cfg.model.ballast > 0.0 {
        let k = PITCH_ANGLE_CURVATURE;
        let (_, _, elevation, _) = run(0.0, k, 4, 2)?;
        Some(floor(-elevation / k))
    } else {
        None
    };
    // The dive table: straight to speed, then the pitch curvature, its
    // dive rate over the third period of it.
    let dive = if cfg.model.ballast > 0.0 {
        let mut rate = [[0.0; DIVE_FREQUENCIES.len()]; DIVE_AMPLITUDES.len()];
        let top = DIVE_FREQUENCIES
            .iter()
            .rposition(|&f| f <= cfg.gait.max_frequency)
            .unwrap_or(0);
        for (i, &a) in DIVE_AMPLITUDES.iter().enumerate() {
            for (j, &f) in DIVE_FREQUENCIES.iter().enumerate() {
                rate[i][j] = if j <= top {
                    // At least 4 s to settle, 2 s measured (whole
                    // periods): the ballasted pitch's swing is slower
                    // than a fast gait's periods.
                    let periods = |secs: f64| (secs * f).ceil() as usize;
                    run_at(a, f, 0.0, DIVE_CURVATURE, periods(4.0), periods(2.0))?.3
                        / DIVE_CURVATURE
                } else {
                    rate[i][top]
                };
            }
        }
        Some(DiveTable { rate })
    } else {
        None
    };
    Ok(Gains {
        turn: floor(turn.z / (k * u_turn.max(MIN_SPEED))),
        pitch: floor(pitch.y / (k * u_pitch.max(MIN_SPEED))),
        pitch_angle,
        speed: u_turn,
        dive,
    })
}

/// An angle wrapped into `(−π, π]`.
pub fn wrap(a: f64) -> f64 {
    let w = a.rem_euclid(core::f64::consts::TAU);
    if w > core::f64::consts::PI {
        w - core::f64::consts::TAU
    } else {
        w
    }
}

/// A hold's settle time (s): beyond its tolerance, an error that has not
/// shrunk by [`HEADING_PROGRESS`] / [`DEPTH_PROGRESS`] for this long is
/// not converging. The heading's: a 180° turn at the autopilot's 30°/s
/// is 6 s, at a slow gait's smaller rate longer.
pub const HEADING_SETTLE: f64 = 10.0;
/// The depth hold's settle time (s): the slow gaits' dive authority is
/// 0.02–0.06 m/s per 1/m, a few cm/s at the law's curvature limit.
pub const DEPTH_SETTLE: f64 = 15.0;
/// Progress that counts as converging (deg) within [`HEADING_SETTLE`].
pub const HEADING_PROGRESS: f64 = 2.0;
/// Progress that counts as converging (m) within [`DEPTH_SETTLE`].
pub const DEPTH_PROGRESS: f64 = 0.05;
/// The smallest dive rate (m/s) the depth law's curvature limit must give
/// at the gait swum for its authority to count.
pub const MIN_DIVE_RATE: f64 = 0.005;

/// The judge of one held quantity: its state ([`HoldState`]) from the
/// error's magnitude over time.
#[derive(Debug, Clone, Copy)]
struct Judge {
    state: HoldState,
    /// The target judged (a new one starts over).
    target: f64,
    /// The smallest error beyond the tolerance since the last progress.
    best: f64,
    /// Time since the error last shrank by the progress margin (s).
    since: f64,
    /// Time at the command's limit since then (s).
    saturated: f64,
}

impl Judge {
    const NEW: Judge = Judge {
        state: HoldState::Off,
        target: f64::NAN,
        best: f64::INFINITY,
        since: 0.0,
        saturated: 0.0,
    };

    /// One period of `dt` s: `held` the target (none: off), `err` the
    /// error's magnitude, within `tol` holding; `progress` in `settle` s
    /// converging; `why` the reason a stalled hold cannot (none: not
    /// converging), `saturated` whether the command is at its limit.
    #[allow(clippy::too_many_arguments)] // two call sites, one per axis
    fn update(
        &mut self,
        dt: f64,
        held: Option<f64>,
        swimming: bool,
        err: f64,
        tol: f64,
        progress: f64,
        settle: f64,
        saturated: bool,
        why: impl Fn(bool) -> Option<HoldState>,
    ) -> HoldState {
        let Some(target) = held else {
            *self = Self::NEW;
            return self.state;
        };
        if target != self.target || !swimming {
            *self = Self {
                target,
                ..Self::NEW
            };
        }
        if !swimming {
            self.state = HoldState::Waiting;
            return self.state;
        }
        if err <= tol {
            self.best = tol;
            self.since = 0.0;
            self.saturated = 0.0;
            self.state = HoldState::Holding;
            return self.state;
        }
        if err < self.best - progress {
            self.best = err;
            self.since = 0.0;
            self.saturated = 0.0;
        } else {
            self.since += dt;
            if saturated {
                self.saturated += dt;
            }
        }
        let stalled = self.since >= settle;
        // Most of the settle time at the limit: the limit is why.
        let at_limit = self.saturated >= 0.8 * settle;
        self.state = match why(stalled) {
            Some(cannot) => cannot,
            None if stalled && at_limit => HoldState::Limit,
            None if stalled => HoldState::NotConverging,
            None => HoldState::Converging,
        };
        self.state
    }
}

/// The autopilot's state: its integrators and the speed it believes.
#[derive(Debug, Clone)]
pub struct Autopilot {
    gains: Gains,
    heading_gain: f64,
    heading_integral: f64,
    max_rate: f64,
    depth_gain: f64,
    depth_integral: f64,
    max_dive: f64,
    pitch_gain: f64,
    max_turn: f64,
    max_pitch: f64,
    curvature_rate: f64,
    curvature_accel: f64,
    speed: f64,
    heading_sum: f64,
    depth_sum: f64,
    authority: f64,
    /// This period's commands were at their limit: heading, depth.
    saturated: [bool; 2],
    /// The depth law wanted to climb (a negative dive rate) this period.
    climbing: bool,
    /// The dive table's authority at the gait swum is too small or of an
    /// uncertain sign.
    no_authority: bool,
    /// The judges of the heading and the depth hold.
    judges: [Judge; 2],
}

impl Autopilot {
    /// The autopilot of `cfg` with the model's `gains`.
    pub fn new(cfg: &Config, gains: Gains) -> Self {
        let a = &cfg.autopilot;
        Self {
            gains,
            heading_gain: a.heading_gain,
            heading_integral: a.heading_integral,
            max_rate: a.max_turn_rate.to_radians(),
            depth_gain: a.depth_gain,
            depth_integral: a.depth_integral,
            max_dive: a.max_dive_angle.to_radians(),
            pitch_gain: a.pitch_gain,
            max_turn: cfg.gait.max_turn,
            max_pitch: cfg.gait.max_pitch,
            curvature_rate: cfg.gait.curvature_rate,
            curvature_accel: cfg.gait.curvature_accel,
            speed: 0.0,
            heading_sum: 0.0,
            depth_sum: 0.0,
            authority: 0.0,
            saturated: [false; 2],
            climbing: false,
            no_authority: false,
            judges: [Judge::NEW; 2],
        }
    }

    /// The hold states of heading and depth, as last judged.
    pub fn states(&self) -> [HoldState; 2] {
        [self.judges[0].state, self.judges[1].state]
    }

    /// One period of `dt` s after [`Autopilot::steer`]: how each held
    /// quantity is doing ([`HoldState`]), from the estimate `est` and what
    /// the law did this period; `swimming` whether the swim is on (a hold
    /// set at rest waits for it).
    pub fn judge(
        &mut self,
        dt: f64,
        hold: &Hold,
        est: &Estimate,
        swimming: bool,
    ) -> [HoldState; 2] {
        let heading_err = hold.heading.map_or(0.0, |t| {
            wrap(t.to_radians() - est.heading).abs().to_degrees()
        });
        let [sat_heading, sat_depth] = self.saturated;
        self.judges[0].update(
            dt,
            hold.heading,
            swimming,
            heading_err,
            HOLD_HEADING_TOLERANCE,
            HEADING_PROGRESS,
            HEADING_SETTLE,
            sat_heading,
            |_| None,
        );
        let depth_err = hold.depth.map_or(0.0, |t| (t - est.depth).abs());
        let surfaced = est.depth < SURFACE_DEPTH;
        let (climbing, no_authority) = (self.climbing, self.no_authority);
        self.judges[1].update(
            dt,
            hold.depth,
            swimming,
            depth_err,
            HOLD_DEPTH_TOLERANCE,
            DEPTH_PROGRESS,
            DEPTH_SETTLE,
            sat_depth,
            |stalled| {
                if surfaced && (climbing || stalled) {
                    Some(HoldState::Surface)
                } else if stalled && no_authority {
                    Some(HoldState::Authority)
                } else {
                    None
                }
            },
        );
        self.states()
    }

    /// `∫κ dt` (m⁻¹ s) while the curvature `k` ramps to zero along the
    /// gait's trapezoid (from rest: an S-curve, or with a cruise at the
    /// rate limit).
    fn stopping(&self, k: f64) -> f64 {
        let (v, a) = (self.curvature_rate, self.curvature_accel);
        let t = if k.abs() <= v * v / a {
            2.0 * (k.abs() / a).sqrt()
        } else {
            k.abs() / v + v / a
        };
        k * t / 2.0
    }

    /// The model's gains.
    pub fn gains(&self) -> Gains {
        self.gains
    }

    /// One period of `dt` s: the turn and pitch curvatures (operator
    /// units: turn positive left, pitch positive diving) for `hold`, from
    /// the estimate `est` and the model's predicted forward speed;
    /// `manual` is the operator's `[turn, pitch]`, kept unchanged while
    /// nothing is held.
    ///
    /// The wanted yaw rate `r` (about the vertical) and nose-down rate `q`
    /// (about the horizontal) are turned into the body's axes by the roll
    /// `φ` when both are held: `ω_y = q cos φ + r sin φ`,
    /// `ω_z = r cos φ − q sin φ`; a free axis keeps the operator's
    /// curvature.
    ///
    /// `gait` is the amplitude (0–1) and frequency (Hz) swum now: the
    /// ballasted body's depth law divides by the model's dive rate per
    /// curvature there ([`DiveTable`]).
    ///
    /// `turning` is the turn curvature the gait executes now: ramping it
    /// back to zero along its trapezoid still turns the body by
    /// `gain · U · ∫κ dt`, which the heading law counts as already done
    /// (the stopping distance), so the body does not overshoot by it.
    #[allow(clippy::too_many_arguments)] // one call site, the controller's
    pub fn steer(
        &mut self,
        dt: f64,
        hold: &Hold,
        est: &Estimate,
        predicted_speed: f64,
        manual: [f64; 2],
        turning: f64,
        gait: [f64; 2],
    ) -> [f64; 2] {
        self.speed += (predicted_speed - self.speed) * (1.0 - (-dt / SPEED_TAU).exp());
        if !hold.is_active() {
            self.heading_sum = 0.0;
            self.depth_sum = 0.0;
            return manual;
        }
        let u = self.speed.max(MIN_SPEED);
        let g = self.gains;
        let r = match hold.heading {
            None => {
                self.heading_sum = 0.0;
                None
            }
            Some(target) => {
                let e =
                    wrap(target.to_radians() - est.heading - g.turn * u * self.stopping(turning));
                let raw = self.heading_gain * e + self.heading_integral * self.heading_sum;
                // At most the rate the largest turn curvature gives at
                // this speed: beyond, the curvature saturates and the
                // integral would wind up unseen.
                let max_rate = self.max_rate.min(g.turn.abs() * u * self.max_turn);
                let r = raw.clamp(-max_rate, max_rate);
                if raw == r {
                    self.heading_sum += e * dt;
                }
                self.saturated[0] = raw != r;
                Some(r)
            }
        };
        let q = match hold.depth {
            None => {
                self.depth_sum = 0.0;
                None
            }
            Some(target) => {
                let e = target - est.depth;
                if let Some(table) = g.dive {
                    // A ballasted body: the dive rate wanted, from the
                    // model's authority at the gait swum now (its sign
                    // too), the integral frozen while either the rate or
                    // the curvature is at its limit.
                    let a = table.at(gait[0], gait[1]);
                    let k_max = self.max_pitch.min(DIVE_LAW_CURVATURE);
                    let w_max = (a.abs() * k_max).min(u * self.max_dive.sin());
                    let raw = self.depth_gain * e + self.depth_integral * self.depth_sum;
                    let w = raw.clamp(-w_max, w_max);
                    let k_raw = if a.abs() > f64::EPSILON { w / a } else { 0.0 };
                    let k = k_raw.clamp(-k_max, k_max);
                    if raw == w && k == k_raw {
                        self.depth_sum += e * dt;
                    }
                    self.saturated[1] = raw != w || k != k_raw;
                    self.climbing = w < 0.0;
                    self.no_authority =
                        w_max < MIN_DIVE_RATE || authority_uncertain(&table, gait[0], gait[1]);
                    let kc2 = k;
                    self.authority = w_max;
                    let turn = r.map_or(manual[0], |r| {
                        (r / (g.turn * u)).clamp(-self.max_turn, self.max_turn)
                    });
                    return [turn, kc2];
                }
                let w_max = u * self.max_dive.sin();
                let raw = self.depth_gain * e + self.depth_integral * self.depth_sum;
                let w = raw.clamp(-w_max, w_max);
                if raw == w {
                    self.depth_sum += e * dt;
                }
                self.saturated[1] = raw != w;
                self.climbing = w < 0.0;
                self.no_authority = false;
                // Nose down to descend: the pitch wanted (nose up) is
                // −asin(w / U).
                let theta = -(w / u).clamp(-1.0, 1.0).asin();
                // Unballasted: reached at a nose-down rate.
                Some((self.pitch_gain * (est.pitch - theta)).clamp(-self.max_rate, self.max_rate))
            }
        };
        // Turned by the roll only when both axes are held: with one free,
        // the roll's noise would leak into the operator's axis.
        let (wy, wz) = match (q, r) {
            (Some(q), Some(r)) => {
                let (sin, cos) = est.roll.sin_cos();
                (q * cos + r * sin, r * cos - q * sin)
            }
            (q, r) => (
                q.unwrap_or(manual[1] * g.pitch * u),
                r.unwrap_or(manual[0] * g.turn * u),
            ),
        };
        [
            (wz / (g.turn * u)).clamp(-self.max_turn, self.max_turn),
            (wy / (g.pitch * u)).clamp(-self.max_pitch, self.max_pitch),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn estimate(heading_deg: f64, depth: f64) -> Estimate {
        Estimate {
            attitude: UnitQuaternion::identity(),
            heading: heading_deg.to_radians(),
            pitch: 0.0,
            roll: 0.0,
            depth,
            depth_rate: 0.0,
        }
    }

    fn autopilot(pitch_angle: Option<f64>) -> Autopilot {
        let gains = Gains {
            turn: 1.0,
            pitch: 1.0,
            pitch_angle,
            speed: 0.5,
            dive: pitch_angle.map(|_| DiveTable {
                rate: [[0.3; DIVE_FREQUENCIES.len()]; DIVE_AMPLITUDES.len()],
            }),
        };
        let mut a = Autopilot::new(&Config::default(), gains);
        a.speed = 0.5;
        a
    }

    #[test]
    fn angles_wrap_the_short_way() {
        assert!((wrap(190f64.to_radians()).to_degrees() + 170.0).abs() < 1e-9);
        assert!((wrap(-190f64.to_radians()).to_degrees() - 170.0).abs() < 1e-9);
        assert!((wrap(core::f64::consts::PI) - core::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn nothing_held_leaves_the_operator_steering() {
        let mut a = autopilot(None);
        let out = a.steer(
            0.01,
            &Hold::MANUAL,
            &estimate(0.0, 1.0),
            0.5,
            [0.7, -0.3],
            0.2,
            [1.0, 1.0],
        );
        assert_eq!(out, [0.7, -0.3]);
    }

    #[test]
    fn a_heading_to_the_left_turns_left_and_a_saturated_loop_does_not_wind_up() {
        let mut a = autopilot(None);
        let hold = Hold {
            heading: Some(90.0),
            depth: None,
        };
        // 90° to the left: the largest rate, 30°/s, at 0.5 m/s and gain 1.
        let [turn, pitch] = a.steer(
            0.01,
            &hold,
            &estimate(0.0, 1.0),
            0.5,
            [0.0, 0.4],
            0.0,
            [1.0, 1.0],
        );
        let want = 30f64.to_radians() / 0.5;
        assert!((turn - want).abs() < 1e-3, "{turn} vs {want}");
        assert_eq!(pitch, 0.4, "the free axis stays the operator's");
        for _ in 0..1000 {
            a.steer(
                0.01,
                &hold,
                &estimate(0.0, 1.0),
                0.5,
                [0.0; 2],
                0.0,
                [1.0, 1.0],
            );
        }
        assert_eq!(a.heading_sum, 0.0, "saturated: no integration");
        // To the right, the other way.
        let right = Hold {
            heading: Some(350.0),
            depth: None,
        };
        let [turn, _] = a.steer(
            0.01,
            &right,
            &estimate(0.0, 1.0),
            0.5,
            [0.0; 2],
            0.0,
            [1.0, 1.0],
        );
        assert!(turn < 0.0);
        // Already turning left hard: the stopping distance covers a small
        // remaining error, so the law eases off (turns right) early.
        let near = Hold {
            heading: Some(5.0),
            depth: None,
        };
        let [turn, _] = a.steer(
            0.01,
            &near,
            &estimate(0.0, 1.0),
            0.5,
            [0.0; 2],
            1.0,
            [1.0, 1.0],
        );
        assert!(turn < 0.0, "eases off: {turn}");
    }

    /// A slow gait's body climbs under a diving curvature (its authority
    /// is negative): the law asks for the opposite curvature to dive, and
    /// an unreachable target does not wind the integral up.
    #[test]
    fn a_reversed_authority_reverses_the_curvature() {
        let mut a = autopilot(Some(0.6));
        let mut table = a.gains.dive.expect("a table");
        for row in &mut table.rate {
            row[0] = -0.1;
        }
        a.gains.dive = Some(table);
        let down = Hold {
            heading: None,
            depth: Some(2.0),
        };
        let [_, slow] = a.steer(
            0.01,
            &down,
            &estimate(0.0, 1.0),
            0.5,
            [0.0; 2],
            0.0,
            [0.5, 0.5],
        );
        assert!(slow < 0.0, "climbing curvature to dive: {slow}");
        let [_, fast] = a.steer(
            0.01,
            &down,
            &estimate(0.0, 1.0),
            0.5,
            [0.0; 2],
            0.0,
            [1.0, 1.0],
        );
        assert!(fast > 0.0, "{fast}");
        for _ in 0..1000 {
            a.steer(
                0.01,
                &down,
                &estimate(0.0, 1.0),
                0.5,
                [0.0; 2],
                0.0,
                [0.5, 0.5],
            );
        }
        assert_eq!(a.depth_sum, 0.0, "saturated: no integration");
    }

    #[test]
    fn the_dive_table_interpolates_and_falls_to_nothing_at_rest() {
        let mut rate = [[0.0; DIVE_FREQUENCIES.len()]; DIVE_AMPLITUDES.len()];
        for (i, row) in rate.iter_mut().enumerate() {
            for (j, r) in row.iter_mut().enumerate() {
                *r = i as f64 + 10.0 * j as f64;
            }
        }
        let t = DiveTable { rate };
        assert!((t.at(0.4, 1.0) - 11.0).abs() < 1e-12);
        assert!((t.at(0.5, 1.25) - 16.5).abs() < 1e-12);
        assert!(
            (t.at(1.0, 3.0) - 34.0).abs() < 1e-12,
            "the last column beyond"
        );
        assert!((t.at(0.1, 0.5) - 0.0).abs() < 1e-12);
        assert!((t.at(0.1, 1.0) - 5.0).abs() < 1e-12, "half the lowest row");
        assert_eq!(t.at(0.0, 1.0), 0.0);
    }

    #[test]
    fn a_depth_below_dives_and_one_above_climbs() {
        for gains in [Some(0.6), None] {
            let mut a = autopilot(gains);
            let down = Hold {
                heading: None,
                depth: Some(2.0),
            };
            let [_, pitch] = a.steer(
                0.01,
                &down,
                &estimate(0.0, 1.0),
                0.5,
                [0.0; 2],
                0.0,
                [1.0, 1.0],
            );
            assert!(pitch > 0.0, "{gains:?}: dives, {pitch}");
            let up = Hold {
                heading: None,
                depth: Some(0.2),
            };
            let [_, pitch] = a.steer(
                0.01,
                &up,
                &estimate(0.0, 1.0),
                0.5,
                [0.0; 2],
                0.0,
                [1.0, 1.0],
            );
            assert!(pitch < 0.0, "{gains:?}: climbs, {pitch}");
        }
    }

    /// Runs `a` for `secs` at 100 Hz with the estimate `at(t)`: steer,
    /// then judge; returns the states seen, repeats dropped.
    fn judged(
        a: &mut Autopilot,
        hold: &Hold,
        secs: f64,
        swimming: bool,
        at: impl Fn(f64) -> Estimate,
    ) -> Vec<[HoldState; 2]> {
        let dt = 0.01;
        let mut seen: Vec<[HoldState; 2]> = Vec::new();
        for i in 0..(secs / dt).round() as usize {
            let e = at(i as f64 * dt);
            a.steer(dt, hold, &e, 0.5, [0.0; 2], 0.0, [1.0, 1.0]);
            let s = a.judge(dt, hold, &e, swimming);
            if seen.last() != Some(&s) {
                seen.push(s);
            }
        }
        seen
    }

    /// Issue 46: the daemon names how a hold is doing. An error that
    /// shrinks converges and then holds; one that stays put is not
    /// converging after the settle time (and, its command at the limit
    /// all along, cannot: limit); at rest a hold waits; off when not held.
    #[test]
    fn each_hold_is_judged_converging_holding_or_not() {
        use HoldState::*;
        let heading = Hold {
            heading: Some(90.0),
            depth: None,
        };
        let mut a = autopilot(None);
        // 0 -> 90 deg at 10 deg/s: converging, then holding at 8 s.
        let seen = judged(&mut a, &heading, 12.0, true, |t| {
            estimate((t * 10.0).min(90.0), 1.0)
        });
        assert_eq!(seen, vec![[Converging, Off], [Holding, Off]]);
        // Stuck 120 deg off, the rate asked (0.8/s x 2.09 rad) beyond the
        // 30 deg/s limit all along: cannot (limit) after HEADING_SETTLE.
        let mut a = autopilot(None);
        let seen = judged(&mut a, &heading, HEADING_SETTLE + 1.0, true, |_| {
            estimate(-30.0, 1.0)
        });
        assert_eq!(seen, vec![[Converging, Off], [Limit, Off]]);
        // Stuck 15 deg off with the rate unsaturated: not converging.
        let mut a = autopilot(None);
        let seen = judged(&mut a, &heading, HEADING_SETTLE + 1.0, true, |_| {
            estimate(75.0, 1.0)
        });
        assert_eq!(seen, vec![[Converging, Off], [NotConverging, Off]]);
        // A new target starts over.
        let other = Hold {
            heading: Some(80.0),
            depth: None,
        };
        let seen = judged(&mut a, &other, 1.0, true, |_| estimate(75.0, 1.0));
        assert_eq!(seen, vec![[Holding, Off]]);
        // At rest the hold waits; released, it is off.
        assert_eq!(
            judged(&mut a, &heading, 1.0, false, |_| estimate(0.0, 1.0)),
            vec![[Waiting, Off]]
        );
        assert_eq!(
            judged(&mut a, &Hold::MANUAL, 1.0, true, |_| estimate(0.0, 1.0)),
            vec![[Off, Off]]
        );
    }

    /// A depth hold stalled at the surface cannot (at the surface); one
    /// stalled where the dive table's authority changes sign cannot
    /// (authority).
    #[test]
    fn a_stalled_depth_hold_names_why_it_cannot() {
        use HoldState::*;
        let depth = Hold {
            heading: None,
            depth: Some(1.2),
        };
        let mut a = autopilot(Some(0.6));
        let seen = judged(&mut a, &depth, DEPTH_SETTLE + 1.0, true, |_| {
            estimate(0.0, 0.01)
        });
        assert_eq!(seen, vec![[Off, Converging], [Off, Surface]]);
        // The table's authority changes sign between amplitude 0.8 and 1.
        let mut a = autopilot(Some(0.6));
        a.gains.dive.as_mut().expect("a table").rate[4] = [-0.3; DIVE_FREQUENCIES.len()];
        let seen = judged(&mut a, &depth, DEPTH_SETTLE + 1.0, true, |_| {
            estimate(0.0, 0.8)
        });
        assert_eq!(seen, vec![[Off, Converging], [Off, Authority]]);
        // The same error shrinking 5 cm every 10 s converges.
        let mut a = autopilot(Some(0.6));
        let seen = judged(&mut a, &depth, 3.0 * DEPTH_SETTLE, true, |t| {
            estimate(0.0, 0.3 + 0.006 * t)
        });
        assert_eq!(seen, vec![[Off, Converging]]);
    }

    #[test]
    fn the_authority_is_uncertain_where_the_table_changes_sign() {
        let mut t = DiveTable {
            rate: [[0.3; DIVE_FREQUENCIES.len()]; DIVE_AMPLITUDES.len()],
        };
        assert!(!authority_uncertain(&t, 0.6, 1.0));
        t.rate[3][1] = -0.1; // amplitude 0.8, 1 Hz
        assert!(authority_uncertain(&t, 0.7, 1.0));
        assert!(!authority_uncertain(&t, 0.4, 1.0));
        // Nothing at rest.
        assert!(authority_uncertain(&t, 0.0, 1.0));
    }
}
