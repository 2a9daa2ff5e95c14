//! The anguilla vertebra CAN protocol.
//!
//! This crate owns everything about the wire that does not need a socket:
//! the [`frame::Frame`] type shared by every bus, and (as they are built) the
//! message definitions, their encoders and decoders, the bus-load arithmetic,
//! the DBC file and can-utils' candump log format.
//!
//! ```
//! use anguilla_protocol::frame::{Frame, Id};
//! let f = Frame::new(Id::standard(0x123)?, &[0xDE, 0xAD])?;
//! assert_eq!(f.to_string(), "123#DEAD");
//! # Ok::<(), anguilla_protocol::frame::FrameError>(())
//! ```
#![warn(missing_docs)]

pub mod frame;

pub use frame::{Frame, FrameError, Id, Kind};
