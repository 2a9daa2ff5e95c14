//! What a simulated joint's drives are, whatever protocol they speak.
//!
//! A joint has a pitch (0) and a yaw (1) axis. Its drives — one anguilla
//! vertebra node ([`crate::node::VertebraNode`]) carrying both axes, or two
//! bought drives (a CiA 402 drive or an ODrive axis each) — hear the bus,
//! talk on it, and servo the joint's two [`Actuator`]s
//! against the load the swimming body puts on them. The robot
//! ([`crate::SimRobot`]) sees only this trait, so a further drive family is
//! one new module implementing it.
//!
//! A joint of two bought single-axis drives is a [`BoughtJoint`]: the
//! shell every such family shares (the servo steps, boot, silence, the
//! frame's way to its drive, the joint's state as the worse of its two
//! drives', reboot, the counters) around the family's [`Firmware`], which
//! supplies only its frames and the behaviour its protocol documents.

use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::NodeState;

use crate::actuator::{Actuator, AxisFaults, Drive, Load};
use crate::node::{Nanos, NodeCounters, SERVO_DT, SERVO_DT_NS};
use crate::rng::Rng;

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

/// One simulated bought drive: the axis of a joint it servos, and the
/// protocol state around it.
pub trait BoughtAxis: Clone + std::fmt::Debug + Send {
    /// Its actuator.
    fn actuator(&self) -> &Actuator;
    /// Its actuator, to step or to place.
    fn actuator_mut(&mut self) -> &mut Actuator;
    /// Whether it has booted (it hears and speaks from then on).
    fn booted(&self) -> bool;
    /// What its servo does this step.
    fn drive(&self) -> Drive;
    /// Its state in the anguilla vocabulary.
    fn node_state(&self) -> NodeState;
}

/// What a bought drive family's firmware does in a [`BoughtJoint`]: its
/// frames and its protocol's rules; the joint-level state it keeps (its
/// configuration, an injected fault) is `Self`.
pub trait Firmware: Clone + std::fmt::Debug + Send + Sized {
    /// One drive.
    type Axis: BoughtAxis;
    /// The drive (0 pitch, 1 yaw) a frame on the bus is addressed to, if it
    /// is one of the joint's.
    fn addressed(joint: &BoughtJoint<Self>, frame: &Frame) -> Option<usize>;
    /// Handles a frame addressed to drive `k` at `now`; `false` when it does
    /// not decode (the shell counts it in [`NodeCounters::bad_frames`]).
    fn on_frame(
        joint: &mut BoughtJoint<Self>,
        now: Nanos,
        k: usize,
        frame: &Frame,
        tx: &mut dyn FnMut(Frame),
    ) -> bool;
    /// Boot ends at `t`: the drives' state after power-on.
    fn boot(joint: &mut BoughtJoint<Self>, t: Nanos);
    /// One servo step at `t` of booted drives that speak: watchdogs,
    /// cyclic messages.
    fn tick(joint: &mut BoughtJoint<Self>, t: Nanos, tx: &mut dyn FnMut(Frame));
    /// Drive `k` as it powers on again: its volatile state lost (the shell
    /// keeps its actuator's motion).
    fn powered_on(&self, k: usize, before: &Self::Axis) -> Self::Axis;
    /// Fault injection: the family's error for anguilla error `bits`, on
    /// both drives (the joint has advanced to now).
    fn inject_fault(joint: &mut BoughtJoint<Self>, bits: u16, tx: &mut dyn FnMut(Frame));
    /// Removes an injected fault condition.
    fn clear_injected_fault(&mut self);
    /// What an impostor on the joint's ids sends to look alive.
    fn impostor_heartbeat(
        joint: &BoughtJoint<Self>,
        state: NodeState,
        counter: u8,
        tx: &mut dyn FnMut(Frame),
    );
}

/// A joint of two bought drives (pitch, yaw) of family `F`. Receiving and
/// advancing allocate nothing.
#[derive(Debug, Clone)]
pub struct BoughtJoint<F: Firmware> {
    /// The family's joint-level state.
    pub(crate) firmware: F,
    /// The drives, pitch then yaw.
    pub(crate) axes: [F::Axis; 2],
    /// Where the simulation of the drives stands.
    pub(crate) time: Nanos,
    /// From power-on to booted.
    pub(crate) boot_time: Nanos,
    /// When the drives finish booting.
    pub(crate) boot_done: Nanos,
    /// The encoders' noise.
    pub(crate) rng: Rng,
    /// Fault injection: neither sends nor hears.
    pub(crate) silent: bool,
    /// What a firmware counts.
    pub(crate) counters: NodeCounters,
}

impl<F: Firmware> BoughtJoint<F> {
    /// A joint of `axes` powered on at `now`, booted `boot_time` later.
    pub(crate) fn powered_on(
        firmware: F,
        axes: [F::Axis; 2],
        now: Nanos,
        boot_time: Nanos,
        seed: u64,
    ) -> Self {
        Self {
            firmware,
            axes,
            time: now,
            boot_time,
            boot_done: now + boot_time,
            rng: Rng::new(seed),
            silent: false,
            counters: NodeCounters::default(),
        }
    }
}

impl<F: Firmware> JointDevice for BoughtJoint<F> {
    fn receive(&mut self, now: Nanos, frame: &Frame, tx: &mut dyn FnMut(Frame)) {
        self.advance(now, tx);
        if self.silent || !self.axes[0].booted() {
            return;
        }
        let Some(k) = F::addressed(self, frame) else {
            return;
        };
        if !F::on_frame(self, now, k, frame, tx) {
            self.counters.bad_frames += 1;
        }
    }

    fn advance(&mut self, now: Nanos, tx: &mut dyn FnMut(Frame)) {
        while self.time + SERVO_DT_NS <= now {
            self.time += SERVO_DT_NS;
            let t = self.time;
            for a in &mut self.axes {
                let drive = a.drive();
                a.actuator_mut().step(SERVO_DT, drive);
            }
            if self.silent {
                continue;
            }
            if !self.axes[0].booted() {
                if t < self.boot_done {
                    continue;
                }
                F::boot(self, t);
            }
            F::tick(self, t, tx);
        }
    }

    fn kinematics(&self, axis: usize) -> (f64, f64, f64) {
        self.axes[axis].actuator().kinematics()
    }

    fn motor_torque(&self, axis: usize) -> f64 {
        self.axes[axis].actuator().torque()
    }

    fn set_load(&mut self, load: [Load; 2]) {
        for (a, l) in self.axes.iter_mut().zip(load) {
            a.actuator_mut().set_load(l);
        }
    }

    fn set_pose(&mut self, angles: [f64; 2]) {
        for (a, th) in self.axes.iter_mut().zip(angles) {
            a.actuator_mut().set_state(th, 0.0);
        }
    }

    fn state(&self) -> NodeState {
        let [p, y] = [self.axes[0].node_state(), self.axes[1].node_state()];
        for worse in [
            NodeState::EStop,
            NodeState::Fault,
            NodeState::Boot,
            NodeState::Disabled,
        ] {
            if p == worse || y == worse {
                return worse;
            }
        }
        NodeState::Enabled
    }

    fn counters(&self) -> NodeCounters {
        self.counters
    }

    fn set_silent(&mut self, silent: bool) {
        self.silent = silent;
    }

    fn reboot(&mut self, now: Nanos) {
        // The volatile state and the silence are lost; the joints keep
        // their motion, the encoders their noise sequence, the counters
        // their counts and an injected fault its cause.
        for k in 0..2 {
            let mut fresh = self.firmware.powered_on(k, &self.axes[k]);
            *fresh.actuator_mut() = self.axes[k].actuator().clone();
            self.axes[k] = fresh;
        }
        self.time = now;
        self.boot_done = now + self.boot_time;
        self.silent = false;
    }

    fn axis_faults_mut(&mut self, axis: usize) -> &mut AxisFaults {
        self.axes[axis].actuator_mut().faults_mut()
    }

    fn inject_fault(&mut self, bits: u16, now: Nanos, tx: &mut dyn FnMut(Frame)) {
        self.advance(now, tx);
        F::inject_fault(self, bits, tx);
    }

    fn clear_injected_fault(&mut self) {
        self.firmware.clear_injected_fault();
    }

    fn impostor_heartbeat(&self, state: NodeState, counter: u8, tx: &mut dyn FnMut(Frame)) {
        F::impostor_heartbeat(self, state, counter, tx)
    }
}
