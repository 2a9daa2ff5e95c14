//! anguilla's state as its viewers see it, one definition for all of
//! them: below the daemon and the operator tools, above the shared-memory
//! payload ([`anguilla_ipc::StateSnapshot`]).
//!
//! - **Messages** ([`State`], [`Joints`], [`Sensors`],
//!   [`truth::Truth`], and Foxglove's [`foxglove::Log`],
//!   [`foxglove::FrameTransforms`], [`foxglove::SceneUpdate`]): typed
//!   structs made from a snapshot, each defined
//!   once with its fields' schema beside them ([`view!`]), so the JSON a
//!   viewer gets and the JSON Schema it is checked against are the same
//!   definition. The recorder (the session's MCAP file) and the live
//!   Foxglove server write them; `docs/data.md`'s field tables are
//!   generated from them ([`schema::markdown`]).
//! - **The head's pose** ([`pose`]): the daemon's estimate where it has
//!   one, else the model's prediction integrated; the recording's `/tf`,
//!   Foxglove and the ROS 2 node's `tf` all take it from here.
//! - **The scene** ([`Scene`]): a stream of snapshots turned into the
//!   channels' messages ([`TOPICS`]), with the `/log` lines of what
//!   changed, the body's links posed from the measured joint angles, and
//!   the guide drawn in the world: the path's legs, the cross-track error
//!   and the position estimate's uncertainty.
//!
//! ```
//! use anguilla_ipc::StateSnapshot;
//! use anguilla_view::{Scene, TOPICS, schema, schemas};
//!
//! let mut scene = Scene::new(12);
//! let s = StateSnapshot { joint_count: 12, ..StateSnapshot::default() };
//! let all = schema::all();
//! for (channel, message) in scene.messages(&s) {
//!     assert_eq!(schema::check(&all[channel].1, &message), Ok(()), "{}", TOPICS[channel]);
//! }
//! assert_eq!(schemas()[0].0, "anguilla.State");
//! ```

#![warn(missing_docs)]

mod changes;
#[doc(hidden)]
pub mod define;
pub mod foxglove;
mod guide;
mod message;
pub mod pose;
mod scene;
pub mod schema;
mod svg;
pub mod truth;

pub use changes::{guide_line, hold_line, position_line, surface_line};
pub use foxglove::GUIDE_LEGS;
pub use guide::centre_and_foot;
pub use message::{Bus, Gait, Guide, Joints, Loop, Nav, Sensor, SensorValue, Sensors, State};
pub use scene::{Link, Scene, segments};

/// The channels, in the order they are created.
pub const TOPICS: [&str; 6] = [
    "/anguilla/state",
    "/anguilla/joints",
    "/log",
    "/tf",
    "/body",
    "/anguilla/sensors",
];

/// The schemas of [`TOPICS`], in order: (name, JSON schema text); see
/// [`schema`].
pub fn schemas() -> [(&'static str, Vec<u8>); 6] {
    schema::all().map(|(name, s)| (name, s.to_string().into_bytes()))
}

/// A message as JSON. The messages here are structs of numbers, strings
/// and lists, which always serialize; `null` is unreachable.
pub fn to_json<T: serde::Serialize>(message: &T) -> serde_json::Value {
    serde_json::to_value(message).unwrap_or(serde_json::Value::Null)
}
