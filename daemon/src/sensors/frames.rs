//! The head-sensor protocol's samples off the bus (protocol/README.md
//! "The head sensor"): one FD `HeadSample`, or the classic `HeadAttitude`,
//! `HeadRates`, `HeadAccel` and `HeadDepth` tied by their sample counter.
//! Every IMU of the robot speaks it, whatever it is for: the head's
//! navigation sensor (`crate::nav::Nav`) and the tail's IMU
//! ([`super::tail_imu::TailImu`]) read their samples here. Counts the
//! samples, the ones lost (gaps in the counter, or classic samples missing
//! a frame) and how many times the measured values repeated exactly.

use anguilla_ipc::SensorHealth;
use anguilla_protocol::Frame;
use anguilla_protocol::message::{
    self, Function, HeadSample, Message, NodeId, NodeSet, SensorStatus, Variant,
};
use anguilla_protocol::time::Nanos;

/// With nothing at all on the bus, a sensor is silent after this many
/// timeouts (the drives' liveness watch normally ends the swim first).
pub const SILENT_BUS_FACTOR: u64 = 5;

#[derive(Debug, Clone, Copy, Default)]
struct Partial {
    sample: Option<u8>,
    quaternion: Option<[f32; 4]>,
    rates: Option<[f32; 3]>,
    accel: Option<[f32; 3]>,
}

/// One sensor's samples, assembled from its frames.
#[derive(Debug, Clone)]
pub struct SampleReader {
    id: NodeId,
    variant: Variant,
    partial: Partial,
    last: Option<HeadSample>,
    counter: Option<u8>,
    last_at: Option<Nanos>,
    /// The bus's clock at the last sample ([`SampleReader::silence`]).
    last_bus: Nanos,
    same: u32,
    samples: u64,
    lost: u64,
    heartbeats: u64,
}

impl SampleReader {
    /// The reader of sensor `id`'s frames in `variant`.
    pub fn new(id: NodeId, variant: Variant) -> Self {
        Self {
            id,
            variant,
            partial: Partial::default(),
            last: None,
            counter: None,
            last_at: None,
            last_bus: Nanos::ZERO,
            same: 0,
            samples: 0,
            lost: 0,
            heartbeats: 0,
        }
    }

    /// Takes `frame` if it is the sensor's (a sample's frame or its
    /// heartbeat): `None` if not (it goes to the drives), else the sample
    /// it completed, if any.
    pub fn ingest(&mut self, now: Nanos, frame: &Frame) -> Option<Option<HeadSample>> {
        let raw = frame.id().as_standard()?;
        let (function, low) = Function::split_id(raw)?;
        if low != self.id.get() {
            return None;
        }
        let ours = matches!(
            function,
            Function::HeadAttitude
                | Function::HeadRates
                | Function::HeadAccel
                | Function::HeadDepth
                | Function::HeadSample
                | Function::Heartbeat
        );
        if !ours {
            return None;
        }
        let mut done = None;
        match message::decode(frame, self.variant, NodeSet::empty().with(self.id)) {
            Ok(Message::HeadSample(s)) => done = Some(self.complete(now, s)),
            Ok(Message::HeadAttitude(a)) => {
                self.start(a.sample);
                self.partial.quaternion = Some(a.quaternion);
            }
            Ok(Message::HeadRates(v)) => {
                self.start(v.sample);
                self.partial.rates = Some(v.xyz);
            }
            Ok(Message::HeadAccel(v)) => {
                self.start(v.sample);
                self.partial.accel = Some(v.xyz);
            }
            Ok(Message::HeadDepth(d)) => {
                let p = core::mem::take(&mut self.partial);
                let attitude_ok = !d.status.has(SensorStatus::ATTITUDE) || p.quaternion.is_some();
                match (p.sample == Some(d.sample), p.rates, p.accel) {
                    (true, Some(rates), Some(accel)) if attitude_ok => {
                        done = Some(self.complete(
                            now,
                            HeadSample {
                                node: d.node,
                                sample: d.sample,
                                quaternion: p.quaternion.unwrap_or([0.0; 4]),
                                rates,
                                accel,
                                pressure: d.pressure,
                                temperature: d.temperature,
                                status: d.status,
                                errors: d.errors,
                            },
                        ))
                    }
                    // A sample whose other frames were lost: counted lost,
                    // and the counter moves on (its gap is not counted again).
                    _ => {
                        self.lost += 1;
                        self.counter = Some(d.sample);
                    }
                }
            }
            Ok(Message::Heartbeat(_)) => self.heartbeats += 1,
            // Malformed sensor frames or another message: dropped.
            _ => {}
        }
        Some(done)
    }

    fn start(&mut self, sample: u8) {
        if self.partial.sample != Some(sample) {
            self.partial = Partial {
                sample: Some(sample),
                ..Partial::default()
            };
        }
    }

    fn complete(&mut self, now: Nanos, s: HeadSample) -> HeadSample {
        if let Some(c) = self.counter {
            let gap = s.sample.wrapping_sub(c);
            if gap > 1 {
                self.lost += u64::from(gap - 1);
            }
        }
        self.counter = Some(s.sample);
        if let Some(last) = &self.last {
            let same = last.quaternion == s.quaternion
                && last.rates == s.rates
                && last.accel == s.accel
                && last.pressure == s.pressure;
            self.same = if same { self.same + 1 } else { 0 };
        }
        self.samples += 1;
        self.last = Some(s);
        self.last_at = Some(now);
        s
    }

    /// Waiting (booting: no sample yet, for five timeouts from `started`)
    /// or Silent, or `None` while samples are current: the first rule of
    /// every IMU's health. Called once a period, after the period's frames.
    ///
    /// Silence is counted on the bus's clock (`bus`: the time of the
    /// periods in which the bus carried a frame, anyone's), not on the
    /// loop's: silent when the bus carried frames for `timeout` since this
    /// sensor's last sample, or when [`SILENT_BUS_FACTOR`] timeouts passed
    /// without one on any clock. A bus on which nobody talks (a robot
    /// stalled as a whole: the built-in robot's thread starved of the CPU)
    /// is the drives' liveness watch's to judge
    /// (`control.heartbeat-timeout`); it is not this sensor's silence.
    pub fn silence(
        &mut self,
        now: Nanos,
        bus: Nanos,
        started: Nanos,
        timeout: Nanos,
    ) -> Option<SensorHealth> {
        if self.last_at == Some(now) {
            self.last_bus = bus;
        }
        match self.last_at {
            None if now.saturating_sub(started) > timeout * 5 => Some(SensorHealth::Silent),
            None => Some(SensorHealth::Waiting),
            Some(at)
                if bus.saturating_sub(self.last_bus) > timeout
                    || now.saturating_sub(at) > timeout * SILENT_BUS_FACTOR =>
            {
                Some(SensorHealth::Silent)
            }
            Some(_) => None,
        }
    }

    /// When the last whole sample arrived.
    pub fn last_at(&self) -> Option<Nanos> {
        self.last_at
    }

    /// The last whole sample.
    pub fn last(&self) -> Option<&HeadSample> {
        self.last.as_ref()
    }

    /// How many samples in a row repeated the one before exactly.
    pub fn repeats(&self) -> u32 {
        self.same
    }

    /// Whole samples received.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Samples lost (counter gaps, incomplete classic samples).
    pub fn lost(&self) -> u64 {
        self.lost
    }

    /// Heartbeats received.
    pub fn heartbeats(&self) -> u64 {
        self.heartbeats
    }
}
