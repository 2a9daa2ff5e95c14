//! The simulated robot: vertebra actuator nodes on a bus and the swimming body (not yet built; see issue 4).
#![warn(missing_docs)]
