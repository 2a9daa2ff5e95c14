//! The causes of a fault or a stop ([`FaultKind`]) and a set of them with
//! the nodes involved ([`FaultSet`]).

use core::fmt;

use super::mode::Cause;

/// A cause of a fault or a stop, one bit each in a [`FaultSet`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum FaultKind {
    /// A node's heartbeat stopped arriving.
    HeartbeatLost = 1 << 0,
    /// A node reported a fault in its heartbeat.
    NodeFault = 1 << 1,
    /// The bus went bus-off or the adapter disappeared.
    BusOff = 1 << 2,
    /// The model produced a non-finite or out-of-limit result.
    ModelDiverged = 1 << 3,
    /// An E-stop frame was seen on the bus (from a node or another tool).
    BusEStop = 1 << 4,
    /// An operator client sent an E-stop.
    OperatorEStop = 1 << 5,
    /// Nodes did not all report enabled within the enable timeout.
    EnableTimeout = 1 << 6,
    /// The bus adapter is gone (unplugged, its device closed).
    AdapterGone = 1 << 7,
    /// A node answered no SYNC for `control.feedback-timeout` periods,
    /// whatever its heartbeats say (a dead joint, or its heartbeats forged).
    FeedbackLost = 1 << 8,
    /// A node's heartbeat counter did not advance by one, again and again:
    /// two senders use its id (a second node, or a forger on the bus).
    DuplicateNode = 1 << 9,
    /// A node reported Boot while it should have been enabled (Ready,
    /// Swimming, Stopping): it rebooted, and its joint went limp.
    NodeRebooted = 1 << 10,
    /// A node reported Disabled while it should have been enabled (Ready,
    /// Swimming, Stopping): someone disabled it, or it did itself; its
    /// joint went limp.
    NodeDisabled = 1 << 11,
    /// Another sender on the bus told one of our drives to change state
    /// (anguilla: Enable, Disable, ClearFaults; CiA 402: an NMT command
    /// other than Stop, an RPDO; ODrive: Set axis state, Clear errors, Set
    /// controller mode; MIT: Enter motor mode, Set zero): taken as an
    /// E-stop from the bus.
    ForeignCommand = 1 << 12,
    /// A joint's measured angle stayed beyond the tracking band from its
    /// setpoint for the tracking time while the drives followed setpoints
    /// (limp, jammed, or not the joint the feedback claims).
    TrackingError = 1 << 13,
    /// A joint's fresh feedback stayed the same, bit for bit, while its
    /// setpoints moved it: a copier replaying a dead joint's frame, or a
    /// half-dead node.
    FeedbackFrozen = 1 << 14,
}

impl FaultKind {
    /// Every kind, in bit order.
    pub const ALL: [FaultKind; 15] = [
        FaultKind::HeartbeatLost,
        FaultKind::NodeFault,
        FaultKind::BusOff,
        FaultKind::ModelDiverged,
        FaultKind::BusEStop,
        FaultKind::OperatorEStop,
        FaultKind::EnableTimeout,
        FaultKind::AdapterGone,
        FaultKind::FeedbackLost,
        FaultKind::DuplicateNode,
        FaultKind::NodeRebooted,
        FaultKind::NodeDisabled,
        FaultKind::ForeignCommand,
        FaultKind::TrackingError,
        FaultKind::FeedbackFrozen,
    ];

    /// The cause (`StateSnapshot.cause`) the daemon shows when this kind
    /// takes it to E-stop or fault: an operator's E-stop is a command,
    /// everything else a fault. The daemon's supervisor takes it from
    /// here, and docs/ipc.md's E-stop sentence is generated from it.
    pub fn cause(self) -> Cause {
        if self == FaultKind::OperatorEStop {
            Cause::Command
        } else {
            Cause::Fault
        }
    }

    /// Its bit's value in `StateSnapshot.fault_kinds`.
    pub fn bit(self) -> u32 {
        self as u32
    }

    /// Short name, as shown to operators.
    pub fn name(self) -> &'static str {
        match self {
            FaultKind::HeartbeatLost => "heartbeat lost",
            FaultKind::NodeFault => "actuator fault",
            FaultKind::BusOff => "bus off",
            FaultKind::ModelDiverged => "model diverged",
            FaultKind::BusEStop => "e-stop on the bus",
            FaultKind::OperatorEStop => "operator e-stop",
            FaultKind::EnableTimeout => "enable timed out",
            FaultKind::AdapterGone => "adapter gone",
            FaultKind::FeedbackLost => "no feedback",
            FaultKind::DuplicateNode => "duplicate node id",
            FaultKind::NodeRebooted => "actuator rebooted",
            FaultKind::NodeDisabled => "actuator disabled",
            FaultKind::ForeignCommand => "foreign drive command",
            FaultKind::TrackingError => "tracking error",
            FaultKind::FeedbackFrozen => "feedback frozen",
        }
    }
}

/// A set of [`FaultKind`]s and the nodes involved. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FaultSet {
    /// One bit per [`FaultKind`].
    pub kinds: u32,
    /// Bit `i` set: node id `i` is involved (ids 0..=63).
    pub nodes: u64,
}

impl FaultSet {
    /// Whether there is no fault.
    pub fn is_empty(&self) -> bool {
        self.kinds == 0
    }

    /// Whether `kind` is in the set.
    pub fn contains(&self, kind: FaultKind) -> bool {
        self.kinds & kind as u32 != 0
    }

    /// Adds `kind` with the `nodes` involved.
    pub fn insert(&mut self, kind: FaultKind, nodes: u64) {
        self.kinds |= kind as u32;
        self.nodes |= nodes;
    }
}

impl fmt::Display for FaultSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_empty() {
            return f.write_str("no fault");
        }
        let mut first = true;
        for k in FaultKind::ALL {
            if self.contains(k) {
                if !first {
                    f.write_str(", ")?;
                }
                f.write_str(k.name())?;
                first = false;
            }
        }
        if self.nodes != 0 {
            f.write_str(" (node")?;
            for i in 0..64 {
                if self.nodes & (1 << i) != 0 {
                    write!(f, " {i}")?;
                }
            }
            f.write_str(")")?;
        }
        Ok(())
    }
}
