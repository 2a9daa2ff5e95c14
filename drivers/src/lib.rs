//! CAN buses for anguilla.
//!
//! This crate will own the `Bus` trait and its implementations (SocketCAN,
//! SLCAN serial adapters, an in-process bus). It moves frames
//! ([`anguilla_protocol::Frame`]) and knows nothing of the messages inside.
#![warn(missing_docs)]

pub use anguilla_protocol::Frame;
