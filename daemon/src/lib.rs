//! The anguilla real-time daemon.
//!
//! It owns the control loop, the safety supervisor, the gait generator and
//! its trapezoidal [`profile`]s, the operator interface (iceoryx2), recording
//! and its configuration (its sections of the file: `[link]` and
//! `[foxglove]` belong to other processes, [`config::OTHER_SECTIONS`]). It holds no model maths (see `anguilla-model`) and no
//! frame layouts (see `anguilla-protocol`).
//!
//! Layers, each using only those below it: [`config`]; [`supervisor`]
//! (modes, authority, faults) and [`nodes`] (what the nodes report);
//! [`drive`] (the joints' drives between the controller and the bus: one
//! master per family — anguilla nodes, CiA 402, ODrive, MIT mode);
//! [`session`] (the recorded events and the `session.log` format);
//! [`control`] (one period: the [`control::Controller`]); [`record`] (the
//! recorder thread) and [`replay`] (a recording replayed bit for bit
//! through the controller); [`run`] (the threads of `anguilla run`), with
//! [`rt`] and [`stats`].
#![warn(missing_docs)]

pub mod autopilot;
pub mod calibration;
pub mod config;
pub mod control;
pub mod drive;

pub mod mcap_log;
pub mod nav;
pub mod nodes;
pub mod profile;
pub mod record;
pub mod replay;
pub mod residual;
pub mod rt;
pub mod run;
pub mod sensors;
pub mod session;
pub mod speed;
pub mod stats;
pub mod supervisor;
pub mod tracking;
pub mod truth;
