//! Fast dynamics of an eel-like swimming robot.
//!
//! This crate will implement the model of Boyer, Porez, Leroyer and
//! Visonneau, *Fast dynamics of an eel-like robot* (IEEE T-RO 2008): body
//! geometry and inertia, hydrodynamic coefficients, gaits, forward and inverse
//! dynamics, and the mapping onto a discrete chain of actuated joints.
#![warn(missing_docs)]
