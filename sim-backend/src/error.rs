//! The simulator's error type, shared by the robot and its devices (its
//! own module, so that no device imports from the robot that builds it).

use anguilla_model::ModelError;

/// Result of this crate's operations.
pub type Result<T> = std::result::Result<T, SimError>;

/// Errors of building or running a simulated robot.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A configuration value is out of range.
    #[error("invalid simulation setting {field}: {reason}")]
    Config {
        /// The setting.
        field: &'static str,
        /// What is accepted.
        reason: String,
    },
    /// The body model refused its configuration.
    #[error("body model: {0}")]
    Model(#[from] ModelError),
    /// A scenario line could not be parsed.
    #[error(transparent)]
    Scenario(#[from] crate::scenario::ScenarioError),
    /// A scenario scripts a bus fault on a bus without fault hooks.
    #[error(
        "scenario line {line}: bus faults other than flood need the in-process bus (mem:NAME); \
         on {bus} only node and joint faults and floods can be simulated"
    )]
    BusFaultNeedsMemBus {
        /// The scenario line.
        line: usize,
        /// The bus spec.
        bus: String,
    },
    /// The bus could not be opened.
    #[error("bus: {0}")]
    Bus(#[from] anguilla_drivers::OpenError),
    /// The robot's thread could not be started.
    #[error("starting the simulated robot's thread: {0}")]
    Thread(std::io::Error),
}
