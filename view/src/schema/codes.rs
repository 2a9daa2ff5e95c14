//! The names and codes the channels write (`/anguilla/state`'s modes,
//! causes, holds, sensors, bus and node states, fault bits, log levels),
//! from the operator vocabulary: the schemas' enumerations and the
//! generated tables of `docs/data.md`.

use anguilla_ipc::{
    Cause, FaultKind, GuideState, Hold, HoldState, JointSnapshot, Mode, PositionHealth,
    SensorHealth, bus_state_name, hold_bits,
};
use anguilla_protocol::behaviour;

/// What the writer puts for a name or a code this anguilla does not know
/// (a snapshot from another version, exported).
pub const UNKNOWN: &str = "unknown";

/// The modes' names, as `/anguilla/state` writes them.
pub fn mode_names() -> impl Iterator<Item = &'static str> {
    Mode::ALL.into_iter().map(Mode::name).chain([UNKNOWN])
}

/// The causes' names.
pub fn cause_names() -> impl Iterator<Item = &'static str> {
    Cause::ALL.into_iter().map(Cause::name).chain([UNKNOWN])
}

/// `nav.heading_hold` and `nav.depth_hold`'s names.
pub fn hold_state_names() -> impl Iterator<Item = &'static str> {
    HoldState::ALL
        .into_iter()
        .map(HoldState::name)
        .chain([UNKNOWN])
}

/// A path's state names (`guide.state`).
pub fn guide_state_names() -> impl Iterator<Item = &'static str> {
    GuideState::ALL
        .into_iter()
        .map(GuideState::name)
        .chain([UNKNOWN])
}

/// The position's health names (`nav.position_health`).
pub fn position_health_names() -> impl Iterator<Item = &'static str> {
    PositionHealth::ALL
        .into_iter()
        .map(PositionHealth::name)
        .chain([UNKNOWN])
}

/// The head sensor's health names.
pub fn sensor_names() -> impl Iterator<Item = &'static str> {
    SensorHealth::ALL
        .into_iter()
        .map(SensorHealth::name)
        .chain([UNKNOWN])
}

/// `bus.state`'s codes and names: every code [`bus_state_name`] names
/// (the drivers' `BusState::code`s; a test of the daemon checks they are
/// the same).
pub fn bus_state_codes() -> Vec<(u64, String)> {
    (0..=u8::MAX)
        .filter(|&c| bus_state_name(c) != UNKNOWN)
        .map(|c| (u64::from(c), bus_state_name(c).to_string()))
        .collect()
}

/// `node_state`'s codes and names: the heartbeat's states, and the code
/// of a node that has reported none yet.
pub fn node_state_codes() -> Vec<(u64, String)> {
    behaviour::STATES
        .into_iter()
        .map(|s| (s as u64, behaviour::state_name(s).to_string()))
        .chain([(
            u64::from(JointSnapshot::NO_NODE_STATE),
            "none reported yet".to_string(),
        )])
        .collect()
}

/// `nav.hold`'s values: every combination of [`hold_bits`], named as
/// [`Hold::name`] names it.
pub fn hold_codes() -> Vec<(u64, String)> {
    let all = hold_bits::HEADING | hold_bits::DEPTH;
    (0..=all)
        .map(|b| {
            let h = Hold {
                heading: (b & hold_bits::HEADING != 0).then_some(0.0),
                depth: (b & hold_bits::DEPTH != 0).then_some(0.0),
            };
            debug_assert_eq!(h.bits(), b);
            (u64::from(b), h.name().to_string())
        })
        .collect()
}

/// `fault_kinds`' bits: (bit number, name).
pub fn fault_bits() -> Vec<(u32, &'static str)> {
    FaultKind::ALL
        .into_iter()
        .map(|k| ((k as u32).trailing_zeros(), k.name()))
        .collect()
}

/// The log levels of `foxglove.LogLevel`: (code, name, meaning).
pub const LOG_LEVELS: [(u64, &str, &str); 6] = [
    (0, "UNKNOWN", "unknown level"),
    (1, "DEBUG", "debug"),
    (2, "INFO", "information (a mode change)"),
    (
        3,
        "WARNING",
        "warning (a refused command, the autopilot letting go)",
    ),
    (4, "ERROR", "error (a fault, an e-stop)"),
    (5, "FATAL", "fatal"),
];
