//! The drive families anguilla drives: its own vertebra protocol
//! ([`crate::message`]), CANopen CiA 402 drives ([`crate::canopen`]) and
//! ODrive's CANSimple ([`crate::odrive`]).
//!
//! A vertebra node of the anguilla protocol carries a joint's two axes;
//! a bought drive carries one axis, so a joint is two drives.

use core::fmt;
use core::str::FromStr;

use crate::frame::Frame;
use crate::message::{NodeSet, Variant};

/// Which protocol the joints' drives speak (config `[robot] drive`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Family {
    /// anguilla's vertebra nodes (one node, two axes, per joint).
    #[default]
    Anguilla,
    /// CANopen CiA 301/402 drives in cyclic synchronous position mode (one
    /// drive per axis).
    Cia402,
    /// ODrive CANSimple axes in position control, passthrough input (one
    /// axis per node id).
    Odrive,
    /// MIT-mode quasi-direct-drive actuators (CubeMars AK, T-Motor and
    /// clones; one per axis).
    Mit,
}

impl Family {
    /// Every family.
    pub const ALL: [Family; 4] = [
        Family::Anguilla,
        Family::Cia402,
        Family::Odrive,
        Family::Mit,
    ];

    /// The name used in configuration files and on the command line.
    pub const fn name(self) -> &'static str {
        match self {
            Family::Anguilla => "anguilla",
            Family::Cia402 => "cia402",
            Family::Odrive => "odrive",
            Family::Mit => "mit",
        }
    }

    /// What the family's drives are, in a sentence's words (the default
    /// configuration's comment lists them).
    pub const fn description(self) -> &'static str {
        match self {
            Family::Anguilla => "anguilla vertebra nodes, one per joint",
            Family::Cia402 => "CANopen CiA 402 drives, one per axis",
            Family::Odrive => "ODrive CANSimple axes, one per axis",
            Family::Mit => "MIT-mode actuators (CubeMars AK, T-Motor), one per axis",
        }
    }

    /// Whether a joint is two drives of this family (one per axis), rather
    /// than one node carrying both axes.
    pub const fn drive_per_axis(self) -> bool {
        match self {
            Family::Anguilla => false,
            Family::Cia402 | Family::Odrive | Family::Mit => true,
        }
    }

    /// The range of node ids a drive of this family takes.
    pub const fn id_range(self) -> (u8, u8) {
        match self {
            Family::Anguilla => (1, 63),
            Family::Cia402 => (1, crate::canopen::MAX_NODE_ID),
            Family::Odrive => (0, crate::odrive::MAX_NODE_ID),
            Family::Mit => (1, crate::mit::MAX_NODE_ID),
        }
    }

    /// The default node ids of joint `j` (0 = head end): one node `j + 1`
    /// for anguilla, drives `2j + 1` (pitch) and `2j + 2` (yaw) for the
    /// bought families.
    pub const fn default_ids(self, j: usize) -> [u8; 2] {
        match self {
            Family::Anguilla => [j as u8 + 1, j as u8 + 1],
            Family::Cia402 | Family::Odrive | Family::Mit => [2 * j as u8 + 1, 2 * j as u8 + 2],
        }
    }

    /// The node (or drive) an 11-bit identifier of this family addresses:
    /// anguilla's low six bits (`None` for ids no function uses), CANopen's
    /// low seven (0: a broadcast), ODrive's high six. Every family answers
    /// here, so a new one cannot compile without saying how it lays out ids.
    pub const fn node_of(self, id: u16) -> Option<u8> {
        match self {
            Family::Anguilla => match crate::message::Function::split_id(id) {
                Some((_, node)) => Some(node),
                None => None,
            },
            Family::Cia402 => Some((id & 0x7F) as u8),
            Family::Odrive => Some(crate::odrive::split_id(id).0),
            Family::Mit => crate::mit::node_of(id),
        }
    }

    /// Whether the family's drives speak CAN FD (anguilla's FD variant);
    /// the others speak classic CAN only. `dump --fd`, `sim --fd` and the
    /// DBC's `--fd` ask here.
    pub const fn speaks_fd(self) -> bool {
        match self {
            Family::Anguilla => true,
            Family::Cia402 | Family::Odrive | Family::Mit => false,
        }
    }

    /// Whether the head sensor (an anguilla-protocol node, frames from
    /// 0x240 + id) can share the bus with this family's drives: only where
    /// the drives use the same identifier layout; the bought families'
    /// traffic overlaps it. The configuration and the simulator ask here.
    pub const fn carries_head_sensor(self) -> bool {
        match self {
            Family::Anguilla => true,
            Family::Cia402 | Family::Odrive | Family::Mit => false,
        }
    }

    /// What the drives of a robot of this family are called, in a budget's
    /// heading ("24 ODrive axes").
    pub const fn drives_noun(self) -> &'static str {
        match self {
            Family::Anguilla => "anguilla axes",
            Family::Cia402 => "CiA 402 drives",
            Family::Odrive => "ODrive axes",
            Family::Mit => "MIT-mode drives",
        }
    }

    /// The cyclic traffic of `axes` axes (two per joint) of this family and
    /// their master, line by line, for the bus budget
    /// ([`crate::budget::Traffic::Drives`]): anguilla's nodes 1..=joints in
    /// `variant`; the bought families' on classic CAN.
    pub fn drive_traffic(self, axes: u32, variant: Variant) -> Vec<crate::budget::BudgetLine> {
        match self {
            Family::Anguilla => {
                crate::budget::control_traffic(variant, NodeSet::first((axes / 2) as u8)).to_vec()
            }
            Family::Cia402 => crate::canopen::traffic(axes),
            Family::Odrive => crate::odrive::traffic(axes),
            Family::Mit => crate::mit::traffic(axes),
        }
    }

    /// The DBC file of the drives with these node ids (a bought family's,
    /// one id per axis), or why the family has none. anguilla's DBC is
    /// written per node count and variant ([`crate::dbc::generate`]).
    pub fn drive_dbc(self, ids: &[u8]) -> Result<String, String> {
        match self {
            Family::Anguilla => Err("anguilla's DBC lists nodes 1..=N (--nodes N)".into()),
            Family::Cia402 => Err("CANopen devices are described by EDS files \
                 (e.g. sim-backend/eds/anguilla-sim-cia402.eds), not a DBC"
                .into()),
            Family::Odrive => {
                let mut nodes = Vec::with_capacity(ids.len());
                for &id in ids {
                    nodes.push(crate::odrive::NodeId::new(id).map_err(|e| e.to_string())?);
                }
                Ok(crate::odrive::dbc::dbc(&nodes))
            }
            Family::Mit => crate::mit::dbc(ids).map_err(|e| e.to_string()),
        }
    }

    /// `frame` as this family's protocol reads it (`variant`: anguilla's
    /// classic or FD layout; the others ignore it), or why it is not one
    /// of the family's frames. What `dump` prints.
    pub fn decode(self, frame: &Frame, variant: Variant) -> Result<Decoded, String> {
        match self {
            Family::Anguilla => crate::message::decode(frame, variant, NodeSet::all())
                .map(Decoded::Anguilla)
                .map_err(|e| e.to_string()),
            Family::Cia402 => crate::canopen::decode(frame)
                .map(Decoded::Cia402)
                .map_err(|e| e.to_string()),
            Family::Odrive => crate::odrive::decode(frame)
                .map(Decoded::Odrive)
                .map_err(|e| e.to_string()),
            Family::Mit => crate::mit::decode(frame, &crate::mit::DEFAULT_RANGES)
                .map(Decoded::Mit)
                .map_err(|e| e.to_string()),
        }
    }
}

/// A frame read by its family's protocol ([`Family::decode`]). Its `Debug`
/// is the message's own.
#[derive(Clone, PartialEq)]
pub enum Decoded {
    /// An anguilla message.
    Anguilla(crate::message::Message),
    /// A CANopen message.
    Cia402(crate::canopen::Message),
    /// An ODrive CANSimple message.
    Odrive(crate::odrive::Message),
    /// An MIT-mode message (over [`crate::mit::DEFAULT_RANGES`]).
    Mit(crate::mit::Message),
}

impl fmt::Debug for Decoded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Decoded::Anguilla(m) => m.fmt(f),
            Decoded::Cia402(m) => m.fmt(f),
            Decoded::Odrive(m) => m.fmt(f),
            Decoded::Mit(m) => m.fmt(f),
        }
    }
}

impl fmt::Display for Family {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A family name that is none of [`Family::ALL`]; its message lists them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownFamily(pub String);

impl fmt::Display for UnknownFamily {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unknown drive family {:?} (expected one of", self.0)?;
        for (i, family) in Family::ALL.into_iter().enumerate() {
            let sep = if i == 0 { "" } else { "," };
            write!(f, "{sep} {:?}", family.name())?;
        }
        f.write_str(")")
    }
}

impl std::error::Error for UnknownFamily {}

impl FromStr for Family {
    type Err = UnknownFamily;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Family::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| UnknownFamily(s.to_owned()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for f in Family::ALL {
            assert_eq!(f.name().parse::<Family>(), Ok(f));
        }
        let e = "canopen".parse::<Family>().unwrap_err();
        assert!(e.to_string().contains("\"canopen\""), "{e}");
        for f in Family::ALL {
            assert!(e.to_string().contains(&format!("{:?}", f.name())), "{e}");
        }
    }

    #[test]
    fn bought_families_put_two_drives_on_a_joint() {
        assert_eq!(Family::Anguilla.default_ids(2), [3, 3]);
        assert_eq!(Family::Cia402.default_ids(0), [1, 2]);
        assert_eq!(Family::Odrive.default_ids(30), [61, 62]);
        assert!(!Family::Anguilla.drive_per_axis());
        assert!(Family::Odrive.drive_per_axis());
    }

    #[test]
    fn node_of_inverts_each_familys_own_ids() {
        use crate::{canopen, message::Function, odrive};
        for node in 1..=63u8 {
            let id = Function::Command.id(node);
            assert_eq!(Family::Anguilla.node_of(id), Some(node));
            let hb = canopen::Function::Heartbeat(canopen::NodeId::new(node).unwrap());
            assert_eq!(Family::Cia402.node_of(hb.cob_id().as_raw()), Some(node));
            let id =
                odrive::arbitration_id(odrive::NodeId::new(node).unwrap(), odrive::Cmd::Heartbeat);
            assert_eq!(Family::Odrive.node_of(id.as_raw()), Some(node));
        }
        // Above anguilla's last function: no node.
        assert_eq!(Family::Anguilla.node_of(0x7FF), None);
    }

    /// Each family reads its own frames and says why another's is not
    /// one; only anguilla speaks CAN FD.
    #[test]
    fn each_family_decodes_its_own_frames() {
        let canopen_hb = Frame::new_standard(0x705, &[0x05]).unwrap();
        let odrive_hb = Frame::new_standard(3 << 5 | 0x01, &[0, 0, 0, 0, 8, 0, 0, 0]).unwrap();
        let shown = |f: Family, frame: &Frame| f.decode(frame, Variant::Classic);
        let m = shown(Family::Cia402, &canopen_hb).unwrap();
        assert!(format!("{m:?}").starts_with("Heartbeat"), "{m:?}");
        let m = shown(Family::Odrive, &odrive_hb).unwrap();
        assert!(format!("{m:?}").contains("Heartbeat"), "{m:?}");
        let e = shown(Family::Anguilla, &canopen_hb).unwrap_err();
        assert!(!e.is_empty());
        assert!(shown(Family::Odrive, &canopen_hb).is_err());
        let fd: Vec<_> = Family::ALL.into_iter().filter(|f| f.speaks_fd()).collect();
        assert_eq!(fd, [Family::Anguilla]);
        let sensor: Vec<_> = Family::ALL
            .into_iter()
            .filter(|f| f.carries_head_sensor())
            .collect();
        assert_eq!(sensor, [Family::Anguilla]);
    }
}
