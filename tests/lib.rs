//! System tests: the daemon and the simulated robot end to end, on each bus.
//!
//! The tests live in `tests/*.rs`; this library holds their shared fixtures.
#![warn(missing_docs)]
