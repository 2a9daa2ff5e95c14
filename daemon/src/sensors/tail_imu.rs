//! An IMU in the tail (`[sensor] tail-imu`): the head sensor's protocol
//! (its samples read by [`super::frames::SampleReader`]) from another
//! node, shown and recorded as measured. The estimate and the autopilot
//! use the head sensor alone: the tail swings with every beat, and the
//! model's prediction is the head's.
//!
//! Health: silent past `[sensor] timeout` (and before the first sample,
//! five times that); error on an IMU or reset bit, or a sample with
//! neither attitude nor rates; stuck when the measured values repeated
//! exactly `crate::nav::STUCK_SAMPLES` times more.

use anguilla_ipc::{SensorEntry, SensorHealth, SensorKind};
use anguilla_protocol::Frame;
use anguilla_protocol::message::{NodeId, SensorErrors, SensorStatus};
use anguilla_protocol::time::Nanos;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use super::Sensor;
use super::frames::SampleReader;
use crate::config::Config;
use crate::nav::{Prediction, STUCK_SAMPLES};

/// The tail IMU.
#[derive(Debug, Clone)]
pub struct TailImu {
    id: NodeId,
    reader: SampleReader,
    timeout: Nanos,
    started: Nanos,
    health: SensorHealth,
}

impl TailImu {
    /// The IMU of `cfg`'s `[sensor] tail-imu`, or `None` without one (0).
    pub fn new(cfg: &Config, now: Nanos) -> Option<Self> {
        let id = NodeId::new(cfg.sensor.tail_imu).ok()?;
        Some(Self {
            id,
            reader: SampleReader::new(id, cfg.bus.variant()),
            timeout: Nanos::from_secs_f64(cfg.sensor.timeout),
            started: now,
            health: SensorHealth::Waiting,
        })
    }

    fn judge(&mut self, now: Nanos, bus: Nanos) -> SensorHealth {
        if let Some(h) = self.reader.silence(now, bus, self.started, self.timeout) {
            return h;
        }
        let Some(s) = self.reader.last() else {
            return SensorHealth::Waiting;
        };
        if s.errors.any(SensorErrors::IMU | SensorErrors::IMU_RESET)
            || !(s.status.has(SensorStatus::IMU) || s.status.has(SensorStatus::ATTITUDE))
        {
            SensorHealth::Error
        } else if self.reader.repeats() >= STUCK_SAMPLES {
            SensorHealth::Stuck
        } else {
            SensorHealth::Ok
        }
    }
}

impl Sensor for TailImu {
    fn kind(&self) -> SensorKind {
        SensorKind::TailImu
    }

    fn id(&self) -> u8 {
        self.id.get()
    }

    fn ingest(&mut self, now: Nanos, frame: &Frame) -> bool {
        self.reader.ingest(now, frame).is_some()
    }

    fn step(&mut self, now: Nanos, bus: Nanos, _dt: f64, _pred: &Prediction) {
        self.health = self.judge(now, bus);
    }

    fn health(&self) -> SensorHealth {
        self.health
    }

    /// Heading, pitch and roll of the sensor's x axis (deg; from its
    /// attitude, 0 without one), its rates (rad/s) and temperature (°C):
    /// [`SensorKind::TailImu`]'s values.
    fn fill(&self, entry: &mut SensorEntry) {
        entry.samples = self.reader.samples().min(u32::MAX as u64) as u32;
        let Some(s) = self.reader.last() else {
            return;
        };
        let mut v = [0.0f64; 7];
        if s.status.has(SensorStatus::ATTITUDE) {
            let q = s.quaternion.map(f64::from);
            let q = Quaternion::new(q[0], q[1], q[2], q[3]);
            if q.norm() > 0.5 {
                let q = UnitQuaternion::from_quaternion(q);
                let f = q * Vector3::x();
                let m = *q.to_rotation_matrix().matrix();
                v[0] = f.y.atan2(f.x).to_degrees().rem_euclid(360.0);
                v[1] = f.z.atan2(f.x.hypot(f.y)).to_degrees();
                v[2] = m[(2, 1)].atan2(m[(2, 2)]).to_degrees();
            }
        }
        for (k, r) in s.rates.iter().enumerate() {
            v[3 + k] = f64::from(*r);
        }
        if s.status.has(SensorStatus::TEMPERATURE) {
            v[6] = f64::from(s.temperature);
        }
        for (slot, x) in entry.values.iter_mut().zip(v) {
            *slot = x as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_protocol::message::{HeadSample, Variant, encode_head_sample};

    const MS: Nanos = Nanos::from_millis(1);

    fn imu() -> TailImu {
        let mut cfg = Config::default();
        cfg.sensor.tail_imu = 21;
        TailImu::new(&cfg, Nanos::ZERO).expect("an IMU")
    }

    /// Sample `i` from node `node`, turned `yaw` rad about z.
    fn sample(node: u8, i: u8, yaw: f32) -> Vec<Frame> {
        let (s, c) = ((yaw / 2.0).sin(), (yaw / 2.0).cos());
        let sample = HeadSample {
            node: NodeId::new(node).unwrap(),
            sample: i,
            quaternion: [c, 0.0, 0.0, s],
            rates: [0.1, -0.2, 0.3 + f32::from(i) * 0.01],
            accel: [0.0, 0.0, 9.81],
            pressure: 111_000,
            temperature: 12.5,
            status: SensorStatus(SensorStatus::ALL),
            errors: SensorErrors(0),
        };
        let mut v = Vec::new();
        encode_head_sample(Variant::Classic, &sample, |f| v.push(f)).unwrap();
        v
    }

    #[test]
    fn samples_become_attitude_and_rates_and_silence_is_seen() {
        let mut t = imu();
        let pred = Prediction::still();
        t.step(10 * MS, 10 * MS, 0.01, &pred);
        assert_eq!(t.health(), SensorHealth::Waiting);
        // Another node's frames are not its own.
        for f in sample(20, 0, 0.0) {
            assert!(!t.ingest(MS, &f));
        }
        for i in 0..3 {
            for f in sample(21, i, 0.5) {
                assert!(t.ingest(20 * MS + u64::from(i) * 10 * MS, &f));
            }
        }
        t.step(45 * MS, 45 * MS, 0.01, &pred);
        assert_eq!(t.health(), SensorHealth::Ok);
        let mut e = SensorEntry::default();
        t.fill(&mut e);
        assert_eq!(e.samples, 3);
        assert!(
            (e.values[0] - 0.5f32.to_degrees()).abs() < 0.1,
            "{:?}",
            e.values
        );
        assert!(e.values[1].abs() < 0.1 && e.values[2].abs() < 0.1);
        assert_eq!(e.values[3..5], [0.1, -0.2]);
        assert_eq!(e.values[6], 12.5);
        // Past the timeout: silent.
        t.step(
            45 * MS + Nanos::from_secs_f64(0.2),
            45 * MS + Nanos::from_secs_f64(0.2),
            0.01,
            &pred,
        );
        assert_eq!(t.health(), SensorHealth::Silent);
    }

    #[test]
    fn frozen_values_are_stuck() {
        // Moving rates: ok.
        let mut t = imu();
        for i in 0..8u8 {
            for f in sample(21, i, 0.5) {
                assert!(t.ingest(u64::from(i) * 10 * MS, &f));
            }
        }
        // The same values every time, the counter moving on: stuck.
        let mut t2 = imu();
        for i in 0..8u8 {
            let mut frames = Vec::new();
            let s = HeadSample {
                node: NodeId::new(21).unwrap(),
                sample: i,
                quaternion: [1.0, 0.0, 0.0, 0.0],
                rates: [0.0; 3],
                accel: [0.0, 0.0, 9.81],
                pressure: 111_000,
                temperature: 12.5,
                status: SensorStatus(SensorStatus::ALL),
                errors: SensorErrors(0),
            };
            encode_head_sample(Variant::Classic, &s, |f| frames.push(f)).unwrap();
            for f in frames {
                t2.ingest(u64::from(i) * 10 * MS, &f);
            }
        }
        t.step(75 * MS, 75 * MS, 0.01, &Prediction::still());
        t2.step(75 * MS, 75 * MS, 0.01, &Prediction::still());
        assert_eq!(t.health(), SensorHealth::Ok);
        assert_eq!(t2.health(), SensorHealth::Stuck);
    }
}
