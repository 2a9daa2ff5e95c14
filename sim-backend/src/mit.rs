//! A joint driven by two MIT-mode actuators (the Mini Cheetah controller's
//! protocol, CubeMars AK / T-Motor firmware; [`anguilla_protocol::mit`]),
//! as docs/drives.md ("MIT mode") describes them to the daemon's master.
//!
//! Each drive ([`MitJoint`] holds two, pitch then yaw) has its own id and
//! behaves as follows (`now` from the caller, so runs are deterministic):
//!
//! - **Boot**: silent and deaf for [`MitJointConfig::boot_time`], then out
//!   of motor mode (limp), error 0.
//! - **Every frame on its id** that decodes is answered at once with an
//!   8-byte reply on the master's id (position and velocity from the
//!   encoder, torque from the current loop, temperature, error code),
//!   whatever the mode, as the firmware does. Nothing is sent unasked.
//! - **Enter motor mode** (without an error) starts the servo with zero
//!   gains and no torque (limp until the first command); **Exit** ends it;
//!   **Set zero** makes the present position the zero of later positions.
//! - **Command** in motor mode sets the servo: the drive applies
//!   `torque + kp (position − θ) + kd (velocity − ω)` at every servo step
//!   (saturated by the actuator), until the next command. Out of motor
//!   mode a command is answered and ignored.
//! - **CAN timeout**: in motor mode, [`MitJointConfig::timeout`] without a
//!   command ends motor mode (CubeMars' configurable CAN timeout; the
//!   master must keep sending), counted in `watchdog_expiries`.
//! - Frames for other ids, the master's replies, extended ids and remote
//!   frames are ignored; a frame on its id that does not decode (a wrong
//!   length, CAN FD) is counted in [`NodeCounters::bad_frames`](crate::node::NodeCounters::bad_frames) and not
//!   answered. `applied` counts the commands applied.
//! - **Fault injection** ([`JointDevice`](crate::device::JointDevice)): a silent joint neither sends
//!   nor hears; a reboot ends motor mode and the zero, and boots again; an
//!   injected anguilla fault becomes an error code on both drives
//!   ([`injected_error`]), which ends motor mode and refuses Enter until
//!   [`JointDevice::clear_injected_fault`](crate::device::JointDevice::clear_injected_fault); Exit motor mode then clears it.
//!
//! In the anguilla vocabulary ([`JointDevice::state`](crate::device::JointDevice::state)) a drive is Boot
//! until booted, Fault with an error, Enabled in motor mode, Disabled
//! otherwise; the joint is the worse of its two drives. Receiving and
//! advancing allocate nothing.

use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{ErrorBits, NodeState};
use anguilla_protocol::mit::{
    self, Body, Command, DEFAULT_RANGES, Message, NodeId, Reply, Status, error_code,
};

use crate::actuator::{Actuator, ActuatorParams, Drive};
use crate::device::{BoughtAxis, BoughtJoint, Firmware};
use crate::error::SimError;
use crate::node::Nanos;
use crate::rng::Rng;

/// The CAN timeout the simulated drives are set to (docs/drives.md): longer
/// than the daemon's heartbeat timeout, so a master that stalls sees its
/// drives lost before they go limp behind its back.
pub const CAN_TIMEOUT: Nanos = Nanos::from_millis(500);

/// The driver temperature the simulated drives report, °C.
pub const TEMPERATURE: i8 = 30;

/// The error code an injected anguilla fault (`ErrorBits`) raises:
/// over-temperature → `OVER_TEMPERATURE`, under-voltage → `UNDER_VOLTAGE`,
/// any other bit → `OVER_CURRENT`.
pub fn injected_error(bits: u16) -> u8 {
    if bits & ErrorBits::OVER_TEMPERATURE != 0 {
        error_code::OVER_TEMPERATURE
    } else if bits & ErrorBits::UNDER_VOLTAGE != 0 {
        error_code::UNDER_VOLTAGE
    } else if bits != 0 {
        error_code::OVER_CURRENT
    } else {
        0
    }
}

/// Configuration of one simulated MIT-mode joint (two drives).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MitJointConfig {
    /// Drive ids `[pitch, yaw]` (1..=127, distinct).
    pub ids: [u8; 2],
    /// Pitch (0) and yaw (1) actuators.
    pub axes: [ActuatorParams; 2],
    /// Time from power-on to the first answer.
    pub boot_time: Nanos,
    /// Seed of the encoders' noise.
    pub seed: u64,
    /// CAN timeout in motor mode ([`CAN_TIMEOUT`]).
    pub timeout: Nanos,
}

/// One drive: its mode, command, zero and actuator.
#[derive(Debug, Clone)]
pub struct MitDrive {
    id: NodeId,
    booted: bool,
    motor_mode: bool,
    command: Command,
    /// Actuator angle that reads as position 0.
    zero: f64,
    error: u8,
    last_command: Nanos,
    actuator: Actuator,
}

const LIMP: Command = Command {
    position: 0.0,
    velocity: 0.0,
    kp: 0.0,
    kd: 0.0,
    torque: 0.0,
};

impl MitDrive {
    fn new(id: NodeId, params: ActuatorParams) -> Self {
        Self {
            id,
            booted: false,
            motor_mode: false,
            command: LIMP,
            zero: 0.0,
            error: 0,
            last_command: Nanos::ZERO,
            actuator: Actuator::new(params),
        }
    }

    fn node_state(&self) -> NodeState {
        if !self.booted {
            NodeState::Boot
        } else if self.error != 0 {
            NodeState::Fault
        } else if self.motor_mode {
            NodeState::Enabled
        } else {
            NodeState::Disabled
        }
    }

    /// The servo's torque for this step: the firmware's impedance law,
    /// handed to the actuator as a feed-forward about where it is.
    fn drive(&self) -> Drive {
        if !self.motor_mode {
            return Drive::Limp;
        }
        let (theta, omega, _) = self.actuator.kinematics();
        let c = self.command;
        let torque = f64::from(c.torque)
            + f64::from(c.kp) * (f64::from(c.position) + self.zero - theta)
            + f64::from(c.kd) * (f64::from(c.velocity) - omega);
        Drive::Servo {
            position: theta,
            velocity: omega,
            torque,
        }
    }

    fn reply(&mut self, rng: &mut Rng, tx: &mut dyn FnMut(Frame)) {
        let r = DEFAULT_RANGES;
        let pos = self.actuator.measure(rng) - self.zero;
        let (_, vel, _) = self.actuator.kinematics();
        let m = Message {
            node: self.id,
            body: Body::Reply(Reply {
                position: (pos as f32).clamp(-r.position, r.position),
                velocity: (vel as f32).clamp(-r.velocity, r.velocity),
                torque: (self.actuator.torque() as f32).clamp(-r.torque, r.torque),
                status: Some(Status {
                    temperature: TEMPERATURE,
                    error: self.error,
                }),
            }),
        };
        // Encoding fails only for a non-finite state (a diverged plant):
        // nothing is sent then.
        if let Ok(f) = m.encode(&r) {
            tx(f);
        }
    }
}

/// The MIT-mode firmware of a joint's two drives: their configuration and
/// an injected fault's error code.
#[derive(Debug, Clone)]
pub struct Mit {
    cfg: MitJointConfig,
    injected: u8,
}

/// A joint of two simulated MIT-mode drives (pitch, yaw).
pub type MitJoint = BoughtJoint<Mit>;

impl BoughtJoint<Mit> {
    /// A joint powered on at `now`. Fails, naming the field, if an id is
    /// outside 1..=127, the two ids are equal, or the timeout is zero.
    pub fn new(cfg: MitJointConfig, now: Nanos) -> crate::Result<Self> {
        let id = |raw: u8| {
            NodeId::new(raw).map_err(|_| SimError::Config {
                field: "ids",
                reason: format!("MIT drive id {raw} outside 1..={}", mit::MAX_NODE_ID),
            })
        };
        let ids = [id(cfg.ids[0])?, id(cfg.ids[1])?];
        if ids[0] == ids[1] {
            return Err(SimError::Config {
                field: "ids",
                reason: format!("pitch and yaw share the drive id {}", cfg.ids[0]),
            });
        }
        if cfg.timeout == Nanos::ZERO {
            return Err(SimError::Config {
                field: "timeout",
                reason: "a timeout above zero".into(),
            });
        }
        Ok(Self::powered_on(
            Mit { cfg, injected: 0 },
            [
                MitDrive::new(ids[0], cfg.axes[0]),
                MitDrive::new(ids[1], cfg.axes[1]),
            ],
            now,
            cfg.boot_time,
            cfg.seed,
        ))
    }

    /// Whether drive `axis` (0 pitch, 1 yaw) is in motor mode.
    pub fn motor_mode(&self, axis: usize) -> bool {
        self.axes[axis].motor_mode
    }

    /// The error code of drive `axis`.
    pub fn error(&self, axis: usize) -> u8 {
        self.axes[axis].error
    }
}

impl BoughtAxis for MitDrive {
    fn actuator(&self) -> &Actuator {
        &self.actuator
    }

    fn actuator_mut(&mut self) -> &mut Actuator {
        &mut self.actuator
    }

    fn booted(&self) -> bool {
        self.booted
    }

    fn drive(&self) -> Drive {
        MitDrive::drive(self)
    }

    fn node_state(&self) -> NodeState {
        MitDrive::node_state(self)
    }
}

impl Firmware for Mit {
    type Axis = MitDrive;

    fn addressed(joint: &MitJoint, frame: &Frame) -> Option<usize> {
        let raw = frame.id().as_standard()?;
        joint.axes.iter().position(|d| u16::from(d.id.get()) == raw)
    }

    fn on_frame(
        joint: &mut MitJoint,
        now: Nanos,
        k: usize,
        frame: &Frame,
        tx: &mut dyn FnMut(Frame),
    ) -> bool {
        let Ok(m) = mit::decode(frame, &DEFAULT_RANGES) else {
            return false;
        };
        let d = &mut joint.axes[k];
        match m.body {
            // The master's id carries replies; ours come from here.
            Body::Reply(_) => return true,
            Body::EnterMotorMode => {
                if d.error == 0 && !d.motor_mode {
                    d.motor_mode = true;
                    d.command = LIMP;
                    d.last_command = now;
                }
            }
            Body::ExitMotorMode => {
                d.motor_mode = false;
                d.error = joint.firmware.injected;
            }
            Body::SetZero => d.zero = d.actuator.kinematics().0,
            Body::Command(c) => {
                if d.motor_mode {
                    d.command = c;
                    d.last_command = now;
                    joint.counters.applied += 1;
                }
            }
        }
        joint.axes[k].reply(&mut joint.rng, tx);
        true
    }

    fn boot(joint: &mut MitJoint, _t: Nanos) {
        for d in &mut joint.axes {
            d.booted = true;
            d.error = joint.firmware.injected;
        }
    }

    fn tick(joint: &mut MitJoint, t: Nanos, _tx: &mut dyn FnMut(Frame)) {
        for d in &mut joint.axes {
            if d.motor_mode && t.saturating_sub(d.last_command) > joint.firmware.cfg.timeout {
                joint.counters.watchdog_expiries += 1;
                d.motor_mode = false;
            }
        }
    }

    fn powered_on(&self, k: usize, before: &MitDrive) -> MitDrive {
        // Motor mode, the command and the zero are lost.
        MitDrive::new(before.id, self.cfg.axes[k])
    }

    fn inject_fault(joint: &mut MitJoint, bits: u16, _tx: &mut dyn FnMut(Frame)) {
        joint.firmware.injected = injected_error(bits);
        for d in &mut joint.axes {
            if d.booted {
                d.error = joint.firmware.injected;
                d.motor_mode = false;
            }
        }
    }

    fn clear_injected_fault(&mut self) {
        self.injected = 0;
    }

    fn impostor_heartbeat(
        joint: &MitJoint,
        _state: NodeState,
        _counter: u8,
        tx: &mut dyn FnMut(Frame),
    ) {
        // The only sign of life this protocol has: a reply, on the master's
        // id, naming our drive.
        let mut rng = joint.rng.clone();
        for d in &joint.axes {
            let mut forged = d.clone();
            forged.error = 0;
            forged.reply(&mut rng, tx);
        }
    }
}

#[cfg(test)]
mod tests;
