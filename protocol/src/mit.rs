//! MIT-mode quasi-direct-drive actuators: the CAN protocol of Ben Katz's
//! Mini Cheetah motor controller, spoken by CubeMars AK and T-Motor
//! actuators and their many clones (`MIT mode`, firmware manuals' "MIT
//! mode communication protocol"). A bought drive family beside anguilla's
//! own [`crate::message`], one drive per axis.
//!
//! Every command goes to the drive's id; every drive answers each frame
//! it takes with a reply on the master's id ([`MASTER_ID`], 0), its own id
//! in the first byte. Fields are unsigned integers spread linearly over a
//! range the firmware fixes per motor model ([`Ranges`]), big-endian and
//! packed on nibble boundaries:
//!
//! | id        | message          | dir          | bytes | layout (bits, most significant first)                        |
//! |-----------|------------------|--------------|-------|--------------------------------------------------------------|
//! | drive     | Enter motor mode | host → drive | 8     | `FF FF FF FF FF FF FF FC`                                    |
//! | drive     | Exit motor mode  | host → drive | 8     | `FF FF FF FF FF FF FF FD`                                    |
//! | drive     | Set zero         | host → drive | 8     | `FF FF FF FF FF FF FF FE`                                    |
//! | drive     | Command          | host → drive | 8     | position 16, velocity 12, kp 12, kd 12, torque 12            |
//! | 0 (master)| Reply            | drive → host | 6 / 8 | id 8, position 16, velocity 12, torque 12 [, temperature 8, error 8] |
//!
//! The drive applies `torque + kp (position − θ) + kd (velocity − ω)` at
//! its output until the next command. In motor mode it takes commands; out
//! of it (after power-on or Exit) it is limp and still replies. The
//! protocol has no heartbeat, no state and no E-stop: a drive is alive
//! while it replies, its mode is what the master last asked, and an E-stop
//! is Exit motor mode. The reply's third field is what the firmware
//! measures as current, scaled to torque at the output over the command's
//! torque range (Ben Katz's firmware sends `i_q × KT`; CubeMars' manual
//! calls it current); CubeMars' 8-byte reply adds the driver's temperature
//! (°C, signed) and an error code ([`error_code`]), which the 6-byte reply
//! of the original firmware lacks.
//!
//! A command whose fields pack to one of the three special patterns
//! (every field at its maximum) would be read as that special command by
//! the drive: encoding refuses it ([`EncodeError::Reserved`]). Encoding
//! also refuses non-finite and out-of-range values, naming the field;
//! values are rounded to the nearest count (the original firmware
//! truncates). Decoding refuses extended ids, CAN FD and remote frames,
//! ids above [`MAX_NODE_ID`], wrong lengths and replies naming no drive.
//!
//! ```
//! use anguilla_protocol::mit::{decode, Body, Command, Message, NodeId, DEFAULT_RANGES};
//! let m = Message {
//!     node: NodeId::new(1)?,
//!     body: Body::Command(Command { position: 0.0, velocity: 0.0, kp: 0.0, kd: 0.0, torque: 0.0 }),
//! };
//! let f = m.encode(&DEFAULT_RANGES)?;
//! // Zero is mid-range for the signed fields (half a count above it: an
//! // odd number of counts has no middle), the bottom for the gains.
//! assert_eq!(f.to_string(), "001#8000800000000800");
//! let Body::Command(c) = decode(&f, &DEFAULT_RANGES)?.body else { unreachable!() };
//! assert!(c.position.abs() < 25.0 / 65535.0 && c.kp == 0.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use core::fmt::{self, Write};

use crate::budget::{BudgetLine, Cadence};
use crate::frame::{Frame, Kind};

/// The largest drive id (the firmware's CAN id, 7 bits; 0 is the master's).
pub const MAX_NODE_ID: u8 = 0x7F;
/// The id every reply is sent on (the firmware's `CAN_MASTER`, 0 by default).
pub const MASTER_ID: u16 = 0;

/// The last byte of the special commands, after seven `0xFF`.
const ENTER: u8 = 0xFC;
const EXIT: u8 = 0xFD;
const ZERO: u8 = 0xFE;

/// CubeMars' error codes in the 8-byte reply (0: none).
pub mod error_code {
    /// Motor over-temperature.
    pub const OVER_TEMPERATURE: u8 = 1;
    /// Over-current.
    pub const OVER_CURRENT: u8 = 2;
    /// Over-voltage.
    pub const OVER_VOLTAGE: u8 = 3;
    /// Under-voltage.
    pub const UNDER_VOLTAGE: u8 = 4;
    /// Encoder fault.
    pub const ENCODER: u8 = 5;
    /// Phase current unbalance (a hardware fault).
    pub const PHASE_UNBALANCE: u8 = 6;
}

/// A drive id, 1..=[`MAX_NODE_ID`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct NodeId(u8);

impl NodeId {
    /// `raw` if it is a drive id.
    pub const fn new(raw: u8) -> Result<Self, EncodeError> {
        if raw >= 1 && raw <= MAX_NODE_ID {
            Ok(NodeId(raw))
        } else {
            Err(EncodeError::NodeOutOfRange(raw))
        }
    }

    /// The id.
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// The ranges a motor model's firmware spreads the fields over: position
/// ±`position` rad, velocity ±`velocity` rad/s, torque ±`torque` N·m (at
/// the actuator's output), gains 0..=`kp` N·m/rad and 0..=`kd` N·m·s/rad.
/// Master and drive must agree; they differ between models (AK80-6,
/// AK10-9, ...), and the vendor's manual gives them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ranges {
    /// Largest |position|, rad.
    pub position: f32,
    /// Largest |velocity|, rad/s.
    pub velocity: f32,
    /// Largest kp, N·m/rad.
    pub kp: f32,
    /// Largest kd, N·m·s/rad.
    pub kd: f32,
    /// Largest |torque|, N·m.
    pub torque: f32,
}

/// The Mini Cheetah controller's ranges (P ±12.5 rad, V ±65 rad/s, KP
/// 0..=500, KD 0..=5, T ±18 N·m), which anguilla's master and simulated
/// drives use.
pub const DEFAULT_RANGES: Ranges = Ranges {
    position: 12.5,
    velocity: 65.0,
    kp: 500.0,
    kd: 5.0,
    torque: 18.0,
};

/// The fields of a command and a reply: name, bits, and where its range
/// comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Field {
    Position,
    Velocity,
    Kp,
    Kd,
    Torque,
}

impl Field {
    const fn name(self) -> &'static str {
        match self {
            Field::Position => "position",
            Field::Velocity => "velocity",
            Field::Kp => "kp",
            Field::Kd => "kd",
            Field::Torque => "torque",
        }
    }

    const fn bits(self) -> u32 {
        match self {
            Field::Position => 16,
            Field::Velocity | Field::Kp | Field::Kd | Field::Torque => 12,
        }
    }

    /// `(min, max)` of the field under `r`.
    fn range(self, r: &Ranges) -> (f32, f32) {
        match self {
            Field::Position => (-r.position, r.position),
            Field::Velocity => (-r.velocity, r.velocity),
            Field::Kp => (0.0, r.kp),
            Field::Kd => (0.0, r.kd),
            Field::Torque => (-r.torque, r.torque),
        }
    }

    const fn unit(self) -> &'static str {
        match self {
            Field::Position => "rad",
            Field::Velocity => "rad/s",
            Field::Kp => "Nm/rad",
            Field::Kd => "Nms/rad",
            Field::Torque => "Nm",
        }
    }
}

impl Ranges {
    /// Checks that every range is finite and above zero.
    pub fn validate(&self) -> Result<(), String> {
        for f in [
            Field::Position,
            Field::Velocity,
            Field::Kp,
            Field::Kd,
            Field::Torque,
        ] {
            let (_, max) = f.range(self);
            if !(max.is_finite() && max > 0.0) {
                return Err(format!(
                    "MIT {} range {max} (expected a finite number above 0)",
                    f.name()
                ));
            }
        }
        Ok(())
    }

    /// The count of `x` in field `f` (checked: finite, in range).
    fn count(&self, f: Field, message: &'static str, x: f32) -> Result<u16, EncodeError> {
        let (min, max) = f.range(self);
        if !x.is_finite() {
            return Err(EncodeError::NotFinite {
                message,
                field: f.name(),
                value: x,
            });
        }
        if !(min..=max).contains(&x) {
            return Err(EncodeError::OutOfRange {
                message,
                field: f.name(),
                value: x,
                min,
                max,
            });
        }
        let top = ((1u32 << f.bits()) - 1) as f32;
        Ok(((x - min) * top / (max - min)).round().clamp(0.0, top) as u16)
    }

    /// The value of count `raw` in field `f`.
    fn value(&self, f: Field, raw: u16) -> f32 {
        let (min, max) = f.range(self);
        let top = ((1u32 << f.bits()) - 1) as f32;
        min + raw as f32 * (max - min) / top
    }

    /// The DBC `(factor, offset)` of field `f` (in f64, as a reader
    /// computes `raw × factor + offset`).
    fn dbc_scale(&self, f: Field) -> (f64, f64) {
        let (min, max) = f.range(self);
        let top = ((1u32 << f.bits()) - 1) as f64;
        ((f64::from(max) - f64::from(min)) / top, f64::from(min))
    }
}

/// A command: where to hold the output and how stiffly, and what torque to
/// add.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    /// Position setpoint, rad.
    pub position: f32,
    /// Velocity setpoint, rad/s.
    pub velocity: f32,
    /// Position gain, N·m/rad.
    pub kp: f32,
    /// Velocity gain, N·m·s/rad.
    pub kd: f32,
    /// Feed-forward torque, N·m.
    pub torque: f32,
}

/// CubeMars' additions to the reply (bytes 6 and 7).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Status {
    /// Driver temperature, °C.
    pub temperature: i8,
    /// Error code ([`error_code`]; 0: none).
    pub error: u8,
}

/// A drive's reply to any frame it took.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reply {
    /// Output position, rad.
    pub position: f32,
    /// Output velocity, rad/s.
    pub velocity: f32,
    /// Output torque (measured current × torque constant), N·m.
    pub torque: f32,
    /// Temperature and error code (8-byte reply), or none (6 bytes).
    pub status: Option<Status>,
}

/// What a frame says.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Body {
    /// Enter motor mode: take commands (the drive starts limp, zero gains).
    EnterMotorMode,
    /// Exit motor mode: limp (anguilla's E-stop and disable).
    ExitMotorMode,
    /// Make the present position the zero (stored by CubeMars firmware).
    SetZero,
    /// A command.
    Command(Command),
    /// A drive's reply.
    Reply(Reply),
}

impl Body {
    /// The message's name, as in the DBC and errors.
    pub const fn name(&self) -> &'static str {
        match self {
            Body::EnterMotorMode => "EnterMotorMode",
            Body::ExitMotorMode => "ExitMotorMode",
            Body::SetZero => "SetZero",
            Body::Command(_) => "Command",
            Body::Reply(_) => "Reply",
        }
    }

    /// Whether the host sends it.
    pub const fn from_master(&self) -> bool {
        !matches!(self, Body::Reply(_))
    }
}

/// One MIT-mode message: to or from drive `node`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Message {
    /// The drive.
    pub node: NodeId,
    /// What it says.
    pub body: Body,
}

/// What was wrong with a message being encoded.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum EncodeError {
    /// A drive id outside 1..=127.
    #[error("MIT drive id {0} is out of range (expected 1..=127)")]
    NodeOutOfRange(u8),
    /// A field that is NaN or infinite.
    #[error("MIT {message}.{field} is {value} (expected a finite number)")]
    NotFinite {
        /// Message name.
        message: &'static str,
        /// Field name.
        field: &'static str,
        /// The value given.
        value: f32,
    },
    /// A field outside its range.
    #[error("MIT {message}.{field} {value} is outside the drive's range (expected {min}..={max})")]
    OutOfRange {
        /// Message name.
        message: &'static str,
        /// Field name.
        field: &'static str,
        /// The value given.
        value: f32,
        /// Smallest value.
        min: f32,
        /// Largest value.
        max: f32,
    },
    /// A command that packs to a special command's bytes.
    #[error(
        "MIT command packs to the bytes of a special command (every field at its maximum; \
         expected at least one field below it)"
    )]
    Reserved,
}

/// What was wrong with a received frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// A 29-bit identifier.
    #[error("extended id 0x{0:08X} (expected an 11-bit MIT-mode id)")]
    ExtendedId(u32),
    /// A CAN FD frame.
    #[error("CAN FD frame on id 0x{0:03X} (expected a classic frame)")]
    FdFrame(u16),
    /// A remote frame.
    #[error("remote frame on id 0x{0:03X} (expected a data frame)")]
    Remote(u16),
    /// An id above the drives' (and not the master's).
    #[error("id 0x{0:03X} (expected 0x000 for a reply or a drive id 0x001..=0x07F)")]
    UnknownId(u16),
    /// A frame of the wrong length.
    #[error("{message} of {len} bytes on id 0x{id:03X} (expected {expected})")]
    Length {
        /// Message name.
        message: &'static str,
        /// The frame's id.
        id: u16,
        /// Length seen.
        len: u8,
        /// Lengths accepted.
        expected: &'static str,
    },
    /// A reply whose first byte is no drive id.
    #[error("reply from drive id {0} (expected 1..=127)")]
    ReplyNode(u8),
}

impl Message {
    /// The frame, fields counted over `r`.
    pub fn encode(&self, r: &Ranges) -> Result<Frame, EncodeError> {
        let special = |last: u8| {
            let mut d = [0xFF; 8];
            d[7] = last;
            d
        };
        let (id, data): (u16, [u8; 8]) = match self.body {
            Body::EnterMotorMode => (self.node.0.into(), special(ENTER)),
            Body::ExitMotorMode => (self.node.0.into(), special(EXIT)),
            Body::SetZero => (self.node.0.into(), special(ZERO)),
            Body::Command(c) => {
                let m = "Command";
                let p = r.count(Field::Position, m, c.position)?;
                let v = r.count(Field::Velocity, m, c.velocity)?;
                let kp = r.count(Field::Kp, m, c.kp)?;
                let kd = r.count(Field::Kd, m, c.kd)?;
                let t = r.count(Field::Torque, m, c.torque)?;
                let d = [
                    (p >> 8) as u8,
                    p as u8,
                    (v >> 4) as u8,
                    ((v & 0xF) << 4) as u8 | (kp >> 8) as u8,
                    kp as u8,
                    (kd >> 4) as u8,
                    ((kd & 0xF) << 4) as u8 | (t >> 8) as u8,
                    t as u8,
                ];
                if d[..7] == [0xFF; 7] && (ENTER..=ZERO).contains(&d[7]) {
                    return Err(EncodeError::Reserved);
                }
                (self.node.0.into(), d)
            }
            Body::Reply(rep) => {
                let m = "Reply";
                let p = r.count(Field::Position, m, rep.position)?;
                let v = r.count(Field::Velocity, m, rep.velocity)?;
                let t = r.count(Field::Torque, m, rep.torque)?;
                let d = [
                    self.node.0,
                    (p >> 8) as u8,
                    p as u8,
                    (v >> 4) as u8,
                    ((v & 0xF) << 4) as u8 | (t >> 8) as u8,
                    t as u8,
                    rep.status.map_or(0, |s| s.temperature as u8),
                    rep.status.map_or(0, |s| s.error),
                ];
                let len = if rep.status.is_some() { 8 } else { 6 };
                let f = Frame::new_standard(MASTER_ID, &d[..len]).expect("a classic frame");
                return Ok(f);
            }
        };
        Ok(Frame::new_standard(id, &data).expect("ids up to 0x7F, 8 bytes"))
    }
}

/// The message in `frame`, fields read over `r`.
pub fn decode(frame: &Frame, r: &Ranges) -> Result<Message, DecodeError> {
    let Some(id) = frame.id().as_standard() else {
        return Err(DecodeError::ExtendedId(frame.id().raw()));
    };
    match frame.kind() {
        Kind::Data => {}
        Kind::Remote { .. } => return Err(DecodeError::Remote(id)),
        _ => return Err(DecodeError::FdFrame(id)),
    }
    let d = frame.data();
    let length = |message, expected| DecodeError::Length {
        message,
        id,
        len: d.len() as u8,
        expected,
    };
    if id == MASTER_ID {
        if d.len() != 6 && d.len() != 8 {
            return Err(length("Reply", "6 or 8"));
        }
        let node = NodeId::new(d[0]).map_err(|_| DecodeError::ReplyNode(d[0]))?;
        let p = u16::from(d[1]) << 8 | u16::from(d[2]);
        let v = u16::from(d[3]) << 4 | u16::from(d[4]) >> 4;
        let t = (u16::from(d[4]) & 0xF) << 8 | u16::from(d[5]);
        let status = (d.len() == 8).then(|| Status {
            temperature: d[6] as i8,
            error: d[7],
        });
        return Ok(Message {
            node,
            body: Body::Reply(Reply {
                position: r.value(Field::Position, p),
                velocity: r.value(Field::Velocity, v),
                torque: r.value(Field::Torque, t),
                status,
            }),
        });
    }
    let node = u8::try_from(id)
        .ok()
        .and_then(|n| NodeId::new(n).ok())
        .ok_or(DecodeError::UnknownId(id))?;
    if d.len() != 8 {
        return Err(length("Command", "8"));
    }
    let body = if d[..7] == [0xFF; 7] && (ENTER..=ZERO).contains(&d[7]) {
        match d[7] {
            ENTER => Body::EnterMotorMode,
            EXIT => Body::ExitMotorMode,
            _ => Body::SetZero,
        }
    } else {
        let p = u16::from(d[0]) << 8 | u16::from(d[1]);
        let v = u16::from(d[2]) << 4 | u16::from(d[3]) >> 4;
        let kp = (u16::from(d[3]) & 0xF) << 8 | u16::from(d[4]);
        let kd = u16::from(d[5]) << 4 | u16::from(d[6]) >> 4;
        let t = (u16::from(d[6]) & 0xF) << 8 | u16::from(d[7]);
        Body::Command(Command {
            position: r.value(Field::Position, p),
            velocity: r.value(Field::Velocity, v),
            kp: r.value(Field::Kp, kp),
            kd: r.value(Field::Kd, kd),
            torque: r.value(Field::Torque, t),
        })
    };
    Ok(Message { node, body })
}

/// The node an 11-bit id addresses: the drive for a command (`None` for
/// the master's id, whose replies name their drive in the first byte, and
/// for ids above [`MAX_NODE_ID`]).
pub const fn node_of(id: u16) -> Option<u8> {
    if id >= 1 && id <= MAX_NODE_ID as u16 {
        Some(id as u8)
    } else {
        None
    }
}

/// The cyclic traffic of `axes` MIT-mode drives for the bus budget: per
/// period a Command to each and its 8-byte Reply (there is nothing else).
pub fn traffic(axes: u32) -> Vec<BudgetLine> {
    let node = NodeId(1);
    let zero = Command {
        position: 0.0,
        velocity: 0.0,
        kp: 0.0,
        kd: 0.0,
        torque: 0.0,
    };
    let cmd = Message {
        node,
        body: Body::Command(zero),
    }
    .encode(&DEFAULT_RANGES)
    .expect("zero encodes");
    let reply = Message {
        node,
        body: Body::Reply(Reply {
            position: 0.0,
            velocity: 0.0,
            torque: 0.0,
            status: Some(Status {
                temperature: 25,
                error: 0,
            }),
        }),
    }
    .encode(&DEFAULT_RANGES)
    .expect("zero encodes");
    vec![
        BudgetLine::of("Command", &cmd, Cadence::PerPeriod(axes)),
        BudgetLine::of("Reply", &reply, Cadence::PerPeriod(axes)),
    ]
}

/// One DBC signal: name, Motorola start bit (the most significant bit,
/// DBC's numbering), length, and its field (`None`: a raw integer).
const COMMAND_SIGNALS: [(&str, u32, Field); 5] = [
    ("Position", 7, Field::Position),
    ("Velocity", 23, Field::Velocity),
    ("Kp", 27, Field::Kp),
    ("Kd", 47, Field::Kd),
    ("Torque", 51, Field::Torque),
];
const REPLY_SIGNALS: [(&str, u32, Field); 3] = [
    ("Position", 15, Field::Position),
    ("Velocity", 31, Field::Velocity),
    ("Torque", 35, Field::Torque),
];

/// The signals of a frame as a DBC reader computes them (`raw × factor +
/// offset` in f64): `(name, value)` in the DBC's order. The special
/// commands have none.
pub fn dbc_values(frame: &Frame, r: &Ranges) -> Vec<(&'static str, f64)> {
    let d = frame.data();
    let bits = |start: u32, len: u32| -> u64 {
        // Motorola: `start` is the most significant bit; bytes big-endian.
        let mut word = 0u64;
        for &b in d {
            word = word << 8 | u64::from(b);
        }
        let msb = (start / 8) * 8 + (7 - start % 8); // from the first byte's MSB
        let shift = (d.len() as u32) * 8 - msb - len;
        (word >> shift) & ((1u64 << len) - 1)
    };
    let scaled = |(name, start, f): (&'static str, u32, Field)| {
        let (factor, offset) = r.dbc_scale(f);
        (name, bits(start, f.bits()) as f64 * factor + offset)
    };
    if frame.id().raw() == u32::from(MASTER_ID) {
        let mut v = vec![("Node", d[0] as f64)];
        v.extend(REPLY_SIGNALS.map(scaled));
        if d.len() == 8 {
            v.push(("Temperature", f64::from(d[6] as i8)));
            v.push(("Error", f64::from(d[7])));
        }
        v
    } else if d[..7] == [0xFF; 7] && (ENTER..=ZERO).contains(&d[7]) {
        Vec::new()
    } else {
        COMMAND_SIGNALS.map(scaled).to_vec()
    }
}

/// The DBC file of drives `ids` (MIT-mode Command per drive, the shared
/// Reply on the master's id) over [`DEFAULT_RANGES`]; an id outside
/// 1..=127 is refused.
pub fn dbc(ids: &[u8]) -> Result<String, EncodeError> {
    let mut nodes = Vec::with_capacity(ids.len());
    for &id in ids {
        nodes.push(NodeId::new(id)?);
    }
    nodes.sort();
    nodes.dedup();
    let mut s = String::new();
    write_dbc(&mut s, &nodes, &DEFAULT_RANGES).expect("writing to a String cannot fail");
    Ok(s)
}

fn write_dbc(out: &mut String, nodes: &[NodeId], r: &Ranges) -> fmt::Result {
    writeln!(out, "VERSION \"anguilla {}\"", env!("CARGO_PKG_VERSION"))?;
    out.write_str("\n\nNS_ :\n    CM_\n    BA_DEF_\n    BA_\n    VAL_\n\nBS_:\n\n")?;
    out.write_str("BU_: Master")?;
    for n in nodes {
        write!(out, " Drive{}", n.0)?;
    }
    out.write_str("\n\n")?;
    let signal = |out: &mut String, (name, start, f): (&str, u32, Field), rx: &str| {
        let (factor, offset) = r.dbc_scale(f);
        let (min, max) = f.range(r);
        writeln!(
            out,
            " SG_ {name} : {start}|{}@0+ ({factor:?},{offset:?}) [{min}|{max}] \"{}\" {rx}",
            f.bits(),
            f.unit()
        )
    };
    for n in nodes {
        writeln!(out, "BO_ {} Drive{}_Command: 8 Master", n.0, n.0)?;
        for s in COMMAND_SIGNALS {
            signal(out, s, &format!("Drive{}", n.0))?;
        }
        out.write_char('\n')?;
    }
    let first = nodes.first().map_or(1, |n| n.0);
    writeln!(out, "BO_ {MASTER_ID} Reply: 8 Drive{first}")?;
    writeln!(out, " SG_ Node : 7|8@0+ (1,0) [1|127] \"\" Master")?;
    for s in REPLY_SIGNALS {
        signal(out, s, "Master")?;
    }
    writeln!(
        out,
        " SG_ Temperature : 55|8@0- (1,0) [-128|127] \"degC\" Master"
    )?;
    writeln!(out, " SG_ Error : 63|8@0+ (1,0) [0|6] \"\" Master")?;
    out.write_char('\n')?;
    let ids: Vec<String> = nodes.iter().map(|n| n.0.to_string()).collect();
    writeln!(
        out,
        "CM_ \"MIT-mode drives {} (ranges P +-{} rad, V +-{} rad/s, KP 0..{}, KD 0..{}, T +-{} Nm). \
         Generated by `anguilla protocol dbc --drive mit`; do not edit. A Command whose bytes are \
         FF FF FF FF FF FF FF FC, FD or FE is Enter motor mode, Exit motor mode or Set zero.\";",
        ids.join(","),
        r.position,
        r.velocity,
        r.kp,
        r.kd,
        r.torque
    )?;
    writeln!(
        out,
        "CM_ BO_ {MASTER_ID} \"Every drive's reply, sent by the drive named in Node; 6 bytes \
         (no Temperature, Error) from the original firmware.\";"
    )?;
    writeln!(
        out,
        "VAL_ {MASTER_ID} Error 0 \"none\" 1 \"over-temperature\" 2 \"over-current\" \
         3 \"over-voltage\" 4 \"under-voltage\" 5 \"encoder\" 6 \"phase unbalance\" ;"
    )
}

impl fmt::Display for NodeId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

#[cfg(test)]
mod tests;
