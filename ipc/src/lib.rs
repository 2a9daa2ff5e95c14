//! The operator interface of the anguilla daemon on iceoryx2: the
//! operator vocabulary ([`vocabulary`]), the `#[repr(C)]` payloads (the
//! state in [`payload`], the command request and reply in [`command`]),
//! the daemon's ports ([`StatePublisher`], [`CommandServer`])
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
//! | `/tmp/anguilla/<prefix>/estop` | Unix datagram socket | any bytes | anyone in the daemon's group: E-stop ([`estop`]) |
//!
//! **Authority.** The daemon identifies a tool by the iceoryx2 client port
//! its request arrived on ([`Envelope::origin`]), never by a field of the
//! request: a tool cannot act as another, and a tool that restarts is a new
//! client. Control is held by one client port at a time; an E-stop is
//! accepted from any client, before any other check, and also through the
//! E-stop socket, which no capacity limit can block.
//!
//! **Who creates.** The daemon creates the services; tools only open them
//! ([`Client::new`] fails with [`IpcError::NoDaemon`] when no daemon runs).
//!
//! The daemon's two sides are separate so that each can live on its own
//! helper thread, never on the control loop's (iceoryx2 allocates when it
//! loans a sample or answers a request): [`StatePublisher`] and
//! [`CommandServer`]. A tool uses one [`Client`].
//!
//! Every payload is `#[repr(C)]`, `Copy` and `ZeroCopySend` (iceoryx2), made of fixed
//! size integers, floats and arrays, so C, C++ and Python iceoryx2 clients can
//! read it with the layout documented in `docs/ipc.md` (generated from
//! [`layout_table`] and checked by a test).
//!
//! ```no_run
//! use anguilla_ipc::{Client, Command};
//! use std::time::Duration;
//! let mut c = Client::new("anguilla", "my-tool")?;
//! let state = c.wait_state(Duration::from_secs(1))?;
//! let r = c.request(Command::TakeControl, Duration::from_secs(1))?;
//! assert_eq!(state.and_then(|s| s.holder()), None.or(Some(c.id())).filter(|_| r.accepted == 1));
//! # Ok::<(), anguilla_ipc::IpcError>(())
//! ```

#![warn(missing_docs)]

pub mod client;
pub mod command;
pub mod error;
pub mod estop;
pub mod guard;
pub mod layout;
pub mod payload;
pub mod service;
pub mod service_user;
pub mod vocabulary;

pub use client::{Client, Session};
pub use command::*;
pub use layout::{LayoutRow, layout_markdown, layout_table};
pub use payload::*;
pub use service::{
    ActiveRequest, CommandServer, Envelope, IpcError, MAX_NODES, MAX_REQUESTS_PER_CLIENT,
    MAX_TOOLS, NodeWatch, StatePublisher, scan_nodes, valid_prefix,
};
pub use vocabulary::*;

#[cfg(test)]
mod tests;
