//! Classic CAN layouts: 8-byte per-node frames, 14-bit positions, 8-bit
//! velocities and torques.

use super::{POSITION_LIMIT, TORQUE_LIMIT, VELOCITY_LIMIT, common};
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
