//! The simulated anguilla robot.
//!
//! Everything in anguilla is developed and tested against this simulated
//! robot, which behaves on the bus as the real one will:
//!
//! - [`node`]: vertebra actuator nodes implementing the firmware contract of
//!   `protocol/README.md`, each driving two [`actuator`]s (pitch and yaw);
//! - [`rng`]: the deterministic random source of sensor noise and faults.
#![warn(missing_docs)]

pub mod actuator;
pub mod node;
pub mod rng;
