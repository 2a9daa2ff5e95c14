//! The simulated anguilla robot.
//!
//! Everything in anguilla is developed and tested against this simulated
//! robot, which behaves on the bus as the real one will:
//!
//! - [`node`]: vertebra actuator nodes implementing the firmware contract of
//!   `protocol/README.md`, each driving two [`actuator`]s (pitch and yaw);
//! - [`plant`]: the swimming body (the Boyer et al. model driven by the
//!   joints' achieved motion), which gives each actuator its load;
//! - [`rng`]: the deterministic random source of sensor noise and faults.
#![warn(missing_docs)]

pub mod actuator;
pub mod node;
pub mod plant;
pub mod rng;
