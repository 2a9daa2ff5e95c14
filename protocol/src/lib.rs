//! The anguilla vertebra CAN protocol.
//!
//! This crate owns everything about the wire that does not need a socket:
//! the [`frame::Frame`] type shared by every bus and its range-checked ids
//! ([`frame::Id`], [`frame::StandardId`], [`frame::ExtendedId`]); the
//! messages ([`message`]), whose source is split along its seams — the
//! message types (`message/types.rs`), the layouts ([`message::common`],
//! [`message::classic`], [`message::fd`]), the message-definition table
//! (`message/definitions.rs`, [`message::definitions`]) and the codec
//! (`message/codec.rs`: [`Message::encode`] and [`decode`], one encoder and
//! one decoder per message), all re-exported from [`message`]; the field
//! descriptors the layouts are built from ([`signal`]); the bus-load
//! arithmetic ([`budget`]); the DBC file generator ([`dbc`]); can-utils'
//! candump log format ([`candump`]); the node's state machine as a rule
//! table ([`behaviour`]); and time on the bus ([`time::Nanos`], the one
//! nanosecond type of the daemon's clock, the simulated firmware's clock,
//! watchdog timeouts and heartbeat periods); and the wire codec of a bought
//! drive families, ODrive's CANSimple ([`odrive`]), CANopen CiA
//! 301/402 ([`canopen`]) and MIT-mode actuators ([`mit`]), and which of them a robot uses ([`Family`]); and the sentence by which a
//! position sensor off the bus hands the daemon a fix ([`position_fix`]). `protocol/README.md` is the contract a node's
//! firmware implements.
//!
//! ```
//! use anguilla_protocol::frame::{Frame, Id};
//! use anguilla_protocol::message::{decode, Message, NodeSet, Variant};
//! let f = Frame::new(Id::standard(0x123)?, &[0xDE, 0xAD])?;
//! assert_eq!(f.to_string(), "123#DEAD");
//!
//! // SYNC number 7 on classic CAN: id 0x040, counter little-endian.
//! let sync = Message::Sync { counter: 7 }.encode(Variant::Classic)?;
//! assert_eq!(sync.to_string(), "040#0700");
//! assert_eq!(decode(&sync, Variant::Classic, NodeSet::first(12))?, Message::Sync { counter: 7 });
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod behaviour;
pub mod budget;
pub mod candump;
pub mod canopen;
pub mod dbc;
pub mod doc;
pub mod family;
pub mod frame;
pub mod message;
pub mod mit;
pub mod odrive;
pub mod position_fix;
pub mod signal;
pub mod time;

pub use family::Family;
pub use frame::{ExtendedId, Frame, FrameError, Id, Kind, StandardId};
pub use message::{DecodeError, EncodeError, Message, NodeId, NodeSet, Variant, decode};
