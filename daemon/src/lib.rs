//! The anguilla real-time daemon.
//!
//! It owns the control loop, the safety supervisor, the gait generator and
//! its trapezoidal [`profile`]s, the operator interface (iceoryx2), recording
//! and its configuration (its sections of the file: `[link]` and
//! `[foxglove]` belong to other processes, [`config::OTHER_SECTIONS`]). It holds no model maths (see `anguilla-model`) and no
//! frame layouts (see `anguilla-protocol`).
//!
//! Its public surface is what the tools and the tests drive; the rest is
//! internal:
//!
//! - **Configuration:** [`config`] (the daemon's sections of the file).
//! - **Running:** [`run`] (the threads of `anguilla run` and `anguillad`),
//!   [`control`] (one period: the [`control::Controller`]), [`rt`] (the
//!   real-time set-up and the clock).
//! - **The robot:** [`drive`] (the joints' drives between the controller
//!   and the bus: one master per family — anguilla nodes, CiA 402, ODrive,
//!   MIT mode), [`sensors`] (the sensors and their sections), [`autopilot`],
//!   [`guidance`] (following a path, the geofence),
//!   [`profile`] (trapezoidal profiles), [`speed`] (the model's steady
//!   speeds, for the ROS 2 velocity command), [`tracking`] (the second
//!   line of defence against a limp joint), [`calibration`] (the
//!   calibration swim's legs).
//! - **Recording:** [`session`] (the recorded events and the `session.log`
//!   format), [`record`] (the recorder thread), [`mcap_log`] (the session's
//!   MCAP file, written with `anguilla_view`'s messages), [`truth`] (a
//!   simulated robot's ground truth), [`replay`] (a recording replayed bit
//!   for bit through the controller).
//!
//! Internal, each used only through the above: the supervisor (modes,
//! authority, faults), the node table (what the nodes report), the head
//! sensor's estimate (`nav`), the torque residuals and the loop
//! statistics.
#![warn(missing_docs)]

pub mod autopilot;
pub mod calibration;
pub mod config;
pub mod control;
pub mod drive;
pub mod guidance;

pub mod mcap_log;
mod nav;
mod nodes;
pub mod profile;
pub mod record;
pub mod replay;
mod residual;
pub mod rt;
pub mod run;
pub mod sensors;
pub mod session;
pub mod speed;
mod stats;
mod supervisor;
pub mod tracking;
pub mod truth;
