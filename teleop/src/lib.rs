//! Operator tools of anguilla: keyboard teleoperation (`anguilla teleop`),
//! a gamepad (`anguilla joy`) and a read-only monitor (`anguilla monitor`).
//!
//! The tools talk only to the daemon, through its iceoryx2 interface
//! (`docs/ipc.md`), never to the bus. This crate holds everything but the
//! terminal and device plumbing, so it is tested without a terminal or a
//! gamepad:
//!
//! - [`app`]: the operator's intent (target gait stepped by keys, clamped to
//!   the daemon's ranges) and the commands it turns into;
//! - [`keys`]: key → [`app::Action`];
//! - [`hold`]: the heading and depth the operator wants held (autopilot);
//! - [`joy`]: evdev event → command, with the deadman rules;
//! - [`operator`]: a connection to the daemon and the steady 10 Hz sender;
//! - [`pad`]: the gamepad session (evdev devices or a scripted pad, hot-plug);
//! - [`session`]: the teleop and monitor sessions and the `--json` pace;
//! - [`view`]: the state view, drawn with ratatui on any backend;
//! - [`ctl`]: `anguilla ctl`, one scripted command per call; [`path`]:
//!   the path file of `ctl follow`;
//! - [`history`]: the monitor's ring buffers; [`json`]: `--json` lines.
//!
//! ```
//! use anguilla_teleop::app::{Action, Intent, Limits};
//! use anguilla_ipc::Command;
//!
//! let mut intent = Intent::new(Limits::default());
//! assert!(matches!(intent.apply(Action::Faster), Some(Command::Swim(_))));
//! assert_eq!(intent.apply(Action::Stop), Some(Command::Stop));
//! assert_eq!(intent.steady(), Command::KeepAlive);
//! ```
#![warn(missing_docs)]
// serde_json's json! macro recurses once per key: the status object has more keys than
// its default limit of 128 allows.
#![recursion_limit = "256"]

pub mod app;
pub mod ctl;
pub mod history;
pub mod hold;
pub mod joy;
pub mod json;
pub mod keys;
pub mod operator;
pub mod pad;
pub mod path;
pub mod session;
pub mod view;
