//! The head sensor and the estimate of the head's attitude and depth
//! (docs/autopilot.md).
//!
//! [`Nav`] takes the head sensor's frames off the bus (protocol/README.md
//! "The head sensor": one FD `HeadSample`, or the classic `HeadAttitude`,
//! `HeadRates`, `HeadAccel` and `HeadDepth` tied by their sample counter),
//! and once a period runs a complementary filter whose process model is the
//! feed-forward model's own prediction of the head:
//!
//! - **attitude** `q` (sensor frame to world; x forward, y left, z up) is
//!   propagated with the model's predicted body rates plus `b`, the gyro's
//!   innovation (gyro − model) low-passed over [`RATE_TAU`] (the same
//!   innovation low-passed over [`INNOVATION_TAU`] is the model's health
//!   figure); each sample pulls
//!   it towards the fusion IMU's quaternion by `1 − e^(−Ts/ATT_TAU)`, or,
//!   from a raw 6-axis IMU, levels it towards the accelerometer's gravity
//!   over `TILT_TAU` (then heading is gyro-integrated and drifts);
//! - **depth** is propagated with the model's predicted velocity turned
//!   into the world by `q`, plus a learnt rate bias (a current, a model
//!   error), and corrected by each pressure sample (α-β, critically damped);
//! - the **heading** and **pitch** the operator and the autopilot see are
//!   the body's, not the head's: the head swings with every tail beat, and
//!   the model knows by how much. The body's axis is the direction from the
//!   centroid of the model's body shape to the nose; its heading is the
//!   estimated attitude applied to that direction.
//!
//! Health ([`SensorHealth`]): silent past `[sensor] timeout`; error (an
//! IMU, pressure or IMU-reset bit, or a sample without pressure, or without
//! both attitude and rates); stuck (the measured values repeated exactly
//! [`STUCK_SAMPLES`] times more: no real sensor's noise does that);
//! implausible (the innovation beyond `[sensor] max-rate-innovation`, or a
//! pressure jump beyond [`MAX_DEPTH_INNOVATION`], which is left out of the
//! estimate). A roll beyond `roll-alarm` is an alarm in the
//! snapshot, not a health: the autopilot steers through it.
//! - the nose's **position** x, y and the water's **current**
//!   ([`position::Plane`]) are propagated with the same world velocity and
//!   corrected by the position fixes other sensors observe
//!   ([`Observation::PositionFix`], handed over by [`Nav::observe`]); the
//!   fixes' age makes the position's health ([`anguilla_ipc::PositionHealth`]).
//!
//! Nothing here allocates after [`Nav::new`].

pub mod position;

use anguilla_ipc::{NavSnapshot, SensorHealth};
use anguilla_model::{HeadState, body_axis, depth_at_pressure, forward_axes};
use anguilla_protocol::Frame;
use anguilla_protocol::message::{HeadSample, NodeId, SensorErrors, SensorStatus};
use anguilla_protocol::time::Nanos;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use crate::config::Config;
use crate::sensors::frames::SampleReader;
use crate::sensors::observation::Observation;
use position::Plane;

/// Time constant of the pull towards a fusion IMU's attitude (s).
pub const ATT_TAU: f64 = 0.05;
/// Time constant of the levelling by a raw IMU's accelerometer (s).
pub const TILT_TAU: f64 = 2.0;
/// Time constant of the gyro innovation's low-pass added to the model's
/// rates in the propagation (s).
pub const RATE_TAU: f64 = 0.2;
/// Time constant of the innovation's low-pass judged for plausibility (s).
pub const INNOVATION_TAU: f64 = 1.0;
/// α of the depth filter (per sample); β follows for critical damping.
pub const DEPTH_ALPHA: f64 = 0.2;
/// Identical consecutive samples that make a sensor stuck.
pub const STUCK_SAMPLES: u32 = 5;
/// A pressure sample this far (m) from the predicted depth is implausible,
/// and left out of the estimate.
pub const MAX_DEPTH_INNOVATION: f64 = 1.0;
/// Implausible pressure samples in a row after which the depth is taken
/// from the sensor again (the estimate, not the sensor, was wrong).
pub const GATE_SAMPLES: u32 = 50;

/// What the model predicts of the head this period, in the sensor's axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// Body rates (rad/s).
    pub rates: Vector3<f64>,
    /// The nose's velocity (m/s).
    pub velocity: Vector3<f64>,
    /// The body's mean axis, forward (unit).
    pub forward: Vector3<f64>,
}

impl Prediction {
    /// From the model's predicted head state and body shape (node
    /// positions from the nose, in the model's head frame).
    pub fn of(head: &HeadState, shape: &[Vector3<f64>]) -> Self {
        let inv = head.orientation.inverse();
        Self {
            rates: forward_axes(inv * head.omega),
            velocity: forward_axes(inv * head.velocity),
            forward: forward_axes(body_axis(shape)),
        }
    }

    /// A body at rest and straight.
    pub fn still() -> Self {
        Self {
            rates: Vector3::zeros(),
            velocity: Vector3::zeros(),
            forward: Vector3::x(),
        }
    }
}

/// The estimate, in SI units and radians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// The head's attitude (sensor frame to world).
    pub attitude: UnitQuaternion<f64>,
    /// The body's heading (rad, `(−π, π]`, counter-clockwise from x).
    pub heading: f64,
    /// The body's pitch (rad, nose up).
    pub pitch: f64,
    /// The head's roll (rad, right side down).
    pub roll: f64,
    /// Depth below the surface (m).
    pub depth: f64,
    /// Depth rate (m/s, descending).
    pub depth_rate: f64,
}

/// The head sensor, its health and the estimate.
#[derive(Debug, Clone)]
pub struct Nav {
    id: NodeId,
    timeout: Nanos,
    sample_period: f64,
    water_density: f64,
    surface_pressure: f64,
    max_innovation: f64,
    roll_alarm: f64,
    started: Nanos,
    reader: SampleReader,
    pending: Option<(Nanos, HeadSample)>,
    corrected_at: Option<Nanos>,
    gated: u32,
    initialised: bool,
    attitude: UnitQuaternion<f64>,
    rate_bias: Vector3<f64>,
    innovation: Vector3<f64>,
    depth: f64,
    depth_bias: f64,
    depth_rate: f64,
    depth_innovation: f64,
    temperature: f64,
    implausible: bool,
    forward: Vector3<f64>,
    errors: SensorErrors,
    status: SensorStatus,
    health: SensorHealth,
    plane: Plane,
}

impl Nav {
    /// The sensor of `cfg`'s `[sensor]`, or `None` without one (node 0).
    pub fn new(cfg: &Config, now: Nanos) -> Option<Self> {
        let s = &cfg.sensor;
        let id = NodeId::new(s.node).ok()?;
        Some(Self {
            id,
            timeout: Nanos::from_secs_f64(s.timeout),
            sample_period: 1.0 / s.rate_hz as f64,
            water_density: s.water_density,
            surface_pressure: s.surface_pressure,
            max_innovation: s.max_rate_innovation,
            roll_alarm: s.roll_alarm.to_radians(),
            started: now,
            reader: SampleReader::new(id, cfg.bus.variant()),
            pending: None,
            corrected_at: None,
            gated: 0,
            initialised: false,
            attitude: UnitQuaternion::identity(),
            rate_bias: Vector3::zeros(),
            innovation: Vector3::zeros(),
            depth: 0.0,
            depth_bias: 0.0,
            depth_rate: 0.0,
            depth_innovation: 0.0,
            temperature: 0.0,
            implausible: false,
            forward: Vector3::x(),
            errors: SensorErrors::default(),
            status: SensorStatus::default(),
            health: SensorHealth::Waiting,
            plane: Plane::new(cfg.sensor.off_bus().any(|s| s.gives_position()).then_some({
                position::FixTimes {
                    stale: cfg.autopilot.fix_stale,
                    lost: cfg.autopilot.fix_lost,
                }
            })),
        })
    }

    /// Takes `frame` if it is the sensor's (a sample's frame or its
    /// heartbeat); `false` leaves it to the drives.
    pub fn ingest(&mut self, now: Nanos, frame: &Frame) -> bool {
        match self.reader.ingest(now, frame) {
            None => false,
            Some(done) => {
                if let Some(s) = done {
                    self.pending = Some((now, s));
                }
                true
            }
        }
    }

    /// One control period of `dt` seconds at `now`: propagates the
    /// estimate with the model's `pred`, takes the newest sample, and
    /// judges the sensor's health ([`Nav::step_on_bus`], the bus's clock
    /// the loop's: a bus heard in every period).
    pub fn step(&mut self, now: Nanos, dt: f64, pred: &Prediction) {
        self.step_on_bus(now, now, dt, pred);
    }

    /// [`Nav::step`] with the bus's clock `bus` (the time of the periods
    /// in which the bus carried a frame, anyone's): the sensor is silent
    /// when the bus carried frames for `[sensor] timeout` and none of its
    /// samples ([`crate::sensors::frames::SampleReader::silence`]).
    pub fn step_on_bus(&mut self, now: Nanos, bus: Nanos, dt: f64, pred: &Prediction) {
        self.forward = pred.forward;
        if self.initialised {
            let w = pred.rates + self.rate_bias;
            self.attitude *= UnitQuaternion::from_scaled_axis(w * dt);
            let v = self.attitude * pred.velocity;
            self.depth_rate = -v.z + self.depth_bias;
            self.depth += self.depth_rate * dt;
            self.plane.propagate(now, v.x, v.y, dt);
        }
        if let Some((at, s)) = self.pending.take() {
            // The time since the last correction: the loop may take one
            // sample in two (a slow loop, a fast sensor), or fewer.
            let ts = self.corrected_at.map_or(self.sample_period, |c| {
                (at.saturating_sub(c).as_nanos() as f64 * 1e-9).clamp(self.sample_period, 1.0)
            });
            self.corrected_at = Some(at);
            self.correct(&s, pred, ts);
        }
        self.health = self.judge(now, bus);
    }

    fn correct(&mut self, s: &HeadSample, pred: &Prediction, ts: f64) {
        self.errors = s.errors;
        self.status = s.status;
        let q = s.quaternion.map(f64::from);
        let measured = (s.status.has(SensorStatus::ATTITUDE))
            .then(|| Quaternion::new(q[0], q[1], q[2], q[3]))
            .filter(|q| q.norm() > 0.5)
            .map(UnitQuaternion::from_quaternion);
        let imu = s.status.has(SensorStatus::IMU);
        let accel = Vector3::from(s.accel.map(f64::from));
        let depth = depth_at_pressure(s.pressure as f64, self.surface_pressure, self.water_density);
        let pressure = s.status.has(SensorStatus::PRESSURE);
        if !self.initialised {
            self.attitude = match measured {
                Some(q) => q,
                None if imu => level(accel),
                None => UnitQuaternion::identity(),
            };
            if pressure {
                self.depth = depth;
            }
            self.initialised = true;
        } else {
            if let Some(mut m) = measured {
                // q and −q are one attitude (a sensor sends w ≥ 0): pull
                // towards the one on this side, not the long way round.
                if self.attitude.coords.dot(&m.coords) < 0.0 {
                    m = UnitQuaternion::new_unchecked(-m.into_inner());
                }
                let k = 1.0 - (-ts / ATT_TAU).exp();
                self.attitude = self.attitude.try_slerp(&m, k, 1e-9).unwrap_or(m);
            } else if imu && accel.norm() > 1.0 {
                // Gravity's direction in the sensor frame, measured and
                // predicted: turn the estimate a little towards the measure.
                let up_pred = self.attitude.inverse() * Vector3::z();
                let axis = up_pred.cross(&(accel / accel.norm()));
                let k = 1.0 - (-ts / TILT_TAU).exp();
                self.attitude *= UnitQuaternion::from_scaled_axis(-axis * k);
            }
            if pressure {
                let e = depth - self.depth;
                self.depth_innovation = e;
                if e.abs() > MAX_DEPTH_INNOVATION && self.gated < GATE_SAMPLES {
                    // A pressure jump no swimmer makes: left out (and
                    // implausible, below); one that lasts is believed.
                    self.gated += 1;
                } else if e.abs() > MAX_DEPTH_INNOVATION {
                    self.depth = depth;
                    self.depth_bias = 0.0;
                    self.gated = 0;
                } else {
                    self.gated = 0;
                    let a = DEPTH_ALPHA;
                    let b = a * a / (2.0 - a);
                    self.depth += a * e;
                    self.depth_bias += b * e / ts;
                }
            }
        }
        if imu {
            let innovation = Vector3::from(s.rates.map(f64::from)) - pred.rates;
            let k = 1.0 - (-ts / RATE_TAU).exp();
            self.rate_bias += (innovation - self.rate_bias) * k;
            let k = 1.0 - (-ts / INNOVATION_TAU).exp();
            self.innovation += (innovation - self.innovation) * k;
        }
        if s.status.has(SensorStatus::TEMPERATURE) {
            self.temperature = s.temperature as f64;
        }
        let innovation = self.innovation.norm();
        // Hysteresis: implausible beyond the bound, plausible again below
        // 70 % of it.
        self.implausible = if self.implausible {
            innovation > 0.7 * self.max_innovation
                || self.depth_innovation.abs() > 0.7 * MAX_DEPTH_INNOVATION
        } else {
            innovation > self.max_innovation || self.depth_innovation.abs() > MAX_DEPTH_INNOVATION
        };
    }

    fn judge(&mut self, now: Nanos, bus: Nanos) -> SensorHealth {
        // Booting (silent once the timeout has passed five times over), or
        // silent.
        if let Some(h) = self.reader.silence(now, bus, self.started, self.timeout) {
            h
        } else if self
            .errors
            .any(SensorErrors::IMU | SensorErrors::PRESSURE | SensorErrors::IMU_RESET)
            || !self.status.has(SensorStatus::PRESSURE)
            || !(self.status.has(SensorStatus::IMU) || self.status.has(SensorStatus::ATTITUDE))
        {
            // A fault bit, a re-converging IMU, or a sample without depth,
            // or without either attitude or rates.
            SensorHealth::Error
        } else if self.reader.repeats() >= STUCK_SAMPLES {
            SensorHealth::Stuck
        } else if self.implausible {
            SensorHealth::Implausible
        } else {
            SensorHealth::Ok
        }
    }

    /// Takes another sensor's observation into the estimate (after this
    /// period's [`Nav::step`]); `false` if it was left out (an outlying
    /// fix, or one before the estimate began).
    pub fn observe(&mut self, obs: &Observation) -> bool {
        match *obs {
            Observation::PositionFix { at, x, y, sigma } => {
                self.initialised && self.plane.fix(at, x, y, sigma)
            }
            Observation::VelocityOverGround { at, vx, vy, sigma } => {
                self.initialised && self.plane.velocity(at, vx, vy, sigma)
            }
        }
    }

    /// The position estimate.
    pub fn plane(&self) -> &Plane {
        &self.plane
    }

    /// The sensor's health after the last [`Nav::step`].
    pub fn health(&self) -> SensorHealth {
        self.health
    }

    /// The estimate after the last [`Nav::step`].
    pub fn estimate(&self) -> Estimate {
        let r = self.attitude.to_rotation_matrix();
        let m = r.matrix();
        let f = self.attitude * self.forward;
        Estimate {
            attitude: self.attitude,
            heading: f.y.atan2(f.x),
            pitch: f.z.atan2(f.x.hypot(f.y)),
            roll: m[(2, 1)].atan2(m[(2, 2)]),
            depth: self.depth,
            depth_rate: self.depth_rate,
        }
    }

    /// The sensor's node id.
    pub fn id(&self) -> u8 {
        self.id.get()
    }

    /// Whole samples received since start.
    pub fn samples(&self) -> u64 {
        self.reader.samples()
    }

    /// Whether the estimate has begun (a first sample was taken).
    pub fn has_estimate(&self) -> bool {
        self.initialised
    }

    /// The water temperature of the last sample that had one (°C).
    pub fn temperature(&self) -> f64 {
        self.temperature
    }

    /// The snapshot's sensor and estimate fields (the autopilot's are the
    /// controller's).
    pub fn fill(&self, s: &mut NavSnapshot) {
        s.sensor = self.health as u8;
        if self.initialised {
            let e = self.estimate();
            s.roll_alarm = (e.roll.abs() > self.roll_alarm) as u8;
            s.heading_deg = e.heading.to_degrees().rem_euclid(360.0) as f32;
            s.pitch_deg = e.pitch.to_degrees() as f32;
            s.roll_deg = e.roll.to_degrees() as f32;
            s.depth_m = e.depth as f32;
            s.depth_rate = e.depth_rate as f32;
            s.temperature = self.temperature as f32;
            s.rate_innovation = self.innovation.norm() as f32;
            s.depth_innovation = self.depth_innovation as f32;
        }
        // At the surface: the daemon's own judgement, from its estimate.
        s.surfaced =
            (self.initialised && self.estimate().depth < anguilla_ipc::SURFACE_DEPTH) as u8;
        s.samples = self.reader.samples();
        s.lost_samples = self.reader.lost();
        let (x, y) = self.plane.position();
        s.x_m = x as f32;
        s.y_m = y as f32;
        s.position_sigma_m = self.plane.sigma() as f32;
        s.position_fixes = self.plane.fixes();
        let (cx, cy) = self.plane.current();
        s.current_x = cx as f32;
        s.current_y = cy as f32;
        s.current_sigma = self.plane.current_sigma() as f32;
        s.fix_age_ms = self
            .plane
            .fix_age()
            .map_or(u32::MAX, |a| (a * 1e3).min(f64::from(u32::MAX - 1)) as u32);
        s.position_health = self.plane.health() as u8;
        s.speed_scale = self.plane.speed_scale() as f32;
    }
}

/// A level attitude with heading 0 whose up is the accelerometer's `accel`
/// (the specific force points up at rest).
fn level(accel: Vector3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::rotation_between(&accel, &Vector3::z()).unwrap_or_else(UnitQuaternion::identity)
}

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_protocol::message::{HeadSample, Variant, encode_head_sample};

    const MS: Nanos = Nanos::from_millis(1);

    fn nav(fd: bool) -> Nav {
        let mut cfg = Config::default();
        cfg.sensor.node = 20;
        cfg.bus.fd = fd;
        Nav::new(&cfg, Nanos::ZERO).expect("a sensor")
    }

    fn sample(n: u8, yaw_rate: f32) -> HeadSample {
        HeadSample {
            node: NodeId::new(20).unwrap(),
            sample: n,
            quaternion: [1.0, 0.0, 0.0, 0.0],
            rates: [0.0, 0.0, yaw_rate],
            accel: [0.0, 0.0, 9.81],
            pressure: 101_325 + 9_810,
            temperature: 15.0,
            status: SensorStatus(SensorStatus::ALL & !SensorStatus::ACCURACY_MASK | 3),
            errors: SensorErrors::default(),
        }
    }

    fn frames(fd: bool, s: &HeadSample) -> Vec<Frame> {
        let mut v = Vec::new();
        let variant = if fd { Variant::Fd } else { Variant::Classic };
        encode_head_sample(variant, s, |f| v.push(f)).unwrap();
        v
    }

    #[test]
    fn classic_and_fd_samples_are_read_and_gaps_counted() {
        for fd in [false, true] {
            let mut n = nav(fd);
            for (k, i) in [0u8, 1, 2, 5].into_iter().enumerate() {
                let now = MS * (10 * k as u64);
                for f in frames(fd, &sample(i, 0.01 * k as f32)) {
                    assert!(n.ingest(now, &f), "the sensor's frame is taken");
                }
                n.step(now, 0.01, &Prediction::still());
            }
            let mut s = NavSnapshot::default();
            n.fill(&mut s);
            assert_eq!(s.samples, 4, "fd {fd}");
            assert_eq!(s.lost_samples, 2, "fd {fd}: 3 and 4 missed");
            assert!(
                (s.depth_m - 1.0).abs() < 1e-3,
                "fd {fd}: depth {}",
                s.depth_m
            );
            assert_eq!(n.health(), SensorHealth::Ok);
        }
    }

    #[test]
    fn a_sample_missing_a_frame_is_lost_and_others_frames_are_left() {
        let mut n = nav(false);
        let f = frames(false, &sample(7, 0.0));
        // Its rates frame lost: the HeadDepth completes nothing.
        for (i, frame) in f.iter().enumerate() {
            if i != 1 {
                n.ingest(MS, frame);
            }
        }
        let mut s = NavSnapshot::default();
        n.fill(&mut s);
        assert_eq!((s.samples, s.lost_samples), (0, 1));
        // The next sample follows it: nothing more is lost.
        for frame in frames(false, &sample(8, 0.0)) {
            n.ingest(MS * 2, &frame);
        }
        n.fill(&mut s);
        assert_eq!((s.samples, s.lost_samples), (1, 1), "counted once");
        // Another node's frames are not the sensor's.
        let other = HeadSample {
            node: NodeId::new(21).unwrap(),
            ..sample(9, 0.0)
        };
        for frame in frames(false, &other) {
            assert!(!n.ingest(MS, &frame));
        }
    }

    /// Feeds sample `i` with `f` applied, at `10 i` ms, and steps.
    fn feed(n: &mut Nav, i: u8, f: impl FnOnce(&mut HeadSample)) {
        let mut s = sample(i, 0.001 * i as f32);
        f(&mut s);
        let now = MS * (10 * i as u64);
        for frame in frames(true, &s) {
            n.ingest(now, &frame);
        }
        n.step(now, 0.01, &Prediction::still());
    }

    #[test]
    fn a_pressure_glitch_is_left_out_and_named_implausible() {
        let mut n = nav(true);
        for i in 0..10 {
            feed(&mut n, i, |_| {});
        }
        let depth = n.estimate().depth;
        // 100 m deeper for one sample: left out.
        feed(&mut n, 10, |s| s.pressure += 981_000);
        assert!(
            (n.estimate().depth - depth).abs() < 0.01,
            "{}",
            n.estimate().depth
        );
        assert_eq!(n.health(), SensorHealth::Implausible);
        for i in 11..20 {
            feed(&mut n, i, |_| {});
        }
        assert_eq!(n.health(), SensorHealth::Ok, "plausible again");
        assert!((n.estimate().depth - depth).abs() < 0.01);
    }

    #[test]
    fn a_sample_without_pressure_is_an_error() {
        let mut n = nav(true);
        feed(&mut n, 0, |_| {});
        assert_eq!(n.health(), SensorHealth::Ok);
        feed(&mut n, 1, |s| {
            s.status = SensorStatus(s.status.0 & !SensorStatus::PRESSURE)
        });
        assert_eq!(n.health(), SensorHealth::Error);
    }

    #[test]
    fn health_names_silence_a_frozen_sensor_and_error_bits() {
        let mut n = nav(true);
        n.step(MS, 0.01, &Prediction::still());
        assert_eq!(n.health(), SensorHealth::Waiting);
        n.step(MS * 600, 0.01, &Prediction::still());
        assert_eq!(n.health(), SensorHealth::Silent, "nothing for 5 timeouts");
        // The same values again and again, the counter running: stuck.
        for i in 0..=STUCK_SAMPLES as u8 {
            let now = MS * (1000 + 10 * i as u64);
            for f in frames(true, &sample(i, 0.0)) {
                n.ingest(now, &f);
            }
            n.step(now, 0.01, &Prediction::still());
        }
        assert_eq!(n.health(), SensorHealth::Stuck);
        let bad = HeadSample {
            errors: SensorErrors(SensorErrors::PRESSURE),
            rates: [0.0, 0.0, 0.002],
            ..sample(9, 0.0)
        };
        for f in frames(true, &bad) {
            n.ingest(MS * 1100, &f);
        }
        n.step(MS * 1100, 0.01, &Prediction::still());
        assert_eq!(n.health(), SensorHealth::Error);
        n.step(MS * 1300, 0.01, &Prediction::still());
        assert_eq!(n.health(), SensorHealth::Silent, "0.1 s timeout");
    }

    /// Silence is counted on the bus (issue 46, finding 11): nothing from
    /// anyone for twice the timeout (a stalled robot) is not the sensor's
    /// silence; the bus carrying frames for the timeout without a sample
    /// is, and so are five timeouts without one on any clock.
    #[test]
    fn silence_is_counted_on_the_bus() {
        let mut n = nav(true);
        let (mut now, mut bus) = (MS * 1000, MS * 1000);
        for f in frames(true, &sample(0, 0.0)) {
            n.ingest(now, &f);
        }
        n.step_on_bus(now, bus, 0.01, &Prediction::still());
        assert_eq!(n.health(), SensorHealth::Ok);
        // The whole bus quiet for 0.2 s (timeout 0.1 s): its clock stands.
        now += MS * 200;
        n.step_on_bus(now, bus, 0.01, &Prediction::still());
        assert_eq!(n.health(), SensorHealth::Ok, "a quiet bus");
        // The vertebrae talk again, the sensor does not: silent once they
        // have talked for the timeout.
        for _ in 0..10 {
            (now, bus) = (now + MS * 10, bus + MS * 10);
            n.step_on_bus(now, bus, 0.01, &Prediction::still());
            assert_eq!(n.health(), SensorHealth::Ok, "{bus:?}");
        }
        (now, bus) = (now + MS * 10, bus + MS * 10);
        n.step_on_bus(now, bus, 0.01, &Prediction::still());
        assert_eq!(
            n.health(),
            SensorHealth::Silent,
            "others heard, not the sensor"
        );
        // Nothing from anyone for five timeouts: silent.
        let mut n = nav(true);
        for f in frames(true, &sample(0, 0.0)) {
            n.ingest(MS * 1000, &f);
        }
        n.step_on_bus(MS * 1000, MS * 1000, 0.01, &Prediction::still());
        n.step_on_bus(MS * 1490, MS * 1000, 0.01, &Prediction::still());
        assert_eq!(n.health(), SensorHealth::Ok);
        n.step_on_bus(MS * 1510, MS * 1000, 0.01, &Prediction::still());
        assert_eq!(n.health(), SensorHealth::Silent, "a bus silent for 0.5 s");
    }
}
