//! The anguilla messages: identifiers, layouts, encode and decode.
//!
//! Every identifier is 11 bits: `function << 6 | node`, with the function
//! code (0..=13) in the high five bits so that arbitration orders the bus by
//! function first (E-stop beats SYNC beats setpoints beats feedback...), and
//! the node id (1..=63, 0 = broadcast / host) in the low six bits, like
//! CANopen's function-code bases. See `protocol/README.md` for the contract.
//!
//! Layouts differ per [`Variant`]: classic CAN packs a whole vertebra's
//! setpoint (both axes) into one 8-byte frame per node, CAN FD sends
//! setpoints for six nodes per 64-byte group frame at higher precision. The
//! positions and scaling of every field are the [`Signal`] constants of the
//! layout modules ([`classic`], [`fd`], [`common`]); the codec reads and
//! writes bits only through them.
//!
//! The source follows those seams, and everything is re-exported here:
//!
//! - `message/types.rs` — the message types ([`Message`] and what it
//!   carries, [`NodeId`], [`NodeSet`]), function codes ([`Function`]) and
//!   [`Addressing`], the documented ranges;
//! - [`common`], [`classic`], [`fd`] (`message/{common,classic,fd}.rs`) —
//!   the layouts: one [`Signal`] per field;
//! - `message/definitions.rs` — the message-definition table
//!   ([`definitions`], [`MessageDef`]) that the codec, the DBC, the budget
//!   and the README are made from, and the identifier questions it answers
//!   ([`addressed_to`], [`estop_target`]);
//! - `message/codec.rs` — [`Message::encode`] and [`decode`], one encoder
//!   and one decoder per message side by side, and [`encode_setpoints`];
//!   `message/head.rs` the head sensor's, with [`encode_head_sample`];
//!   `message/field.rs` the field access both go through; `message/error.rs`
//!   their errors.
//!
//! [`Signal`]: crate::signal::Signal

pub mod classic;
mod codec;
pub mod common;
mod definitions;
mod error;
pub mod fd;
mod field;
mod head;
mod node;
mod sensor;
mod types;
mod variant;

pub use codec::*;
pub use definitions::*;
pub use error::{DecodeError, EncodeError};
pub use head::encode_head_sample;
pub use node::{MAX_NODE_ID, NodeId, NodeSet};
pub use sensor::{HeadAttitude, HeadDepth, HeadSample, HeadVector, SensorErrors, SensorStatus};
pub use types::*;
pub use variant::Variant;
