//! The wire's arithmetic: one frame's worst-case length, the bit rates,
//! a budget line (frames of one kind and their cadence), and the anguilla
//! protocol's own lines. Below the families ([`crate::family`]), which
//! give their drives' lines in these terms, and below the whole budget
//! ([`super::Traffic`]), which sums them.

use crate::frame::{Frame, Kind};
use crate::message::{
    AxisFeedback, DEFAULT_HEAD_SENSOR_ID, ErrorBits, Feedback, HEARTBEAT_PERIOD_MS, HeadSample,
    Heartbeat, Message, NodeId, NodeSet, NodeState, SensorErrors, SensorStatus, Variant,
    encode_head_sample, encode_setpoints,
};

/// Worst-case length of one frame: bits at the nominal rate and at the data
/// rate (FD with bit-rate switch only), including the interframe space.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameBits {
    /// Bit times at the nominal (arbitration) rate.
    pub nominal: u32,
    /// Bit times at the data rate (0 for classic frames and FD without BRS).
    pub data: u32,
}

impl FrameBits {
    /// Duration in seconds at the given rates.
    pub fn seconds(self, rates: Bitrates) -> f64 {
        let data_rate = rates.data.unwrap_or(rates.nominal);
        self.nominal as f64 / rates.nominal as f64 + self.data as f64 / data_rate as f64
    }
}

/// Worst-case on-the-wire length of `frame` with bit stuffing and IFS.
pub fn worst_case_bits(frame: &Frame) -> FrameBits {
    let n = frame.len() as u32;
    match frame.kind() {
        Kind::Data | Kind::Remote { .. } => {
            let header = if frame.id().is_extended() { 39 } else { 19 };
            let stuffed = header + 8 * n + 15;
            FrameBits {
                nominal: stuffed + (stuffed - 1) / 4 + 13,
                data: 0,
            }
        }
        Kind::Fd { brs, .. } => {
            let arbitration = if frame.id().is_extended() { 36 } else { 17 };
            let dynamic = arbitration + 5 + 8 * n;
            let stuff = (dynamic - 1) / 4;
            let arb_stuff = (arbitration - 1) / 4;
            let crc_field = if n <= 16 { 4 + 17 + 6 } else { 4 + 21 + 7 };
            let nominal = arbitration + arb_stuff + 13;
            let data = 5 + 8 * n + (stuff - arb_stuff) + crc_field;
            if brs {
                FrameBits { nominal, data }
            } else {
                FrameBits {
                    nominal: nominal + data,
                    data: 0,
                }
            }
        }
    }
}

/// Nominal and (CAN FD) data bit rates, bit/s.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bitrates {
    /// Nominal (arbitration) rate.
    pub nominal: u32,
    /// Data-phase rate (CAN FD with BRS); `None` on classic CAN.
    pub data: Option<u32>,
}

impl Bitrates {
    /// The variant these rates imply.
    pub const fn variant(self) -> Variant {
        match self.data {
            Some(_) => Variant::Fd,
            None => Variant::Classic,
        }
    }

    /// Checks the rates are physically sensible: nominal 10 kbit/s..=1 Mbit/s,
    /// data rate nominal..=12 Mbit/s.
    pub fn validate(self) -> Result<Self, BudgetError> {
        if !(10_000..=1_000_000).contains(&self.nominal) {
            return Err(BudgetError::NominalRate(self.nominal));
        }
        if let Some(d) = self.data
            && !(self.nominal..=12_000_000).contains(&d)
        {
            return Err(BudgetError::DataRate {
                data: d,
                nominal: self.nominal,
            });
        }
        Ok(self)
    }
}

/// Bad budget inputs.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum BudgetError {
    /// Nominal bit rate outside 10 kbit/s..=1 Mbit/s.
    #[error("nominal bit rate {0} bit/s (expected 10000..=1000000)")]
    NominalRate(u32),
    /// Data bit rate below the nominal rate or above 12 Mbit/s.
    #[error("data bit rate {data} bit/s (expected {nominal}..=12000000)")]
    DataRate {
        /// Given data rate.
        data: u32,
        /// Nominal rate.
        nominal: u32,
    },
    /// Control rate not a positive finite number, or above 20 kHz.
    #[error("control rate {0} Hz (expected > 0 and <= 20000)")]
    Rate(f64),
    /// Joint count outside 1..=63.
    #[error("{0} joints (expected 1..=63, one node per joint)")]
    Joints(u32),
    /// A bought drive family on CAN FD (their protocols are classic CAN).
    #[error("CiA 402 and ODrive drives speak classic CAN (expected no data bit rate)")]
    ClassicOnly,
    /// Load target outside (0, 1].
    #[error("load limit {0} (expected a fraction in (0, 1])")]
    Load(f64),
    /// Head sensor sample rate outside 100..=200 Hz.
    #[error("head sensor rate {0} Hz (expected 100..=200)")]
    HeadSensorRate(u16),
}

/// How often a budget line's frames are sent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Cadence {
    /// `count` frames every control period.
    PerPeriod(u32),
    /// `count` frames per second whatever the control rate (heartbeats).
    PerSecond(f64),
}

/// One kind of frame in the control traffic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BudgetLine {
    /// Message name.
    pub name: &'static str,
    /// Data bytes of the frame (the longest, where frames differ).
    pub bytes: u8,
    /// How many are sent.
    pub cadence: Cadence,
    /// Worst-case bits of all these frames in one period, summed: nominal
    /// and data-rate bits per frame sum over the frames of one period (for
    /// per-second lines, per frame).
    pub bits: FrameBits,
}

impl BudgetLine {
    /// Bus time per second, at control rate `rate`, in seconds.
    pub fn busy_per_second(&self, rates: Bitrates, rate: f64) -> f64 {
        match self.cadence {
            Cadence::PerPeriod(_) => self.bits.seconds(rates) * rate,
            Cadence::PerSecond(c) => self.bits.seconds(rates) * c,
        }
    }

    /// Frames in one period (fractional for per-second lines).
    pub fn frames_per_period(&self, rate: f64) -> f64 {
        match self.cadence {
            Cadence::PerPeriod(c) => c as f64,
            Cadence::PerSecond(c) => c / rate,
        }
    }
}

/// The cyclic traffic of a robot whose nodes have the ids in `nodes`,
/// computed by encoding the actual frames: setpoints, SYNC, feedback,
/// heartbeats. Event messages (E-stop, commands, configuration) are not
/// cyclic and not counted. On CAN FD the setpoint frames depend on the ids,
/// not only their number: ids 1..=6 share one group frame, ids 1, 7, 13
/// take three. An empty set counts as node 1.
pub fn control_traffic(variant: Variant, nodes: NodeSet) -> [BudgetLine; 4] {
    let nodes = if nodes.is_empty() {
        NodeSet::first(1)
    } else {
        nodes
    };
    let joints = nodes.len() as u32;
    // Setpoints: encode a real period's frames and sum them.
    let (mut sp_count, mut sp_bytes, mut sp_bits) = (
        0u32,
        0u8,
        FrameBits {
            nominal: 0,
            data: 0,
        },
    );
    let setpoints = nodes.iter().map(|id| (id, [Default::default(); 2]));
    encode_setpoints(variant, 0, setpoints, |f| {
        let b = worst_case_bits(&f);
        sp_count += 1;
        sp_bytes = sp_bytes.max(f.len() as u8);
        sp_bits.nominal += b.nominal;
        sp_bits.data += b.data;
    })
    .expect("zero setpoints encode");
    let sp_name = match variant {
        Variant::Classic => "Setpoint",
        Variant::Fd => "SetpointGroup",
    };
    let node = NodeId::new(1).expect("1 is a node id");
    let sync = Message::Sync { counter: 0 }
        .encode(variant)
        .expect("sync encodes");
    let feedback = Message::Feedback(Feedback {
        node,
        enabled: true,
        fault: false,
        axes: [AxisFeedback::default(); 2],
    })
    .encode(variant)
    .expect("feedback encodes");
    let heartbeat = heartbeat_frame(variant, node);
    let fb = worst_case_bits(&feedback);
    [
        BudgetLine {
            name: sp_name,
            bytes: sp_bytes,
            cadence: Cadence::PerPeriod(sp_count),
            bits: sp_bits,
        },
        BudgetLine {
            name: "Sync",
            bytes: sync.len() as u8,
            cadence: Cadence::PerPeriod(1),
            bits: worst_case_bits(&sync),
        },
        BudgetLine {
            name: "Feedback",
            bytes: feedback.len() as u8,
            cadence: Cadence::PerPeriod(joints),
            bits: FrameBits {
                nominal: fb.nominal * joints,
                data: fb.data * joints,
            },
        },
        BudgetLine {
            name: "Heartbeat",
            bytes: heartbeat.len() as u8,
            cadence: Cadence::PerSecond(joints as f64 * 1000.0 / HEARTBEAT_PERIOD_MS as f64),
            bits: worst_case_bits(&heartbeat),
        },
    ]
}

/// The cyclic traffic of a head sensor sampling at `rate_hz` (100..=200):
/// its sample frames every sample (on classic CAN the four frames of a
/// fusion IMU, the worst case; one HeadSample on CAN FD) and its heartbeat
/// every 100 ms. Per-second lines: the sensor runs on its own clock, not
/// the control period.
pub fn head_sensor_traffic(variant: Variant, rate_hz: u16) -> Vec<BudgetLine> {
    let node = NodeId::new(DEFAULT_HEAD_SENSOR_ID).expect("a node id");
    let sample = HeadSample {
        node,
        sample: 0,
        quaternion: [1.0, 0.0, 0.0, 0.0],
        rates: [0.0; 3],
        accel: [0.0; 3],
        pressure: 101_325,
        temperature: 15.0,
        status: SensorStatus(SensorStatus::ALL),
        errors: SensorErrors(0),
    };
    let mut lines = Vec::with_capacity(5);
    encode_head_sample(variant, &sample, |f| {
        let name = match crate::message::decode(&f, variant, NodeSet::empty().with(node)) {
            Ok(m) => crate::message::function_name(m.function()),
            Err(_) => "HeadSample",
        };
        lines.push(BudgetLine {
            name,
            bytes: f.len() as u8,
            cadence: Cadence::PerSecond(rate_hz as f64),
            bits: worst_case_bits(&f),
        });
    })
    .expect("a zero sample encodes");
    let heartbeat = heartbeat_frame(variant, node);
    lines.push(BudgetLine {
        name: "Heartbeat (head sensor)",
        bytes: heartbeat.len() as u8,
        cadence: Cadence::PerSecond(1000.0 / HEARTBEAT_PERIOD_MS as f64),
        bits: worst_case_bits(&heartbeat),
    });
    lines
}

impl BudgetLine {
    /// The line of `cadence` frames like `f` (per period: that many frames
    /// each period; per second: one frame's bits, paid `count` times a
    /// second).
    pub fn of(name: &'static str, f: &Frame, cadence: Cadence) -> BudgetLine {
        let b = worst_case_bits(f);
        let k = match cadence {
            Cadence::PerPeriod(c) => c,
            Cadence::PerSecond(_) => 1,
        };
        BudgetLine {
            name,
            bytes: f.len() as u8,
            cadence,
            bits: FrameBits {
                nominal: b.nominal * k,
                data: b.data * k,
            },
        }
    }
}

/// A node's heartbeat as the budget counts it (its length does not depend
/// on the values).
fn heartbeat_frame(variant: Variant, node: NodeId) -> Frame {
    Message::Heartbeat(Heartbeat {
        node,
        state: NodeState::Enabled,
        errors: ErrorBits(0),
        counter: 0,
        missed_syncs: 0,
        temperature: 20,
    })
    .encode(variant)
    .expect("heartbeat encodes")
}
