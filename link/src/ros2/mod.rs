//! ROS 2 without ROS: the robot as a ROS 2 node on rmw_zenoh's wire
//! (docs/ros2.md). rmw_zenoh, ROS 2's Zenoh middleware, talks plain Zenoh:
//! a session that declares its liveliness tokens, keys, CDR payloads and
//! attachments is a node to every other node, with no ROS installed here.
//!
//! - [`cdr`]: the payloads' encoding;
//! - [`msgs`]: the messages, their type names and RIHS01 hashes;
//! - [`graph`]: tokens, keys, QoS text and attachments;
//! - [`state`]: the daemon's state as those messages;
//! - [`bag`]: a recorded session as a rosbag2 MCAP (`anguilla export --ros2`);
//! - `node` (feature `zenoh`): the node `anguilla link` runs beside its
//!   bridge, publishing the daemon's state as ROS 2 topics;
//! - `acl` (feature `zenoh`): the node's part of the link's access list.

#[cfg(feature = "zenoh")]
pub(crate) mod acl;
pub mod bag;
pub mod cdr;
pub mod graph;
pub mod msgs;
#[cfg(feature = "zenoh")]
pub mod node;
pub mod state;

/// The topics the node publishes, in the order they are declared (their
/// entity ids follow): name under the namespace, and type.
pub const TOPICS: [(&str, msgs::MsgType); N_TOPICS] = [
    ("joint_states", msgs::JOINT_STATE),
    ("imu", msgs::IMU),
    ("pressure", msgs::FLUID_PRESSURE),
    ("feedforward", msgs::FLOAT64_MULTI_ARRAY),
    ("torque_residual", msgs::FLOAT64_MULTI_ARRAY),
    ("diagnostics", msgs::DIAGNOSTIC_ARRAY),
    ("tf", msgs::TF_MESSAGE),
    ("cross_track_error", msgs::FLOAT64),
    ("current", msgs::VECTOR3_STAMPED),
];

/// How many topics the node publishes ([`TOPICS`]).
pub const N_TOPICS: usize = 9;

/// The transient-local topics (reliable, keep last 1; late joiners get
/// their last message from the publisher's cache): published once.
pub const LATCHED: [(&str, msgs::MsgType); 2] = [
    ("robot_description", msgs::STRING),
    ("tf_static", msgs::TF_MESSAGE),
];

/// The ROS 2 distributions the node speaks: `jazzy` (and later: RIHS01
/// type hashes in keys and tokens) and `humble` (`TypeHashNotSupported`
/// in their place). The messages it uses are the same in both.
pub const DISTROS: [&str; 2] = ["jazzy", "humble"];
