//! The `anguilla` binary's wiring that is more than argument handling,
//! as a library, so that the system tests start what `anguilla run` starts
//! instead of a copy of it: [`builtin_sim`], the simulated robot the
//! daemon drives when no bus is named.

pub mod builtin_sim;
