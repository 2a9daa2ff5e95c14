//! Layouts shared by both variants: SYNC, Command, Heartbeat, ConfigWrite,
//! ConfigAck and the status bits of Feedback.

use super::{ErrorBits, POSITION_LIMIT, TORQUE_LIMIT, VELOCITY_LIMIT, WATCHDOG_RANGE_MS};
use crate::signal::{Mux, Signal};

/// SYNC: the cycle counter.
pub const SYNC_COUNTER: Signal =
    Signal::uint("Counter", 0, 16, 65535, "cycle counter, +1 per period");
/// Command code.
pub const COMMAND: Signal = Signal {
    min: 1.0,
    ..Signal::uint("Command", 0, 8, 3, "1 Enable, 2 Disable, 3 ClearFaults")
};
/// Heartbeat state.
pub const HB_STATE: Signal = Signal::uint(
    "State",
    0,
    8,
    4,
    "0 Boot, 1 Disabled, 2 Enabled, 3 Fault, 4 EStop",
);
/// Heartbeat error bits.
pub const HB_ERRORS: Signal = Signal::uint(
    "Errors",
    8,
    16,
    ErrorBits::ALL as u32,
    "error bits, see README",
);
/// Heartbeat counter.
pub const HB_COUNTER: Signal = Signal::uint("Counter", 24, 8, 255, "+1 per heartbeat");
/// Missed SYNC count.
pub const HB_MISSED: Signal = Signal::uint(
    "MissedSyncs",
    32,
    8,
    255,
    "SYNC gaps since ClearFaults, saturating",
);
/// Temperature.
pub const HB_TEMPERATURE: Signal = Signal {
    unit: "degC",
    min: -40.0,
    max: 125.0,
    signed: true,
    ..Signal::uint("Temperature", 40, 8, 0, "hottest motor/driver temperature")
};
/// Config parameter index (multiplexor).
pub const CFG_PARAM: Signal = Signal::uint(
    "Param",
    0,
    8,
    4,
    "0 WatchdogTimeout, 1 SafeAction, 2 PositionLimits, 3 VelocityLimit, 4 TorqueLimit",
)
.muxed(Mux::Switch);
/// Config axis (write: 8 bits).
pub const CFG_AXIS: Signal = Signal::uint(
    "Axis",
    8,
    8,
    1,
    "0 pitch, 1 yaw (0 for node-wide parameters)",
);
/// Config axis (ack: 4 bits).
pub const ACK_AXIS: Signal = Signal::uint(
    "Axis",
    8,
    4,
    1,
    "0 pitch, 1 yaw (0 for node-wide parameters)",
);
/// Config result (ack).
pub const ACK_RESULT: Signal = Signal::uint(
    "Result",
    12,
    4,
    2,
    "0 Accepted, 1 OutOfRange, 2 NotDisabled",
);
/// Watchdog timeout value.
pub const CFG_WATCHDOG: Signal = Signal::ufixed(
    "WatchdogTimeout",
    16,
    16,
    1.0,
    WATCHDOG_RANGE_MS.0 as f64,
    WATCHDOG_RANGE_MS.1 as f64,
    "ms",
    "no setpoint/SYNC for this long: safe action",
)
.muxed(Mux::When(0));
/// Safe action value.
pub const CFG_SAFE_ACTION: Signal =
    Signal::uint("SafeAction", 16, 8, 2, "0 Hold, 1 Limp, 2 Brake").muxed(Mux::When(1));
/// Position lower limit.
pub const CFG_POS_MIN: Signal = Signal::fixed(
    "PositionMin",
    16,
    16,
    0.0001,
    POSITION_LIMIT,
    "rad",
    "lower position limit",
)
.muxed(Mux::When(2));
/// Position upper limit.
pub const CFG_POS_MAX: Signal = Signal::fixed(
    "PositionMax",
    32,
    16,
    0.0001,
    POSITION_LIMIT,
    "rad",
    "upper position limit",
)
.muxed(Mux::When(2));
/// Velocity limit.
pub const CFG_VEL_MAX: Signal = Signal::ufixed(
    "VelocityMax",
    16,
    16,
    0.001,
    0.0,
    VELOCITY_LIMIT,
    "rad/s",
    "absolute velocity limit",
)
.muxed(Mux::When(3));
/// Torque limit.
pub const CFG_TRQ_MAX: Signal = Signal::ufixed(
    "TorqueMax",
    16,
    16,
    0.001,
    0.0,
    TORQUE_LIMIT,
    "N.m",
    "absolute torque limit",
)
.muxed(Mux::When(4));

/// SYNC fields.
pub const SYNC: [Signal; 1] = [SYNC_COUNTER];
/// Command fields.
pub const COMMANDS: [Signal; 1] = [COMMAND];
/// Heartbeat fields.
pub const HEARTBEAT: [Signal; 5] = [HB_STATE, HB_ERRORS, HB_COUNTER, HB_MISSED, HB_TEMPERATURE];
/// ConfigWrite fields.
pub const CONFIG_WRITE: [Signal; 8] = [
    CFG_PARAM,
    CFG_AXIS,
    CFG_WATCHDOG,
    CFG_SAFE_ACTION,
    CFG_POS_MIN,
    CFG_POS_MAX,
    CFG_VEL_MAX,
    CFG_TRQ_MAX,
];
/// ConfigAck fields.
pub const CONFIG_ACK: [Signal; 9] = [
    CFG_PARAM,
    ACK_AXIS,
    ACK_RESULT,
    CFG_WATCHDOG,
    CFG_SAFE_ACTION,
    CFG_POS_MIN,
    CFG_POS_MAX,
    CFG_VEL_MAX,
    CFG_TRQ_MAX,
];
/// Feedback status: node enabled.
pub const FB_ENABLED: Signal = Signal::uint("Enabled", 0, 1, 1, "node is Enabled");
/// Feedback status: node in Fault or E-stop.
pub const FB_FAULT: Signal = Signal::uint("Fault", 1, 1, 1, "node is in Fault or EStop");
/// Feedback status: axis limited.
pub const FB_LIMITED: [Signal; 2] = [
    Signal::uint("PitchLimited", 2, 1, 1, "pitch at or clamped to a limit"),
    Signal::uint("YawLimited", 3, 1, 1, "yaw at or clamped to a limit"),
];
