//! Classic CAN layouts: 8-byte per-node frames, 14-bit positions, 8-bit
//! velocities and torques.

use super::common;
use super::types::{POSITION_LIMIT, TORQUE_LIMIT, VELOCITY_LIMIT};
use crate::signal::Signal;

/// Position scale: 0.2 mrad per count (14 bits, ±1.638 rad representable).
pub const POSITION_FACTOR: f64 = 0.0002;
/// Velocity scale: 0.08 rad/s per count (8 bits).
pub const VELOCITY_FACTOR: f64 = 0.08;
/// Torque scale: 0.04 N·m per count (8 bits).
pub const TORQUE_FACTOR: f64 = 0.04;

/// Setpoint cycle tag.
pub const SP_CYCLE: Signal = Signal::uint(
    "Cycle",
    0,
    4,
    15,
    "low 4 bits of the SYNC counter to apply at",
);
/// Setpoint positions (pitch, yaw).
pub const SP_POSITION: [Signal; 2] = [
    Signal::fixed(
        "PitchPosition",
        4,
        14,
        POSITION_FACTOR,
        POSITION_LIMIT,
        "rad",
        "pitch position setpoint",
    ),
    Signal::fixed(
        "YawPosition",
        18,
        14,
        POSITION_FACTOR,
        POSITION_LIMIT,
        "rad",
        "yaw position setpoint",
    ),
];
/// Setpoint velocity feedforward (pitch, yaw).
pub const SP_VELOCITY: [Signal; 2] = [
    Signal::fixed(
        "PitchVelocity",
        32,
        8,
        VELOCITY_FACTOR,
        VELOCITY_LIMIT,
        "rad/s",
        "pitch velocity feedforward",
    ),
    Signal::fixed(
        "YawVelocity",
        40,
        8,
        VELOCITY_FACTOR,
        VELOCITY_LIMIT,
        "rad/s",
        "yaw velocity feedforward",
    ),
];
/// Setpoint torque feedforward (pitch, yaw).
pub const SP_TORQUE: [Signal; 2] = [
    Signal::fixed(
        "PitchTorque",
        48,
        8,
        TORQUE_FACTOR,
        TORQUE_LIMIT,
        "N.m",
        "pitch torque feedforward",
    ),
    Signal::fixed(
        "YawTorque",
        56,
        8,
        TORQUE_FACTOR,
        TORQUE_LIMIT,
        "N.m",
        "yaw torque feedforward",
    ),
];
/// Feedback positions.
pub const FB_POSITION: [Signal; 2] = [
    Signal::fixed(
        "PitchPosition",
        4,
        14,
        POSITION_FACTOR,
        POSITION_LIMIT,
        "rad",
        "pitch position",
    ),
    Signal::fixed(
        "YawPosition",
        18,
        14,
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
        32,
        8,
        VELOCITY_FACTOR,
        VELOCITY_LIMIT,
        "rad/s",
        "pitch velocity",
    ),
    Signal::fixed(
        "YawVelocity",
        40,
        8,
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
        48,
        8,
        TORQUE_FACTOR,
        TORQUE_LIMIT,
        "N.m",
        "pitch torque",
    ),
    Signal::fixed(
        "YawTorque",
        56,
        8,
        TORQUE_FACTOR,
        TORQUE_LIMIT,
        "N.m",
        "yaw torque",
    ),
];
/// Setpoint fields.
pub const SETPOINT: [Signal; 7] = [
    SP_CYCLE,
    SP_POSITION[0],
    SP_POSITION[1],
    SP_VELOCITY[0],
    SP_VELOCITY[1],
    SP_TORQUE[0],
    SP_TORQUE[1],
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

/// Head sensor sample counter (every head frame's first byte).
pub const HEAD_SAMPLE: Signal = common::head_sample(0);
/// Head attitude: quaternion w, x, y, z in 14 bits each, full scale ±1
/// (1/8191 per count).
pub const HEAD_QUATERNION: [Signal; 4] = common::head_quaternion(8, 14);
/// Head body rates.
pub const HEAD_RATES: [Signal; 3] = common::head_rates(8);
/// Head accelerations.
pub const HEAD_ACCEL: [Signal; 3] = common::head_accel(8);
/// Head absolute pressure.
pub const HEAD_PRESSURE: Signal = common::head_pressure(8);
/// Head water temperature.
pub const HEAD_TEMPERATURE: Signal = common::head_temperature(32);
/// Head sensor status.
pub const HEAD_STATUS: Signal = common::head_status(48);
/// Head sensor errors.
pub const HEAD_ERRORS: Signal = common::head_errors(56);
/// HeadAttitude fields.
pub const HEAD_ATTITUDE_FRAME: [Signal; 5] = [
    HEAD_SAMPLE,
    HEAD_QUATERNION[0],
    HEAD_QUATERNION[1],
    HEAD_QUATERNION[2],
    HEAD_QUATERNION[3],
];
/// HeadRates fields.
pub const HEAD_RATES_FRAME: [Signal; 4] =
    [HEAD_SAMPLE, HEAD_RATES[0], HEAD_RATES[1], HEAD_RATES[2]];
/// HeadAccel fields.
pub const HEAD_ACCEL_FRAME: [Signal; 4] =
    [HEAD_SAMPLE, HEAD_ACCEL[0], HEAD_ACCEL[1], HEAD_ACCEL[2]];
/// HeadDepth fields.
pub const HEAD_DEPTH_FRAME: [Signal; 5] = [
    HEAD_SAMPLE,
    HEAD_PRESSURE,
    HEAD_TEMPERATURE,
    HEAD_STATUS,
    HEAD_ERRORS,
];
