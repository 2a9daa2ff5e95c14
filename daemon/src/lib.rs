//! The anguilla real-time daemon.
//!
//! It owns the control loop, the safety supervisor, the gait generator and
//! its trapezoidal [`profile`]s, the operator interface (iceoryx2), recording
//! and configuration. It holds no model maths (see `anguilla-model`) and no
//! frame layouts (see `anguilla-protocol`).
#![warn(missing_docs)]

pub mod config;
pub mod control;
pub use anguilla_ipc as ipc;
pub mod nodes;
pub mod profile;
pub mod record;
pub mod rt;
pub mod run;
pub mod stats;
pub mod supervisor;
