//! A joint the simulator does not play: a real vertebra on the same bus
//! (`anguilla sim --skip IDS`, [`crate::RobotConfig::observed`]). The
//! simulated robot sends nothing for it and hears its feedback frames as
//! the daemon does; the body swims with the joint's measured angles and
//! rates (played one feedback interval late, along the cubic between the
//! last two frames), so the simulated vertebrae, the head sensor and the
//! ground truth feel what the real joint did. The body's load on the
//! joint ([`crate::SimRobot::loads`]) is what the real joint would feel in
//! the water.
//!
//! The anguilla protocol's vertebrae (feedback and heartbeat frames of the
//! node's id). The simulator cannot fault a real node: a scenario naming
//! it is refused when it is loaded.

use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{
    self, AxisFeedback, Message, NodeId, NodeSet, NodeState, Variant,
};

use crate::actuator::{AxisFaults, Load};
use crate::device::JointDevice;
use crate::node::{Nanos, NodeCounters};

/// A real vertebra's joint, seen on the bus.
#[derive(Debug)]
pub struct ObservedJoint {
    id: NodeId,
    variant: Variant,
    /// The last feedback and when it arrived.
    last: Option<([AxisFeedback; 2], Nanos)>,
    /// The one before it.
    before: Option<([AxisFeedback; 2], Nanos)>,
    state: NodeState,
    now: Nanos,
    /// What fault injection would write: kept, never applied.
    faults: [AxisFaults; 2],
    /// Frames of its id that did not decode ([`NodeCounters::bad_frames`]).
    undecodable: u64,
}

impl ObservedJoint {
    /// Node `id` of a bus of `variant`, not yet heard.
    pub fn new(id: NodeId, variant: Variant, start: Nanos) -> Self {
        Self {
            id,
            variant,
            last: None,
            before: None,
            state: NodeState::Boot,
            now: start,
            faults: [AxisFaults::default(); 2],
            undecodable: 0,
        }
    }
}

impl JointDevice for ObservedJoint {
    fn receive(&mut self, now: Nanos, frame: &Frame, _tx: &mut dyn FnMut(Frame)) {
        self.now = self.now.max(now);
        let Some(raw) = frame.id().as_standard() else {
            return;
        };
        if message::Function::split_id(raw).map(|(_, node)| node) != Some(self.id.get()) {
            return;
        }
        match message::decode(frame, self.variant, NodeSet::empty().with(self.id)) {
            Ok(Message::Feedback(f)) if f.node == self.id => {
                let finite = f
                    .axes
                    .iter()
                    .all(|a| a.position.is_finite() && a.velocity.is_finite());
                if finite {
                    self.before = self.last.replace((f.axes, now));
                } else {
                    self.undecodable += 1;
                }
            }
            Ok(Message::Heartbeat(h)) if h.node == self.id => self.state = h.state,
            // Its id's other traffic (what the daemon sends it).
            Ok(_) => {}
            Err(_) => self.undecodable += 1,
        }
    }

    fn advance(&mut self, now: Nanos, _tx: &mut dyn FnMut(Frame)) {
        self.now = self.now.max(now);
    }

    /// The measured motion played one feedback interval late: along the
    /// cubic from the frame before the last to the last (their angles and
    /// rates), so it is continuous when a frame arrives; held at the last
    /// frame's angle, still, once a further interval has passed without
    /// one (a joint gone silent).
    fn kinematics(&self, axis: usize) -> (f64, f64, f64) {
        let axis = axis.min(1);
        let at = |f: &[AxisFeedback; 2]| [f[axis].position as f64, f[axis].velocity as f64, 0.0];
        match (self.before, self.last) {
            (Some((f0, t0)), Some((f1, t1))) => {
                let h = (t1.saturating_sub(t0).as_nanos() as f64 * 1e-9).clamp(1e-3, 0.05);
                let s = self.now.saturating_sub(t1).as_nanos() as f64 * 1e-9 / h;
                if s <= 1.0 {
                    let [p, v, a] = anguilla_model::hermite(at(&f0), at(&f1), h, s);
                    (p, v, a)
                } else {
                    (at(&f1)[0], 0.0, 0.0)
                }
            }
            (None, Some((f1, _))) => (at(&f1)[0], 0.0, 0.0),
            _ => (0.0, 0.0, 0.0),
        }
    }

    /// Its measured torque.
    fn motor_torque(&self, axis: usize) -> f64 {
        self.last.map_or(0.0, |(f, _)| f[axis.min(1)].torque as f64)
    }

    /// The real joint's actuator feels the water, not the simulator.
    fn set_load(&mut self, _load: [Load; 2]) {}

    /// A real joint is where it is.
    fn set_pose(&mut self, _angles: [f64; 2]) {}

    fn state(&self) -> NodeState {
        self.state
    }

    fn counters(&self) -> NodeCounters {
        NodeCounters {
            bad_frames: self.undecodable,
            ..NodeCounters::default()
        }
    }

    fn set_silent(&mut self, _silent: bool) {}

    fn reboot(&mut self, _now: Nanos) {}

    fn axis_faults_mut(&mut self, axis: usize) -> &mut AxisFaults {
        &mut self.faults[axis.min(1)]
    }

    fn inject_fault(&mut self, _bits: u16, _now: Nanos, _tx: &mut dyn FnMut(Frame)) {}

    fn clear_injected_fault(&mut self) {}

    fn impostor_heartbeat(&self, _state: NodeState, _counter: u8, _tx: &mut dyn FnMut(Frame)) {}
}
