//! A joint driven by two ODrive axes speaking CANSimple (firmware 0.6), as
//! docs/drives.md ("ODrive") describes them to the daemon's master.
//!
//! Each axis ([`OdriveJoint`] holds two, pitch then yaw) has its own node
//! id and behaves as follows (`now` from the caller, so runs are
//! deterministic):
//!
//! - **Boot**: silent for [`OdriveJointConfig::boot_time`], then IDLE with
//!   no error. From then on it sends `Heartbeat` every
//!   [`HEARTBEAT_PERIOD`] and `Get_Encoder_Estimates` every
//!   [`ENCODER_PERIOD`] (position turns, velocity turns/s: gear 1,
//!   direction +1, offset 0, so joint angle (rad) = turns · 2π), and
//!   answers a remote frame on either id with that message at once. It also
//!   sends a `Heartbeat` at once whenever its state or error changes (the
//!   firmware waits for the next cyclic one; a master must not rely on
//!   either).
//! - **Set_Controller_Mode** is stored (volatile: lost on reboot) and
//!   checked when closed loop is requested. The
//!   emulation starts with no mode, unlike a real drive that keeps a saved
//!   configuration, so a master that skips the documented enable sequence
//!   is caught.
//! - **Set_Axis_State(CLOSED_LOOP_CONTROL)** enters closed loop, holding the
//!   current position (`input_pos` = position estimate, no feedforward),
//!   only with no active error and `POSITION_CONTROL` + `PASSTHROUGH` set
//!   (the only mode this emulation servos). Otherwise the axis stays IDLE
//!   and reports the refusal in the heartbeat's `procedure_result`:
//!   [`procedure_result::DISARMED`] with an active error,
//!   [`procedure_result::INVALID_STATE`] without the mode. A granted request
//!   sets [`procedure_result::SUCCESS`]. **IDLE** disarms (no torque).
//!   Other requested states (calibrations, homing...) are not emulated:
//!   refused with `INVALID_STATE`, the state unchanged.
//! - **Set_Input_Pos** in closed loop is applied at once: position turns,
//!   `vel_ff` turns/s and `torque_ff` N·m drive the servo. Every message
//!   for the axis feeds its watchdog (as the firmware's CAN handler does);
//!   in closed loop, [`OdriveJointConfig::watchdog`] without one sets
//!   [`axis_error::WATCHDOG_TIMER_EXPIRED`] and disarms.
//! - **Estop** sets [`axis_error::ESTOP_REQUESTED`] and disarms;
//!   **Clear_Errors** clears the errors (not the state: the axis stays IDLE),
//!   except an injected fault's until [`JointDevice::clear_injected_fault`](crate::device::JointDevice::clear_injected_fault).
//!   Any error disarms (IDLE, `procedure_result` DISARMED).
//! - Frames for other node ids, extended ids and drive-to-host messages are
//!   ignored; a frame on an own id that does not decode (wrong length,
//!   unknown value, a command this emulation does not implement, a CAN FD
//!   frame) is counted in [`NodeCounters::bad_frames`](crate::node::NodeCounters::bad_frames) and otherwise
//!   ignored. `applied` counts the Set_Input_Pos applied, and
//!   `watchdog_expiries` each axis's expiry.
//! - **Fault injection** ([`JointDevice`](crate::device::JointDevice)): a silent joint neither sends nor
//!   hears (its servos hold what they were doing, as a silent vertebra
//!   node's do); a reboot loses the volatile state (mode, errors, closed
//!   loop) and boots again; an injected anguilla fault becomes an axis
//!   error on both axes ([`injected_error`]), present again after a reboot
//!   while its cause is (until [`JointDevice::clear_injected_fault`](crate::device::JointDevice::clear_injected_fault)).
//!
//! In the anguilla vocabulary ([`JointDevice::state`](crate::device::JointDevice::state)) an axis is Boot until
//! booted, EStop with `ESTOP_REQUESTED` alone, Fault with any other error,
//! Enabled in closed loop, Disabled otherwise; the joint is the worse of its
//! two axes. Receiving and advancing allocate nothing.

use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{ErrorBits, NodeState};
use anguilla_protocol::odrive::{
    self, AxisState, Body, ControlMode, EncoderEstimates, Heartbeat, InputMode, InputPos, Message,
    NodeId,
};

use crate::actuator::{Actuator, ActuatorParams, Drive};
use crate::device::{BoughtAxis, BoughtJoint, Firmware};
use crate::error::SimError;
use crate::node::Nanos;
use crate::rng::Rng;

/// Period of the cyclic `Heartbeat` (`axis.config.can.heartbeat_msg_rate_ms`
/// default).
pub const HEARTBEAT_PERIOD: Nanos = Nanos::from_millis(100);
/// Period of the cyclic `Get_Encoder_Estimates`
/// (`axis.config.can.encoder_msg_rate_ms` default).
pub const ENCODER_PERIOD: Nanos = Nanos::from_millis(10);

/// The `ODriveError` bits (firmware 0.6) this emulation raises.
pub mod axis_error {
    /// `DC_BUS_UNDER_VOLTAGE`: an injected under-voltage fault.
    pub const DC_BUS_UNDER_VOLTAGE: u32 = 0x0000_0200;
    /// `DRV_FAULT`: an injected fault without a closer ODrive error.
    pub const DRV_FAULT: u32 = 0x0000_0020;
    /// `MOTOR_OVER_TEMP`: an injected over-temperature fault.
    pub const MOTOR_OVER_TEMP: u32 = 0x0000_2000;
    /// `WATCHDOG_TIMER_EXPIRED`: no message within the watchdog timeout in
    /// closed loop.
    pub const WATCHDOG_TIMER_EXPIRED: u32 = 0x0100_0000;
    /// `ESTOP_REQUESTED`: an `Estop` message.
    pub const ESTOP_REQUESTED: u32 = 0x0200_0000;
}

/// The `ProcedureResult` values (firmware 0.6) this emulation reports.
pub mod procedure_result {
    /// `SUCCESS`: the last state request was granted (or errors cleared).
    pub const SUCCESS: u8 = 0;
    /// `DISARMED`: the axis disarmed on an error, or a request for closed
    /// loop was refused because an error is active.
    pub const DISARMED: u8 = 3;
    /// `INVALID_STATE`: closed loop requested without position control and
    /// passthrough input, or a state this emulation does not run.
    pub const INVALID_STATE: u8 = 13;
}

/// The ODrive error bits an injected anguilla fault (`ErrorBits`) raises:
/// over-temperature → `MOTOR_OVER_TEMP`, under-voltage →
/// `DC_BUS_UNDER_VOLTAGE`, any other bit → `DRV_FAULT`.
pub fn injected_error(bits: u16) -> u32 {
    let mut e = 0;
    if bits & ErrorBits::OVER_TEMPERATURE != 0 {
        e |= axis_error::MOTOR_OVER_TEMP;
    }
    if bits & ErrorBits::UNDER_VOLTAGE != 0 {
        e |= axis_error::DC_BUS_UNDER_VOLTAGE;
    }
    if bits & !(ErrorBits::OVER_TEMPERATURE | ErrorBits::UNDER_VOLTAGE) != 0 {
        e |= axis_error::DRV_FAULT;
    }
    e
}

/// Configuration of one simulated ODrive joint (two axes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdriveJointConfig {
    /// CANSimple node ids `[pitch, yaw]` (0..=63, distinct).
    pub ids: [u8; 2],
    /// Pitch (0) and yaw (1) actuators.
    pub axes: [ActuatorParams; 2],
    /// Time from power-on to IDLE (and the first heartbeat).
    pub boot_time: Nanos,
    /// Seed of the encoders' noise.
    pub seed: u64,
    /// `axis.config.watchdog_timeout` (enabled; docs/drives.md: 100 ms).
    pub watchdog: Nanos,
}

/// What an axis is doing with its input in closed loop (SI units at the
/// joint: rad, rad/s, N·m).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Input {
    position: f64,
    velocity: f64,
    torque: f64,
}

/// One ODrive axis: its CANSimple state and its actuator.
#[derive(Debug, Clone)]
pub struct OdriveAxis {
    id: NodeId,
    state: AxisState,
    error: u32,
    procedure_result: u8,
    mode: Option<(ControlMode, InputMode)>,
    input: Input,
    last_fed: Nanos,
    next_heartbeat: Nanos,
    next_estimate: Nanos,
    actuator: Actuator,
}

const TURN: f64 = core::f64::consts::TAU;

impl OdriveAxis {
    fn new(id: NodeId, params: ActuatorParams) -> Self {
        Self {
            id,
            state: AxisState::Undefined,
            error: 0,
            procedure_result: procedure_result::SUCCESS,
            mode: None,
            input: Input {
                position: 0.0,
                velocity: 0.0,
                torque: 0.0,
            },
            last_fed: Nanos::ZERO,
            next_heartbeat: Nanos::ZERO,
            next_estimate: Nanos::ZERO,
            actuator: Actuator::new(params),
        }
    }

    fn node_state(&self) -> NodeState {
        if !self.booted() {
            NodeState::Boot
        } else if self.error == axis_error::ESTOP_REQUESTED {
            NodeState::EStop
        } else if self.error != 0 {
            NodeState::Fault
        } else if self.state == AxisState::ClosedLoopControl {
            NodeState::Enabled
        } else {
            NodeState::Disabled
        }
    }

    fn drive(&self) -> Drive {
        if self.state == AxisState::ClosedLoopControl {
            Drive::Servo {
                position: self.input.position,
                velocity: self.input.velocity,
                torque: self.input.torque,
            }
        } else {
            Drive::Limp
        }
    }

    fn send(&self, body: Body, tx: &mut dyn FnMut(Frame)) {
        // Encoding fails only for a non-finite estimate (a diverged plant):
        // nothing is sent then.
        if let Ok(f) = (Message {
            node: self.id,
            body,
        })
        .encode()
        {
            tx(f);
        }
    }

    fn heartbeat(&self, tx: &mut dyn FnMut(Frame)) {
        self.send(
            Body::Heartbeat(Heartbeat {
                axis_error: self.error,
                axis_state: self.state,
                procedure_result: self.procedure_result,
                trajectory_done: true,
            }),
            tx,
        );
    }

    fn estimates(&mut self, rng: &mut Rng, tx: &mut dyn FnMut(Frame)) {
        let pos = self.actuator.measure(rng);
        let (_, vel, _) = self.actuator.kinematics();
        self.send(
            Body::EncoderEstimates(EncoderEstimates {
                pos: (pos / TURN) as f32,
                vel: (vel / TURN) as f32,
            }),
            tx,
        );
    }

    /// Sets error bits; an error disarms. A heartbeat goes out on a change.
    fn raise(&mut self, bits: u32, tx: &mut dyn FnMut(Frame)) {
        let before = (self.error, self.state);
        self.error |= bits;
        if self.state == AxisState::ClosedLoopControl {
            self.state = AxisState::Idle;
            self.procedure_result = procedure_result::DISARMED;
        }
        if (self.error, self.state) != before {
            self.heartbeat(tx);
        }
    }

    fn request(&mut self, requested: AxisState, now: Nanos, tx: &mut dyn FnMut(Frame)) {
        let before = (self.state, self.procedure_result);
        match requested {
            AxisState::Idle => {
                self.state = AxisState::Idle;
                self.procedure_result = procedure_result::SUCCESS;
            }
            AxisState::ClosedLoopControl if self.error != 0 => {
                self.procedure_result = procedure_result::DISARMED;
            }
            AxisState::ClosedLoopControl
                if self.mode != Some((ControlMode::PositionControl, InputMode::Passthrough)) =>
            {
                self.procedure_result = procedure_result::INVALID_STATE;
            }
            AxisState::ClosedLoopControl => {
                if self.state != AxisState::ClosedLoopControl {
                    // Hold where the axis is until the first input.
                    self.input = Input {
                        position: self.actuator.kinematics().0,
                        velocity: 0.0,
                        torque: 0.0,
                    };
                    self.state = AxisState::ClosedLoopControl;
                }
                self.last_fed = now;
                self.procedure_result = procedure_result::SUCCESS;
            }
            _ => self.procedure_result = procedure_result::INVALID_STATE,
        }
        if (self.state, self.procedure_result) != before {
            self.heartbeat(tx);
        }
    }
}

/// The CANSimple firmware of a joint's two ODrive axes: their
/// configuration and an injected fault's error bits.
#[derive(Debug, Clone)]
pub struct Odrive {
    cfg: OdriveJointConfig,
    injected: u32,
}

/// A joint of two simulated ODrive axes (pitch, yaw) on CANSimple.
pub type OdriveJoint = BoughtJoint<Odrive>;

impl BoughtJoint<Odrive> {
    /// A joint powered on at `now`. Fails, naming the field, if an id is
    /// beyond 63, the two ids are equal, or the watchdog is zero.
    pub fn new(cfg: OdriveJointConfig, now: Nanos) -> crate::Result<Self> {
        let id = |raw: u8| {
            NodeId::new(raw).map_err(|_| SimError::Config {
                field: "ids",
                reason: format!("ODrive node id {raw} outside 0..={}", odrive::MAX_NODE_ID),
            })
        };
        let ids = [id(cfg.ids[0])?, id(cfg.ids[1])?];
        if ids[0] == ids[1] {
            return Err(SimError::Config {
                field: "ids",
                reason: format!("pitch and yaw share the node id {}", cfg.ids[0]),
            });
        }
        if cfg.watchdog == Nanos::ZERO {
            return Err(SimError::Config {
                field: "watchdog",
                reason: "a timeout above zero".into(),
            });
        }
        Ok(Self::powered_on(
            Odrive { cfg, injected: 0 },
            [
                OdriveAxis::new(ids[0], cfg.axes[0]),
                OdriveAxis::new(ids[1], cfg.axes[1]),
            ],
            now,
            cfg.boot_time,
            cfg.seed,
        ))
    }

    /// The configuration.
    pub fn config(&self) -> &OdriveJointConfig {
        &self.firmware.cfg
    }

    /// The CANSimple state of an axis (0 pitch, 1 yaw; `Undefined` while
    /// booting).
    pub fn axis_state(&self, axis: usize) -> AxisState {
        self.axes[axis].state
    }

    /// The active `ODriveError` bits of an axis.
    pub fn axis_error(&self, axis: usize) -> u32 {
        self.axes[axis].error
    }

    /// The last `procedure_result` of an axis.
    pub fn procedure_result(&self, axis: usize) -> u8 {
        self.axes[axis].procedure_result
    }
}

impl BoughtAxis for OdriveAxis {
    fn actuator(&self) -> &Actuator {
        &self.actuator
    }

    fn actuator_mut(&mut self) -> &mut Actuator {
        &mut self.actuator
    }

    fn booted(&self) -> bool {
        self.state != AxisState::Undefined
    }

    fn drive(&self) -> Drive {
        OdriveAxis::drive(self)
    }

    fn node_state(&self) -> NodeState {
        OdriveAxis::node_state(self)
    }
}

impl Firmware for Odrive {
    type Axis = OdriveAxis;

    fn addressed(joint: &OdriveJoint, frame: &Frame) -> Option<usize> {
        let (node, _) = odrive::split_id(frame.id().as_standard()?);
        joint.axes.iter().position(|a| a.id.get() == node)
    }

    fn on_frame(
        joint: &mut OdriveJoint,
        now: Nanos,
        k: usize,
        frame: &Frame,
        tx: &mut dyn FnMut(Frame),
    ) -> bool {
        let Ok(m) = odrive::decode(frame) else {
            return false;
        };
        let a = &mut joint.axes[k];
        match m.body {
            // Another device's (or our own echoed) drive-to-host messages.
            Body::Heartbeat(_) | Body::EncoderEstimates(_) => return true,
            Body::Request(odrive::Cmd::Heartbeat) => a.heartbeat(tx),
            Body::Request(odrive::Cmd::GetEncoderEstimates) => a.estimates(&mut joint.rng, tx),
            // The codec decodes requests only for requestable commands.
            Body::Request(_) => {}
            Body::Estop => a.raise(axis_error::ESTOP_REQUESTED, tx),
            Body::SetAxisState(s) => a.request(s, now, tx),
            Body::SetControllerMode {
                control_mode,
                input_mode,
            } => a.mode = Some((control_mode, input_mode)),
            Body::SetInputPos(InputPos {
                input_pos,
                vel_ff,
                torque_ff,
            }) => {
                if a.state == AxisState::ClosedLoopControl {
                    a.input = Input {
                        position: f64::from(input_pos) * TURN,
                        velocity: f64::from(vel_ff) * TURN,
                        torque: f64::from(torque_ff),
                    };
                    joint.counters.applied += 1;
                }
            }
            Body::ClearErrors { .. } => {
                let before = a.error;
                a.error = joint.firmware.injected;
                if a.error == 0 {
                    a.procedure_result = procedure_result::SUCCESS;
                }
                if a.error != before {
                    a.heartbeat(tx);
                }
            }
        }
        // The firmware's CAN handler feeds the watchdog on every message
        // for the axis.
        a.last_fed = now;
        true
    }

    /// IDLE, the first cyclic messages due at once.
    fn boot(joint: &mut OdriveJoint, t: Nanos) {
        for a in &mut joint.axes {
            a.state = AxisState::Idle;
            a.error = joint.firmware.injected;
            a.procedure_result = procedure_result::SUCCESS;
            a.next_heartbeat = t;
            a.next_estimate = t;
        }
    }

    fn tick(joint: &mut OdriveJoint, t: Nanos, tx: &mut dyn FnMut(Frame)) {
        for a in &mut joint.axes {
            if a.state == AxisState::ClosedLoopControl
                && t.saturating_sub(a.last_fed) > joint.firmware.cfg.watchdog
            {
                joint.counters.watchdog_expiries += 1;
                a.raise(axis_error::WATCHDOG_TIMER_EXPIRED, tx);
            }
            if t >= a.next_heartbeat {
                a.heartbeat(tx);
                a.next_heartbeat = t + HEARTBEAT_PERIOD;
            }
            if t >= a.next_estimate {
                a.estimates(&mut joint.rng, tx);
                a.next_estimate = t + ENCODER_PERIOD;
            }
        }
    }

    fn powered_on(&self, k: usize, before: &OdriveAxis) -> OdriveAxis {
        // Mode, errors and closed loop are volatile; an injected fault is
        // back as soon as the axes boot.
        OdriveAxis::new(before.id, self.cfg.axes[k])
    }

    fn inject_fault(joint: &mut OdriveJoint, bits: u16, tx: &mut dyn FnMut(Frame)) {
        let e = injected_error(bits);
        joint.firmware.injected |= e;
        // A silent drive faults all the same; it just says nothing.
        let mut quiet = |_: Frame| {};
        let out: &mut dyn FnMut(Frame) = if joint.silent { &mut quiet } else { tx };
        for a in &mut joint.axes {
            if a.booted() {
                a.raise(e, out);
            }
        }
    }

    fn clear_injected_fault(&mut self) {
        self.injected = 0;
    }

    fn impostor_heartbeat(
        joint: &OdriveJoint,
        state: NodeState,
        _counter: u8,
        tx: &mut dyn FnMut(Frame),
    ) {
        let axis_state = if state == NodeState::Enabled {
            AxisState::ClosedLoopControl
        } else {
            AxisState::Idle
        };
        for a in &joint.axes {
            a.send(
                Body::Heartbeat(Heartbeat {
                    axis_error: 0,
                    axis_state,
                    procedure_result: 0,
                    trajectory_done: true,
                }),
                tx,
            );
        }
    }
}

#[cfg(test)]
mod tests;
