//! `[robot]` and `[robot.axis]`: the body's actuators and their ids.

use serde::{Deserialize, Serialize};

use super::error::fmt_f;

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
    /// The drives' protocol: one of [`anguilla_protocol::Family::ALL`]'s
    /// names.
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

/// One axis of a bought drive, resolved ([`Config::axes`](super::Config::axes)).
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

/// `[robot]` and `[robot.axis]` in the commented default file ([`super::sections_toml`]).
pub(super) fn write_default(d: &RobotConfig, w: &mut dyn FnMut(String)) {
    w("[robot]".into());
    w("# Actuated joints, head to tail (each: a pitch and a yaw axis on one node). 1..=32".into());
    w(format!("joints = {}", d.joints));
    w("# The drives' protocol, one of:".into());
    for f in anguilla_protocol::Family::ALL {
        w(format!(
            "#   {:<10} {}",
            format!("{:?}", f.name()),
            f.description()
        ));
    }
    w("drive = \"anguilla\"".into());
    w(
        "# anguilla: node id of each joint, head to tail; [] means 1..=joints. Distinct, 1..=63"
            .into(),
    );
    w("node-ids = []".into());
    w("# cia402: the master's node id (its heartbeat is 0x700 + id). 1..=127".into());
    w(format!("master-node-id = {}", d.master_node_id));
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
    w(format!("direction = {}", d.axis.direction));
    w(format!("offset = {}", fmt_f(d.axis.offset)));
    w(format!("gear = {}", fmt_f(d.axis.gear)));
    w(format!("counts-per-turn = {}", d.axis.counts_per_turn));
    w(format!("rated-torque = {}", fmt_f(d.axis.rated_torque)));
    w(String::new());
}
