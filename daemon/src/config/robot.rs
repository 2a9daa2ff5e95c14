//! `[robot]` and `[robot.axis]`: the body's actuators and their ids.

use serde::{Deserialize, Serialize};

use super::{Config, ConfigError, fmt_f, fmt_number, range};

/// `[robot] drive` as text: a [`Family`](anguilla_protocol::Family)'s name.
mod family_name {
    use anguilla_protocol::Family;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(f: &Family, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(f.name())
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Family, D::Error> {
        let name = String::deserialize(d)?;
        name.parse().map_err(serde::de::Error::custom)
    }
}

/// `[robot.axis]`: what every axis of a bought drive family has unless
/// its entry in `robot.axes` says otherwise.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct AxisDefaults {
    /// +1, or −1 when the motor turns the other way from the joint.
    pub direction: i8,
    /// The joint angle at motor position zero (rad).
    pub offset: f64,
    /// Motor turns per joint turn.
    pub gear: f64,
    /// CiA 402: position increments per motor turn.
    pub counts_per_turn: u32,
    /// CiA 402: the motor's rated torque (N·m), the unit of the torque
    /// objects; 0 reads it from the drive (0x6076).
    pub rated_torque: f64,
}

impl Default for AxisDefaults {
    fn default() -> Self {
        Self {
            direction: 1,
            offset: 0.0,
            gear: 1.0,
            counts_per_turn: 65536,
            rated_torque: 0.0,
        }
    }
}

/// One entry of `robot.axes`: one drive (bought families). Keys left out
/// take `[robot.axis]`'s value.
#[derive(Debug, Clone, PartialEq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct AxisConfig {
    /// The drive's node id (CiA 402: 1..=127, ODrive: 0..=63); default
    /// pitch 2j + 1, yaw 2j + 2 for joint j (0 = head end).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub node: Option<u8>,
    /// +1 or −1.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub direction: Option<i8>,
    /// Joint angle at motor zero (rad).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub offset: Option<f64>,
    /// Motor turns per joint turn.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gear: Option<f64>,
    /// CiA 402: increments per motor turn.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub counts_per_turn: Option<u32>,
    /// CiA 402: rated torque (N·m), 0 = read from the drive.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rated_torque: Option<f64>,
}

/// `[robot]`: the body's actuators.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct RobotConfig {
    /// Number of actuated joints (each a pitch and a yaw axis).
    pub joints: usize,
    /// The drives' protocol: `"anguilla"`, `"cia402"` or `"odrive"`.
    #[serde(with = "family_name")]
    pub drive: anguilla_protocol::Family,
    /// anguilla: node id of each joint from head to tail; empty means
    /// 1..=joints.
    pub node_ids: Vec<u8>,
    /// CiA 402: the master's own node id (its heartbeat is 0x700 + id).
    pub master_node_id: u8,
    /// CiA 402: the drives' EDS file, checked at start-up for every object
    /// the master uses (mappable where it maps them) and the bus's bit
    /// rate; empty: CiA 402's standard objects are taken as given.
    pub eds: String,
    /// Bought families: the axes, pitch then yaw for each joint from head
    /// to tail (2 × joints entries), or empty for every axis at its
    /// default id with `[robot.axis]`.
    pub axes: Vec<AxisConfig>,
    /// Bought families: every axis's defaults.
    pub axis: AxisDefaults,
}

impl Default for RobotConfig {
    fn default() -> Self {
        Self {
            joints: 12,
            drive: anguilla_protocol::Family::Anguilla,
            node_ids: Vec::new(),
            master_node_id: 127,
            eds: String::new(),
            axes: Vec::new(),
            axis: AxisDefaults::default(),
        }
    }
}

/// One axis of a bought drive, resolved ([`Config::axes`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisMap {
    /// Node id.
    pub node: u8,
    /// +1.0 or −1.0.
    pub direction: f64,
    /// Joint angle at motor zero (rad).
    pub offset: f64,
    /// Motor turns per joint turn.
    pub gear: f64,
    /// CiA 402 increments per motor turn.
    pub counts_per_turn: u32,
    /// CiA 402 rated torque (N·m); 0: read from the drive.
    pub rated_torque: f64,
}

impl Config {
    /// Each joint's two axes (bought families), pitch then yaw, with
    /// `[robot.axis]` filling what `robot.axes` leaves out.
    pub fn axes(&self) -> Vec<[AxisMap; 2]> {
        let d = &self.robot.axis;
        let family = self.robot.drive;
        (0..self.robot.joints)
            .map(|j| {
                let ids = family.default_ids(j);
                [0, 1].map(|a| {
                    let e = self.robot.axes.get(2 * j + a).cloned().unwrap_or_default();
                    AxisMap {
                        node: e.node.unwrap_or(ids[a]),
                        direction: e.direction.unwrap_or(d.direction) as f64,
                        offset: e.offset.unwrap_or(d.offset),
                        gear: e.gear.unwrap_or(d.gear),
                        counts_per_turn: e.counts_per_turn.unwrap_or(d.counts_per_turn),
                        rated_torque: e.rated_torque.unwrap_or(d.rated_torque),
                    }
                })
            })
            .collect()
    }

    /// The bought drives' node ids, `[pitch, yaw]` per joint (empty for
    /// anguilla, whose node carries both axes).
    pub fn axis_ids(&self) -> Vec<[u8; 2]> {
        if !self.robot.drive.drive_per_axis() {
            return Vec::new();
        }
        self.axes().iter().map(|p| [p[0].node, p[1].node]).collect()
    }

    /// The node id of each joint, head to tail (anguilla); for the bought
    /// families, each joint's report id 1..=joints.
    pub fn node_ids(&self) -> Vec<u8> {
        if self.robot.drive.drive_per_axis() {
            return (1..=self.robot.joints as u8).collect();
        }
        if self.robot.node_ids.is_empty() {
            (1..=self.robot.joints as u8).collect()
        } else {
            self.robot.node_ids.clone()
        }
    }

    /// Checks `[robot]`: the joints, their ids, and a bought family's
    /// axes (which read `[bus]`'s bit rate for an EDS).
    pub(super) fn validate_robot(&self) -> Result<(), ConfigError> {
        let r = &self.robot;
        range("robot.joints", r.joints as f64, 1.0, 32.0, "1 ..= 32")?;
        if !r.node_ids.is_empty() {
            if r.node_ids.len() != r.joints {
                return Err(ConfigError::Range {
                    key: "robot.node-ids",
                    value: format!("{} ids", r.node_ids.len()),
                    expected: "one id per joint (robot.joints of them), or none for 1..=joints",
                });
            }
            let mut seen = [false; 256];
            for &id in &r.node_ids {
                if !(1..=63).contains(&id) || seen[id as usize] {
                    return Err(ConfigError::Range {
                        key: "robot.node-ids",
                        value: format!("{:?}", r.node_ids),
                        expected: "distinct ids in 1 ..= 63",
                    });
                }
                seen[id as usize] = true;
            }
        }
        self.validate_axes()
    }

    fn validate_axes(&self) -> Result<(), ConfigError> {
        let r = &self.robot;
        let family = r.drive;
        if !family.drive_per_axis() {
            if !r.axes.is_empty() {
                return Err(ConfigError::Range {
                    key: "robot.axes",
                    value: format!("{} entries", r.axes.len()),
                    expected: "none with drive = \"anguilla\" (a node carries both axes; \
                               use robot.node-ids)",
                });
            }
            return Ok(());
        }
        if !r.node_ids.is_empty() {
            return Err(ConfigError::Range {
                key: "robot.node-ids",
                value: format!("{:?}", r.node_ids),
                expected: "[] with a bought drive family (give the drives' ids in robot.axes)",
            });
        }
        if !r.axes.is_empty() && r.axes.len() != 2 * r.joints {
            return Err(ConfigError::Range {
                key: "robot.axes",
                value: format!("{} entries", r.axes.len()),
                expected: "2 × robot.joints entries (pitch then yaw of each joint, head \
                           first), or none for the default ids",
            });
        }
        if !r.eds.is_empty() {
            if family != anguilla_protocol::Family::Cia402 {
                return Err(ConfigError::Range {
                    key: "robot.eds",
                    value: format!("{:?}", r.eds),
                    expected: "\"\" unless drive = \"cia402\" (an EDS describes a CANopen device)",
                });
            }
            use anguilla_protocol::canopen::eds;
            let text = std::fs::read_to_string(&r.eds).map_err(|source| ConfigError::Read {
                path: r.eds.clone(),
                source,
            })?;
            eds::Eds::parse(&text)
                .and_then(|e| eds::check_cia402(&e, self.bus.bitrate))
                .map_err(|e| ConfigError::Derived(format!("robot.eds = {:?}: {e}", r.eds)))?;
        }
        let (lo, hi) = family.id_range();
        let mut seen = [false; 256];
        if family == anguilla_protocol::Family::Cia402 {
            if !(1..=127).contains(&r.master_node_id) {
                return Err(ConfigError::Range {
                    key: "robot.master-node-id",
                    value: r.master_node_id.to_string(),
                    expected: "1 ..= 127",
                });
            }
            seen[r.master_node_id as usize] = true;
        }
        for (j, axes) in self.axes().iter().enumerate() {
            for a in axes {
                if a.node < lo || a.node > hi || seen[a.node as usize] {
                    return Err(ConfigError::Derived(format!(
                        "robot.axes: joint {} has drive id {}; {} drives take distinct ids in \
                         {lo}..={hi}{} (by default pitch 2j+1, yaw 2j+2 for joint j from 0: \
                         at most {} joints)",
                        j + 1,
                        a.node,
                        family,
                        if family == anguilla_protocol::Family::Cia402 {
                            ", other than robot.master-node-id"
                        } else {
                            ""
                        },
                        (hi as usize) / 2
                    )));
                }
                seen[a.node as usize] = true;
                if a.direction != 1.0 && a.direction != -1.0 {
                    return Err(ConfigError::Range {
                        key: "robot.axis.direction",
                        value: fmt_number(a.direction),
                        expected: "1 or -1",
                    });
                }
                range("robot.axis.offset", a.offset, -3.2, 3.2, "-3.2 ..= 3.2 rad")?;
                range("robot.axis.gear", a.gear, 1e-3, 1e4, "0.001 ..= 10000")?;
                range(
                    "robot.axis.counts-per-turn",
                    a.counts_per_turn as f64,
                    4.0,
                    (1u64 << 24) as f64,
                    "4 ..= 16777216",
                )?;
                if a.rated_torque != 0.0 {
                    range(
                        "robot.axis.rated-torque",
                        a.rated_torque,
                        1e-3,
                        1e4,
                        "0 (read from the drive) or 0.001 ..= 10000 N·m",
                    )?;
                }
            }
        }
        Ok(())
    }
}

/// `[robot]` and `[robot.axis]` in the commented default file ([`super::default_toml`]).
pub(super) fn write_default(d: &Config, w: &mut dyn FnMut(String)) {
    w("[robot]".into());
    w("# Actuated joints, head to tail (each: a pitch and a yaw axis on one node). 1..=32".into());
    w(format!("joints = {}", d.robot.joints));
    w("# The drives' protocol: \"anguilla\" (vertebra nodes, one per joint), \"cia402\"".into());
    w("# (CANopen CiA 402 drives) or \"odrive\" (ODrive CANSimple), one drive per axis.".into());
    w("drive = \"anguilla\"".into());
    w(
        "# anguilla: node id of each joint, head to tail; [] means 1..=joints. Distinct, 1..=63"
            .into(),
    );
    w("node-ids = []".into());
    w("# cia402: the master's node id (its heartbeat is 0x700 + id). 1..=127".into());
    w(format!("master-node-id = {}", d.robot.master_node_id));
    w("# cia402: the drives' EDS file, checked at start-up for every object the master".into());
    w("# uses and the bit rate; \"\": CiA 402's standard objects are taken as given.".into());
    w("eds = \"\"".into());
    w("# cia402/odrive: the drives, pitch then yaw of each joint from the head, e.g.".into());
    w("# [{ node = 1, direction = -1, gear = 50.0 }, { node = 2 }, ...] (2 × joints),".into());
    w("# keys left out from [robot.axis]; [] puts pitch on 2j+1, yaw on 2j+2 (j from 0).".into());
    w("axes = []".into());
    w(String::new());
    w("[robot.axis]".into());
    w("# Every bought drive's defaults: direction (1 or -1), offset (rad: joint angle at".into());
    w("# motor zero), gear (motor turns per joint turn); cia402: increments per motor".into());
    w("# turn and rated torque (N·m; 0 reads 0x6076 from the drive).".into());
    w(format!("direction = {}", d.robot.axis.direction));
    w(format!("offset = {}", fmt_f(d.robot.axis.offset)));
    w(format!("gear = {}", fmt_f(d.robot.axis.gear)));
    w(format!(
        "counts-per-turn = {}",
        d.robot.axis.counts_per_turn
    ));
    w(format!(
        "rated-torque = {}",
        fmt_f(d.robot.axis.rated_torque)
    ));
    w(String::new());
}
