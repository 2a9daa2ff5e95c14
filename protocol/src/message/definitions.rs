//! The message-definition table: for each variant, every message's
//! function code, name, sender, addressing, length, cadence and fields.
//! One table feeds the codec, the DBC generator, the bus budget and the
//! README tables; [`addressed_to`] and [`estop_target`] read identifiers
//! through it.

use super::node::NodeId;
use super::types::{Addressing, Direction, Function, Target};
use super::variant::Variant;
use super::{classic, common, fd};
use crate::frame::Id;
use crate::signal::Signal;

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

/// When a head sensor sends its sample frames.
const HEAD_PERIOD: &str = "every sample, 100-200 Hz on the sensor's own clock (not SYNC)";

const CLASSIC_DEFS: [MessageDef; 12] = [
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
    MessageDef {
        function: Function::HeadAttitude,
        name: "HeadAttitude",
        direction: Direction::NodeToHost,
        addressing: Addressing::Sensor,
        len: 8,
        period: HEAD_PERIOD,
        signals: &classic::HEAD_ATTITUDE_FRAME,
        comment: "head attitude quaternion (fusion IMUs only)",
    },
    MessageDef {
        function: Function::HeadRates,
        name: "HeadRates",
        direction: Direction::NodeToHost,
        addressing: Addressing::Sensor,
        len: 7,
        period: HEAD_PERIOD,
        signals: &classic::HEAD_RATES_FRAME,
        comment: "head body rates",
    },
    MessageDef {
        function: Function::HeadAccel,
        name: "HeadAccel",
        direction: Direction::NodeToHost,
        addressing: Addressing::Sensor,
        len: 7,
        period: HEAD_PERIOD,
        signals: &classic::HEAD_ACCEL_FRAME,
        comment: "head accelerations (specific force)",
    },
    MessageDef {
        function: Function::HeadDepth,
        name: "HeadDepth",
        direction: Direction::NodeToHost,
        addressing: Addressing::Sensor,
        len: 8,
        period: HEAD_PERIOD,
        signals: &classic::HEAD_DEPTH_FRAME,
        comment: "pressure, water temperature, status and errors; the sample's last frame",
    },
];

const FD_DEFS: [MessageDef; 9] = [
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
    MessageDef {
        function: Function::HeadSample,
        name: "HeadSample",
        direction: Direction::NodeToHost,
        addressing: Addressing::Sensor,
        len: 32,
        period: HEAD_PERIOD,
        signals: &fd::HEAD_SAMPLE_FRAME,
        comment: "a whole head-sensor sample: attitude, rates, accelerations, pressure, temperature, status",
    },
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

#[cfg(test)]
mod tests {
    use super::*;

    fn node(n: u8) -> NodeId {
        NodeId::new(n).unwrap()
    }

    /// The identifiers of protocol/README.md, as seen by node 5 (group 0)
    /// and node 7 (group 1).
    #[test]
    fn addressed_to_follows_the_readme_identifiers() {
        use Variant::{Classic, Fd};
        let std = Id::standard_literal;
        let cases: [(u16, Variant, u8, bool); 27] = [
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
            (0x245, Classic, 5, false), // HeadAttitude: sensor to host
            (0x345, Fd, 5, false),      // HeadSample: sensor to host
            (0x385, Classic, 5, false), // unused
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
}
