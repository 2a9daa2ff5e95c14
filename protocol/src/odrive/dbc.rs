//! The DBC file of the CANSimple messages the codec implements.
//!
//! ODrive publishes a DBC for its own ids; a robot's axes have other ids,
//! and a DBC has no wildcard ids, so [`dbc`] writes one `BO_` per (axis,
//! message) for the axes given, named as ODrive's DBC names its `Axis0_*`
//! messages (`Axis7_Set_Input_Pos` is id `7 << 5 | 0x0C`), transmitted by
//! `Master` or by `ODrive_Axis<N>`.
//!
//! The codec in [`super`] places its fields in code, not from a table, so
//! the layout lives here once, in [`fields`], built from the codec's own
//! constants where it has them (command ids, names and lengths from
//! [`Cmd`], the feedforward scale [`FF_SCALE`] and range, the value tables
//! from the enums' `ALL`); the tests encode every message with the codec
//! and read each field back from the bytes through this table. Remote
//! frames (requests) are not described: a DBC has no notation for them.
//!
//! ```
//! use anguilla_protocol::odrive::{NodeId, dbc};
//! let text = dbc::dbc(&[NodeId::new(1)?, NodeId::new(2)?]);
//! assert!(text.contains("BO_ 44 Axis1_Set_Input_Pos: 8 Master"));
//! assert!(text.contains("SG_ Vel_FF : 32|16@1- (0.001,0) [-32.768|32.767] \"turns/s\" ODrive_Axis1"));
//! assert!(text.contains("SIG_VALTYPE_ 44 Input_Pos : 1;"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use core::fmt::{self, Write};

use super::{AxisState, Body, Cmd, ControlMode, FF_SCALE, InputMode, NodeId, arbitration_id};

/// Joints of the robot the committed `protocol/odrive.dbc` describes (the
/// default robot, as [`crate::dbc::DEFAULT_NODES`]).
pub const DEFAULT_JOINTS: usize = crate::dbc::DEFAULT_NODES as usize;

/// How a field's bits are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// An unsigned integer, `physical = raw × factor`.
    Unsigned,
    /// A two's complement integer, `physical = raw × factor`.
    Signed,
    /// An IEEE 754 single (`SIG_VALTYPE_ ... : 1`), 32 bits, factor 1.
    Float32,
}

/// Which value table labels a field.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Values {
    /// No value table.
    None,
    /// [`AxisState::ALL`].
    AxisState,
    /// [`ControlMode::ALL`].
    ControlMode,
    /// [`InputMode::ALL`].
    InputMode,
}

impl Values {
    /// (wire value, variant name) of every entry.
    pub fn entries(self) -> Vec<(u32, &'static str)> {
        match self {
            Values::None => Vec::new(),
            Values::AxisState => AxisState::ALL.iter().map(|v| (v.raw(), v.name())).collect(),
            Values::ControlMode => ControlMode::ALL
                .iter()
                .map(|v| (v.raw(), v.name()))
                .collect(),
            Values::InputMode => InputMode::ALL.iter().map(|v| (v.raw(), v.name())).collect(),
        }
    }
}

/// One signal of a CANSimple message: where it is and how it reads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Field {
    /// Signal name, as in ODrive's DBC.
    pub name: &'static str,
    /// Least significant bit, Intel numbering (bit `b` of byte `k` = `8k + b`).
    pub start: u16,
    /// Number of bits.
    pub len: u8,
    /// How the bits read.
    pub encoding: Encoding,
    /// Physical units per raw count (1 for floats).
    pub factor: f32,
    /// Documented range of the raw value (`None` for floats: the DBC
    /// writes `[0|0]`, open).
    pub raw_range: Option<(i64, i64)>,
    /// Unit (empty for enumerations, flags and counters).
    pub unit: &'static str,
    /// The value table labelling it.
    pub values: Values,
    /// One-line meaning (the DBC comment).
    pub comment: &'static str,
}

impl Field {
    const fn uint(name: &'static str, start: u16, len: u8, comment: &'static str) -> Self {
        Field {
            name,
            start,
            len,
            encoding: Encoding::Unsigned,
            factor: 1.0,
            raw_range: Some((0, (1i64 << len) - 1)),
            unit: "",
            values: Values::None,
            comment,
        }
    }

    const fn labelled(mut self, values: Values, count: usize) -> Self {
        self.values = values;
        self.raw_range = Some((0, count as i64 - 1));
        self
    }

    const fn float(
        name: &'static str,
        start: u16,
        unit: &'static str,
        comment: &'static str,
    ) -> Self {
        Field {
            name,
            start,
            len: 32,
            encoding: Encoding::Float32,
            factor: 1.0,
            raw_range: None,
            unit,
            values: Values::None,
            comment,
        }
    }

    const fn feedforward(
        name: &'static str,
        start: u16,
        unit: &'static str,
        comment: &'static str,
    ) -> Self {
        Field {
            name,
            start,
            len: 16,
            encoding: Encoding::Signed,
            factor: FF_SCALE,
            // FF_MIN..=FF_MAX.
            raw_range: Some((i16::MIN as i64, i16::MAX as i64)),
            unit,
            values: Values::None,
            comment,
        }
    }

    /// The raw bits of this field in `data` (which must cover them),
    /// sign-extended for [`Encoding::Signed`].
    pub fn raw(&self, data: &[u8]) -> i64 {
        let mut bits: u64 = 0;
        for i in 0..self.len as usize {
            let pos = self.start as usize + i;
            bits |= (((data[pos / 8] >> (pos % 8)) & 1) as u64) << i;
        }
        if self.encoding == Encoding::Signed && (bits >> (self.len - 1)) & 1 == 1 {
            (bits | (!0u64 << self.len)) as i64
        } else {
            bits as i64
        }
    }

    /// The physical value a DBC reader computes from `data`: the float
    /// itself, or `raw × factor` in f64 (as cantools does).
    pub fn physical(&self, data: &[u8]) -> f64 {
        let raw = self.raw(data);
        match self.encoding {
            Encoding::Float32 => f32::from_bits(raw as u32) as f64,
            _ => raw as f64 * dbc_factor(self.factor),
        }
    }

    /// The DBC's `[min|max]`: the raw range times the factor, `[0|0]`
    /// for a float.
    pub fn physical_range(&self) -> (f64, f64) {
        match self.raw_range {
            Some((lo, hi)) => {
                let k = dbc_factor(self.factor);
                (lo as f64 * k, hi as f64 * k)
            }
            None => (0.0, 0.0),
        }
    }
}

/// A factor as the DBC text writes it (`0.001`, not the f32's binary
/// value 0.0010000000474974513).
fn dbc_factor(factor: f32) -> f64 {
    factor
        .to_string()
        .parse()
        .expect("an f32 prints as a number")
}

const HEARTBEAT: &[Field] = &[
    Field::uint(
        "Axis_Error",
        0,
        32,
        "Active ODriveError bits (0x01000000 WATCHDOG_TIMER_EXPIRED, 0x02000000 ESTOP_REQUESTED, ...)",
    ),
    Field::uint("Axis_State", 32, 8, "Current axis state")
        .labelled(Values::AxisState, AxisState::ALL.len()),
    Field::uint(
        "Procedure_Result",
        40,
        8,
        "Result of the last procedure (0 SUCCESS, 1 BUSY, ...)",
    ),
    Field::uint(
        "Trajectory_Done_Flag",
        48,
        1,
        "1 when the trapezoidal trajectory is done",
    ),
];
const SET_AXIS_STATE: &[Field] =
    &[
        Field::uint("Axis_Requested_State", 0, 32, "Requested axis state")
            .labelled(Values::AxisState, AxisState::ALL.len()),
    ];
const ENCODER_ESTIMATES: &[Field] = &[
    Field::float("Pos_Estimate", 0, "turns", "Position estimate"),
    Field::float("Vel_Estimate", 32, "turns/s", "Velocity estimate"),
];
const SET_CONTROLLER_MODE: &[Field] = &[
    Field::uint("Control_Mode", 0, 32, "Control mode")
        .labelled(Values::ControlMode, ControlMode::ALL.len()),
    Field::uint("Input_Mode", 32, 32, "Input mode")
        .labelled(Values::InputMode, InputMode::ALL.len()),
];
const SET_INPUT_POS: &[Field] = &[
    Field::float("Input_Pos", 0, "turns", "Position setpoint"),
    Field::feedforward("Vel_FF", 32, "turns/s", "Velocity feedforward"),
    Field::feedforward("Torque_FF", 48, "Nm", "Torque feedforward"),
];
const CLEAR_ERRORS: &[Field] = &[Field {
    raw_range: Some((0, 1)),
    ..Field::uint("Identify", 0, 8, "1: also blink the LED")
}];

/// The signals of a message, in bit order.
pub const fn fields(cmd: Cmd) -> &'static [Field] {
    match cmd {
        Cmd::Heartbeat => HEARTBEAT,
        Cmd::Estop => &[],
        Cmd::SetAxisState => SET_AXIS_STATE,
        Cmd::GetEncoderEstimates => ENCODER_ESTIMATES,
        Cmd::SetControllerMode => SET_CONTROLLER_MODE,
        Cmd::SetInputPos => SET_INPUT_POS,
        Cmd::ClearErrors => CLEAR_ERRORS,
    }
}

/// A signal's value as the codec holds it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    /// An integer, enumeration or flag (its wire value).
    Int(u32),
    /// A float field or a scaled count (the codec's f32).
    F32(f32),
}

/// The codec's value of every signal of a data-frame `body`, named as in
/// [`fields`] and in the same order; `None` for a request.
pub fn values(body: &Body) -> Option<Vec<(&'static str, Value)>> {
    use Value::{F32, Int};
    Some(match *body {
        Body::Heartbeat(h) => vec![
            ("Axis_Error", Int(h.axis_error)),
            ("Axis_State", Int(h.axis_state.raw())),
            ("Procedure_Result", Int(h.procedure_result as u32)),
            ("Trajectory_Done_Flag", Int(h.trajectory_done as u32)),
        ],
        Body::Estop => Vec::new(),
        Body::SetAxisState(s) => vec![("Axis_Requested_State", Int(s.raw()))],
        Body::EncoderEstimates(e) => {
            vec![("Pos_Estimate", F32(e.pos)), ("Vel_Estimate", F32(e.vel))]
        }
        Body::SetControllerMode {
            control_mode,
            input_mode,
        } => vec![
            ("Control_Mode", Int(control_mode.raw())),
            ("Input_Mode", Int(input_mode.raw())),
        ],
        Body::SetInputPos(p) => vec![
            ("Input_Pos", F32(p.input_pos)),
            ("Vel_FF", F32(p.vel_ff)),
            ("Torque_FF", F32(p.torque_ff)),
        ],
        Body::ClearErrors { identify } => vec![("Identify", Int(identify as u32))],
        Body::Request(_) => return None,
    })
}

/// `Axis<N>_<message>`, the message's name in the DBC.
pub fn message_name(node: NodeId, cmd: Cmd) -> String {
    format!("Axis{}_{}", node.get(), cmd.name())
}

const MASTER: &str = "Master";

/// The DBC text for these axes (written in ascending id order, each once).
pub fn dbc(nodes: &[NodeId]) -> String {
    let mut s = String::new();
    write_dbc(&mut s, nodes).expect("writing to a String cannot fail");
    s
}

/// `ODrive_Axis<N>`, the axis's node in the DBC.
struct Axis(NodeId);

impl fmt::Display for Axis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ODrive_Axis{}", self.0.get())
    }
}

/// Whether the host sends this message (else the drive does).
const fn from_master(cmd: Cmd) -> bool {
    !matches!(cmd, Cmd::Heartbeat | Cmd::GetEncoderEstimates)
}

/// `CLOSED_LOOP_CONTROL` from `ClosedLoopControl`: ODrive's spelling.
fn screaming_snake(name: &str) -> String {
    let mut out = String::with_capacity(name.len() + 4);
    for (i, c) in name.chars().enumerate() {
        if c.is_ascii_uppercase() && i > 0 {
            out.push('_');
        }
        out.push(c.to_ascii_uppercase());
    }
    out
}

fn sorted(nodes: &[NodeId]) -> Vec<NodeId> {
    let mut v = nodes.to_vec();
    v.sort();
    v.dedup();
    v
}

/// Writes the DBC text for these axes.
pub fn write_dbc(out: &mut impl Write, nodes: &[NodeId]) -> fmt::Result {
    let nodes = sorted(nodes);
    writeln!(out, "VERSION \"anguilla {}\"", env!("CARGO_PKG_VERSION"))?;
    out.write_str(
        "\n\nNS_ :\n    CM_\n    BA_DEF_\n    BA_\n    VAL_\n    BA_DEF_DEF_\n    SIG_VALTYPE_\n\nBS_:\n\n",
    )?;
    write!(out, "BU_: {MASTER}")?;
    for &n in &nodes {
        write!(out, " {}", Axis(n))?;
    }
    out.write_str("\n\n")?;
    let each = |out: &mut dyn FnMut(NodeId, Cmd, u16) -> fmt::Result| -> fmt::Result {
        for &n in &nodes {
            for cmd in Cmd::ALL {
                out(n, cmd, arbitration_id(n, cmd).as_raw())?;
            }
        }
        Ok(())
    };
    each(&mut |n, cmd, id| {
        let (tx, rx) = if from_master(cmd) {
            (MASTER.to_string(), Axis(n).to_string())
        } else {
            (Axis(n).to_string(), MASTER.to_string())
        };
        writeln!(
            out,
            "BO_ {id} {}: {} {tx}",
            message_name(n, cmd),
            cmd.dbc_len()
        )?;
        for f in fields(cmd) {
            let sign = if f.encoding == Encoding::Unsigned {
                '+'
            } else {
                '-'
            };
            let (min, max) = f.physical_range();
            writeln!(
                out,
                " SG_ {} : {}|{}@1{sign} ({},0) [{min}|{max}] \"{}\" {rx}",
                f.name, f.start, f.len, f.factor, f.unit
            )?;
        }
        out.write_char('\n')
    })?;
    let ids: Vec<String> = nodes.iter().map(|n| n.get().to_string()).collect();
    writeln!(
        out,
        "CM_ \"ODrive CANSimple (firmware 0.6.10 layouts), the messages anguilla uses, axes {}. Generated by `anguilla protocol dbc --drive odrive`; do not edit. Heartbeat and Get_Encoder_Estimates are also requested by a remote frame on their id, which a DBC cannot describe.\";",
        ids.join(",")
    )?;
    each(&mut |_, cmd, id| {
        let (dir, period) = match cmd {
            Cmd::Heartbeat => (
                "drive to host",
                ", cyclic every heartbeat_msg_rate_ms (ODrive default 100 ms)",
            ),
            Cmd::GetEncoderEstimates => (
                "drive to host",
                ", cyclic every encoder_msg_rate_ms (ODrive default 10 ms)",
            ),
            _ => ("host to drive", ""),
        };
        writeln!(
            out,
            "CM_ BO_ {id} \"{} (0x{:02X}), {dir}{period}\";",
            cmd.name(),
            cmd.id()
        )?;
        for f in fields(cmd) {
            writeln!(out, "CM_ SG_ {id} {} \"{}\";", f.name, f.comment)?;
        }
        Ok(())
    })?;
    out.write_str("BA_DEF_ \"BusType\" STRING ;\n")?;
    out.write_str("BA_DEF_DEF_ \"BusType\" \"\";\n")?;
    out.write_str("BA_ \"BusType\" \"CAN\";\n")?;
    each(&mut |_, cmd, id| {
        for f in fields(cmd).iter().filter(|f| f.values != Values::None) {
            write!(out, "VAL_ {id} {}", f.name)?;
            for (v, name) in f.values.entries() {
                write!(out, " {v} \"{}\"", screaming_snake(name))?;
            }
            out.write_str(" ;\n")?;
        }
        Ok(())
    })?;
    each(&mut |_, cmd, id| {
        for f in fields(cmd)
            .iter()
            .filter(|f| f.encoding == Encoding::Float32)
        {
            writeln!(out, "SIG_VALTYPE_ {id} {} : 1;", f.name)?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::super::{EncoderEstimates, Heartbeat, InputPos, Message, decode, ff_value};
    use super::*;
    use crate::family::Family;

    /// The axes of the committed `protocol/odrive.dbc`: the default drive ids
    /// of [`DEFAULT_JOINTS`] joints (`Family::default_ids`: 1..=24).
    fn default_nodes() -> Vec<NodeId> {
        (0..DEFAULT_JOINTS)
            .flat_map(|j| Family::Odrive.default_ids(j))
            .map(|id| NodeId::new(id).expect("default ids are 6-bit"))
            .collect()
    }

    /// One message of every command, with distinctive values (negative
    /// feedforwards, high error bits, the last enum values).
    fn samples() -> Vec<Body> {
        vec![
            Body::Heartbeat(Heartbeat {
                axis_error: 0x8300_0041,
                axis_state: AxisState::AnticoggingCalibration,
                procedure_result: 0xA5,
                trajectory_done: true,
            }),
            Body::Estop,
            Body::SetAxisState(AxisState::ClosedLoopControl),
            Body::EncoderEstimates(EncoderEstimates {
                pos: -1234.567,
                vel: 3.3e-5,
            }),
            Body::SetControllerMode {
                control_mode: ControlMode::PositionControl,
                input_mode: InputMode::Tuning,
            },
            Body::SetInputPos(InputPos {
                input_pos: 0.1,
                vel_ff: -32.768,
                torque_ff: -0.001,
            }),
            Body::SetInputPos(InputPos {
                input_pos: -7.25,
                vel_ff: 32.767,
                torque_ff: 1.234,
            }),
            Body::ClearErrors { identify: true },
        ]
    }

    /// Every field read back from the codec's bytes through the table is
    /// the codec's own value: integers exactly, floats bit for bit, and a
    /// scaled count's `raw × 0.001` (what a DBC reader computes in f64)
    /// rounds to the codec's f32.
    #[test]
    fn the_table_reads_the_codecs_bytes() {
        let mut seen = std::collections::HashSet::new();
        for body in samples() {
            let m = Message {
                node: NodeId::new(5).unwrap(),
                body,
            };
            let frame = m.encode().unwrap();
            let data = frame.data();
            let cmd = body.cmd();
            seen.insert(cmd);
            assert_eq!(data.len(), cmd.dbc_len() as usize);
            let table = fields(cmd);
            let vals = values(&decode(&frame).unwrap().body).unwrap();
            assert_eq!(
                table.iter().map(|f| f.name).collect::<Vec<_>>(),
                vals.iter().map(|(n, _)| *n).collect::<Vec<_>>(),
                "{cmd:?}: table and codec name different signals"
            );
            for (f, (_, v)) in table.iter().zip(vals) {
                let got = f.physical(data);
                match v {
                    Value::Int(i) => assert_eq!(got, i as f64, "{}", f.name),
                    Value::F32(x) if f.encoding == Encoding::Float32 => {
                        assert_eq!(f.raw(data) as u32, x.to_bits(), "{}", f.name)
                    }
                    Value::F32(x) => assert_eq!(got as f32, x, "{}", f.name),
                }
                if let Some((lo, hi)) = f.raw_range {
                    assert!((lo..=hi).contains(&f.raw(data)), "{}", f.name);
                }
            }
            // The fields lie inside the frame and do not overlap, and every
            // bit the codec set is some field's.
            let mut covered = vec![0u8; data.len()];
            for f in table {
                assert!((f.start as usize + f.len as usize) <= data.len() * 8);
                for b in f.start..f.start + f.len as u16 {
                    let (k, i) = (b as usize / 8, b % 8);
                    assert_eq!(covered[k] >> i & 1, 0, "{} overlaps", f.name);
                    covered[k] |= 1 << i;
                }
            }
            for (k, (&d, &c)) in data.iter().zip(&covered).enumerate() {
                assert_eq!(d & !c, 0, "{cmd:?}: byte {k} has bits outside the fields");
            }
        }
        assert_eq!(seen.len(), Cmd::ALL.len(), "a command has no sample");
    }

    /// The claim the sample JSON rests on: for every i16 count, the codec's
    /// feedforward is the f32 nearest to the f64 `count × 0.001`.
    #[test]
    fn every_feedforward_count_is_the_nearest_f32() {
        for c in i16::MIN..=i16::MAX {
            assert_eq!(ff_value(c), (c as f64 * 0.001) as f32, "{c}");
        }
        assert_eq!(dbc_factor(FF_SCALE), 0.001);
    }

    #[test]
    fn committed_dbc_is_the_generated_one() {
        // If this fails after a codec change, regenerate with
        // `cargo run -- protocol dbc --drive odrive --out protocol/odrive.dbc`
        // and review the diff.
        assert!(
            include_str!("../../odrive.dbc") == dbc(&default_nodes()),
            "protocol/odrive.dbc is stale"
        );
        let ids: Vec<u8> = default_nodes().iter().map(|n| n.get()).collect();
        assert_eq!(ids, (1..=24).collect::<Vec<_>>());
    }

    #[test]
    fn one_message_per_axis_and_command_with_unique_ids() {
        let all: Vec<NodeId> = (0..=63).map(|n| NodeId::new(n).unwrap()).collect();
        let text = dbc(&all);
        let mut seen = std::collections::HashSet::new();
        for line in text.lines().filter(|l| l.starts_with("BO_ ")) {
            let id: u16 = line.split_whitespace().nth(1).unwrap().parse().unwrap();
            assert!(id <= 0x7FF && seen.insert(id), "id {id}");
        }
        assert_eq!(seen.len(), 64 * Cmd::ALL.len());
        // Duplicates and order do not matter.
        let n = |i| NodeId::new(i).unwrap();
        assert_eq!(dbc(&[n(3), n(1), n(3)]), dbc(&[n(1), n(3)]));
    }

    #[test]
    fn value_tables_come_from_the_enums() {
        let text = dbc(&[NodeId::new(2).unwrap()]);
        assert!(text.contains(
            "VAL_ 75 Input_Mode 0 \"INACTIVE\" 1 \"PASSTHROUGH\" 2 \"VEL_RAMP\" 3 \"POS_FILTER\" 4 \"MIX_CHANNELS\" 5 \"TRAP_TRAJ\" 6 \"TORQUE_RAMP\" 7 \"MIRROR\" 8 \"TUNING\" ;"
        ));
        assert!(text.contains(" 8 \"CLOSED_LOOP_CONTROL\" "));
        assert!(text.contains("VAL_ 65 Axis_State 0 \"UNDEFINED\""));
        assert!(text.contains("VAL_ 71 Axis_Requested_State 0 \"UNDEFINED\""));
        assert!(text.contains("BO_ 65 Axis2_Heartbeat: 8 ODrive_Axis2"));
        assert!(text.contains("BO_ 88 Axis2_Clear_Errors: 1 Master"));
        assert!(text.contains("BO_ 66 Axis2_Estop: 0 Master"));
    }
}
