//! Why a command was refused ([`Refusal`]), in words the client shows.

use core::fmt;

use super::ClientId;
use super::commands::CommandKind;
use super::fault::FaultSet;
use super::mode::Mode;
use super::sensor::SensorHealth;

/// Which swim parameter a range refusal is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    /// [`SwimParams::amplitude`](super::SwimParams::amplitude).
    Amplitude,
    /// [`SwimParams::frequency`](super::SwimParams::frequency).
    Frequency,
    /// [`SwimParams::turn`](super::SwimParams::turn).
    Turn,
    /// [`SwimParams::pitch`](super::SwimParams::pitch).
    Pitch,
    /// [`Hold::heading`](super::Hold::heading).
    Heading,
    /// [`Hold::depth`](super::Hold::depth).
    Depth,
}

impl Field {
    fn name(self) -> &'static str {
        match self {
            Field::Amplitude => "amplitude",
            Field::Frequency => "frequency (Hz)",
            Field::Turn => "turn curvature (1/m)",
            Field::Pitch => "pitch curvature (1/m)",
            Field::Heading => "heading (deg)",
            Field::Depth => "depth (m)",
        }
    }
}

/// Why a command was refused. `Copy`; its `Display` is the text the client shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Refusal {
    /// The command needs control authority and another client holds it.
    ControlHeldBy(ClientId),
    /// The command needs control authority and nobody holds it.
    NotInControl,
    /// The command is not valid in the current mode.
    InvalidInMode {
        /// The command refused.
        command: CommandKind,
        /// The mode it arrived in.
        mode: Mode,
        /// What would make it valid.
        hint: &'static str,
    },
    /// A swim parameter was NaN or infinite.
    NonFinite(Field),
    /// A swim parameter was outside its configured range.
    OutOfRange {
        /// The parameter.
        field: Field,
        /// The value sent.
        value: f64,
        /// Smallest accepted value.
        min: f64,
        /// Largest accepted value.
        max: f64,
    },
    /// The sequence number was not above the last one from this client
    /// port (a duplicate).
    StaleSequence {
        /// Sequence number received.
        got: u32,
        /// Last sequence number accepted from that client.
        last: u32,
    },
    /// Reset refused: the cause of the fault is still present.
    FaultPersists(FaultSet),
    /// More clients than the daemon tracks (their sequence numbers).
    TooManyClients,
    /// A hold needs a healthy head sensor; this is how it is.
    Sensor(SensorHealth),
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Refusal::ControlHeldBy(c) => write!(
                f,
                "client {c:032x} holds control; ask it to release, or wait for it to time out"
            ),
            Refusal::NotInControl => write!(f, "take control first"),
            Refusal::InvalidInMode {
                command,
                mode,
                hint,
            } => write!(f, "'{command}' is not valid in mode {mode}: {hint}"),
            Refusal::NonFinite(field) => write!(f, "{} is not a finite number", field.name()),
            Refusal::OutOfRange {
                field,
                value,
                min,
                max,
            } => write!(
                f,
                "{} = {value} is out of range (expected {min} ..= {max})",
                field.name()
            ),
            Refusal::StaleSequence { got, last } => write!(
                f,
                "sequence number {got} is not after this client's last one ({last}): every \
                 request uses up its number, accepted or refused"
            ),
            Refusal::FaultPersists(set) => {
                write!(f, "the fault is still present ({set}); fix it, then reset")
            }
            Refusal::TooManyClients => write!(f, "too many clients"),
            Refusal::Sensor(SensorHealth::None) => write!(
                f,
                "no head sensor is configured ([sensor] node); heading and depth hold need one"
            ),
            Refusal::Sensor(h) => write!(
                f,
                "the head sensor is {h}; heading and depth hold need it healthy"
            ),
        }
    }
}
