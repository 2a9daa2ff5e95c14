//! The operator vocabulary: modes, causes, commands, swim parameters,
//! refusals and fault sets — what the daemon and every operator tool say to
//! each other, independent of the transport.
//!
//! Its files: `mode.rs` ([`Mode`], [`Cause`]), `swim.rs` ([`SwimParams`],
//! [`Hold`], [`HoldState`]), `sensor.rs` ([`SensorHealth`],
//! [`PositionHealth`], [`SensorKind`]), `commands.rs` ([`Command`], [`CommandKind`]), `path.rs` ([`Waypoint`],
//! [`Follow`], [`GuideState`]),
//! `refusal.rs` ([`Refusal`], [`Field`]) and `fault.rs` ([`FaultKind`],
//! [`FaultSet`]).

/// Monotonic time in nanoseconds, from the daemon loop's clock (the one
/// time type of the bus, defined in `anguilla_protocol::time`).
pub use anguilla_protocol::time::Nanos;

/// A client's identity: the unique id of the iceoryx2 client port its
/// requests arrive on (chosen by iceoryx2, not by the client).
pub type ClientId = u128;

mod commands;
mod fault;
mod mode;
mod path;
mod refusal;
mod sensor;
mod swim;

pub use commands::{Command, CommandKind};
pub use fault::{FaultKind, FaultSet};
pub use mode::{Cause, Mode};
pub use path::{Follow, GuideState, MAX_WAYPOINTS, Waypoint};
pub use refusal::{Field, Refusal};
pub use sensor::{PositionHealth, SensorHealth, SensorKind};
pub use swim::{
    HOLD_DEPTH_TOLERANCE, HOLD_HEADING_TOLERANCE, Hold, HoldState, SURFACE_DEPTH, SwimParams,
    hold_bits, wrap_heading,
};
