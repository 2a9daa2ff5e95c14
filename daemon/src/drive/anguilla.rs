//! anguilla's own vertebra nodes (`protocol/README.md`): one node carries
//! a joint's two axes. Commands go to every node at once (Enable, Disable,
//! ClearFaults, E-stop on 0x000), the watchdog is written to each node
//! before every enable, setpoints carry the cycle tag and SYNC applies
//! them; what the nodes say is kept in the `NodeTable`.

use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{
    self, Command as NodeCommand, Message, NodeId, NodeSet, NodeState, Target, Variant,
};

use super::report::{Liveness, NodeReport, RxCounters};
use super::{DriveError, Drives, JointReport, Out, Period};
use crate::config::Config;
use crate::nodes::NodeTable;
use crate::supervisor::Drive;
use anguilla_ipc::vocabulary::{Mode, Nanos};

const MS: Nanos = Nanos::from_millis(1);

/// Sends `m`, encoded for `variant` (a failure is counted).
fn send(variant: Variant, out: &mut Out<'_>, m: Message) {
    match m.encode(variant) {
        Ok(f) => out.send(&f),
        Err(_) => out.encode_failed(),
    }
}

/// The vertebra nodes.
pub struct Nodes {
    variant: Variant,
    ids: Vec<NodeId>,
    set: NodeSet,
    table: NodeTable,
    watchdog: Nanos,
    last_command_sent: Nanos,
    /// Each node's heartbeats heard (its [`NodeTable`] entry's count) when
    /// Enable was last sent to it: see [`Nodes::period`]'s re-sending.
    enable_sent_at: Vec<u64>,
}

impl Nodes {
    /// The nodes of `cfg` (`robot.node-ids`), unheard-of at `now`, for the
    /// control period `period`.
    pub fn new(cfg: &Config, now: Nanos, period: Nanos) -> Result<Self, DriveError> {
        let ids = cfg
            .node_ids()
            .into_iter()
            .map(|i| {
                NodeId::new(i).map_err(|_| DriveError::NodeId {
                    family: anguilla_protocol::Family::Anguilla,
                    id: i,
                    min: 1,
                    max: message::MAX_NODE_ID,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let variant = cfg.bus.variant();
        let watchdog = match cfg.control.node_watchdog {
            // Five periods, but no less than 100 ms: a loop that is not
            // real-time (no SCHED_FIFO) can stall for tens of milliseconds
            // on a busy machine.
            0.0 => (5 * period).max(100 * MS),
            s => Nanos::from_secs_f64(s),
        };
        Ok(Self {
            variant,
            set: NodeSet::of(ids.iter().copied()),
            table: NodeTable::new(variant, &ids, now),
            enable_sent_at: vec![0; ids.len()],
            ids,
            watchdog,
            last_command_sent: Nanos::ZERO,
        })
    }

    /// The node table.
    pub fn table(&self) -> &NodeTable {
        &self.table
    }

    fn command_all(&self, out: &mut Out<'_>, command: NodeCommand) {
        send(
            self.variant,
            out,
            Message::Command {
                target: Target::All,
                command,
            },
        );
    }
}

impl Drives for Nodes {
    fn family(&self) -> anguilla_protocol::Family {
        anguilla_protocol::Family::Anguilla
    }

    fn report_ids(&self) -> NodeSet {
        self.set
    }

    fn ingest(&mut self, now: Nanos, frame: &Frame) {
        self.table.ingest(now, frame);
    }

    fn observe(&self, now: Nanos, limits: &Liveness) -> NodeReport {
        self.table.observe(now, limits)
    }

    fn take_bus_estop(&mut self) -> bool {
        self.table.take_bus_estop()
    }

    fn take_foreign_command(&mut self) -> NodeSet {
        self.table.take_foreign_command()
    }

    fn counters(&self) -> RxCounters {
        self.table.counters()
    }

    fn joint(&self, j: usize) -> JointReport {
        let e = &self.table.entries()[j];
        JointReport {
            state: e.state,
            errors: e.errors.0 as u32,
            last_heard: e.last_heartbeat,
            feedback: e.feedback.map(|f| f.axes),
            // One Feedback frame carries both axes.
            feedback_age: [e.syncs_since_feedback; 2],
        }
    }

    fn estop(&mut self, out: &mut Out<'_>) {
        // Nothing queued before the E-stop may follow it.
        out.flush();
        send(self.variant, out, Message::EStop(Target::All));
    }

    fn clear_faults(&mut self, out: &mut Out<'_>) {
        self.command_all(out, NodeCommand::ClearFaults);
        self.table.forget_states();
    }

    fn period(&mut self, p: &Period<'_>, out: &mut Out<'_>) {
        let every = p.now.saturating_sub(self.last_command_sent) >= 100 * MS;
        match p.drive {
            Drive::Disabled => {
                if (p.entering || every) && p.mode != Mode::EStop {
                    self.last_command_sent = p.now;
                    self.command_all(out, NodeCommand::Disable);
                }
            }
            Drive::Enable => {
                if p.entering {
                    self.last_command_sent = p.now;
                    // Configuration first (nodes accept it only while
                    // disabled): the watchdog (`control.node-watchdog`).
                    let ms = (self.watchdog / MS).clamp(
                        message::WATCHDOG_RANGE_MS.0 as u64,
                        message::WATCHDOG_RANGE_MS.1 as u64,
                    ) as u16;
                    for &node in &self.ids {
                        send(
                            self.variant,
                            out,
                            Message::ConfigWrite {
                                node,
                                param: message::ConfigParam::WatchdogTimeout { ms },
                            },
                        );
                    }
                    self.command_all(out, NodeCommand::Enable);
                    for (sent, e) in self.enable_sent_at.iter_mut().zip(self.table.entries()) {
                        *sent = e.heartbeats;
                    }
                } else if every {
                    // Nodes that missed it (or were still booting): those
                    // that said Disabled in two heartbeats since it was
                    // sent. The first may have left before the node read
                    // the Enable (a loaded node, a queue on the bus); an
                    // Enable sent again to a node that has just enabled
                    // is refused with BAD_FRAME (protocol/README.md), a
                    // false "undecodable frame" warning on every joint
                    // of a loaded robot.
                    self.last_command_sent = p.now;
                    let variant = self.variant;
                    for (sent, e) in self.enable_sent_at.iter_mut().zip(self.table.entries()) {
                        if e.state == Some(NodeState::Disabled) && e.heartbeats >= *sent + 2 {
                            *sent = e.heartbeats;
                            send(
                                variant,
                                out,
                                Message::Command {
                                    target: Target::Node(e.id),
                                    command: NodeCommand::Enable,
                                },
                            );
                        }
                    }
                }
            }
            Drive::Setpoints => {
                if !p.bus_off {
                    let pairs = self
                        .ids
                        .iter()
                        .zip(p.setpoints.iter())
                        .filter(|(id, _)| !p.skip.contains(id.get()))
                        .map(|(id, axes)| (*id, *axes));
                    let r =
                        message::encode_setpoints(self.variant, p.counter, pairs, |f| out.send(&f));
                    if r.is_err() {
                        out.encode_failed();
                    }
                }
            }
        }
        if !p.bus_off {
            self.table.sync_sent();
            send(self.variant, out, Message::Sync { counter: p.counter });
        }
    }

    fn disable_all(&mut self, out: &mut Out<'_>) {
        self.command_all(out, NodeCommand::Disable);
    }
}
