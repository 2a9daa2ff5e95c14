//! The message types: every message of the protocol as a small `Copy`
//! value ([`Message`] and what it carries), node ids and sets, the function
//! codes of identifiers ([`Function`]) and how their low bits address
//! nodes ([`Addressing`]), and the documented ranges.

use super::node::{MAX_NODE_ID, NodeId};
use super::sensor::{HeadAttitude, HeadDepth, HeadSample, HeadVector};
use crate::frame::Id;

/// Documented joint position range: ±1.5 rad (eel joints stay within about
/// ±1.2 rad; the margin lets a node report an overshoot).
pub const POSITION_LIMIT: f64 = 1.5;
/// Documented joint velocity range: ±10 rad/s.
pub const VELOCITY_LIMIT: f64 = 10.0;
/// Documented joint torque range: ±5 N·m (a 1 m robot).
pub const TORQUE_LIMIT: f64 = 5.0;
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
/// Documented body-rate range of the head sensor: ±35 rad/s (±2000 °/s,
/// the widest gyro range of common IMUs).
pub const RATE_LIMIT: f64 = 35.0;
/// Documented acceleration range of the head sensor: ±160 m/s² (±16 g).
pub const ACCEL_LIMIT: f64 = 160.0;
/// Sample rates a head sensor may run at, Hz (inclusive).
pub const HEAD_SENSOR_RATE_HZ: (u16, u16) = (100, 200);
/// The head sensor's node id unless configured otherwise: the top of the
/// id range, away from vertebrae numbered from 1 (the DBC files list the
/// sensor's messages for this id).
pub const DEFAULT_HEAD_SENSOR_ID: u8 = MAX_NODE_ID;

/// Who a command is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Target {
    /// Every node (node field 0).
    All,
    /// One node.
    Node(NodeId),
}

impl Target {
    pub(super) const fn raw(self) -> u8 {
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
    /// ([`Variant::cycle_tag`](super::Variant::cycle_tag)).
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
    pub(super) fn from_raw(raw: i64) -> Option<Self> {
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

    /// Every defined bit with its name for an operator, lowest first.
    pub const NAMES: [(u16, &'static str); 12] = [
        (
            Self::WATCHDOG,
            "watchdog (no setpoint or SYNC within the node's timeout)",
        ),
        (Self::SYNC_MISSED, "SYNC missed"),
        (
            Self::POSITION_LIMIT,
            "setpoint clamped to the position limits",
        ),
        (
            Self::VELOCITY_LIMIT,
            "setpoint clamped to the velocity limit",
        ),
        (Self::TORQUE_LIMIT, "torque at its limit"),
        (Self::OVER_TEMPERATURE, "over temperature"),
        (Self::ENCODER, "position sensor fault"),
        (Self::BUS, "CAN error-passive or bus-off"),
        (Self::ESTOP_LATCHED, "E-stop latched"),
        (Self::BAD_FRAME, "undecodable frame ignored"),
        (Self::STALE_SETPOINT, "stale setpoint discarded"),
        (Self::UNDER_VOLTAGE, "supply under-voltage"),
    ];
}

/// The set bits' names, comma-separated ("none" without any); an
/// undefined bit is shown by its number.
impl std::fmt::Display for ErrorBits {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0 == 0 {
            return f.write_str("none");
        }
        let mut first = true;
        for bit in 0..16 {
            let b = 1u16 << bit;
            if self.0 & b == 0 {
                continue;
            }
            if !first {
                f.write_str(", ")?;
            }
            first = false;
            match Self::NAMES.iter().find(|(v, _)| *v == b) {
                Some((_, name)) => f.write_str(name)?,
                None => write!(f, "bit {bit}")?,
            }
        }
        Ok(())
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
    pub(super) const fn index(&self) -> u8 {
        match self {
            ConfigParam::WatchdogTimeout { .. } => 0,
            ConfigParam::SafeAction(_) => 1,
            ConfigParam::PositionLimits { .. } => 2,
            ConfigParam::VelocityLimit { .. } => 3,
            ConfigParam::TorqueLimit { .. } => 4,
        }
    }

    pub(super) const fn axis(&self) -> u8 {
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
    /// Head sensor → host, classic CAN: attitude (fusion IMUs only).
    HeadAttitude(HeadAttitude),
    /// Head sensor → host, classic CAN: body rates, rad/s.
    HeadRates(HeadVector),
    /// Head sensor → host, classic CAN: accelerations, m/s².
    HeadAccel(HeadVector),
    /// Head sensor → host, classic CAN: pressure, water temperature,
    /// status and errors (the sample's last frame).
    HeadDepth(HeadDepth),
    /// Head sensor → host, CAN FD: a whole sample.
    HeadSample(HeadSample),
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
    /// 0x240 + sensor (classic only).
    HeadAttitude = 9,
    /// 0x280 + sensor (classic only).
    HeadRates = 10,
    /// 0x2C0 + sensor (classic only).
    HeadAccel = 11,
    /// 0x300 + sensor (classic only).
    HeadDepth = 12,
    /// 0x340 + sensor (CAN FD only).
    HeadSample = 13,
}

impl Function {
    /// Every function, in priority order.
    pub const ALL: [Function; 14] = [
        Function::EStop,
        Function::Sync,
        Function::Command,
        Function::Setpoint,
        Function::SetpointGroup,
        Function::Feedback,
        Function::Heartbeat,
        Function::ConfigWrite,
        Function::ConfigAck,
        Function::HeadAttitude,
        Function::HeadRates,
        Function::HeadAccel,
        Function::HeadDepth,
        Function::HeadSample,
    ];

    /// The identifier of this function for node (or group) `low`.
    pub const fn id(self, low: u8) -> u16 {
        ((self as u16) << LOW_BITS) | (low as u16 & LOW_MASK)
    }

    /// The CAN identifier of this function for node (or group) `low`: a
    /// standard id, always in range (the highest, HeadSample for node 63, is
    /// 0x37F).
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

/// The first identifier above every function's range (0x380): ids from
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
    /// The head sensor's node id (1..=63, distinct from the vertebrae's).
    Sensor,
}

impl Addressing {
    /// Whether an identifier whose low six bits are `low` reaches node
    /// `node` under this addressing: [`Addressing::Broadcast`] only with
    /// 0, [`Addressing::AllOrNode`] with 0 or the node's id,
    /// [`Addressing::Node`] with the node's id, [`Addressing::Group`] with
    /// the group that carries the node ([`SetpointGroup::locate`]),
    /// [`Addressing::Sensor`] with the sensor's id.
    pub const fn reaches(self, low: u8, node: NodeId) -> bool {
        match self {
            Addressing::Broadcast => low == 0,
            Addressing::AllOrNode => low == 0 || low == node.0,
            Addressing::Node | Addressing::Sensor => low == node.0,
            Addressing::Group => low == SetpointGroup::locate(node).0,
        }
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
        Function::HeadAttitude => "HeadAttitude",
        Function::HeadRates => "HeadRates",
        Function::HeadAccel => "HeadAccel",
        Function::HeadDepth => "HeadDepth",
        Function::HeadSample => "HeadSample",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node(n: u8) -> NodeId {
        NodeId::new(n).unwrap()
    }

    #[test]
    fn error_bits_read_as_words() {
        assert_eq!(ErrorBits(0).to_string(), "none");
        assert_eq!(
            ErrorBits(ErrorBits::WATCHDOG | ErrorBits::UNDER_VOLTAGE).to_string(),
            "watchdog (no setpoint or SYNC within the node's timeout), supply under-voltage"
        );
        assert_eq!(ErrorBits(1 << 14).to_string(), "bit 14");
        // Every defined bit has exactly one name.
        let named = ErrorBits::NAMES.iter().fold(0u16, |acc, (b, _)| {
            assert_eq!(acc & b, 0, "{b:#x} named twice");
            acc | b
        });
        assert_eq!(named, ErrorBits::ALL);
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
        assert_eq!(
            Function::split_id(0x27F),
            Some((Function::HeadAttitude, 63))
        );
        assert_eq!(Function::split_id(0x341), Some((Function::HeadSample, 1)));
        assert_eq!(FIRST_UNUSED_ID, 0x380);
        for id in FIRST_UNUSED_ID..=crate::frame::MAX_STANDARD_ID {
            assert_eq!(Function::split_id(id), None, "0x{id:03X}");
            assert_eq!(Function::from_id(id), None, "0x{id:03X}");
        }
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
