//! What every drive family reports to the supervisor, whatever its
//! protocol: the nodes' liveness and states ([`NodeReport`]), judged by
//! [`Liveness`], and the frames it could not use ([`RxCounters`]).

use anguilla_ipc::vocabulary::Nanos;
use anguilla_protocol::message::{DecodeError, NodeSet};

/// When a node counts as lost.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Liveness {
    /// A heartbeat older than this is lost.
    pub heartbeat_timeout: Nanos,
    /// A node that answered none of this many SYNCs is silent
    /// (`control.feedback-timeout`).
    pub feedback_periods: u32,
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
    /// Replies with every field at the top of its range (MIT: position,
    /// velocity and torque all ones), taken but suspect.
    pub saturated: u64,
}

/// The nodes' (or drives') reports at one instant: what every family's
/// [`Drives::observe`](super::Drives::observe) gives the supervisor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeReport {
    /// Every configured node reports Enabled.
    pub all_enabled: bool,
    /// Nodes whose heartbeat is overdue.
    pub lost: NodeSet,
    /// Nodes that stopped answering SYNC with feedback.
    pub silent: NodeSet,
    /// Nodes whose id two senders use.
    pub duplicate: NodeSet,
    /// Nodes in Fault.
    pub fault: NodeSet,
    /// Nodes in EStop.
    pub estop: NodeSet,
    /// Nodes that report Boot (they rebooted, or never finished booting).
    pub booting: NodeSet,
    /// Nodes that report Disabled.
    pub disabled: NodeSet,
}

impl Default for NodeReport {
    fn default() -> Self {
        NodeReport {
            all_enabled: false,
            lost: NodeSet::empty(),
            silent: NodeSet::empty(),
            duplicate: NodeSet::empty(),
            fault: NodeSet::empty(),
            estop: NodeSet::empty(),
            booting: NodeSet::empty(),
            disabled: NodeSet::empty(),
        }
    }
}
