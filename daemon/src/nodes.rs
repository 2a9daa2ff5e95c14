//! What the daemon knows of each vertebra node, from the frames it reads.
//!
//! Every frame received in a period goes through [`NodeTable::ingest`]: it is
//! decoded with the protocol crate against the configured node ids;
//! feedback and heartbeats update the node's entry, an E-stop frame from
//! another sender is noted, and anything that does not decode is counted
//! (never a panic). [`NodeTable::observe`] turns the table into the
//! supervisor's [`Observations`](crate::supervisor::Observations).
//!
//! A node is judged alive by what it does, not only by what it says:
//!
//! - **Feedback.** Every node that has booted answers each SYNC with a
//!   Feedback frame (`protocol/README.md`). [`NodeTable::sync_sent`] counts
//!   the SYNCs since each node's last feedback; a node that answered none
//!   of the last [`Liveness::feedback_periods`] is *silent*, whatever its
//!   heartbeats say. Counting SYNCs, not time, keeps a stalled loop (a busy
//!   machine) from faulting nodes that had no SYNC to answer.
//! - **Heartbeat counters.** A node's heartbeat counter advances by one per
//!   heartbeat. A counter that repeats or jumps is an anomaly; a reboot
//!   gives one. [`DUPLICATE_ANOMALIES`] anomalies within
//!   [`DUPLICATE_WINDOW`] mean two senders with one id: a second node
//!   configured to it, or a forger; the node is *duplicate*.

use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{
    self, ErrorBits, Feedback, Message, NodeId, NodeSet, NodeState, Target, Variant,
};

use anguilla_ipc::vocabulary::Nanos;

use crate::drive::report::{Liveness, NodeReport, RxCounters};

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
    /// The counter of its last heartbeat.
    pub last_counter: Option<u8>,
    /// When its last [`DUPLICATE_ANOMALIES`] counter anomalies were seen
    /// (a ring, oldest overwritten).
    anomalies: [Option<Nanos>; DUPLICATE_ANOMALIES],
    /// SYNCs sent since its last feedback.
    pub syncs_since_feedback: u32,
    /// Its states were forgotten (a clear-faults went out) and no
    /// heartbeat came since: the next one may have been sent before the
    /// node read the clear, so its state and errors are not taken.
    stale: bool,
}

/// Counter anomalies that mean two senders share a node id, when they
/// fall within [`DUPLICATE_WINDOW`]. Three: a reboot gives one, a lost
/// heartbeat frame one more; two senders give one per heartbeat (ten a
/// second), so the fault comes within about 0.3 s.
pub const DUPLICATE_ANOMALIES: usize = 3;

/// The window for [`DUPLICATE_ANOMALIES`].
pub const DUPLICATE_WINDOW: Nanos = Nanos::from_millis(1_000);

/// The table of nodes, in joint order (head to tail).
#[derive(Debug, Clone)]
pub struct NodeTable {
    variant: Variant,
    set: NodeSet,
    entries: Vec<NodeEntry>,
    index: [u8; 64],
    counters: RxCounters,
    bus_estop: bool,
    /// Nodes another sender commanded (Enable, Disable, ClearFaults).
    foreign: NodeSet,
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
                    last_counter: None,
                    anomalies: [None; DUPLICATE_ANOMALIES],
                    syncs_since_feedback: 0,
                    stale: false,
                })
                .collect(),
            index,
            counters: RxCounters::default(),
            bus_estop: false,
            foreign: NodeSet::empty(),
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
                    // The first heartbeat after a clear-faults may be one
                    // the node sent before it read the clear (on a bus, at
                    // most one: a node reads its frames in order), so its
                    // state is old news. A node that stayed latched says so
                    // in the next. A simulated robot catching up after
                    // starvation can send several at once; the supervisor's
                    // settle time (one heartbeat timeout) covers those.
                    if e.stale {
                        e.stale = false;
                    } else {
                        e.state = Some(hb.state);
                        e.errors = hb.errors;
                    }
                    e.last_heartbeat = Some(now);
                    e.heartbeats += 1;
                    if e.last_counter
                        .is_some_and(|c| hb.counter != c.wrapping_add(1))
                    {
                        e.anomalies.rotate_left(1);
                        e.anomalies[DUPLICATE_ANOMALIES - 1] = Some(now);
                    }
                    e.last_counter = Some(hb.counter);
                }
            }
            Ok(Message::Feedback(fb)) => {
                if let Some(e) = self.entry(fb.node) {
                    e.feedback = Some(fb);
                    e.syncs_since_feedback = 0;
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
            // Another sender tells our nodes to enable, disable or clear
            // their faults: they obey it behind the daemon's back (a one-byte
            // Disable, `083#02`, left a joint limp mid-swim). Taken as the
            // E-stop from the bus that it is.
            Ok(Message::Command { target, .. }) => {
                self.counters.foreign_commands += 1;
                self.foreign = self.foreign.union(match target {
                    Target::All => self.set,
                    Target::Node(n) => NodeSet::empty().with(n),
                });
            }
            Ok(
                Message::Sync { .. }
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

    /// The nodes another sender commanded (Enable, Disable, ClearFaults)
    /// since the last call (then cleared).
    pub fn take_foreign_command(&mut self) -> NodeSet {
        core::mem::replace(&mut self.foreign, NodeSet::empty())
    }

    /// A SYNC went out: every node that has booted owes an answer. A
    /// node never heard, or booting, owes none (its heartbeats, or their
    /// absence, say enough).
    pub fn sync_sent(&mut self) {
        for e in &mut self.entries {
            match e.state {
                None | Some(NodeState::Boot) => e.syncs_since_feedback = 0,
                Some(_) => e.syncs_since_feedback = e.syncs_since_feedback.saturating_add(1),
            }
        }
    }

    /// What the nodes report, for the supervisor. A node never heard of is
    /// lost once the heartbeat timeout has passed since the table was made.
    pub fn observe(&self, now: Nanos, limits: &Liveness) -> NodeReport {
        let mut r = NodeReport {
            all_enabled: true,
            ..NodeReport::default()
        };
        for e in &self.entries {
            let since = now.saturating_sub(e.last_heartbeat.unwrap_or(self.started));
            if since > limits.heartbeat_timeout {
                r.lost = r.lost.with(e.id);
            }
            if e.syncs_since_feedback > limits.feedback_periods {
                r.silent = r.silent.with(e.id);
            }
            if e.anomalies[0].is_some_and(|t| now.saturating_sub(t) <= DUPLICATE_WINDOW) {
                r.duplicate = r.duplicate.with(e.id);
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
                Some(NodeState::Boot) => {
                    r.booting = r.booting.with(e.id);
                    r.all_enabled = false;
                }
                Some(NodeState::Disabled) => {
                    r.disabled = r.disabled.with(e.id);
                    r.all_enabled = false;
                }
                None => r.all_enabled = false,
            }
        }
        r
    }

    /// Forgets every node's state (after a clear-faults, the old reports
    /// are stale) but keeps heartbeat times and counter anomalies (a reset
    /// does not make two senders one).
    pub fn forget_states(&mut self) {
        for e in &mut self.entries {
            e.state = None;
            e.errors = ErrorBits(0);
            e.syncs_since_feedback = 0;
            e.stale = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_protocol::frame::Id;
    use anguilla_protocol::message::{AxisFeedback, Heartbeat};

    const MS: Nanos = Nanos::from_millis(1);
    const LIMITS: Liveness = Liveness {
        heartbeat_timeout: Nanos::from_millis(350),
        feedback_periods: 10,
    };

    fn ids(n: u8) -> Vec<NodeId> {
        (1..=n).map(|i| NodeId::new(i).unwrap()).collect()
    }

    fn hb(node: u8, state: NodeState) -> Frame {
        hb_n(node, state, 0)
    }

    fn hb_n(node: u8, state: NodeState, counter: u8) -> Frame {
        Message::Heartbeat(Heartbeat {
            node: NodeId::new(node).unwrap(),
            state,
            errors: ErrorBits(0),
            counter,
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
        let r = t.observe(2 * MS, &LIMITS);
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
        let r = t.observe(400 * MS, &LIMITS);
        let only = |n| NodeSet::empty().with(NodeId::new(n).unwrap());
        assert!(!r.all_enabled);
        assert_eq!(r.lost, only(2), "node 2 silent for 400 ms");
        assert_eq!(r.fault, only(2));
        assert_eq!(r.estop, only(3));
    }

    /// A VM run failed this way: a heartbeat the nodes sent before they
    /// read the reset's clear-faults said E-stop, the simulated robot was
    /// then starved of CPU past the supervisor's settle time, and that old
    /// state latched the E-stop again on the enable that followed.
    #[test]
    fn the_first_heartbeat_after_a_clear_is_not_taken_but_a_latched_node_is_seen() {
        let mut t = NodeTable::new(Variant::Classic, &ids(2), Nanos::ZERO);
        t.ingest(Nanos::ZERO, &hb_n(1, NodeState::EStop, 0));
        t.ingest(Nanos::ZERO, &hb_n(2, NodeState::EStop, 0));
        assert_eq!(t.observe(Nanos::ZERO, &LIMITS).estop.bits(), 0b110);
        t.forget_states();
        // Sent before the clear was read: old news, for both.
        t.ingest(10 * MS, &hb_n(1, NodeState::EStop, 1));
        t.ingest(10 * MS, &hb_n(2, NodeState::EStop, 1));
        let r = t.observe(10 * MS, &LIMITS);
        assert!(r.estop.is_empty(), "{r:?}");
        assert!(r.duplicate.is_empty() && r.lost.is_empty());
        // Node 1 cleared; node 2 is still latched, and says so again.
        t.ingest(110 * MS, &hb_n(1, NodeState::Disabled, 2));
        t.ingest(110 * MS, &hb_n(2, NodeState::EStop, 2));
        let r = t.observe(110 * MS, &LIMITS);
        assert_eq!(r.estop.bits(), 0b100, "{r:?}");
        assert!(!r.all_enabled);
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

    fn fb(node: u8) -> Frame {
        Message::Feedback(Feedback {
            node: NodeId::new(node).unwrap(),
            enabled: true,
            fault: false,
            axes: [AxisFeedback::default(); 2],
        })
        .encode(Variant::Classic)
        .unwrap()
    }

    fn only(n: u8) -> NodeSet {
        NodeSet::empty().with(NodeId::new(n).unwrap())
    }

    /// A forger's attack: node 2 is dead, and someone sends perfect
    /// heartbeats for it (state Enabled, counter +1 each). Its silence on
    /// SYNC gives it away after `feedback_periods` SYNCs, not before.
    #[test]
    fn a_node_that_answers_no_sync_is_silent_whatever_its_heartbeats_say() {
        let mut t = NodeTable::new(Variant::Classic, &ids(2), Nanos::ZERO);
        let mut now = Nanos::ZERO;
        for sync in 0..=LIMITS.feedback_periods + 1 {
            // Forged or not, both heartbeats are flawless.
            if sync % 5 == 0 {
                let c = (sync / 5) as u8;
                t.ingest(now, &hb_n(1, NodeState::Enabled, c));
                t.ingest(now, &hb_n(2, NodeState::Enabled, c));
            }
            t.ingest(now, &fb(1));
            let r = t.observe(now, &LIMITS);
            assert!(r.lost.is_empty() && r.duplicate.is_empty());
            let expect = if sync > LIMITS.feedback_periods {
                only(2)
            } else {
                NodeSet::empty()
            };
            assert_eq!(r.silent, expect, "after {sync} SYNCs");
            t.sync_sent();
            now += MS;
        }
        // Feedback again: alive again.
        t.ingest(now, &fb(2));
        assert!(t.observe(now, &LIMITS).silent.is_empty());
    }

    #[test]
    fn booting_or_unheard_nodes_owe_no_feedback_and_a_stalled_loop_faults_nothing() {
        let mut t = NodeTable::new(Variant::Classic, &ids(2), Nanos::ZERO);
        t.ingest(Nanos::ZERO, &hb(1, NodeState::Boot));
        for _ in 0..100 {
            t.sync_sent();
        }
        assert!(t.observe(Nanos::ZERO, &LIMITS).silent.is_empty());
        // A node that answered the last SYNC stays alive through a loop
        // stall of any length: no SYNC went out, none was owed.
        t.ingest(Nanos::ZERO, &hb(1, NodeState::Enabled));
        t.ingest(Nanos::ZERO, &fb(1));
        t.sync_sent();
        t.ingest(300 * MS, &fb(1));
        assert!(t.observe(300 * MS, &LIMITS).silent.is_empty());
    }

    #[test]
    fn interleaved_heartbeat_counters_mean_two_senders_but_a_reboot_does_not() {
        let mut t = NodeTable::new(Variant::Classic, &ids(2), Nanos::ZERO);
        // Node 1 reboots once (counter back to 0) and loses one frame.
        let mut now = Nanos::ZERO;
        for c in [10u8, 11, 12, 0, 1, 3, 4, 5] {
            t.ingest(now, &hb_n(1, NodeState::Enabled, c));
            now += 100 * MS;
        }
        assert!(
            t.observe(now, &LIMITS).duplicate.is_empty(),
            "two anomalies"
        );
        // Node 2 has a twin: two counters interleave.
        let mut first = None;
        for k in 0..10u8 {
            t.ingest(now, &hb_n(2, NodeState::Enabled, k));
            t.ingest(now + 50 * MS, &hb_n(2, NodeState::Enabled, 128 + k));
            now += 100 * MS;
            if first.is_none() && t.observe(now, &LIMITS).duplicate == only(2) {
                first = Some(k);
            }
        }
        assert_eq!(
            first,
            Some(1),
            "the third anomaly comes with the second pair"
        );
        // It stays reported while the anomalies go on, and clears a window
        // after they stop (the latched fault is the supervisor's).
        assert_eq!(t.observe(now, &LIMITS).duplicate, only(2));
        assert!(
            t.observe(now + 2 * DUPLICATE_WINDOW, &LIMITS)
                .duplicate
                .is_empty()
        );
    }

    #[test]
    fn a_wrapping_counter_is_no_anomaly() {
        let mut t = NodeTable::new(Variant::Classic, &ids(1), Nanos::ZERO);
        for k in 0..600u32 {
            t.ingest(k as u64 * 100 * MS, &hb_n(1, NodeState::Enabled, k as u8));
        }
        let now = Nanos::from_millis(60_000);
        assert!(t.observe(now, &LIMITS).duplicate.is_empty());
    }
}
