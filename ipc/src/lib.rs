//! The operator interface of the anguilla daemon on iceoryx2: the
//! operator vocabulary ([`vocabulary`]), the `#[repr(C)]` payloads
//! ([`payload`]), the daemon's ports ([`StatePublisher`], [`CommandServer`])
//! and the tools' [`Client`]. Operator tools depend on this crate, never on
//! the daemon.
//!
//! Four services, named under a prefix (`anguilla` by default, so several
//! daemons can share a machine):
//!
//! | service | pattern | payload | who |
//! |---|---|---|---|
//! | `<prefix>/state` | publish-subscribe, history 1 | [`StateSnapshot`] | daemon publishes every period |
//! | `<prefix>/state-ready` | event | — | daemon notifies after each publication |
//! | `<prefix>/command` | request-response | [`CommandRequest`] → [`CommandReply`] | tools send, daemon replies to each |
//! | `<prefix>/command-ready` | event | — | tools notify after sending a request |
//!
//! The daemon's two sides are separate so that each can live on its own
//! helper thread, never on the control loop's (iceoryx2 allocates when it
//! loans a sample or answers a request): [`StatePublisher`] and
//! [`CommandServer`]. A tool uses one [`Client`].
//!
//! Every payload is `#[repr(C)]`, `Copy` and [`ZeroCopySend`], made of fixed
//! size integers, floats and arrays, so C, C++ and Python iceoryx2 clients can
//! read it with the layout documented in `docs/ipc.md` (generated from
//! [`layout_table`] and checked by a test).

#![warn(missing_docs)]

pub mod client;
pub mod layout;
pub mod payload;
pub mod service;
pub mod vocabulary;

pub use client::Client;
pub use layout::{LayoutRow, layout_markdown, layout_table};
pub use payload::*;
pub use service::{ActiveRequest, CommandServer, IpcError, NodeWatch, StatePublisher, scan_nodes};
pub use vocabulary::*;

#[cfg(test)]
mod tests;
