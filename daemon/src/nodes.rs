//! What the daemon knows of each vertebra node, from the frames it reads.
//!
//! Every frame received in a period goes through [`NodeTable::ingest`]: it is
//! decoded with the protocol crate against the configured node ids;
//! feedback and heartbeats update the node's entry, an E-stop frame from
//! another sender is noted, and anything that does not decode is counted
//! (never a panic). [`NodeTable::observe`] turns the table into the
//! supervisor's [`Observations`](crate::supervisor::Observations).

use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{
    self, DecodeError, ErrorBits, Feedback, Message, NodeId, NodeSet, NodeState, Target, Variant,
};

use crate::supervisor::Nanos;

/// One node's latest reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeEntry {
    /// The node's id.
    pub id: NodeId,
    /// State from its last heartbeat (`None` before the first).
    pub state: Option<NodeState>,
    /// Error bits from its last heartbeat.
    pub errors: ErrorBits,
    /// When its last heartbeat arrived.
    pub last_heartbeat: Option<Nanos>,
    /// Its last feedback.
    pub feedback: Option<Feedback>,
    /// Heartbeats received.
    pub heartbeats: u64,
}

/// Why frames were not used; counted, never fatal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RxCounters {
    /// Frames that did not decode (unknown id, wrong length, bad value, unknown node).
    pub malformed: u64,
    /// The last decode error, for the operator.
    pub last_error: Option<DecodeError>,
    /// Host-to-node frames seen from another sender (another tool on the bus).
    pub foreign_commands: u64,
    /// E-stop frames seen on the bus.
    pub estops_seen: u64,
}

/// The nodes' reports at one instant ([`NodeTable::observe`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeReport {
    /// Every configured node reports Enabled.
    pub all_enabled: bool,
    /// Nodes whose heartbeat is overdue.
    pub lost: NodeSet,
    /// Nodes in Fault.
    pub fault: NodeSet,
    /// Nodes in EStop.
    pub estop: NodeSet,
}

impl Default for NodeReport {
    fn default() -> Self {
        NodeReport {
            all_enabled: false,
            lost: NodeSet::empty(),
            fault: NodeSet::empty(),
            estop: NodeSet::empty(),
        }
    }
}

/// The table of nodes, in joint order (head to tail).
#[derive(Debug, Clone)]
pub struct NodeTable {
    variant: Variant,
    set: NodeSet,
    entries: Vec<NodeEntry>,
    index: [u8; 64],
    counters: RxCounters,
    bus_estop: bool,
    started: Nanos,
}

const NONE: u8 = u8::MAX;

impl NodeTable {
    /// A table for `ids` (joint order), all unheard-of, created at `now`.
    pub fn new(variant: Variant, ids: &[NodeId], now: Nanos) -> Self {
        let mut set = NodeSet::empty();
        let mut index = [NONE; 64];
        for (i, id) in ids.iter().enumerate() {
            set = set.with(*id);
            index[id.get() as usize] = i as u8;
        }
        Self {
            variant,
            set,
            entries: ids
                .iter()
                .map(|&id| NodeEntry {
                    id,
                    state: None,
                    errors: ErrorBits(0),
                    last_heartbeat: None,
                    feedback: None,
                    heartbeats: 0,
                })
                .collect(),
            index,
            counters: RxCounters::default(),
            bus_estop: false,
            started: now,
        }
    }

    /// The entries, in joint order.
    pub fn entries(&self) -> &[NodeEntry] {
        &self.entries
    }

    /// Receive counters.
    pub fn counters(&self) -> RxCounters {
        self.counters
    }

    fn entry(&mut self, id: NodeId) -> Option<&mut NodeEntry> {
        let i = self.index[id.get() as usize];
        self.entries.get_mut(i as usize)
    }

    /// Takes one received frame into account. Allocates nothing.
    pub fn ingest(&mut self, now: Nanos, frame: &Frame) {
        // An E-stop from anyone else on the bus (a node, cansend, another
        // tool): act on it whatever its payload, as the nodes do.
        let estop = match message::estop_target(frame.id()) {
            Some(Target::All) => true,
            Some(Target::Node(n)) => self.set.contains(n.get()),
            None => false,
        };
        if estop {
            self.counters.estops_seen += 1;
            self.bus_estop = true;
            return;
        }
        match message::decode(frame, self.variant, self.set) {
            Ok(Message::Heartbeat(hb)) => {
                if let Some(e) = self.entry(hb.node) {
                    e.state = Some(hb.state);
                    e.errors = hb.errors;
                    e.last_heartbeat = Some(now);
                    e.heartbeats += 1;
                }
            }
            Ok(Message::Feedback(fb)) => {
                if let Some(e) = self.entry(fb.node) {
                    e.feedback = Some(fb);
                }
            }
            Ok(Message::ConfigAck { .. }) => {}
            // A head sensor's frames: the configured sensor's never get here
            // (the controller hands them to `nav::Nav` first); an
            // unconfigured sensor's arrive as unknown-node errors below,
            // and this arm is for a sensor sharing a joint's id.
            Ok(
                Message::HeadAttitude(_)
                | Message::HeadRates(_)
                | Message::HeadAccel(_)
                | Message::HeadDepth(_)
                | Message::HeadSample(_),
            ) => {}
            Ok(
                Message::Sync { .. }
                | Message::Command { .. }
                | Message::Setpoint(_)
                | Message::SetpointGroup(_)
                | Message::ConfigWrite { .. }
                | Message::EStop(_),
            ) => self.counters.foreign_commands += 1,
            Err(e) => {
                self.counters.malformed += 1;
                self.counters.last_error = Some(e);
            }
        }
    }

    /// Whether an E-stop was seen since the last call (then cleared).
    pub fn take_bus_estop(&mut self) -> bool {
        core::mem::take(&mut self.bus_estop)
    }

    /// What the nodes report, for the supervisor. A node never heard of is
    /// lost once `heartbeat_timeout` has passed since the table was made.
    pub fn observe(&self, now: Nanos, heartbeat_timeout: Nanos) -> NodeReport {
        let mut r = NodeReport {
            all_enabled: true,
            ..NodeReport::default()
        };
        for e in &self.entries {
            let since = now.saturating_sub(e.last_heartbeat.unwrap_or(self.started));
            if since > heartbeat_timeout {
                r.lost = r.lost.with(e.id);
            }
            match e.state {
                Some(NodeState::Enabled) => {}
                Some(NodeState::Fault) => {
                    r.fault = r.fault.with(e.id);
                    r.all_enabled = false;
                }
                Some(NodeState::EStop) => {
                    r.estop = r.estop.with(e.id);
                    r.all_enabled = false;
                }
                _ => r.all_enabled = false,
            }
        }
        r
    }

    /// Forgets every node's state (after a clear-faults, the old reports
    /// are stale) but keeps heartbeat times.
    pub fn forget_states(&mut self) {
        for e in &mut self.entries {
            e.state = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_protocol::frame::Id;
    use anguilla_protocol::message::{AxisFeedback, Heartbeat};

    const MS: Nanos = Nanos::from_millis(1);

    fn ids(n: u8) -> Vec<NodeId> {
        (1..=n).map(|i| NodeId::new(i).unwrap()).collect()
    }

    fn hb(node: u8, state: NodeState) -> Frame {
        Message::Heartbeat(Heartbeat {
            node: NodeId::new(node).unwrap(),
            state,
            errors: ErrorBits(0),
            counter: 0,
            missed_syncs: 0,
            temperature: 30,
        })
        .encode(Variant::Classic)
        .unwrap()
    }

    #[test]
    fn heartbeats_and_feedback_update_the_table() {
        let mut t = NodeTable::new(Variant::Classic, &ids(3), Nanos::ZERO);
        for n in 1..=3 {
            t.ingest(MS, &hb(n, NodeState::Enabled));
        }
        let fb = Message::Feedback(Feedback {
            node: NodeId::new(2).unwrap(),
            enabled: true,
            fault: false,
            axes: [AxisFeedback {
                position: 0.25,
                ..Default::default()
            }; 2],
        })
        .encode(Variant::Classic)
        .unwrap();
        t.ingest(MS, &fb);
        let r = t.observe(2 * MS, 350 * MS);
        assert!(r.all_enabled);
        let none = NodeSet::empty();
        assert_eq!((r.lost, r.fault, r.estop), (none, none, none));
        let p = t.entries()[1].feedback.unwrap().axes[0].position;
        assert!((p - 0.25).abs() < 1e-3);
    }

    #[test]
    fn silence_faults_and_estops_are_reported_by_node_bit() {
        let mut t = NodeTable::new(Variant::Classic, &ids(3), Nanos::ZERO);
        t.ingest(Nanos::ZERO, &hb(1, NodeState::Enabled));
        t.ingest(Nanos::ZERO, &hb(2, NodeState::Fault));
        t.ingest(400 * MS, &hb(1, NodeState::Enabled));
        t.ingest(400 * MS, &hb(3, NodeState::EStop));
        let r = t.observe(400 * MS, 350 * MS);
        let only = |n| NodeSet::empty().with(NodeId::new(n).unwrap());
        assert!(!r.all_enabled);
        assert_eq!(r.lost, only(2), "node 2 silent for 400 ms");
        assert_eq!(r.fault, only(2));
        assert_eq!(r.estop, only(3));
    }

    #[test]
    fn junk_is_counted_and_an_estop_frame_is_noticed() {
        let mut t = NodeTable::new(Variant::Classic, &ids(3), Nanos::ZERO);
        t.ingest(Nanos::ZERO, &Frame::new_standard(0x7FF, &[1, 2]).unwrap());
        t.ingest(
            Nanos::ZERO,
            &Frame::new(Id::extended(5).unwrap(), &[]).unwrap(),
        );
        t.ingest(Nanos::ZERO, &hb(9, NodeState::Enabled)); // not a configured node
        assert_eq!(t.counters().malformed, 3);
        assert!(t.counters().last_error.is_some());
        assert!(!t.take_bus_estop());
        t.ingest(Nanos::ZERO, &Frame::new_standard(0x000, &[]).unwrap());
        assert!(t.take_bus_estop());
        assert!(!t.take_bus_estop(), "taken once");
    }
}
