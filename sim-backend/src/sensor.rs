//! The simulated head sensor: an IMU and pressure sensor
//! in the robot's head, derived from the body's true head state.
//!
//! Each sample (every `1 / rate_hz`, on the sensor's own clock, at the
//! first physics tick at or after the sample time) takes the true head
//! state and adds what a real sensor adds:
//!
//! - **frames**: the protocol's head frame is x forward, y left, z up
//!   (protocol/README.md "The head sensor"). The model's head frame
//!   `(t1, t2, t3)` has `t1` towards the tail and `t3` up, so the sensor
//!   frame is the model's turned by π about `t3`: `x = −t1`, `y = −t2`,
//!   `z = t3`; its attitude is `q_model ⊗ q_z(π)`, head to world (world z
//!   up, gravity `−9.81 e3`).
//! - **rates** `ω_s = C Rᵀ ω + b_g + σ_g n`, the true angular velocity
//!   (world frame in the model) expressed in the head frame, plus the gyro
//!   bias and white noise; the bias walks by `σ_walk √dt n` per sample;
//! - **accelerations**: the specific force `C Rᵀ (a − g) + b_a + σ_a n`
//!   (+9.81 on z at rest, level), `a` the nose's acceleration by finite
//!   difference of the true velocity between samples;
//! - **attitude** (a fusion IMU only): the true attitude turned by a small
//!   random rotation of `σ_att` rad per axis, `w ≥ 0`;
//! - **pressure** `p0 + ρ g depth + σ_p n`, `depth = origin_depth − z`
//!   (the model's z is up and its origin is `origin_depth` below the
//!   surface);
//! - **quantization**: the wire's scales (the codec rounds each field);
//!   values beyond the documented ranges saturate, as a sensor's do;
//! - **latency**: each sample is sent `latency_samples` samples after it
//!   was taken (a fixed ring; nothing is allocated after construction).
//!
//! A heartbeat (the protocol's Heartbeat, state Enabled) goes out every
//! 100 ms. Scripted faults ([`SensorFault`]): silent (nothing sent; the
//! sample counter keeps counting, so the host sees the gap), stuck (the
//! last sent sample's values repeated with a counting sample counter: the
//! IMU froze while the microcontroller keeps sending), bias jump (a step in
//! the gyro bias of every axis), ok (ends silent and stuck; a bias jump
//! stays, as it would).

use anguilla_protocol::Frame;
use anguilla_protocol::message::{
    ACCEL_LIMIT, ErrorBits, HEAD_SENSOR_RATE_HZ, HEARTBEAT_PERIOD_MS, HeadSample, Heartbeat,
    Message, NodeId, NodeState, RATE_LIMIT, SensorErrors, SensorStatus, Variant, common,
    encode_head_sample,
};

use crate::node::Nanos;
use crate::rng::Rng;

/// Gravity the model uses, m/s² (the model's one definition).
pub use anguilla_model::GRAVITY;

/// The longest latency a sensor simulates, in samples.
pub const MAX_LATENCY_SAMPLES: usize = 16;

/// Configuration of the simulated head sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorConfig {
    /// Its node id, 1..=63, distinct from the vertebrae's.
    pub id: u8,
    /// Samples per second, 100..=200.
    pub rate_hz: u16,
    /// A fusion IMU (sends attitude); `false`: a raw 6-axis IMU.
    pub fusion: bool,
    /// Gyro white noise, rad/s (standard deviation per sample).
    pub gyro_noise: f64,
    /// Accelerometer white noise, m/s² (standard deviation per sample).
    pub accel_noise: f64,
    /// Attitude noise, rad per axis (standard deviation per sample).
    pub attitude_noise: f64,
    /// Pressure white noise, Pa (standard deviation per sample).
    pub pressure_noise: f64,
    /// Initial gyro bias, rad/s, head frame.
    pub gyro_bias: [f64; 3],
    /// Initial accelerometer bias, m/s², head frame.
    pub accel_bias: [f64; 3],
    /// Gyro bias random walk, rad/s per √s.
    pub gyro_bias_walk: f64,
    /// Accelerometer bias random walk, m/s² per √s.
    pub accel_bias_walk: f64,
    /// Samples between taking a sample and sending it,
    /// 0..=[`MAX_LATENCY_SAMPLES`].
    pub latency_samples: usize,
    /// Water density, kg/m³ (fresh 1000, sea 1025).
    pub water_density: f64,
    /// Absolute pressure at the surface, Pa.
    pub surface_pressure: f64,
    /// Depth of the model's origin below the surface, m.
    pub origin_depth: f64,
    /// Water temperature, °C.
    pub water_temperature: f64,
}

/// How deep (m) the model's origin lies below the surface unless a head
/// sensor says otherwise: the robot starts 1 m deep.
pub const DEFAULT_ORIGIN_DEPTH: f64 = 1.0;

impl SensorConfig {
    /// A BNO08x-class fusion IMU with an MS5837-class pressure sensor on
    /// node `id` at 100 Hz: datasheet-order noise and bias, no latency,
    /// fresh water, 1 m deep.
    pub fn typical(id: u8) -> Self {
        Self {
            id,
            rate_hz: 100,
            fusion: true,
            gyro_noise: 0.003,
            accel_noise: 0.02,
            attitude_noise: 0.005,
            pressure_noise: 20.0,
            gyro_bias: [0.0; 3],
            accel_bias: [0.0; 3],
            gyro_bias_walk: 1e-4,
            accel_bias_walk: 1e-3,
            latency_samples: 0,
            water_density: 1000.0,
            surface_pressure: 101_325.0,
            origin_depth: DEFAULT_ORIGIN_DEPTH,
            water_temperature: 15.0,
        }
    }

    /// [`SensorConfig::typical`] with the sample rate and the water a
    /// host's configuration assumes (so its depth is the simulated one).
    pub fn typical_in(id: u8, rate_hz: u16, water_density: f64, surface_pressure: f64) -> Self {
        Self {
            rate_hz,
            water_density,
            surface_pressure,
            ..Self::typical(id)
        }
    }

    /// Checks every setting; the error names it and the accepted range.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if NodeId::new(self.id).is_err() {
            return Err(("head_sensor.id", format!("{} outside 1..=63", self.id)));
        }
        let (lo, hi) = HEAD_SENSOR_RATE_HZ;
        if !(lo..=hi).contains(&self.rate_hz) {
            return Err((
                "head_sensor.rate_hz",
                format!("{} Hz outside {lo}..={hi}", self.rate_hz),
            ));
        }
        if self.latency_samples > MAX_LATENCY_SAMPLES {
            return Err((
                "head_sensor.latency_samples",
                format!("{} outside 0..={MAX_LATENCY_SAMPLES}", self.latency_samples),
            ));
        }
        let nonneg = [
            ("head_sensor.gyro_noise", self.gyro_noise),
            ("head_sensor.accel_noise", self.accel_noise),
            ("head_sensor.attitude_noise", self.attitude_noise),
            ("head_sensor.pressure_noise", self.pressure_noise),
            ("head_sensor.gyro_bias_walk", self.gyro_bias_walk),
            ("head_sensor.accel_bias_walk", self.accel_bias_walk),
            ("head_sensor.water_density", self.water_density),
            ("head_sensor.surface_pressure", self.surface_pressure),
        ];
        for (field, v) in nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return Err((field, format!("{v} (expected a finite value >= 0)")));
            }
        }
        let finite = self
            .gyro_bias
            .iter()
            .chain(&self.accel_bias)
            .chain([&self.origin_depth, &self.water_temperature]);
        for v in finite {
            if !v.is_finite() {
                return Err((
                    "head_sensor",
                    format!("{v} (expected finite biases, depth and temperature)"),
                ));
            }
        }
        Ok(())
    }
}

/// A scripted fault of the head sensor (scenario target `sensor`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SensorFault {
    /// Sends nothing, for a duration or until `ok`.
    Silent(Option<std::time::Duration>),
    /// Repeats the last sent sample's values until `ok`.
    Stuck,
    /// A step of this many rad/s in the gyro bias of every axis.
    BiasJump(f64),
    /// Ends silent and stuck.
    Ok,
}

/// The true head state a sample is taken from (the simulation's
/// [`Truth`](crate::robot::Truth) fields of the head).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HeadTruth {
    /// Nose position, m, world frame (z up).
    pub position: [f64; 3],
    /// Model head frame to world, `[w, x, y, z]`.
    pub orientation: [f64; 4],
    /// Nose velocity, m/s, world frame.
    pub velocity: [f64; 3],
    /// Angular velocity, rad/s, world frame.
    pub angular_velocity: [f64; 3],
}

/// The simulated head sensor.
#[derive(Debug, Clone)]
pub struct HeadSensor {
    cfg: SensorConfig,
    variant: Variant,
    node: NodeId,
    rng: Rng,
    period: Nanos,
    next_sample: Nanos,
    next_heartbeat: Nanos,
    sample: u8,
    hb_counter: u8,
    gyro_bias: [f64; 3],
    accel_bias: [f64; 3],
    /// Previous sample's true velocity, for the acceleration.
    last_velocity: Option<[f64; 3]>,
    /// Samples taken and not yet sent (latency), oldest at `ring_head`.
    ring: [HeadSample; MAX_LATENCY_SAMPLES + 1],
    ring_head: usize,
    ring_len: usize,
    silent_until: Option<Nanos>,
    silent: bool,
    stuck: bool,
    last_sent: Option<HeadSample>,
    sent: u64,
}

/// `a ⊗ b`, quaternions `[w, x, y, z]`.
fn q_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// `v` rotated by the inverse of unit quaternion `q`: a world vector in the
/// frame `q` maps to the world.
pub fn rotate_inv(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let c = [q[0], -q[1], -q[2], -q[3]];
    let r = q_mul(q_mul(c, [0.0, v[0], v[1], v[2]]), q);
    [r[1], r[2], r[3]]
}

/// The sensor frame's attitude (head to world) from the model head
/// frame's: turned by π about z (`x = −t1`, `y = −t2`, `z = t3`).
pub fn sensor_attitude(model: [f64; 4]) -> [f64; 4] {
    let [w, x, y, z] = model;
    let q = nalgebra::UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(w, x, y, z))
        * anguilla_model::forward_turn();
    [q.w, q.i, q.j, q.k]
}

impl HeadSensor {
    /// A sensor speaking `variant`, seeded with `seed`, its first sample at
    /// `start`; the error of [`SensorConfig::validate`] for a bad
    /// configuration.
    pub fn new(
        cfg: SensorConfig,
        variant: Variant,
        seed: u64,
        start: Nanos,
    ) -> Result<Self, (&'static str, String)> {
        cfg.validate()?;
        let node = NodeId::new(cfg.id).map_err(|e| ("head_sensor.id", e.to_string()))?;
        let blank = HeadSample {
            node,
            sample: 0,
            quaternion: [0.0; 4],
            rates: [0.0; 3],
            accel: [0.0; 3],
            pressure: 0,
            temperature: 0.0,
            status: SensorStatus(0),
            errors: SensorErrors(0),
        };
        Ok(Self {
            cfg,
            variant,
            node,
            rng: Rng::new(seed),
            period: Nanos::from_nanos(1_000_000_000 / u64::from(cfg.rate_hz)),
            next_sample: start,
            next_heartbeat: start,
            sample: 0,
            hb_counter: 0,
            gyro_bias: cfg.gyro_bias,
            accel_bias: cfg.accel_bias,
            last_velocity: None,
            ring: [blank; MAX_LATENCY_SAMPLES + 1],
            ring_head: 0,
            ring_len: 0,
            silent_until: None,
            silent: false,
            stuck: false,
            last_sent: None,
            sent: 0,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &SensorConfig {
        &self.cfg
    }

    /// Samples sent so far.
    pub fn samples_sent(&self) -> u64 {
        self.sent
    }

    /// The gyro bias now, rad/s, head frame.
    pub fn gyro_bias(&self) -> [f64; 3] {
        self.gyro_bias
    }

    /// Applies a scripted fault at `at`.
    pub fn apply(&mut self, fault: SensorFault, at: Nanos) {
        match fault {
            SensorFault::Silent(d) => {
                self.silent = true;
                self.silent_until = d.map(|d| at + Nanos::from(d));
            }
            SensorFault::Stuck => self.stuck = true,
            SensorFault::BiasJump(r) => {
                for b in &mut self.gyro_bias {
                    *b += r;
                }
            }
            SensorFault::Ok => {
                self.silent = false;
                self.silent_until = None;
                self.stuck = false;
            }
        }
    }

    /// Runs the sensor up to `now` with the head in state `truth`: takes
    /// the samples due, sends those whose latency has passed and the
    /// heartbeats due. Allocates nothing.
    pub fn advance(&mut self, now: Nanos, truth: &HeadTruth, send: &mut dyn FnMut(Frame)) {
        if let Some(t) = self.silent_until
            && now >= t
        {
            self.silent = false;
            self.silent_until = None;
        }
        while self.next_sample <= now {
            let s = self.take(truth);
            self.next_sample += self.period;
            // Latency: queue, and send the sample `latency_samples` old.
            let cap = self.ring.len();
            let tail = (self.ring_head + self.ring_len) % cap;
            self.ring[tail] = s;
            self.ring_len += 1;
            if self.ring_len > self.cfg.latency_samples {
                let out = self.ring[self.ring_head];
                self.ring_head = (self.ring_head + 1) % cap;
                self.ring_len -= 1;
                self.emit(out, send);
            }
        }
        while self.next_heartbeat <= now {
            self.next_heartbeat += Nanos::from_millis(u64::from(HEARTBEAT_PERIOD_MS));
            let hb = Message::Heartbeat(Heartbeat {
                node: self.node,
                state: NodeState::Enabled,
                errors: ErrorBits(0),
                counter: self.hb_counter,
                missed_syncs: 0,
                temperature: self.cfg.water_temperature.round().clamp(-40.0, 125.0) as i8,
            });
            self.hb_counter = self.hb_counter.wrapping_add(1);
            if !self.silent
                && let Ok(f) = hb.encode(self.variant)
            {
                send(f);
            }
        }
    }

    fn emit(&mut self, mut s: HeadSample, send: &mut dyn FnMut(Frame)) {
        if self.stuck
            && let Some(last) = self.last_sent
        {
            s = HeadSample {
                sample: s.sample,
                ..last
            };
        }
        if self.silent {
            return;
        }
        if encode_head_sample(self.variant, &s, &mut *send).is_ok() {
            self.last_sent = Some(s);
            self.sent += 1;
        }
    }

    /// One sample of the true state with noise, bias and saturation.
    fn take(&mut self, t: &HeadTruth) -> HeadSample {
        let dt = self.period.as_secs_f64();
        let c = self.cfg;
        let q_s = sensor_attitude(t.orientation);
        let to_head = |v: [f64; 3]| rotate_inv(q_s, v);
        // Bias random walk.
        for b in &mut self.gyro_bias {
            *b += c.gyro_bias_walk * dt.sqrt() * self.rng.normal();
        }
        for b in &mut self.accel_bias {
            *b += c.accel_bias_walk * dt.sqrt() * self.rng.normal();
        }
        let omega = to_head(t.angular_velocity);
        let a = match self.last_velocity {
            Some(v0) => [0, 1, 2].map(|i| (t.velocity[i] - v0[i]) / dt),
            None => [0.0; 3],
        };
        self.last_velocity = Some(t.velocity);
        let f = to_head([a[0], a[1], a[2] + GRAVITY]);
        let mut rates = [0.0f32; 3];
        let mut accel = [0.0f32; 3];
        for i in 0..3 {
            let r = omega[i] + self.gyro_bias[i] + c.gyro_noise * self.rng.normal();
            rates[i] = r.clamp(-RATE_LIMIT, RATE_LIMIT) as f32;
            let x = f[i] + self.accel_bias[i] + c.accel_noise * self.rng.normal();
            accel[i] = x.clamp(-ACCEL_LIMIT, ACCEL_LIMIT) as f32;
        }
        let mut status = SensorStatus::IMU | SensorStatus::PRESSURE | SensorStatus::TEMPERATURE;
        let quaternion = if c.fusion {
            status |= SensorStatus::ATTITUDE | 3;
            let n = [0; 3].map(|_| c.attitude_noise * self.rng.normal() / 2.0);
            let d = [1.0, n[0], n[1], n[2]];
            let norm = d.iter().map(|x| x * x).sum::<f64>().sqrt();
            let mut q = q_mul(q_s, d.map(|x| x / norm));
            if q[0] < 0.0 {
                q = q.map(|x| -x);
            }
            q.map(|x| x.clamp(-1.0, 1.0) as f32)
        } else {
            [0.0; 4]
        };
        let depth = c.origin_depth - t.position[2];
        let p = anguilla_model::pressure_at_depth(depth, c.surface_pressure, c.water_density)
            + c.pressure_noise * self.rng.normal();
        let sample = self.sample;
        self.sample = self.sample.wrapping_add(1);
        HeadSample {
            node: self.node,
            sample,
            quaternion,
            rates,
            accel,
            pressure: p.round().clamp(0.0, f64::from(common::PRESSURE_MAX)) as u32,
            temperature: c.water_temperature.clamp(-40.0, 85.0) as f32,
            status: SensorStatus(status),
            errors: SensorErrors(0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sensor_frame_is_the_model_frame_turned_about_z() {
        // Model identity: t1 = e1 (towards the tail), so the head's x
        // (forward) is −e1; a world rate about e3 (yaw) is +z in both.
        let q = sensor_attitude([1.0, 0.0, 0.0, 0.0]);
        let v = rotate_inv(q, [1.0, 0.0, 0.0]);
        assert!((v[0] + 1.0).abs() < 1e-12 && v[1].abs() < 1e-12, "{v:?}");
        let w = rotate_inv(q, [0.0, 0.0, 0.3]);
        assert!((w[2] - 0.3).abs() < 1e-12, "{w:?}");
        // A model turned 90° about z: t1 = e2, so forward is −e2.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let q = sensor_attitude([h, 0.0, 0.0, h]);
        let v = rotate_inv(q, [0.0, -1.0, 0.0]);
        assert!((v[0] - 1.0).abs() < 1e-12, "{v:?}");
    }

    #[test]
    fn bad_settings_name_the_field() {
        let mut c = SensorConfig::typical(20);
        assert!(c.validate().is_ok());
        c.rate_hz = 50;
        assert_eq!(c.validate().unwrap_err().0, "head_sensor.rate_hz");
        c = SensorConfig::typical(0);
        assert_eq!(c.validate().unwrap_err().0, "head_sensor.id");
        c = SensorConfig::typical(20);
        c.latency_samples = MAX_LATENCY_SAMPLES + 1;
        assert_eq!(c.validate().unwrap_err().0, "head_sensor.latency_samples");
        c = SensorConfig::typical(20);
        c.gyro_noise = f64::NAN;
        assert_eq!(c.validate().unwrap_err().0, "head_sensor.gyro_noise");
    }
}
