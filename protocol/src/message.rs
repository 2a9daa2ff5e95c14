//! The anguilla messages: identifiers, layouts, encode and decode.
//!
//! Every identifier is 11 bits: `function << 6 | node`, with the function
//! code (0..=8) in the high five bits so that arbitration orders the bus by
//! function first (E-stop beats SYNC beats setpoints beats feedback...), and
//! the node id (1..=63, 0 = broadcast / host) in the low six bits, like
//! CANopen's function-code bases. See `protocol/README.md` for the contract.
//!
//! Layouts differ per [`Variant`]: classic CAN packs a whole vertebra's
//! setpoint (both axes) into one 8-byte frame per node, CAN FD sends
//! setpoints for six nodes per 64-byte group frame at higher precision. The
//! positions and scaling of every field are the [`Signal`] constants of the
//! layout modules ([`classic`], [`fd`], [`common`]); the codec reads and
//! writes bits only through them.

use crate::frame::{Frame, FrameError, Id, Kind};
use crate::signal::{Mux, Signal};

/// Documented joint position range: ±1.5 rad (eel joints stay within about
/// ±1.2 rad; the margin lets a node report an overshoot).
pub const POSITION_LIMIT: f64 = 1.5;
/// Documented joint velocity range: ±10 rad/s.
pub const VELOCITY_LIMIT: f64 = 10.0;
/// Documented joint torque range: ±5 N·m (a 1 m robot).
pub const TORQUE_LIMIT: f64 = 5.0;
/// Largest node id the identifier scheme carries (six bits; 0 is broadcast).
pub const MAX_NODE_ID: u8 = 63;
/// Nodes per CAN FD setpoint group frame.
pub const GROUP_SLOTS: usize = 6;
/// Heartbeat period of every node, in milliseconds.
pub const HEARTBEAT_PERIOD_MS: u32 = 100;
/// A node's watchdog timeout after boot, ms (five periods at 100 Hz).
pub const DEFAULT_WATCHDOG_MS: u16 = 50;
/// A node's safe action after boot.
pub const DEFAULT_SAFE_ACTION: SafeAction = SafeAction::Limp;
/// Watchdog timeout range a node accepts, in milliseconds.
pub const WATCHDOG_RANGE_MS: (u16, u16) = (2, 1000);

/// Which bus the protocol runs on; layouts and frame kinds differ.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Variant {
    /// Classic CAN 2.0A, 8-byte frames.
    Classic,
    /// CAN FD with bit-rate switching, frames up to 64 bytes.
    Fd,
}

impl Variant {
    /// Bits of the SYNC counter a setpoint carries as its cycle tag.
    pub const fn cycle_tag_bits(self) -> u8 {
        match self {
            Variant::Classic => 4,
            Variant::Fd => 8,
        }
    }

    /// The cycle tag of the setpoints to apply at SYNC `counter`.
    pub const fn cycle_tag(self, counter: u16) -> u8 {
        (counter & ((1 << self.cycle_tag_bits()) - 1)) as u8
    }
}

impl core::fmt::Display for Variant {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Variant::Classic => "classic CAN",
            Variant::Fd => "CAN FD",
        })
    }
}

/// A node (vertebra actuator) id, 1..=63.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(u8);

impl NodeId {
    /// A node id, checked to be in 1..=63.
    pub const fn new(id: u8) -> Result<Self, EncodeError> {
        if id == 0 || id > MAX_NODE_ID {
            Err(EncodeError::BadNodeId(id))
        } else {
            Ok(NodeId(id))
        }
    }

    /// The raw id.
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// The set of node ids a decoder accepts; others are [`DecodeError::UnknownNode`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct NodeSet(u64);

impl NodeSet {
    /// No nodes.
    pub const fn empty() -> Self {
        NodeSet(0)
    }

    /// Every id 1..=63.
    pub const fn all() -> Self {
        NodeSet(!1u64)
    }

    /// Ids 1..=n (n clamped to 63): a robot of n vertebrae numbered from 1.
    pub const fn first(n: u8) -> Self {
        let n = if n > MAX_NODE_ID { MAX_NODE_ID } else { n };
        NodeSet(((1u128 << (n as u32 + 1)) - 2) as u64)
    }

    /// The same set with `id` added.
    pub const fn with(self, id: NodeId) -> Self {
        NodeSet(self.0 | (1 << id.0))
    }

    /// Whether `id` (raw) is in the set.
    pub const fn contains(self, id: u8) -> bool {
        id < 64 && (self.0 >> id) & 1 == 1
    }

    /// The set of the given ids.
    pub fn of(ids: impl IntoIterator<Item = NodeId>) -> Self {
        ids.into_iter().fold(Self::empty(), Self::with)
    }

    /// How many ids the set holds.
    pub const fn len(self) -> usize {
        self.0.count_ones() as usize
    }

    /// Whether the set is empty.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The ids, ascending.
    pub fn iter(self) -> impl Iterator<Item = NodeId> {
        (1..=MAX_NODE_ID)
            .filter(move |&i| self.contains(i))
            .map(NodeId)
    }
}

/// Who a command is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Target {
    /// Every node (node field 0).
    All,
    /// One node.
    Node(NodeId),
}

impl Target {
    const fn raw(self) -> u8 {
        match self {
            Target::All => 0,
            Target::Node(n) => n.0,
        }
    }

    /// Whether a message for this target is for node `node`: every node, or
    /// that one.
    pub const fn includes(self, node: NodeId) -> bool {
        match self {
            Target::All => true,
            Target::Node(n) => n.0 == node.0,
        }
    }
}

/// The two axes of a vertebra's universal joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Axis {
    /// Axis 0: pitch (bending in the vertical plane).
    Pitch = 0,
    /// Axis 1: yaw (bending in the horizontal plane).
    Yaw = 1,
}

/// One axis' setpoint: position with velocity and torque feedforward.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisSetpoint {
    /// Position, rad, within ±[`POSITION_LIMIT`].
    pub position: f32,
    /// Velocity feedforward, rad/s, within ±[`VELOCITY_LIMIT`].
    pub velocity: f32,
    /// Torque feedforward, N·m, within ±[`TORQUE_LIMIT`].
    pub torque: f32,
}

/// One axis' measured state.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisFeedback {
    /// Measured position, rad.
    pub position: f32,
    /// Measured velocity, rad/s.
    pub velocity: f32,
    /// Measured (current-estimated) torque, N·m.
    pub torque: f32,
    /// The axis is at, or was clamped to, one of its configured limits.
    pub limited: bool,
}

/// Setpoints for one node, to apply at the SYNC whose tag is `cycle`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setpoint {
    /// Addressed node.
    pub node: NodeId,
    /// Cycle tag: low bits of the SYNC counter this is for
    /// ([`Variant::cycle_tag`]).
    pub cycle: u8,
    /// Pitch (index 0) and yaw (index 1).
    pub axes: [AxisSetpoint; 2],
}

/// CAN FD: setpoints for up to six consecutive nodes in one frame. Group `g`
/// carries nodes `6g+1 ..= 6g+6` in slots 0..=5.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SetpointGroup {
    /// Group index, 0..=10.
    pub group: u8,
    /// Cycle tag (8 bits in CAN FD).
    pub cycle: u8,
    /// Per slot: the node's pitch and yaw setpoints, or `None` (no update
    /// for that node in this frame).
    pub slots: [Option<[AxisSetpoint; 2]>; GROUP_SLOTS],
}

impl SetpointGroup {
    /// The group that carries `node`, and its slot.
    pub const fn locate(node: NodeId) -> (u8, usize) {
        let i = node.0 as usize - 1;
        ((i / GROUP_SLOTS) as u8, i % GROUP_SLOTS)
    }

    /// The setpoints this frame carries for `node`, if any.
    pub fn for_node(&self, node: NodeId) -> Option<[AxisSetpoint; 2]> {
        let (g, s) = Self::locate(node);
        if g == self.group { self.slots[s] } else { None }
    }
}

/// Feedback of one node, sampled at the SYNC instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Feedback {
    /// Reporting node.
    pub node: NodeId,
    /// The node is Enabled (servoing).
    pub enabled: bool,
    /// The node is in Fault or E-stop (details in its heartbeat).
    pub fault: bool,
    /// Pitch (index 0) and yaw (index 1).
    pub axes: [AxisFeedback; 2],
}

/// A node's state machine state (see the README for transitions).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NodeState {
    /// Starting up; ignores setpoints.
    Boot = 0,
    /// Powered, motors off (torque-free or braked per safe action); accepts
    /// configuration.
    Disabled = 1,
    /// Servoing to setpoints applied at each SYNC.
    Enabled = 2,
    /// A fault stopped the motors; leaves only with ClearFaults.
    Fault = 3,
    /// E-stop received; latched until ClearFaults.
    EStop = 4,
}

impl NodeState {
    fn from_raw(raw: i64) -> Option<Self> {
        Some(match raw {
            0 => NodeState::Boot,
            1 => NodeState::Disabled,
            2 => NodeState::Enabled,
            3 => NodeState::Fault,
            4 => NodeState::EStop,
            _ => return None,
        })
    }
}

/// Error and warning bits a node reports in its heartbeat.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct ErrorBits(pub u16);

impl ErrorBits {
    /// No setpoint or SYNC within the watchdog timeout (safe action taken).
    pub const WATCHDOG: u16 = 1 << 0;
    /// A SYNC counter gap was seen (warning; see `missed_syncs`).
    pub const SYNC_MISSED: u16 = 1 << 1;
    /// A setpoint was clamped to the position limits.
    pub const POSITION_LIMIT: u16 = 1 << 2;
    /// A setpoint was clamped to the velocity limit.
    pub const VELOCITY_LIMIT: u16 = 1 << 3;
    /// Torque saturated at the torque limit.
    pub const TORQUE_LIMIT: u16 = 1 << 4;
    /// Motor or driver over temperature (fault).
    pub const OVER_TEMPERATURE: u16 = 1 << 5;
    /// Position sensor fault (fault).
    pub const ENCODER: u16 = 1 << 6;
    /// CAN error-passive or bus-off seen (warning).
    pub const BUS: u16 = 1 << 7;
    /// E-stop latched.
    pub const ESTOP_LATCHED: u16 = 1 << 8;
    /// A frame addressed to this node failed to decode (out of range,
    /// wrong length, reserved bits): ignored.
    pub const BAD_FRAME: u16 = 1 << 9;
    /// A setpoint with the wrong cycle tag was discarded.
    pub const STALE_SETPOINT: u16 = 1 << 10;
    /// Supply under-voltage (fault).
    pub const UNDER_VOLTAGE: u16 = 1 << 11;
    /// Every defined bit.
    pub const ALL: u16 = (1 << 12) - 1;

    /// Whether any of `bits` is set.
    pub const fn any(self, bits: u16) -> bool {
        self.0 & bits != 0
    }
}

/// Heartbeat of one node, every [`HEARTBEAT_PERIOD_MS`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Heartbeat {
    /// Reporting node.
    pub node: NodeId,
    /// State machine state.
    pub state: NodeState,
    /// Error bits; latched bits stay set until ClearFaults.
    pub errors: ErrorBits,
    /// Increments by one per heartbeat (wraps): detects lost heartbeats and
    /// reboots.
    pub counter: u8,
    /// SYNCs missed since boot or ClearFaults (saturates at 255).
    pub missed_syncs: u8,
    /// Hottest driver/motor temperature, °C, -40..=125.
    pub temperature: i8,
}

/// Enable, disable or clear-faults.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Command {
    /// Disabled → Enabled (holds current position until the first SYNC).
    Enable = 1,
    /// Enabled → Disabled.
    Disable = 2,
    /// Fault / E-stop → Disabled, clears latched error bits.
    ClearFaults = 3,
}

/// What a node does when its watchdog expires.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SafeAction {
    /// Hold the last applied position (stiff).
    Hold = 0,
    /// Go limp: zero torque.
    Limp = 1,
    /// Short the motor windings / engage the brake.
    Brake = 2,
}

/// A configuration parameter and its value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ConfigParam {
    /// Watchdog timeout, ms ([`WATCHDOG_RANGE_MS`]).
    WatchdogTimeout {
        /// Timeout in milliseconds.
        ms: u16,
    },
    /// Action on watchdog expiry.
    SafeAction(SafeAction),
    /// Position limits of one axis, rad (`min <= max`, within ±1.5).
    PositionLimits {
        /// Axis.
        axis: Axis,
        /// Lower limit, rad.
        min: f32,
        /// Upper limit, rad.
        max: f32,
    },
    /// Velocity limit of one axis, rad/s (0..=10).
    VelocityLimit {
        /// Axis.
        axis: Axis,
        /// Absolute limit, rad/s.
        max: f32,
    },
    /// Torque limit of one axis, N·m (0..=5).
    TorqueLimit {
        /// Axis.
        axis: Axis,
        /// Absolute limit, N·m.
        max: f32,
    },
}

impl ConfigParam {
    const fn index(&self) -> u8 {
        match self {
            ConfigParam::WatchdogTimeout { .. } => 0,
            ConfigParam::SafeAction(_) => 1,
            ConfigParam::PositionLimits { .. } => 2,
            ConfigParam::VelocityLimit { .. } => 3,
            ConfigParam::TorqueLimit { .. } => 4,
        }
    }

    const fn axis(&self) -> u8 {
        match self {
            ConfigParam::WatchdogTimeout { .. } | ConfigParam::SafeAction(_) => 0,
            ConfigParam::PositionLimits { axis, .. }
            | ConfigParam::VelocityLimit { axis, .. }
            | ConfigParam::TorqueLimit { axis, .. } => *axis as u8,
        }
    }
}

/// A node's answer to a configuration write.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ConfigResult {
    /// Stored; the echoed value is now in effect.
    Accepted = 0,
    /// Value outside what the node supports; the echo is the value in effect.
    OutOfRange = 1,
    /// Refused because the node is not Disabled.
    NotDisabled = 2,
}

/// Every message of the protocol, both directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Message {
    /// Host → node(s): emergency stop, latched until ClearFaults. Id 0x000 (all) / 0x000+n.
    EStop(Target),
    /// Host → all: apply the setpoints tagged with this counter's low bits now.
    Sync {
        /// Cycle counter, +1 per control period (wraps).
        counter: u16,
    },
    /// Host → node(s): enable, disable, clear faults.
    Command {
        /// Addressed node(s).
        target: Target,
        /// What to do.
        command: Command,
    },
    /// Host → node, classic CAN: one node's setpoints.
    Setpoint(Setpoint),
    /// Host → nodes, CAN FD: setpoints of up to six nodes.
    SetpointGroup(SetpointGroup),
    /// Node → host, each period after SYNC.
    Feedback(Feedback),
    /// Node → host, every 100 ms.
    Heartbeat(Heartbeat),
    /// Host → node: write a configuration parameter (only when Disabled).
    ConfigWrite {
        /// Addressed node.
        node: NodeId,
        /// Parameter and value.
        param: ConfigParam,
    },
    /// Node → host: answer to a ConfigWrite, echoing the value in effect.
    ConfigAck {
        /// Answering node.
        node: NodeId,
        /// Parameter and the value now in effect.
        param: ConfigParam,
        /// Outcome.
        result: ConfigResult,
    },
}

/// Function codes: the high five bits of every identifier.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Function {
    /// 0x000 + node (0 = all).
    EStop = 0,
    /// 0x040.
    Sync = 1,
    /// 0x080 + node (0 = all).
    Command = 2,
    /// 0x0C0 + node (classic only).
    Setpoint = 3,
    /// 0x100 + group (CAN FD only).
    SetpointGroup = 4,
    /// 0x140 + node.
    Feedback = 5,
    /// 0x180 + node.
    Heartbeat = 6,
    /// 0x1C0 + node.
    ConfigWrite = 7,
    /// 0x200 + node.
    ConfigAck = 8,
}

impl Function {
    /// Every function, in priority order.
    pub const ALL: [Function; 9] = [
        Function::EStop,
        Function::Sync,
        Function::Command,
        Function::Setpoint,
        Function::SetpointGroup,
        Function::Feedback,
        Function::Heartbeat,
        Function::ConfigWrite,
        Function::ConfigAck,
    ];

    /// The identifier of this function for node (or group) `low`.
    pub const fn id(self, low: u8) -> u16 {
        ((self as u16) << LOW_BITS) | (low as u16 & LOW_MASK)
    }

    /// The CAN identifier of this function for node (or group) `low`: a
    /// standard id, always in range (the highest, ConfigAck for node 63, is
    /// 0x23F).
    pub const fn can_id(self, low: u8) -> Id {
        Id::standard_literal(self.id(low))
    }

    /// The function and the low six bits (node, 0 = all, or setpoint
    /// group) of 11-bit identifier `id`: the inverse of [`Function::id`].
    /// `None` for identifiers no function uses ([`FIRST_UNUSED_ID`] and up).
    pub const fn split_id(id: u16) -> Option<(Function, u8)> {
        let code = (id >> LOW_BITS) as usize;
        if code < Function::ALL.len() {
            Some((Function::ALL[code], (id & LOW_MASK) as u8))
        } else {
            None
        }
    }

    /// The function of 11-bit identifier `id` (its high five bits), `None`
    /// for identifiers no function uses ([`FIRST_UNUSED_ID`] and up).
    pub const fn from_id(id: u16) -> Option<Function> {
        match Function::split_id(id) {
            Some((f, _)) => Some(f),
            None => None,
        }
    }
}

/// Bits of an identifier below the function code: the node or group.
const LOW_BITS: u16 = 6;
/// Mask of the low bits of an identifier.
const LOW_MASK: u16 = (1 << LOW_BITS) - 1;

/// The first identifier above every function's range (0x240): ids from
/// here to 0x7FF are not used by the protocol, and nodes ignore them.
pub const FIRST_UNUSED_ID: u16 = (Function::ALL.len() as u16) << LOW_BITS;

/// Who sends a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// The daemon (tether computer) sends, nodes receive.
    HostToNode,
    /// A node sends, the daemon receives.
    NodeToHost,
}

/// How the low six bits of a message's identifier are used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Addressing {
    /// Always 0.
    Broadcast,
    /// 0 = every node, else one node.
    AllOrNode,
    /// A node id 1..=63.
    Node,
    /// A setpoint group index 0..=10.
    Group,
}

impl Addressing {
    /// Whether an identifier whose low six bits are `low` reaches node
    /// `node` under this addressing: [`Addressing::Broadcast`] only with
    /// 0, [`Addressing::AllOrNode`] with 0 or the node's id,
    /// [`Addressing::Node`] with the node's id, [`Addressing::Group`] with
    /// the group that carries the node ([`SetpointGroup::locate`]).
    pub const fn reaches(self, low: u8, node: NodeId) -> bool {
        match self {
            Addressing::Broadcast => low == 0,
            Addressing::AllOrNode => low == 0 || low == node.0,
            Addressing::Node => low == node.0,
            Addressing::Group => low == SetpointGroup::locate(node).0,
        }
    }
}

/// The definition of a message in one variant: the table the codec, the
/// DBC generator, the budget and the README are made from.
#[derive(Debug, Clone, Copy)]
pub struct MessageDef {
    /// Function code (identifier base).
    pub function: Function,
    /// Name (DBC message name prefix).
    pub name: &'static str,
    /// Sender.
    pub direction: Direction,
    /// Identifier low bits.
    pub addressing: Addressing,
    /// Data length in bytes (for a setpoint group: the full 6-slot length).
    pub len: u8,
    /// When it is sent.
    pub period: &'static str,
    /// Fields.
    pub signals: &'static [Signal],
    /// One-line meaning.
    pub comment: &'static str,
}

/// Layouts shared by both variants.
pub mod common {
    use super::*;

    /// SYNC: the cycle counter.
    pub const SYNC_COUNTER: Signal =
        Signal::uint("Counter", 0, 16, 65535, "cycle counter, +1 per period");
    /// Command code.
    pub const COMMAND: Signal = Signal {
        min: 1.0,
        ..Signal::uint("Command", 0, 8, 3, "1 Enable, 2 Disable, 3 ClearFaults")
    };
    /// Heartbeat state.
    pub const HB_STATE: Signal = Signal::uint(
        "State",
        0,
        8,
        4,
        "0 Boot, 1 Disabled, 2 Enabled, 3 Fault, 4 EStop",
    );
    /// Heartbeat error bits.
    pub const HB_ERRORS: Signal = Signal::uint(
        "Errors",
        8,
        16,
        ErrorBits::ALL as u32,
        "error bits, see README",
    );
    /// Heartbeat counter.
    pub const HB_COUNTER: Signal = Signal::uint("Counter", 24, 8, 255, "+1 per heartbeat");
    /// Missed SYNC count.
    pub const HB_MISSED: Signal = Signal::uint(
        "MissedSyncs",
        32,
        8,
        255,
        "SYNC gaps since ClearFaults, saturating",
    );
    /// Temperature.
    pub const HB_TEMPERATURE: Signal = Signal {
        unit: "degC",
        min: -40.0,
        max: 125.0,
        signed: true,
        ..Signal::uint("Temperature", 40, 8, 0, "hottest motor/driver temperature")
    };
    /// Config parameter index (multiplexor).
    pub const CFG_PARAM: Signal = Signal::uint(
        "Param",
        0,
        8,
        4,
        "0 WatchdogTimeout, 1 SafeAction, 2 PositionLimits, 3 VelocityLimit, 4 TorqueLimit",
    )
    .muxed(Mux::Switch);
    /// Config axis (write: 8 bits).
    pub const CFG_AXIS: Signal = Signal::uint(
        "Axis",
        8,
        8,
        1,
        "0 pitch, 1 yaw (0 for node-wide parameters)",
    );
    /// Config axis (ack: 4 bits).
    pub const ACK_AXIS: Signal = Signal::uint(
        "Axis",
        8,
        4,
        1,
        "0 pitch, 1 yaw (0 for node-wide parameters)",
    );
    /// Config result (ack).
    pub const ACK_RESULT: Signal = Signal::uint(
        "Result",
        12,
        4,
        2,
        "0 Accepted, 1 OutOfRange, 2 NotDisabled",
    );
    /// Watchdog timeout value.
    pub const CFG_WATCHDOG: Signal = Signal::ufixed(
        "WatchdogTimeout",
        16,
        16,
        1.0,
        WATCHDOG_RANGE_MS.0 as f64,
        WATCHDOG_RANGE_MS.1 as f64,
        "ms",
        "no setpoint/SYNC for this long: safe action",
    )
    .muxed(Mux::When(0));
    /// Safe action value.
    pub const CFG_SAFE_ACTION: Signal =
        Signal::uint("SafeAction", 16, 8, 2, "0 Hold, 1 Limp, 2 Brake").muxed(Mux::When(1));
    /// Position lower limit.
    pub const CFG_POS_MIN: Signal = Signal::fixed(
        "PositionMin",
        16,
        16,
        0.0001,
        POSITION_LIMIT,
        "rad",
        "lower position limit",
    )
    .muxed(Mux::When(2));
    /// Position upper limit.
    pub const CFG_POS_MAX: Signal = Signal::fixed(
        "PositionMax",
        32,
        16,
        0.0001,
        POSITION_LIMIT,
        "rad",
        "upper position limit",
    )
    .muxed(Mux::When(2));
    /// Velocity limit.
    pub const CFG_VEL_MAX: Signal = Signal::ufixed(
        "VelocityMax",
        16,
        16,
        0.001,
        0.0,
        VELOCITY_LIMIT,
        "rad/s",
        "absolute velocity limit",
    )
    .muxed(Mux::When(3));
    /// Torque limit.
    pub const CFG_TRQ_MAX: Signal = Signal::ufixed(
        "TorqueMax",
        16,
        16,
        0.001,
        0.0,
        TORQUE_LIMIT,
        "N.m",
        "absolute torque limit",
    )
    .muxed(Mux::When(4));

    /// SYNC fields.
    pub const SYNC: [Signal; 1] = [SYNC_COUNTER];
    /// Command fields.
    pub const COMMANDS: [Signal; 1] = [COMMAND];
    /// Heartbeat fields.
    pub const HEARTBEAT: [Signal; 5] = [HB_STATE, HB_ERRORS, HB_COUNTER, HB_MISSED, HB_TEMPERATURE];
    /// ConfigWrite fields.
    pub const CONFIG_WRITE: [Signal; 8] = [
        CFG_PARAM,
        CFG_AXIS,
        CFG_WATCHDOG,
        CFG_SAFE_ACTION,
        CFG_POS_MIN,
        CFG_POS_MAX,
        CFG_VEL_MAX,
        CFG_TRQ_MAX,
    ];
    /// ConfigAck fields.
    pub const CONFIG_ACK: [Signal; 9] = [
        CFG_PARAM,
        ACK_AXIS,
        ACK_RESULT,
        CFG_WATCHDOG,
        CFG_SAFE_ACTION,
        CFG_POS_MIN,
        CFG_POS_MAX,
        CFG_VEL_MAX,
        CFG_TRQ_MAX,
    ];
    /// Feedback status: node enabled.
    pub const FB_ENABLED: Signal = Signal::uint("Enabled", 0, 1, 1, "node is Enabled");
    /// Feedback status: node in Fault or E-stop.
    pub const FB_FAULT: Signal = Signal::uint("Fault", 1, 1, 1, "node is in Fault or EStop");
    /// Feedback status: axis limited.
    pub const FB_LIMITED: [Signal; 2] = [
        Signal::uint("PitchLimited", 2, 1, 1, "pitch at or clamped to a limit"),
        Signal::uint("YawLimited", 3, 1, 1, "yaw at or clamped to a limit"),
    ];
}

/// Classic CAN layouts: 8-byte per-node frames, 14-bit positions, 8-bit
/// velocities and torques.
pub mod classic {
    use super::*;

    /// Position scale: 0.2 mrad per count (14 bits, ±1.638 rad representable).
    pub const POSITION_FACTOR: f64 = 0.0002;
    /// Velocity scale: 0.08 rad/s per count (8 bits).
    pub const VELOCITY_FACTOR: f64 = 0.08;
    /// Torque scale: 0.04 N·m per count (8 bits).
    pub const TORQUE_FACTOR: f64 = 0.04;

    /// Setpoint cycle tag.
    pub const SP_CYCLE: Signal = Signal::uint(
        "Cycle",
        0,
        4,
        15,
        "low 4 bits of the SYNC counter to apply at",
    );
    /// Setpoint positions (pitch, yaw).
    pub const SP_POSITION: [Signal; 2] = [
        Signal::fixed(
            "PitchPosition",
            4,
            14,
            POSITION_FACTOR,
            POSITION_LIMIT,
            "rad",
            "pitch position setpoint",
        ),
        Signal::fixed(
            "YawPosition",
            18,
            14,
            POSITION_FACTOR,
            POSITION_LIMIT,
            "rad",
            "yaw position setpoint",
        ),
    ];
    /// Setpoint velocity feedforward (pitch, yaw).
    pub const SP_VELOCITY: [Signal; 2] = [
        Signal::fixed(
            "PitchVelocity",
            32,
            8,
            VELOCITY_FACTOR,
            VELOCITY_LIMIT,
            "rad/s",
            "pitch velocity feedforward",
        ),
        Signal::fixed(
            "YawVelocity",
            40,
            8,
            VELOCITY_FACTOR,
            VELOCITY_LIMIT,
            "rad/s",
            "yaw velocity feedforward",
        ),
    ];
    /// Setpoint torque feedforward (pitch, yaw).
    pub const SP_TORQUE: [Signal; 2] = [
        Signal::fixed(
            "PitchTorque",
            48,
            8,
            TORQUE_FACTOR,
            TORQUE_LIMIT,
            "N.m",
            "pitch torque feedforward",
        ),
        Signal::fixed(
            "YawTorque",
            56,
            8,
            TORQUE_FACTOR,
            TORQUE_LIMIT,
            "N.m",
            "yaw torque feedforward",
        ),
    ];
    /// Feedback positions.
    pub const FB_POSITION: [Signal; 2] = [
        Signal::fixed(
            "PitchPosition",
            4,
            14,
            POSITION_FACTOR,
            POSITION_LIMIT,
            "rad",
            "pitch position",
        ),
        Signal::fixed(
            "YawPosition",
            18,
            14,
            POSITION_FACTOR,
            POSITION_LIMIT,
            "rad",
            "yaw position",
        ),
    ];
    /// Feedback velocities.
    pub const FB_VELOCITY: [Signal; 2] = [
        Signal::fixed(
            "PitchVelocity",
            32,
            8,
            VELOCITY_FACTOR,
            VELOCITY_LIMIT,
            "rad/s",
            "pitch velocity",
        ),
        Signal::fixed(
            "YawVelocity",
            40,
            8,
            VELOCITY_FACTOR,
            VELOCITY_LIMIT,
            "rad/s",
            "yaw velocity",
        ),
    ];
    /// Feedback torques.
    pub const FB_TORQUE: [Signal; 2] = [
        Signal::fixed(
            "PitchTorque",
            48,
            8,
            TORQUE_FACTOR,
            TORQUE_LIMIT,
            "N.m",
            "pitch torque",
        ),
        Signal::fixed(
            "YawTorque",
            56,
            8,
            TORQUE_FACTOR,
            TORQUE_LIMIT,
            "N.m",
            "yaw torque",
        ),
    ];
    /// Setpoint fields.
    pub const SETPOINT: [Signal; 7] = [
        SP_CYCLE,
        SP_POSITION[0],
        SP_POSITION[1],
        SP_VELOCITY[0],
        SP_VELOCITY[1],
        SP_TORQUE[0],
        SP_TORQUE[1],
    ];
    /// Feedback fields.
    pub const FEEDBACK: [Signal; 10] = [
        common::FB_ENABLED,
        common::FB_FAULT,
        common::FB_LIMITED[0],
        common::FB_LIMITED[1],
        FB_POSITION[0],
        FB_POSITION[1],
        FB_VELOCITY[0],
        FB_VELOCITY[1],
        FB_TORQUE[0],
        FB_TORQUE[1],
    ];
}

/// CAN FD layouts: six-node setpoint groups and 12-byte feedback, 16-bit
/// positions, 12-bit velocities and torques.
pub mod fd {
    use super::*;

    /// Position scale: 0.05 mrad per count (16 bits, ±1.638 rad representable).
    pub const POSITION_FACTOR: f64 = 0.00005;
    /// Velocity scale: 5 mrad/s per count (12 bits).
    pub const VELOCITY_FACTOR: f64 = 0.005;
    /// Torque scale: 2.5 mN·m per count (12 bits).
    pub const TORQUE_FACTOR: f64 = 0.0025;
    /// First bit of slot 0 in a group frame.
    pub const SLOT_BASE: u16 = 16;
    /// Bits per slot.
    pub const SLOT_BITS: u16 = 80;

    /// Group cycle tag.
    pub const GROUP_CYCLE: Signal = Signal::uint(
        "Cycle",
        0,
        8,
        255,
        "low 8 bits of the SYNC counter to apply at",
    );
    /// Which slots carry setpoints.
    pub const GROUP_MASK: Signal = Signal::uint(
        "SlotMask",
        8,
        6,
        63,
        "bit s set: slot s (node 6g+s+1) present",
    );
    /// Slot-relative positions.
    pub const SLOT_POSITION: [Signal; 2] = [
        Signal::fixed(
            "PitchPosition",
            0,
            16,
            POSITION_FACTOR,
            POSITION_LIMIT,
            "rad",
            "pitch position setpoint",
        ),
        Signal::fixed(
            "YawPosition",
            16,
            16,
            POSITION_FACTOR,
            POSITION_LIMIT,
            "rad",
            "yaw position setpoint",
        ),
    ];
    /// Slot-relative velocities.
    pub const SLOT_VELOCITY: [Signal; 2] = [
        Signal::fixed(
            "PitchVelocity",
            32,
            12,
            VELOCITY_FACTOR,
            VELOCITY_LIMIT,
            "rad/s",
            "pitch velocity feedforward",
        ),
        Signal::fixed(
            "YawVelocity",
            44,
            12,
            VELOCITY_FACTOR,
            VELOCITY_LIMIT,
            "rad/s",
            "yaw velocity feedforward",
        ),
    ];
    /// Slot-relative torques.
    pub const SLOT_TORQUE: [Signal; 2] = [
        Signal::fixed(
            "PitchTorque",
            56,
            12,
            TORQUE_FACTOR,
            TORQUE_LIMIT,
            "N.m",
            "pitch torque feedforward",
        ),
        Signal::fixed(
            "YawTorque",
            68,
            12,
            TORQUE_FACTOR,
            TORQUE_LIMIT,
            "N.m",
            "yaw torque feedforward",
        ),
    ];

    const fn group_signals() -> [Signal; 2 + 6 * GROUP_SLOTS] {
        let per_slot = [
            SLOT_POSITION[0],
            SLOT_POSITION[1],
            SLOT_VELOCITY[0],
            SLOT_VELOCITY[1],
            SLOT_TORQUE[0],
            SLOT_TORQUE[1],
        ];
        let mut out = [GROUP_CYCLE; 2 + 6 * GROUP_SLOTS];
        out[1] = GROUP_MASK;
        let mut s = 0;
        while s < GROUP_SLOTS {
            let mut k = 0;
            while k < 6 {
                out[2 + s * 6 + k] = per_slot[k].in_slot(s as u8, SLOT_BASE, SLOT_BITS);
                k += 1;
            }
            s += 1;
        }
        out
    }

    /// Setpoint group fields (slot signals at their absolute positions).
    pub const SETPOINT_GROUP: [Signal; 2 + 6 * GROUP_SLOTS] = group_signals();

    /// Feedback positions.
    pub const FB_POSITION: [Signal; 2] = [
        Signal::fixed(
            "PitchPosition",
            8,
            16,
            POSITION_FACTOR,
            POSITION_LIMIT,
            "rad",
            "pitch position",
        ),
        Signal::fixed(
            "YawPosition",
            24,
            16,
            POSITION_FACTOR,
            POSITION_LIMIT,
            "rad",
            "yaw position",
        ),
    ];
    /// Feedback velocities.
    pub const FB_VELOCITY: [Signal; 2] = [
        Signal::fixed(
            "PitchVelocity",
            40,
            12,
            VELOCITY_FACTOR,
            VELOCITY_LIMIT,
            "rad/s",
            "pitch velocity",
        ),
        Signal::fixed(
            "YawVelocity",
            52,
            12,
            VELOCITY_FACTOR,
            VELOCITY_LIMIT,
            "rad/s",
            "yaw velocity",
        ),
    ];
    /// Feedback torques.
    pub const FB_TORQUE: [Signal; 2] = [
        Signal::fixed(
            "PitchTorque",
            64,
            12,
            TORQUE_FACTOR,
            TORQUE_LIMIT,
            "N.m",
            "pitch torque",
        ),
        Signal::fixed(
            "YawTorque",
            76,
            12,
            TORQUE_FACTOR,
            TORQUE_LIMIT,
            "N.m",
            "yaw torque",
        ),
    ];
    /// Feedback fields.
    pub const FEEDBACK: [Signal; 10] = [
        common::FB_ENABLED,
        common::FB_FAULT,
        common::FB_LIMITED[0],
        common::FB_LIMITED[1],
        FB_POSITION[0],
        FB_POSITION[1],
        FB_VELOCITY[0],
        FB_VELOCITY[1],
        FB_TORQUE[0],
        FB_TORQUE[1],
    ];

    /// Data length of a group frame whose highest present slot is `slots - 1`.
    pub const fn group_len(slots: usize) -> usize {
        let bytes = (SLOT_BASE as usize + slots * SLOT_BITS as usize).div_ceil(8);
        let l = crate::frame::FD_LENGTHS;
        let mut i = 0;
        while i < l.len() {
            if l[i] as usize >= bytes {
                return l[i] as usize;
            }
            i += 1;
        }
        64
    }
}

const ESTOP_DEF: MessageDef = MessageDef {
    function: Function::EStop,
    name: "EStop",
    direction: Direction::HostToNode,
    addressing: Addressing::AllOrNode,
    len: 0,
    period: "on event (operator E-stop, supervisor)",
    signals: &[],
    comment: "emergency stop: motors off at once, latched until ClearFaults",
};
const SYNC_DEF: MessageDef = MessageDef {
    function: Function::Sync,
    name: "Sync",
    direction: Direction::HostToNode,
    addressing: Addressing::Broadcast,
    len: 2,
    period: "every control period, after the setpoints",
    signals: &common::SYNC,
    comment: "apply the setpoints tagged with this counter now",
};
const COMMAND_DEF: MessageDef = MessageDef {
    function: Function::Command,
    name: "Command",
    direction: Direction::HostToNode,
    addressing: Addressing::AllOrNode,
    len: 1,
    period: "on event",
    signals: &common::COMMANDS,
    comment: "enable, disable, clear faults",
};
const HEARTBEAT_DEF: MessageDef = MessageDef {
    function: Function::Heartbeat,
    name: "Heartbeat",
    direction: Direction::NodeToHost,
    addressing: Addressing::Node,
    len: 6,
    period: "every 100 ms, and at once on a state change",
    signals: &common::HEARTBEAT,
    comment: "node state and error bits",
};
const CONFIG_WRITE_DEF: MessageDef = MessageDef {
    function: Function::ConfigWrite,
    name: "ConfigWrite",
    direction: Direction::HostToNode,
    addressing: Addressing::Node,
    len: 8,
    period: "on event (start-up, while Disabled)",
    signals: &common::CONFIG_WRITE,
    comment: "write one configuration parameter",
};
const CONFIG_ACK_DEF: MessageDef = MessageDef {
    function: Function::ConfigAck,
    name: "ConfigAck",
    direction: Direction::NodeToHost,
    addressing: Addressing::Node,
    len: 8,
    period: "in answer to each ConfigWrite",
    signals: &common::CONFIG_ACK,
    comment: "outcome and value in effect",
};

const CLASSIC_DEFS: [MessageDef; 8] = [
    ESTOP_DEF,
    SYNC_DEF,
    COMMAND_DEF,
    MessageDef {
        function: Function::Setpoint,
        name: "Setpoint",
        direction: Direction::HostToNode,
        addressing: Addressing::Node,
        len: 8,
        period: "every control period, before SYNC",
        signals: &classic::SETPOINT,
        comment: "both axes' position, velocity and torque feedforward",
    },
    MessageDef {
        function: Function::Feedback,
        name: "Feedback",
        direction: Direction::NodeToHost,
        addressing: Addressing::Node,
        len: 8,
        period: "every control period, sampled at SYNC",
        signals: &classic::FEEDBACK,
        comment: "both axes' position, velocity, torque and status",
    },
    HEARTBEAT_DEF,
    CONFIG_WRITE_DEF,
    CONFIG_ACK_DEF,
];

const FD_DEFS: [MessageDef; 8] = [
    ESTOP_DEF,
    SYNC_DEF,
    COMMAND_DEF,
    MessageDef {
        function: Function::SetpointGroup,
        name: "SetpointGroup",
        direction: Direction::HostToNode,
        addressing: Addressing::Group,
        len: 64,
        period: "every control period, before SYNC",
        signals: &fd::SETPOINT_GROUP,
        comment: "setpoints of nodes 6g+1..6g+6",
    },
    MessageDef {
        function: Function::Feedback,
        name: "Feedback",
        direction: Direction::NodeToHost,
        addressing: Addressing::Node,
        len: 12,
        period: "every control period, sampled at SYNC",
        signals: &fd::FEEDBACK,
        comment: "both axes' position, velocity, torque and status",
    },
    HEARTBEAT_DEF,
    CONFIG_WRITE_DEF,
    CONFIG_ACK_DEF,
];

/// Every message definition of a variant, in identifier order.
pub const fn definitions(variant: Variant) -> &'static [MessageDef] {
    match variant {
        Variant::Classic => &CLASSIC_DEFS,
        Variant::Fd => &FD_DEFS,
    }
}

/// The definition of `function` in `variant`, if the variant uses it.
pub fn definition(variant: Variant, function: Function) -> Option<&'static MessageDef> {
    definitions(variant).iter().find(|d| d.function == function)
}

/// Whether a frame on `id` is, on `variant`, addressed to node `node`: a
/// standard identifier of a host-to-node message of that variant whose low
/// bits reach the node ([`Addressing::reaches`]). This is the node
/// contract's "addressed to this node" (protocol/README.md): such a frame
/// that does not decode counts as `BAD_FRAME`; one on an E-stop identifier
/// is an E-stop whatever it holds ([`estop_target`]). Extended ids,
/// node-to-host messages, the other variant's messages and unused ids
/// address no node.
pub fn addressed_to(variant: Variant, id: Id, node: NodeId) -> bool {
    let Some(raw) = id.as_standard() else {
        return false;
    };
    let Some((function, low)) = Function::split_id(raw) else {
        return false;
    };
    match definition(variant, function) {
        Some(def) => def.direction == Direction::HostToNode && def.addressing.reaches(low, node),
        None => false,
    }
}

/// Who an E-stop identifier stops: [`Target::All`] on 0x000,
/// [`Target::Node`] on 0x000 + node; `None` for any other identifier. The
/// identifier alone decides, whatever the frame holds (fail safe: nodes and
/// the host act on any frame there, protocol/README.md "E-stop").
pub const fn estop_target(id: Id) -> Option<Target> {
    let Some(raw) = id.as_standard() else {
        return None;
    };
    match Function::split_id(raw) {
        Some((Function::EStop, 0)) => Some(Target::All),
        Some((Function::EStop, low)) => Some(Target::Node(NodeId(low))),
        _ => None,
    }
}

/// Why a message could not be encoded.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum EncodeError {
    /// A physical value outside its documented range, or not finite; the
    /// daemon clamps before encoding.
    #[error("{signal} = {value} is out of range (expected {min}..={max})")]
    ValueOutOfRange {
        /// Field name.
        signal: &'static str,
        /// The value given.
        value: f64,
        /// Smallest accepted.
        min: f64,
        /// Largest accepted.
        max: f64,
    },
    /// A node id outside 1..=63.
    #[error("node id {0} is out of range (expected 1..=63)")]
    BadNodeId(u8),
    /// A setpoint group index outside 0..=10.
    #[error("setpoint group {0} is out of range (expected 0..=10)")]
    BadGroup(u8),
    /// A setpoint group slot beyond node 63.
    #[error("setpoint group {group} slot {slot} would be node {node} (expected node ids 1..=63)")]
    SlotBeyondLastNode {
        /// Group.
        group: u8,
        /// Slot.
        slot: u8,
        /// The node id it would address.
        node: u8,
    },
    /// A setpoint group with no slot present.
    #[error("setpoint group {0} carries no node (expected at least one slot)")]
    EmptyGroup(u8),
    /// Position limits with min above max.
    #[error("position limits min {min} > max {max} (expected min <= max)")]
    InvertedLimits {
        /// Lower limit.
        min: f32,
        /// Upper limit.
        max: f32,
    },
    /// The message does not exist in this variant.
    #[error("{message} is not used on {variant} (use the other variant's message)")]
    NotInVariant {
        /// Message name.
        message: &'static str,
        /// Variant asked for.
        variant: Variant,
    },
    /// Building the frame failed (cannot happen with the built-in layouts).
    #[error("frame: {0}")]
    Frame(#[from] FrameError),
}

/// Why a frame could not be decoded. Decoding never panics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// A 29-bit identifier: the protocol uses 11-bit identifiers only.
    #[error("extended id 0x{0:08X} (expected an 11-bit standard id)")]
    ExtendedId(u32),
    /// A remote frame: the protocol uses none.
    #[error("remote frame on id 0x{0:03X} (expected a data frame)")]
    RemoteFrame(u16),
    /// Classic frame on a CAN FD protocol or FD frame on a classic one.
    #[error("{found} frame on id 0x{id:03X} (expected {expected} frames)")]
    WrongKind {
        /// Identifier.
        id: u16,
        /// Frame kind seen ("classic" / "FD").
        found: &'static str,
        /// The variant decoded for.
        expected: Variant,
    },
    /// An identifier no message of this variant uses.
    #[error("unknown id 0x{0:03X} (expected one of the ids of protocol/README.md)")]
    UnknownId(u16),
    /// A node id not in the configured set.
    #[error("message {message} for/from node {node}, which is not configured")]
    UnknownNode {
        /// Message name.
        message: &'static str,
        /// The node id seen.
        node: u8,
    },
    /// Wrong data length.
    #[error("{message} of {len} bytes (expected {expected})")]
    WrongLength {
        /// Message name.
        message: &'static str,
        /// Length seen.
        len: u8,
        /// Length expected.
        expected: u8,
    },
    /// A field outside its documented range.
    #[error("{message}.{signal} raw value {raw} is out of range (expected {min}..={max})")]
    ValueOutOfRange {
        /// Message name.
        message: &'static str,
        /// Field name.
        signal: &'static str,
        /// Raw value seen.
        raw: i64,
        /// Smallest valid raw value.
        min: i64,
        /// Largest valid raw value.
        max: i64,
    },
    /// Reserved bits (or an absent slot) not zero.
    #[error("{message} byte {byte} has reserved bits set (expected 0)")]
    ReservedBits {
        /// Message name.
        message: &'static str,
        /// Byte index.
        byte: u8,
    },
    /// Position limits with min above max.
    #[error("ConfigWrite/Ack position limits min > max (expected min <= max)")]
    InvertedLimits,
    /// A setpoint group with an empty slot mask.
    #[error("SetpointGroup with empty slot mask (expected at least one slot)")]
    EmptyGroup,
}

fn put(buf: &mut [u8], s: &Signal, value: f64) -> Result<(), EncodeError> {
    let raw = s.to_raw(value).ok_or(EncodeError::ValueOutOfRange {
        signal: s.name,
        value,
        min: s.to_physical(s.raw_min()),
        max: s.to_physical(s.raw_max()),
    })?;
    s.put(buf, raw);
    Ok(())
}

fn get_raw(buf: &[u8], s: &Signal, message: &'static str) -> Result<i64, DecodeError> {
    let raw = s.get(buf);
    if raw < s.raw_min() || raw > s.raw_max() {
        return Err(DecodeError::ValueOutOfRange {
            message,
            signal: s.name,
            raw,
            min: s.raw_min(),
            max: s.raw_max(),
        });
    }
    Ok(raw)
}

fn get(buf: &[u8], s: &Signal, message: &'static str) -> Result<f32, DecodeError> {
    Ok(s.to_physical(get_raw(buf, s, message)?) as f32)
}

/// Errors if any bit of `data` outside `signals` is set.
fn check_reserved<'a>(
    data: &[u8],
    signals: impl Iterator<Item = &'a Signal>,
    message: &'static str,
) -> Result<(), DecodeError> {
    let mut used = [0u8; 64];
    for s in signals {
        for pos in s.start as usize..=s.end() as usize {
            used[pos / 8] |= 1 << (pos % 8);
        }
    }
    match data.iter().zip(used).position(|(d, u)| d & !u != 0) {
        Some(byte) => Err(DecodeError::ReservedBits {
            message,
            byte: byte as u8,
        }),
        None => Ok(()),
    }
}

fn active_config_signals(signals: &[Signal], param: u8) -> impl Iterator<Item = &Signal> {
    signals.iter().filter(move |s| match s.mux {
        Mux::When(v) => v == param,
        _ => true,
    })
}

impl Message {
    /// The function code of this message.
    pub const fn function(&self) -> Function {
        match self {
            Message::EStop(_) => Function::EStop,
            Message::Sync { .. } => Function::Sync,
            Message::Command { .. } => Function::Command,
            Message::Setpoint(_) => Function::Setpoint,
            Message::SetpointGroup(_) => Function::SetpointGroup,
            Message::Feedback(_) => Function::Feedback,
            Message::Heartbeat(_) => Function::Heartbeat,
            Message::ConfigWrite { .. } => Function::ConfigWrite,
            Message::ConfigAck { .. } => Function::ConfigAck,
        }
    }

    /// The frame for this message on `variant`. Never allocates.
    pub fn encode(&self, variant: Variant) -> Result<Frame, EncodeError> {
        let function = self.function();
        let def = definition(variant, function).ok_or(EncodeError::NotInVariant {
            message: function_name(function),
            variant,
        })?;
        let mut buf = [0u8; 64];
        let mut len = def.len as usize;
        let low: u8 = match *self {
            Message::EStop(target) => target.raw(),
            Message::Sync { counter } => {
                common::SYNC_COUNTER.put(&mut buf, counter as i64);
                0
            }
            Message::Command { target, command } => {
                common::COMMAND.put(&mut buf, command as i64);
                target.raw()
            }
            Message::Setpoint(sp) => {
                put(&mut buf, &classic::SP_CYCLE, sp.cycle as f64)?;
                for (a, v) in sp.axes.iter().enumerate() {
                    put(&mut buf, &classic::SP_POSITION[a], v.position as f64)?;
                    put(&mut buf, &classic::SP_VELOCITY[a], v.velocity as f64)?;
                    put(&mut buf, &classic::SP_TORQUE[a], v.torque as f64)?;
                }
                sp.node.0
            }
            Message::SetpointGroup(g) => {
                let groups = (MAX_NODE_ID as usize).div_ceil(GROUP_SLOTS) as u8;
                if g.group >= groups {
                    return Err(EncodeError::BadGroup(g.group));
                }
                let mut mask = 0i64;
                for (s, slot) in g.slots.iter().enumerate() {
                    let Some(axes) = slot else { continue };
                    let node = g.group as usize * GROUP_SLOTS + s + 1;
                    if node > MAX_NODE_ID as usize {
                        return Err(EncodeError::SlotBeyondLastNode {
                            group: g.group,
                            slot: s as u8,
                            node: node as u8,
                        });
                    }
                    mask |= 1 << s;
                    for (a, v) in axes.iter().enumerate() {
                        let sig = |x: Signal| x.in_slot(s as u8, fd::SLOT_BASE, fd::SLOT_BITS);
                        put(&mut buf, &sig(fd::SLOT_POSITION[a]), v.position as f64)?;
                        put(&mut buf, &sig(fd::SLOT_VELOCITY[a]), v.velocity as f64)?;
                        put(&mut buf, &sig(fd::SLOT_TORQUE[a]), v.torque as f64)?;
                    }
                }
                if mask == 0 {
                    return Err(EncodeError::EmptyGroup(g.group));
                }
                fd::GROUP_CYCLE.put(&mut buf, g.cycle as i64);
                fd::GROUP_MASK.put(&mut buf, mask);
                len = fd::group_len(64 - mask.leading_zeros() as usize);
                g.group
            }
            Message::Feedback(fb) => {
                let (pos, vel, trq) = match variant {
                    Variant::Classic => (
                        classic::FB_POSITION,
                        classic::FB_VELOCITY,
                        classic::FB_TORQUE,
                    ),
                    Variant::Fd => (fd::FB_POSITION, fd::FB_VELOCITY, fd::FB_TORQUE),
                };
                common::FB_ENABLED.put(&mut buf, fb.enabled as i64);
                common::FB_FAULT.put(&mut buf, fb.fault as i64);
                for (a, v) in fb.axes.iter().enumerate() {
                    common::FB_LIMITED[a].put(&mut buf, v.limited as i64);
                    put(&mut buf, &pos[a], v.position as f64)?;
                    put(&mut buf, &vel[a], v.velocity as f64)?;
                    put(&mut buf, &trq[a], v.torque as f64)?;
                }
                fb.node.0
            }
            Message::Heartbeat(hb) => {
                common::HB_STATE.put(&mut buf, hb.state as i64);
                if hb.errors.0 & !ErrorBits::ALL != 0 {
                    return Err(EncodeError::ValueOutOfRange {
                        signal: "Errors",
                        value: hb.errors.0 as f64,
                        min: 0.0,
                        max: ErrorBits::ALL as f64,
                    });
                }
                common::HB_ERRORS.put(&mut buf, hb.errors.0 as i64);
                common::HB_COUNTER.put(&mut buf, hb.counter as i64);
                common::HB_MISSED.put(&mut buf, hb.missed_syncs as i64);
                put(&mut buf, &common::HB_TEMPERATURE, hb.temperature as f64)?;
                hb.node.0
            }
            Message::ConfigWrite { node, param } => {
                common::CFG_AXIS.put(&mut buf, param.axis() as i64);
                put_param(&mut buf, &param)?;
                node.0
            }
            Message::ConfigAck {
                node,
                param,
                result,
            } => {
                common::ACK_AXIS.put(&mut buf, param.axis() as i64);
                common::ACK_RESULT.put(&mut buf, result as i64);
                put_param(&mut buf, &param)?;
                node.0
            }
        };
        let id = function.can_id(low);
        Ok(match variant {
            Variant::Classic => Frame::new(id, &buf[..len])?,
            Variant::Fd => Frame::new_fd(id, &buf[..len], true)?,
        })
    }
}

fn put_param(buf: &mut [u8], param: &ConfigParam) -> Result<(), EncodeError> {
    common::CFG_PARAM.put(buf, param.index() as i64);
    match *param {
        ConfigParam::WatchdogTimeout { ms } => put(buf, &common::CFG_WATCHDOG, ms as f64),
        ConfigParam::SafeAction(a) => {
            common::CFG_SAFE_ACTION.put(buf, a as i64);
            Ok(())
        }
        ConfigParam::PositionLimits { min, max, .. } => {
            // Compare after quantization, as the node will see them.
            put(buf, &common::CFG_POS_MIN, min as f64)?;
            put(buf, &common::CFG_POS_MAX, max as f64)?;
            if common::CFG_POS_MIN.get(buf) > common::CFG_POS_MAX.get(buf) {
                return Err(EncodeError::InvertedLimits { min, max });
            }
            Ok(())
        }
        ConfigParam::VelocityLimit { max, .. } => put(buf, &common::CFG_VEL_MAX, max as f64),
        ConfigParam::TorqueLimit { max, .. } => put(buf, &common::CFG_TRQ_MAX, max as f64),
    }
}

/// The name of a function's message (as in the DBC and README).
pub const fn function_name(f: Function) -> &'static str {
    match f {
        Function::EStop => "EStop",
        Function::Sync => "Sync",
        Function::Command => "Command",
        Function::Setpoint => "Setpoint",
        Function::SetpointGroup => "SetpointGroup",
        Function::Feedback => "Feedback",
        Function::Heartbeat => "Heartbeat",
        Function::ConfigWrite => "ConfigWrite",
        Function::ConfigAck => "ConfigAck",
    }
}

fn decode_param(
    data: &[u8],
    axis_sig: &Signal,
    message: &'static str,
) -> Result<ConfigParam, DecodeError> {
    let index = get_raw(data, &common::CFG_PARAM, message)? as u8;
    let axis_raw = get_raw(data, axis_sig, message)?;
    let axis = if axis_raw == 0 {
        Axis::Pitch
    } else {
        Axis::Yaw
    };
    let node_wide = index <= 1;
    if node_wide && axis_raw != 0 {
        return Err(DecodeError::ValueOutOfRange {
            message,
            signal: axis_sig.name,
            raw: axis_raw,
            min: 0,
            max: 0,
        });
    }
    Ok(match index {
        0 => ConfigParam::WatchdogTimeout {
            ms: get_raw(data, &common::CFG_WATCHDOG, message)? as u16,
        },
        1 => ConfigParam::SafeAction(match get_raw(data, &common::CFG_SAFE_ACTION, message)? {
            0 => SafeAction::Hold,
            1 => SafeAction::Limp,
            _ => SafeAction::Brake,
        }),
        2 => {
            if common::CFG_POS_MIN.get(data) > common::CFG_POS_MAX.get(data) {
                return Err(DecodeError::InvertedLimits);
            }
            ConfigParam::PositionLimits {
                axis,
                min: get(data, &common::CFG_POS_MIN, message)?,
                max: get(data, &common::CFG_POS_MAX, message)?,
            }
        }
        3 => ConfigParam::VelocityLimit {
            axis,
            max: get(data, &common::CFG_VEL_MAX, message)?,
        },
        _ => ConfigParam::TorqueLimit {
            axis,
            max: get(data, &common::CFG_TRQ_MAX, message)?,
        },
    })
}

/// Decodes a frame of `variant`, accepting only node ids in `nodes`.
///
/// Physical-layer flags (FD bit-rate switch and error-state indicator) are
/// not part of the message and are ignored. Every failure is an error value:
/// this function never panics, whatever the frame.
///
/// The host passes the configured nodes (`NodeSet::first(n)`), so a frame
/// from or for any other id is [`DecodeError::UnknownNode`]. A node (the
/// simulated one) passes [`NodeSet::all`] and keeps what is addressed to it:
/// a [`SetpointGroup`] carries other nodes' slots too
/// ([`SetpointGroup::for_node`]).
pub fn decode(frame: &Frame, variant: Variant, nodes: NodeSet) -> Result<Message, DecodeError> {
    let id = match frame.id() {
        Id::Standard(id) => id.as_raw(),
        Id::Extended(id) => return Err(DecodeError::ExtendedId(id.as_raw())),
    };
    match (frame.kind(), variant) {
        (Kind::Remote { .. }, _) => return Err(DecodeError::RemoteFrame(id)),
        (Kind::Data, Variant::Classic) | (Kind::Fd { .. }, Variant::Fd) => {}
        (Kind::Data, Variant::Fd) => {
            return Err(DecodeError::WrongKind {
                id,
                found: "classic",
                expected: variant,
            });
        }
        (Kind::Fd { .. }, Variant::Classic) => {
            return Err(DecodeError::WrongKind {
                id,
                found: "FD",
                expected: variant,
            });
        }
    }
    let (function, low) = Function::split_id(id).ok_or(DecodeError::UnknownId(id))?;
    let def = definition(variant, function).ok_or(DecodeError::UnknownId(id))?;
    let message = def.name;
    let data = frame.data();
    let node = || -> Result<NodeId, DecodeError> {
        if nodes.contains(low) {
            Ok(NodeId(low))
        } else {
            Err(DecodeError::UnknownNode { message, node: low })
        }
    };
    let target = || -> Result<Target, DecodeError> {
        if low == 0 {
            Ok(Target::All)
        } else {
            node().map(Target::Node)
        }
    };
    // Length: fixed, except the FD setpoint group (checked below).
    if def.addressing != Addressing::Group && data.len() != def.len as usize {
        return Err(DecodeError::WrongLength {
            message,
            len: data.len() as u8,
            expected: def.len,
        });
    }
    match function {
        Function::EStop => Ok(Message::EStop(target()?)),
        Function::Sync => {
            if low != 0 {
                return Err(DecodeError::UnknownId(id));
            }
            Ok(Message::Sync {
                counter: common::SYNC_COUNTER.get(data) as u16,
            })
        }
        Function::Command => {
            let target = target()?;
            let command = match get_raw(data, &common::COMMAND, message)? {
                1 => Command::Enable,
                2 => Command::Disable,
                3 => Command::ClearFaults,
                raw => {
                    return Err(DecodeError::ValueOutOfRange {
                        message,
                        signal: common::COMMAND.name,
                        raw,
                        min: 1,
                        max: 3,
                    });
                }
            };
            Ok(Message::Command { target, command })
        }
        Function::Setpoint => {
            let node = node()?;
            let mut axes = [AxisSetpoint::default(); 2];
            for (a, v) in axes.iter_mut().enumerate() {
                v.position = get(data, &classic::SP_POSITION[a], message)?;
                v.velocity = get(data, &classic::SP_VELOCITY[a], message)?;
                v.torque = get(data, &classic::SP_TORQUE[a], message)?;
            }
            Ok(Message::Setpoint(Setpoint {
                node,
                cycle: classic::SP_CYCLE.get(data) as u8,
                axes,
            }))
        }
        Function::SetpointGroup => {
            let group = low;
            if group as usize >= (MAX_NODE_ID as usize).div_ceil(GROUP_SLOTS) {
                return Err(DecodeError::UnknownId(id));
            }
            if data.len() < 2 {
                return Err(DecodeError::WrongLength {
                    message,
                    len: data.len() as u8,
                    expected: fd::group_len(1) as u8,
                });
            }
            let mask = fd::GROUP_MASK.get(data) as u8;
            if mask == 0 {
                return Err(DecodeError::EmptyGroup);
            }
            let slots_used = 8 - mask.leading_zeros() as usize;
            let expected = fd::group_len(slots_used);
            if data.len() != expected {
                return Err(DecodeError::WrongLength {
                    message,
                    len: data.len() as u8,
                    expected: expected as u8,
                });
            }
            let present = |s: &&Signal| match s.slot {
                Some(k) => mask >> k & 1 == 1,
                None => true,
            };
            check_reserved(data, fd::SETPOINT_GROUP.iter().filter(present), message)?;
            let mut slots = [None; GROUP_SLOTS];
            for (s, slot) in slots.iter_mut().enumerate() {
                if mask >> s & 1 == 0 {
                    continue;
                }
                let raw_node = group as usize * GROUP_SLOTS + s + 1;
                if raw_node > MAX_NODE_ID as usize || !nodes.contains(raw_node as u8) {
                    return Err(DecodeError::UnknownNode {
                        message,
                        node: raw_node.min(255) as u8,
                    });
                }
                let mut axes = [AxisSetpoint::default(); 2];
                for (a, v) in axes.iter_mut().enumerate() {
                    let sig = |x: Signal| x.in_slot(s as u8, fd::SLOT_BASE, fd::SLOT_BITS);
                    v.position = get(data, &sig(fd::SLOT_POSITION[a]), message)?;
                    v.velocity = get(data, &sig(fd::SLOT_VELOCITY[a]), message)?;
                    v.torque = get(data, &sig(fd::SLOT_TORQUE[a]), message)?;
                }
                *slot = Some(axes);
            }
            Ok(Message::SetpointGroup(SetpointGroup {
                group,
                cycle: fd::GROUP_CYCLE.get(data) as u8,
                slots,
            }))
        }
        Function::Feedback => {
            let node = node()?;
            check_reserved(data, def.signals.iter(), message)?;
            let (pos, vel, trq) = match variant {
                Variant::Classic => (
                    classic::FB_POSITION,
                    classic::FB_VELOCITY,
                    classic::FB_TORQUE,
                ),
                Variant::Fd => (fd::FB_POSITION, fd::FB_VELOCITY, fd::FB_TORQUE),
            };
            let mut axes = [AxisFeedback::default(); 2];
            for (a, v) in axes.iter_mut().enumerate() {
                v.position = get(data, &pos[a], message)?;
                v.velocity = get(data, &vel[a], message)?;
                v.torque = get(data, &trq[a], message)?;
                v.limited = common::FB_LIMITED[a].get(data) == 1;
            }
            Ok(Message::Feedback(Feedback {
                node,
                enabled: common::FB_ENABLED.get(data) == 1,
                fault: common::FB_FAULT.get(data) == 1,
                axes,
            }))
        }
        Function::Heartbeat => {
            let node = node()?;
            let state_raw = get_raw(data, &common::HB_STATE, message)?;
            let state = NodeState::from_raw(state_raw).ok_or(DecodeError::ValueOutOfRange {
                message,
                signal: common::HB_STATE.name,
                raw: state_raw,
                min: 0,
                max: 4,
            })?;
            let errors = common::HB_ERRORS.get(data);
            if errors & !(ErrorBits::ALL as i64) != 0 {
                return Err(DecodeError::ReservedBits { message, byte: 2 });
            }
            Ok(Message::Heartbeat(Heartbeat {
                node,
                state,
                errors: ErrorBits(errors as u16),
                counter: common::HB_COUNTER.get(data) as u8,
                missed_syncs: common::HB_MISSED.get(data) as u8,
                temperature: get_raw(data, &common::HB_TEMPERATURE, message)? as i8,
            }))
        }
        Function::ConfigWrite => {
            let node = node()?;
            let index = get_raw(data, &common::CFG_PARAM, message)? as u8;
            check_reserved(data, active_config_signals(def.signals, index), message)?;
            let param = decode_param(data, &common::CFG_AXIS, message)?;
            Ok(Message::ConfigWrite { node, param })
        }
        Function::ConfigAck => {
            let node = node()?;
            let index = get_raw(data, &common::CFG_PARAM, message)? as u8;
            check_reserved(data, active_config_signals(def.signals, index), message)?;
            let param = decode_param(data, &common::ACK_AXIS, message)?;
            let result = match get_raw(data, &common::ACK_RESULT, message)? {
                0 => ConfigResult::Accepted,
                1 => ConfigResult::OutOfRange,
                _ => ConfigResult::NotDisabled,
            };
            Ok(Message::ConfigAck {
                node,
                param,
                result,
            })
        }
    }
}

/// `setpoints[i]` paired with node `i + 1`, for [`encode_setpoints`]: a
/// robot whose nodes are numbered from 1 (at most 63 nodes; any further
/// setpoints are left out).
pub fn from_node_one(
    setpoints: &[[AxisSetpoint; 2]],
) -> impl Iterator<Item = (NodeId, [AxisSetpoint; 2])> + '_ {
    (1..=MAX_NODE_ID).map(NodeId).zip(setpoints.iter().copied())
}

/// Setpoint groups a CAN FD bus can carry: node ids 1..=63 in groups of
/// [`GROUP_SLOTS`].
pub const MAX_GROUPS: usize = (MAX_NODE_ID as usize).div_ceil(GROUP_SLOTS);

/// Encodes one period's setpoints for `variant` and hands each frame to
/// `send`, without allocating: one [`Setpoint`] frame per node on classic
/// CAN, in the order given; on CAN FD one [`SetpointGroup`] frame per group
/// that holds at least one of the nodes (the group of node `n` is
/// `(n - 1) / 6`, [`SetpointGroup::locate`]), in group order. Node ids need
/// not be contiguous: ids 1, 7 and 13 take three FD frames. The caller sends
/// SYNC `counter` after these frames. A node given twice keeps its last
/// setpoint on CAN FD and is sent twice on classic CAN.
pub fn encode_setpoints(
    variant: Variant,
    counter: u16,
    setpoints: impl IntoIterator<Item = (NodeId, [AxisSetpoint; 2])>,
    mut send: impl FnMut(Frame),
) -> Result<(), EncodeError> {
    let cycle = variant.cycle_tag(counter);
    match variant {
        Variant::Classic => {
            for (node, axes) in setpoints {
                send(Message::Setpoint(Setpoint { node, cycle, axes }).encode(variant)?);
            }
        }
        Variant::Fd => {
            let mut groups = [SetpointGroup {
                group: 0,
                cycle,
                slots: [None; GROUP_SLOTS],
            }; MAX_GROUPS];
            let mut used = 0u16;
            for (node, axes) in setpoints {
                let (g, slot) = SetpointGroup::locate(node);
                let g = g as usize;
                groups[g].group = g as u8;
                groups[g].slots[slot] = Some(axes);
                used |= 1 << g;
            }
            for (g, group) in groups.iter().enumerate() {
                if used & (1 << g) != 0 {
                    send(Message::SetpointGroup(*group).encode(variant)?);
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node(n: u8) -> NodeId {
        NodeId::new(n).unwrap()
    }

    #[test]
    fn split_id_inverts_function_id() {
        for f in Function::ALL {
            assert_eq!(Function::from_id(f.id(0)), Some(f));
            for low in 0..=MAX_NODE_ID {
                assert_eq!(Function::split_id(f.id(low)), Some((f, low)), "{f:?} {low}");
            }
        }
        // README identifiers: SYNC 0x040, heartbeat of node 5 0x185.
        assert_eq!(Function::split_id(0x040), Some((Function::Sync, 0)));
        assert_eq!(Function::split_id(0x185), Some((Function::Heartbeat, 5)));
        assert_eq!(Function::split_id(0x23F), Some((Function::ConfigAck, 63)));
        assert_eq!(FIRST_UNUSED_ID, 0x240);
        for id in FIRST_UNUSED_ID..=crate::frame::MAX_STANDARD_ID {
            assert_eq!(Function::split_id(id), None, "0x{id:03X}");
            assert_eq!(Function::from_id(id), None, "0x{id:03X}");
        }
    }

    /// The identifiers of protocol/README.md, as seen by node 5 (group 0)
    /// and node 7 (group 1).
    #[test]
    fn addressed_to_follows_the_readme_identifiers() {
        use Variant::{Classic, Fd};
        let std = Id::standard_literal;
        let cases: [(u16, Variant, u8, bool); 25] = [
            (0x000, Classic, 5, true), // E-stop all
            (0x005, Classic, 5, true), // E-stop node 5
            (0x006, Classic, 5, false),
            (0x040, Classic, 5, true), // SYNC
            (0x040, Fd, 7, true),
            (0x041, Classic, 1, false), // SYNC is broadcast only
            (0x080, Fd, 5, true),       // Command all
            (0x085, Classic, 5, true),
            (0x087, Classic, 5, false),
            (0x0C5, Classic, 5, true), // Setpoint: classic only
            (0x0C5, Fd, 5, false),
            (0x100, Fd, 5, true), // SetpointGroup 0: nodes 1..=6
            (0x100, Fd, 6, true),
            (0x100, Fd, 7, false),
            (0x101, Fd, 7, true), // group 1: nodes 7..=12
            (0x101, Fd, 5, false),
            (0x100, Classic, 5, false), // no groups on classic CAN
            (0x145, Classic, 5, false), // Feedback: node to host
            (0x185, Fd, 5, false),      // Heartbeat: node to host
            (0x1C5, Classic, 5, true),  // ConfigWrite
            (0x1C0, Classic, 5, false), // ConfigWrite is never broadcast
            (0x1C7, Fd, 7, true),
            (0x205, Classic, 5, false), // ConfigAck: node to host
            (0x245, Classic, 5, false), // unused
            (0x7FF, Fd, 5, false),
        ];
        for (raw, variant, n, expected) in cases {
            assert_eq!(
                addressed_to(variant, std(raw), node(n)),
                expected,
                "0x{raw:03X} on {variant} for node {n}"
            );
        }
        let ext = Id::extended(0x005).unwrap();
        assert!(!addressed_to(Classic, ext, node(5)));
    }

    #[test]
    fn estop_target_reads_the_identifier_only() {
        assert_eq!(estop_target(Id::standard_literal(0x000)), Some(Target::All));
        assert_eq!(
            estop_target(Id::standard_literal(0x03F)),
            Some(Target::Node(node(63)))
        );
        assert_eq!(estop_target(Id::standard_literal(0x040)), None);
        assert_eq!(estop_target(Id::extended(0).unwrap()), None);
        assert!(Target::All.includes(node(1)));
        assert!(Target::Node(node(2)).includes(node(2)));
        assert!(!Target::Node(node(2)).includes(node(3)));
    }

    #[test]
    fn addressing_reaches() {
        assert!(Addressing::Broadcast.reaches(0, node(9)));
        assert!(!Addressing::Broadcast.reaches(9, node(9)));
        assert!(Addressing::AllOrNode.reaches(0, node(9)));
        assert!(Addressing::AllOrNode.reaches(9, node(9)));
        assert!(!Addressing::Node.reaches(0, node(9)));
        assert!(Addressing::Group.reaches(10, node(61)));
        assert!(Addressing::Group.reaches(10, node(63)));
        assert!(!Addressing::Group.reaches(9, node(61)));
    }
}
