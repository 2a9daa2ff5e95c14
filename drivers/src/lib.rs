//! CAN buses for anguilla.
//!
//! This crate owns the [`Bus`] trait — send, receive with a timeout, drain
//! without blocking, bus state and counters, purge and reopen — and its
//! implementations, selected at run time from a bus spec string
//! ([`BusSpec`], [`open`]):
//!
//! * [`mem`] — an in-process bus with any number of participants, optional
//!   wire-time simulation (bit time, arbitration by id) on a pluggable
//!   [`Clock`], and fault hooks for tests (`mem:NAME`);
//! * [`slcan`] — SLCAN (Lawicel ASCII) serial adapters such as CANable,
//!   USBtin and CANUSB, plus an adapter emulator that makes any bus look like
//!   one on a pseudo-terminal (`slcan:/dev/ttyACM0@1000000`);
//! * [`socketcan`] — Linux SocketCAN, classic and FD (`socketcan:can0`).
//!
//! It moves frames ([`anguilla_protocol::Frame`]) and knows nothing of the
//! messages inside.
//!
//! ```
//! use anguilla_drivers::{open, Frame};
//! use std::time::Duration;
//!
//! let mut a = open("mem:doc-example").unwrap();
//! let mut b = open("mem:doc-example").unwrap();
//! let frame = Frame::new_standard(0x123, &[1, 2, 3]).unwrap();
//! a.send(&frame).unwrap();
//! let got = b.recv(Duration::from_secs(1)).unwrap().expect("a frame");
//! assert_eq!(got.frame, frame);
//! // The sender does not hear itself (no loopback), and nothing is left.
//! assert!(a.try_recv().unwrap().is_none());
//! assert!(b.try_recv().unwrap().is_none());
//! ```
#![warn(missing_docs)]

mod backoff;
mod bus;
pub mod clock;
mod error;
pub mod mem;
pub mod slcan;
pub mod socketcan;
mod spec;

pub use anguilla_protocol::Frame;
pub use bus::{Bus, BusCounters, BusState, Capabilities, Received, TimestampBase};
pub use clock::{Clock, ManualClock, MonotonicClock};
pub use error::{
    IoCause, LinkError, LostReason, OpenError, OpenResult, Result, SpecError, Unsendable,
};
pub use spec::BusSpec;

/// Opens a bus from a spec string (see [`BusSpec`] for the accepted forms).
///
/// `mem:NAME` joins (or creates, with the options given) the in-process bus
/// `NAME` as a new participant.
pub fn open(spec: &str) -> OpenResult<Box<dyn Bus>> {
    BusSpec::parse(spec)?.open()
}
