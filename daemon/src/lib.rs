//! The real-time daemon: control loop, supervisor, gait generator, IPC (not yet built; see issue 5).
#![warn(missing_docs)]
