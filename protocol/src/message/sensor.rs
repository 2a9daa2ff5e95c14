//! The head sensor's payloads: its status and error bytes, and the sample
//! (attitude, rates, acceleration, pressure, depth, temperature) in its
//! CAN FD form and its classic CAN parts.

use super::node::NodeId;

/// The head sensor's status byte: what the sample holds and how good the
/// attitude is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct SensorStatus(pub u8);

impl SensorStatus {
    /// Bits 0..=1: attitude accuracy as a BNO08x reports it (0 unreliable,
    /// 1 low, 2 medium, 3 high); 0 without attitude.
    pub const ACCURACY_MASK: u8 = 0b11;
    /// The attitude (quaternion) is valid: a fusion IMU. A raw 6-axis IMU
    /// leaves this clear and sends no HeadAttitude frame on classic CAN.
    pub const ATTITUDE: u8 = 1 << 2;
    /// Body rates and accelerations are valid.
    pub const IMU: u8 = 1 << 3;
    /// Pressure is valid.
    pub const PRESSURE: u8 = 1 << 4;
    /// Water temperature is valid.
    pub const TEMPERATURE: u8 = 1 << 5;
    /// Every defined bit.
    pub const ALL: u8 = (1 << 6) - 1;

    /// The attitude accuracy, 0..=3.
    pub const fn accuracy(self) -> u8 {
        self.0 & Self::ACCURACY_MASK
    }

    /// Whether every bit of `bits` is set.
    pub const fn has(self, bits: u8) -> bool {
        self.0 & bits == bits
    }
}

/// The head sensor's error byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct SensorErrors(pub u8);

impl SensorErrors {
    /// The IMU does not answer or failed its self-test (fault).
    pub const IMU: u8 = 1 << 0;
    /// The pressure sensor does not answer (fault).
    pub const PRESSURE: u8 = 1 << 1;
    /// The IMU reset since the last sample: attitude is re-converging.
    pub const IMU_RESET: u8 = 1 << 2;
    /// Samples were dropped inside the sensor (the sample counter skips).
    pub const OVERRUN: u8 = 1 << 3;
    /// CAN error-passive or bus-off seen (warning).
    pub const BUS: u8 = 1 << 4;
    /// Every defined bit.
    pub const ALL: u8 = (1 << 5) - 1;

    /// Whether any of `bits` is set.
    pub const fn any(self, bits: u8) -> bool {
        self.0 & bits != 0
    }
}

/// One head-sensor sample: everything the sensor measured at one instant.
/// On CAN FD it travels as one [`Message::HeadSample`](super::Message::HeadSample) frame; on classic
/// CAN as [`Message::HeadAttitude`](super::Message::HeadAttitude) (fusion IMUs only),
/// [`Message::HeadRates`](super::Message::HeadRates), [`Message::HeadAccel`](super::Message::HeadAccel) and
/// [`Message::HeadDepth`](super::Message::HeadDepth), tied together by `sample`
/// ([`encode_head_sample`](super::encode_head_sample)).
///
/// Frames: the head frame is the body frame of the robot's first link,
/// x forward, y left, z up; the attitude rotates head-frame vectors into
/// the world frame (x, y horizontal, z up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadSample {
    /// Reporting sensor.
    pub node: NodeId,
    /// Sample counter, +1 per sample (wraps): pairs a sample's classic
    /// frames and shows lost samples.
    pub sample: u8,
    /// Attitude quaternion `[w, x, y, z]`, each within ±1 (zeros when the
    /// status has no [`SensorStatus::ATTITUDE`]).
    pub quaternion: [f32; 4],
    /// Body rates about the head's x, y, z axes, rad/s, within
    /// ±[`RATE_LIMIT`](super::RATE_LIMIT).
    pub rates: [f32; 3],
    /// Specific force along the head's x, y, z axes, m/s², within
    /// ±[`ACCEL_LIMIT`](super::ACCEL_LIMIT) (what an accelerometer measures: +9.81 on z at rest,
    /// level).
    pub accel: [f32; 3],
    /// Absolute pressure, Pa (0..=16 777 215); the daemon converts it to
    /// depth with its configured water density and surface pressure.
    pub pressure: u32,
    /// Water temperature, °C, -40..=85.
    pub temperature: f32,
    /// What is valid, attitude accuracy.
    pub status: SensorStatus,
    /// Error bits.
    pub errors: SensorErrors,
}

/// Classic CAN: a head sample's attitude.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadAttitude {
    /// Reporting sensor.
    pub node: NodeId,
    /// Sample counter.
    pub sample: u8,
    /// `[w, x, y, z]`, each within ±1.
    pub quaternion: [f32; 4],
}

/// Classic CAN: a head sample's body rates (rad/s) or accelerations (m/s²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadVector {
    /// Reporting sensor.
    pub node: NodeId,
    /// Sample counter.
    pub sample: u8,
    /// Components along the head's x, y, z axes.
    pub xyz: [f32; 3],
}

/// Classic CAN: a head sample's pressure, water temperature, status and
/// errors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadDepth {
    /// Reporting sensor.
    pub node: NodeId,
    /// Sample counter.
    pub sample: u8,
    /// Absolute pressure, Pa.
    pub pressure: u32,
    /// Water temperature, °C.
    pub temperature: f32,
    /// What is valid, attitude accuracy.
    pub status: SensorStatus,
    /// Error bits.
    pub errors: SensorErrors,
}
