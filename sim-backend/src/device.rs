//! What a simulated joint's drives are, whatever protocol they speak.
//!
//! A joint has a pitch (0) and a yaw (1) axis. Its drives — one anguilla
//! vertebra node ([`crate::node::VertebraNode`]) carrying both axes, or two
//! bought drives (a CiA 402 drive or an ODrive axis each) — hear the bus,
//! talk on it, and servo the joint's two [`Actuator`](crate::actuator::Actuator)s
//! against the load the swimming body puts on them. The robot
//! ([`crate::SimRobot`]) sees only this trait, so a further drive family is
//! one new module implementing it.

use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::NodeState;

use crate::actuator::{AxisFaults, Load};
use crate::node::{Nanos, NodeCounters};

/// One joint's drives on the bus (the simulated firmware of one node, or
/// of two single-axis drives).
pub trait JointDevice: Send + std::fmt::Debug {
    /// Handles one frame seen on the bus at `now` (advancing to `now`
    /// first); frames to send go to `tx`.
    fn receive(&mut self, now: Nanos, frame: &Frame, tx: &mut dyn FnMut(Frame));
    /// Runs the drives' own loops (servo, watchdogs, cyclic messages) up
    /// to `now`.
    fn advance(&mut self, now: Nanos, tx: &mut dyn FnMut(Frame));
    /// True angle (rad), velocity and acceleration of axis 0 (pitch) or 1
    /// (yaw), at the joint.
    fn kinematics(&self, axis: usize) -> (f64, f64, f64);
    /// The torque the actuator of an axis applies to the joint (N·m).
    fn motor_torque(&self, axis: usize) -> f64;
    /// The body's load on each axis from now on
    /// ([`crate::actuator::Actuator::set_load`]).
    fn set_load(&mut self, load: [Load; 2]);
    /// Places both axes at these joint angles (rad), at rest: a
    /// simulation's initial pose, or a limp joint moved by hand.
    fn set_pose(&mut self, angles: [f64; 2]);
    /// The joint's state in the anguilla vocabulary: for two drives, the
    /// worse of the two (EStop, then Fault, then Boot, then Disabled;
    /// Enabled only when both are).
    fn state(&self) -> NodeState;
    /// Counters a firmware would keep.
    fn counters(&self) -> NodeCounters;
    /// Fault injection: silent drives neither send nor hear anything.
    fn set_silent(&mut self, silent: bool);
    /// Fault injection: the drives reboot (volatile configuration lost).
    fn reboot(&mut self, now: Nanos);
    /// Fault injection: the faults of an axis (stuck, torque cap, noise, spike).
    fn axis_faults_mut(&mut self, axis: usize) -> &mut AxisFaults;
    /// Fault injection: a latched drive fault on both axes (anguilla error
    /// bits for a vertebra node; the bought drives map them to their own
    /// codes) until [`JointDevice::clear_injected_fault`].
    fn inject_fault(&mut self, bits: u16, now: Nanos, tx: &mut dyn FnMut(Frame));
    /// Removes an injected fault condition (a fault reset can then succeed).
    fn clear_injected_fault(&mut self);
    /// Fault injection: what an impostor on this joint's ids sends to look
    /// alive in `state` (the family's liveness message: a heartbeat, or a
    /// drive's reply), `counter` where the family's message has one.
    fn impostor_heartbeat(&self, state: NodeState, counter: u8, tx: &mut dyn FnMut(Frame));
}

impl JointDevice for crate::node::VertebraNode {
    fn receive(&mut self, now: Nanos, frame: &Frame, tx: &mut dyn FnMut(Frame)) {
        crate::node::VertebraNode::receive(self, now, frame, &mut |f| tx(f))
    }
    fn advance(&mut self, now: Nanos, tx: &mut dyn FnMut(Frame)) {
        crate::node::VertebraNode::advance(self, now, &mut |f| tx(f))
    }
    fn kinematics(&self, axis: usize) -> (f64, f64, f64) {
        crate::node::VertebraNode::kinematics(self, axis)
    }
    fn motor_torque(&self, axis: usize) -> f64 {
        crate::node::VertebraNode::motor_torque(self, axis)
    }
    fn set_load(&mut self, load: [Load; 2]) {
        crate::node::VertebraNode::set_load(self, load)
    }
    fn set_pose(&mut self, angles: [f64; 2]) {
        crate::node::VertebraNode::set_pose(self, angles)
    }
    fn state(&self) -> NodeState {
        crate::node::VertebraNode::state(self)
    }
    fn counters(&self) -> NodeCounters {
        crate::node::VertebraNode::counters(self)
    }
    fn set_silent(&mut self, silent: bool) {
        crate::node::VertebraNode::set_silent(self, silent)
    }
    fn reboot(&mut self, now: Nanos) {
        crate::node::VertebraNode::reboot(self, now)
    }
    fn axis_faults_mut(&mut self, axis: usize) -> &mut AxisFaults {
        crate::node::VertebraNode::axis_faults_mut(self, axis)
    }
    fn inject_fault(&mut self, bits: u16, now: Nanos, tx: &mut dyn FnMut(Frame)) {
        crate::node::VertebraNode::inject_fault(self, bits, now, &mut |f| tx(f))
    }
    fn clear_injected_fault(&mut self) {
        crate::node::VertebraNode::clear_injected_fault(self)
    }
    fn impostor_heartbeat(&self, state: NodeState, counter: u8, tx: &mut dyn FnMut(Frame)) {
        use anguilla_protocol::message::{ErrorBits, Heartbeat, Message};
        let hb = Message::Heartbeat(Heartbeat {
            node: self.id(),
            state,
            errors: ErrorBits(0),
            counter,
            missed_syncs: 0,
            temperature: 30,
        });
        if let Ok(f) = hb.encode(self.variant()) {
            tx(f);
        }
    }
}
