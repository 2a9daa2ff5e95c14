//! How one joint's two simulated drives are set up: their node ids, their
//! actuators, their boot time, and the checks on the ids.

use anguilla_protocol::canopen::NodeId;

use crate::actuator::ActuatorParams;
use crate::node::Nanos;

/// Configuration of one joint's two simulated CiA 402 drives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cia402JointConfig {
    /// Node ids of the pitch and yaw drives (1..=127, distinct).
    pub ids: [u8; 2],
    /// Pitch (0) and yaw (1) actuators.
    pub axes: [ActuatorParams; 2],
    /// Time from power-on to the boot-up message.
    pub boot_time: Nanos,
    /// Seed of the drives' sensor noise.
    pub seed: u64,
}

impl Cia402JointConfig {
    /// Joint `joint` (0 = head end) with docs/drives.md's default ids
    /// (pitch 2j + 1, yaw 2j + 2), default actuators and a 20 ms boot.
    pub fn for_joint(joint: u8, seed: u64) -> Self {
        let pitch = joint.saturating_mul(2).saturating_add(1);
        Self {
            ids: [pitch, pitch.saturating_add(1)],
            axes: [ActuatorParams::default(); 2],
            boot_time: Nanos::from_millis(20),
            seed,
        }
    }

    /// Checks the node ids: each 1..=127, pitch and yaw distinct.
    pub fn validate(&self) -> Result<(), Cia402ConfigError> {
        for (axis, &id) in self.ids.iter().enumerate() {
            if NodeId::new(id).is_err() {
                return Err(Cia402ConfigError::NodeId { axis, id });
            }
        }
        if self.ids[0] == self.ids[1] {
            return Err(Cia402ConfigError::SameIds(self.ids[0]));
        }
        Ok(())
    }
}

/// What is wrong with a [`Cia402JointConfig`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Cia402ConfigError {
    /// A node id outside 1..=127.
    #[error("CiA 402 node id {id} of axis {axis} is out of range (expected 1..=127)")]
    NodeId {
        /// 0 pitch, 1 yaw.
        axis: usize,
        /// The id given.
        id: u8,
    },
    /// Both axes given the same id.
    #[error("CiA 402 pitch and yaw drives both have node id {0} (expected two distinct ids)")]
    SameIds(u8),
}
