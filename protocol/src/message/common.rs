//! Layouts shared by both variants: SYNC, Command, Heartbeat, ConfigWrite,
//! ConfigAck, the status bits of Feedback, and the head sensor's fields
//! (placed per variant by [`super::classic`] and [`super::fd`]).

use super::sensor::{SensorErrors, SensorStatus};
use super::types::{
    ACCEL_LIMIT, ErrorBits, POSITION_LIMIT, RATE_LIMIT, TORQUE_LIMIT, VELOCITY_LIMIT,
    WATCHDOG_RANGE_MS,
};
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

/// Head sensor body-rate scale: 2 mrad/s per count (16 bits, ±35 rad/s).
pub const RATE_FACTOR: f64 = 0.002;
/// Head sensor acceleration scale: 5 mm/s² per count (16 bits, ±160 m/s²).
pub const ACCEL_FACTOR: f64 = 0.005;
/// Head sensor pressure scale: 1 Pa per count (24 bits unsigned, up to
/// 16.7 MPa absolute, about 1 700 m of water).
pub const PRESSURE_FACTOR: f64 = 1.0;
/// Head sensor water temperature scale: 0.01 °C per count (16 bits).
pub const WATER_TEMPERATURE_FACTOR: f64 = 0.01;
/// Largest pressure a head sample carries, Pa.
pub const PRESSURE_MAX: u32 = (1 << 24) - 1;

/// The head sensor's sample counter at `start`.
pub const fn head_sample(start: u16) -> Signal {
    Signal::uint(
        "Sample",
        start,
        8,
        255,
        "+1 per sample: pairs frames, shows losses",
    )
}

/// The head sensor's status byte at `start`.
pub const fn head_status(start: u16) -> Signal {
    Signal::uint(
        "Status",
        start,
        8,
        SensorStatus::ALL as u32,
        "bits 0-1 attitude accuracy, 2 attitude, 3 IMU, 4 pressure, 5 temperature valid",
    )
}

/// The head sensor's error byte at `start`.
pub const fn head_errors(start: u16) -> Signal {
    Signal::uint(
        "Errors",
        start,
        8,
        SensorErrors::ALL as u32,
        "0 IMU, 1 pressure sensor, 2 IMU reset, 3 overrun, 4 bus",
    )
}

/// The head sensor's absolute pressure (u24) at `start`.
pub const fn head_pressure(start: u16) -> Signal {
    Signal::ufixed(
        "Pressure",
        start,
        24,
        PRESSURE_FACTOR,
        0.0,
        PRESSURE_MAX as f64,
        "Pa",
        "absolute pressure",
    )
}

/// The head sensor's water temperature (i16) at `start`.
pub const fn head_temperature(start: u16) -> Signal {
    Signal {
        min: -40.0,
        max: 85.0,
        ..Signal::fixed(
            "WaterTemperature",
            start,
            16,
            WATER_TEMPERATURE_FACTOR,
            0.0,
            "degC",
            "water temperature",
        )
    }
}

/// The head sensor's body rates (x, y, z; i16 each) from `start`.
pub const fn head_rates(start: u16) -> [Signal; 3] {
    const fn s(name: &'static str, start: u16, comment: &'static str) -> Signal {
        Signal::fixed(name, start, 16, RATE_FACTOR, RATE_LIMIT, "rad/s", comment)
    }
    [
        s(
            "RateX",
            start,
            "body rate about the head's x (forward) axis",
        ),
        s(
            "RateY",
            start + 16,
            "body rate about the head's y (left) axis",
        ),
        s(
            "RateZ",
            start + 32,
            "body rate about the head's z (up) axis",
        ),
    ]
}

/// The head sensor's accelerations (x, y, z; i16 each) from `start`.
pub const fn head_accel(start: u16) -> [Signal; 3] {
    const fn s(name: &'static str, start: u16, comment: &'static str) -> Signal {
        Signal::fixed(name, start, 16, ACCEL_FACTOR, ACCEL_LIMIT, "m/s^2", comment)
    }
    [
        s("AccelX", start, "specific force along the head's x axis"),
        s(
            "AccelY",
            start + 16,
            "specific force along the head's y axis",
        ),
        s(
            "AccelZ",
            start + 32,
            "specific force along the head's z axis",
        ),
    ]
}

/// The head sensor's attitude quaternion (w, x, y, z; `bits` each, full
/// scale ±1) from `start`.
pub const fn head_quaternion(start: u16, bits: u8) -> [Signal; 4] {
    let factor = 1.0 / ((1u32 << (bits - 1)) - 1) as f64;
    let b = bits as u16;
    let q = Signal::fixed(
        "QuatW",
        start,
        bits,
        factor,
        1.0,
        "",
        "attitude quaternion w (head to world)",
    );
    [
        q,
        Signal {
            name: "QuatX",
            start: start + b,
            comment: "attitude quaternion x",
            ..q
        },
        Signal {
            name: "QuatY",
            start: start + 2 * b,
            comment: "attitude quaternion y",
            ..q
        },
        Signal {
            name: "QuatZ",
            start: start + 3 * b,
            comment: "attitude quaternion z",
            ..q
        },
    ]
}
