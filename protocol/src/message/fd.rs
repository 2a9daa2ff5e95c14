//! CAN FD layouts: six-node setpoint groups and 12-byte feedback, 16-bit
//! positions, 12-bit velocities and torques.

use super::common;
use super::types::{GROUP_SLOTS, POSITION_LIMIT, TORQUE_LIMIT, VELOCITY_LIMIT};
use crate::signal::Signal;

/// Position scale: 0.05 mrad per count (16 bits, ±1.638 rad representable).
pub const POSITION_FACTOR: f64 = 0.00005;
/// Velocity scale: 5 mrad/s per count (12 bits).
pub const VELOCITY_FACTOR: f64 = 0.005;
/// Torque scale: 2.5 mN·m per count (12 bits).
pub const TORQUE_FACTOR: f64 = 0.0025;
/// First bit of slot 0 in a group frame.
pub const SLOT_BASE: u16 = 16;
/// Bits per slot.
pub const SLOT_BITS: u16 = 80;

/// Group cycle tag.
pub const GROUP_CYCLE: Signal = Signal::uint(
    "Cycle",
    0,
    8,
    255,
    "low 8 bits of the SYNC counter to apply at",
);
/// Which slots carry setpoints.
pub const GROUP_MASK: Signal = Signal::uint(
    "SlotMask",
    8,
    6,
    63,
    "bit s set: slot s (node 6g+s+1) present",
);
/// Slot-relative positions.
pub const SLOT_POSITION: [Signal; 2] = [
    Signal::fixed(
        "PitchPosition",
        0,
        16,
        POSITION_FACTOR,
        POSITION_LIMIT,
        "rad",
        "pitch position setpoint",
    ),
    Signal::fixed(
        "YawPosition",
        16,
        16,
        POSITION_FACTOR,
        POSITION_LIMIT,
        "rad",
        "yaw position setpoint",
    ),
];
/// Slot-relative velocities.
pub const SLOT_VELOCITY: [Signal; 2] = [
    Signal::fixed(
        "PitchVelocity",
        32,
        12,
        VELOCITY_FACTOR,
        VELOCITY_LIMIT,
        "rad/s",
        "pitch velocity feedforward",
    ),
    Signal::fixed(
        "YawVelocity",
        44,
        12,
        VELOCITY_FACTOR,
        VELOCITY_LIMIT,
        "rad/s",
        "yaw velocity feedforward",
    ),
];
/// Slot-relative torques.
pub const SLOT_TORQUE: [Signal; 2] = [
    Signal::fixed(
        "PitchTorque",
        56,
        12,
        TORQUE_FACTOR,
        TORQUE_LIMIT,
        "N.m",
        "pitch torque feedforward",
    ),
    Signal::fixed(
        "YawTorque",
        68,
        12,
        TORQUE_FACTOR,
        TORQUE_LIMIT,
        "N.m",
        "yaw torque feedforward",
    ),
];

const fn group_signals() -> [Signal; 2 + 6 * GROUP_SLOTS] {
    let per_slot = [
        SLOT_POSITION[0],
        SLOT_POSITION[1],
        SLOT_VELOCITY[0],
        SLOT_VELOCITY[1],
        SLOT_TORQUE[0],
        SLOT_TORQUE[1],
    ];
    let mut out = [GROUP_CYCLE; 2 + 6 * GROUP_SLOTS];
    out[1] = GROUP_MASK;
    let mut s = 0;
    while s < GROUP_SLOTS {
        let mut k = 0;
        while k < 6 {
            out[2 + s * 6 + k] = per_slot[k].in_slot(s as u8, SLOT_BASE, SLOT_BITS);
            k += 1;
        }
        s += 1;
    }
    out
}

/// Setpoint group fields (slot signals at their absolute positions).
pub const SETPOINT_GROUP: [Signal; 2 + 6 * GROUP_SLOTS] = group_signals();

/// Feedback positions.
pub const FB_POSITION: [Signal; 2] = [
    Signal::fixed(
        "PitchPosition",
        8,
        16,
        POSITION_FACTOR,
        POSITION_LIMIT,
        "rad",
        "pitch position",
    ),
    Signal::fixed(
        "YawPosition",
        24,
        16,
        POSITION_FACTOR,
        POSITION_LIMIT,
        "rad",
        "yaw position",
    ),
];
/// Feedback velocities.
pub const FB_VELOCITY: [Signal; 2] = [
    Signal::fixed(
        "PitchVelocity",
        40,
        12,
        VELOCITY_FACTOR,
        VELOCITY_LIMIT,
        "rad/s",
        "pitch velocity",
    ),
    Signal::fixed(
        "YawVelocity",
        52,
        12,
        VELOCITY_FACTOR,
        VELOCITY_LIMIT,
        "rad/s",
        "yaw velocity",
    ),
];
/// Feedback torques.
pub const FB_TORQUE: [Signal; 2] = [
    Signal::fixed(
        "PitchTorque",
        64,
        12,
        TORQUE_FACTOR,
        TORQUE_LIMIT,
        "N.m",
        "pitch torque",
    ),
    Signal::fixed(
        "YawTorque",
        76,
        12,
        TORQUE_FACTOR,
        TORQUE_LIMIT,
        "N.m",
        "yaw torque",
    ),
];
/// Feedback fields.
pub const FEEDBACK: [Signal; 10] = [
    common::FB_ENABLED,
    common::FB_FAULT,
    common::FB_LIMITED[0],
    common::FB_LIMITED[1],
    FB_POSITION[0],
    FB_POSITION[1],
    FB_VELOCITY[0],
    FB_VELOCITY[1],
    FB_TORQUE[0],
    FB_TORQUE[1],
];

/// Data length of a group frame whose highest present slot is `slots - 1`.
pub const fn group_len(slots: usize) -> usize {
    let bytes = (SLOT_BASE as usize + slots * SLOT_BITS as usize).div_ceil(8);
    let l = crate::frame::FD_LENGTHS;
    let mut i = 0;
    while i < l.len() {
        if l[i] as usize >= bytes {
            return l[i] as usize;
        }
        i += 1;
    }
    64
}

/// Head sensor sample counter.
pub const HEAD_SAMPLE: Signal = common::head_sample(0);
/// Head sensor status.
pub const HEAD_STATUS: Signal = common::head_status(8);
/// Head sensor errors.
pub const HEAD_ERRORS: Signal = common::head_errors(16);
/// Head absolute pressure.
pub const HEAD_PRESSURE: Signal = common::head_pressure(24);
/// Head water temperature.
pub const HEAD_TEMPERATURE: Signal = common::head_temperature(48);
/// Head attitude: quaternion w, x, y, z in 16 bits each, full scale ±1
/// (1/32767 per count).
pub const HEAD_QUATERNION: [Signal; 4] = common::head_quaternion(64, 16);
/// Head body rates.
pub const HEAD_RATES: [Signal; 3] = common::head_rates(128);
/// Head accelerations.
pub const HEAD_ACCEL: [Signal; 3] = common::head_accel(176);
/// HeadSample fields (28 bytes used of a 32-byte frame).
pub const HEAD_SAMPLE_FRAME: [Signal; 15] = [
    HEAD_SAMPLE,
    HEAD_STATUS,
    HEAD_ERRORS,
    HEAD_PRESSURE,
    HEAD_TEMPERATURE,
    HEAD_QUATERNION[0],
    HEAD_QUATERNION[1],
    HEAD_QUATERNION[2],
    HEAD_QUATERNION[3],
    HEAD_RATES[0],
    HEAD_RATES[1],
    HEAD_RATES[2],
    HEAD_ACCEL[0],
    HEAD_ACCEL[1],
    HEAD_ACCEL[2],
];
