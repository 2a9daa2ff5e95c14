//! ODrive's "CAN Simple" (CANSimple) protocol: the wire codec for a bought
//! drive family, beside anguilla's own [`crate::message`].
//!
//! Source: ODrive's `docs/can-protocol.rst` (odriverobotics/ODrive: the
//! arbitration id `node_id << 5 | cmd_id`, node ids 0..=63, little-endian
//! payloads, "get" messages answered to a remote frame) and the DBC file
//! `odrive-cansimple-0.6.10.dbc` published with the current firmware
//! (ODrive Pro / S1, firmware 0.6.x) for the payload layouts. Where the
//! firmware 0.5.x layout (ODrive 3.x, `docs/_static/can-protocol.csv`)
//! differs — its heartbeat carries motor/encoder/controller error flags in
//! bytes 5..=7 and its Clear_Errors has no payload — **this module follows
//! 0.6.10**: heartbeat byte 5 is the procedure result and bit 0 of byte 6
//! the trajectory-done flag; Clear_Errors carries one `Identify` byte (an
//! empty Clear_Errors from an older master is still decoded, as
//! `identify: false`).
//!
//! | cmd  | message                | dir          | bytes | layout (byte offsets, little-endian)                          |
//! |------|------------------------|--------------|-------|---------------------------------------------------------------|
//! | 0x01 | Heartbeat              | drive → host | 8     | 0 axis_error u32, 4 axis_state u8, 5 procedure_result u8, 6.0 trajectory_done |
//! | 0x02 | Estop                  | host → drive | 0     | —                                                             |
//! | 0x07 | Set_Axis_State         | host → drive | 8     | 0 requested state u32                                         |
//! | 0x09 | Get_Encoder_Estimates  | drive → host | 8     | 0 pos f32 turns, 4 vel f32 turns/s                            |
//! | 0x0B | Set_Controller_Mode    | host → drive | 8     | 0 control_mode u32, 4 input_mode u32                          |
//! | 0x0C | Set_Input_Pos          | host → drive | 8     | 0 input_pos f32 turns, 4 vel_ff i16 ×0.001 turns/s, 6 torque_ff i16 ×0.001 Nm |
//! | 0x18 | Clear_Errors           | host → drive | 1     | 0 identify u8 (0/1)                                           |
//!
//! A request ([`Body::Request`]) is a remote frame (RTR) on the id of the
//! message asked for; the drive answers with the data frame on the same
//! id. Decoding takes any length from the bytes the fields cover up to 8
//! (masters in the wild send 4-byte Set_Axis_State); encoding writes the
//! DBC's length. Floats must be finite both ways; enumerations outside the
//! 0.6.10 DBC's value tables are decode errors.
//!
//! ```
//! use anguilla_protocol::odrive::{decode, Body, InputPos, Message, NodeId};
//! let m = Message {
//!     node: NodeId::new(1)?,
//!     body: Body::SetInputPos(InputPos { input_pos: 1.0, vel_ff: 0.5, torque_ff: -0.25 }),
//! };
//! let f = m.encode()?;
//! assert_eq!(f.to_string(), "02C#0000803FF40106FF");
//! assert_eq!(decode(&f)?, m);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::frame::{Frame, Id, Kind, StandardId};

pub mod dbc;

/// The largest CANSimple node id on 11-bit identifiers (6 bits).
pub const MAX_NODE_ID: u8 = 0x3F;
/// The largest command id (5 bits).
pub const MAX_CMD_ID: u8 = 0x1F;
/// Counts of `Set_Input_Pos`'s `vel_ff` and `torque_ff` per turn/s or Nm.
pub const FF_COUNTS_PER_UNIT: f32 = 1000.0;
/// The scale of `Set_Input_Pos`'s `vel_ff` and `torque_ff`: one count is
/// 0.001 turns/s or 0.001 Nm (the DBC's factor).
pub const FF_SCALE: f32 = 1.0 / FF_COUNTS_PER_UNIT;
/// Smallest feedforward an i16 at [`FF_SCALE`] carries (−32.768).
pub const FF_MIN: f32 = ff_value(i16::MIN);
/// Largest feedforward an i16 at [`FF_SCALE`] carries (32.767).
pub const FF_MAX: f32 = ff_value(i16::MAX);

/// What was wrong with a message being encoded (or a node id being built).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum EncodeError {
    /// A node id above 63.
    #[error("ODrive node id {0} is out of range (expected 0..=63)")]
    NodeOutOfRange(u8),
    /// A float field that is NaN or infinite.
    #[error("{message}.{field} is {value} (expected a finite number)")]
    NotFinite {
        /// Message name.
        message: &'static str,
        /// Field name.
        field: &'static str,
        /// The value given.
        value: f32,
    },
    /// A feedforward that does not fit an i16 at 0.001 per count.
    #[error(
        "{message}.{field} {value} does not fit an i16 at 0.001 per count \
         (expected -32.768..=32.767)"
    )]
    FeedforwardOutOfRange {
        /// Message name.
        message: &'static str,
        /// Field name (`vel_ff` or `torque_ff`).
        field: &'static str,
        /// The value given.
        value: f32,
    },
    /// A request for a message the drive does not send on request.
    #[error("request (remote frame) for {0:?} (expected Heartbeat or GetEncoderEstimates)")]
    NotRequestable(Cmd),
}

/// What was wrong with a received frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// A 29-bit identifier: this codec speaks 11-bit CANSimple only.
    #[error("extended id 0x{0:08X} (expected an 11-bit CANSimple id)")]
    ExtendedId(u32),
    /// A CAN FD frame: CANSimple is classic CAN.
    #[error("CAN FD frame on id 0x{0:03X} (expected a classic frame)")]
    FdFrame(u16),
    /// A command id this codec does not implement.
    #[error(
        "command id 0x{cmd:02X} on id 0x{id:03X} (expected one of 0x01, 0x02, 0x07, \
         0x09, 0x0B, 0x0C, 0x18)"
    )]
    UnknownCmd {
        /// The frame's identifier.
        id: u16,
        /// Its low 5 bits.
        cmd: u8,
    },
    /// A remote frame for a message that is not sent on request.
    #[error(
        "remote frame for {0:?} (expected a data frame; only Heartbeat and GetEncoderEstimates are requested)"
    )]
    NotRequestable(Cmd),
    /// Fewer bytes than the message's fields cover.
    #[error("{message} of {len} bytes (expected {min}..=8)")]
    TooShort {
        /// Message name.
        message: &'static str,
        /// Length seen.
        len: u8,
        /// Bytes the fields cover.
        min: u8,
    },
    /// An enumeration value outside the DBC's value table.
    #[error("{message}.{field} value {raw} is unknown (expected 0..={max})")]
    UnknownValue {
        /// Message name.
        message: &'static str,
        /// Field name.
        field: &'static str,
        /// Raw value seen.
        raw: u32,
        /// Largest known value.
        max: u32,
    },
    /// A float field that is NaN or infinite.
    #[error("{message}.{field} is not finite (raw 0x{raw:08X}; expected a finite f32)")]
    NotFinite {
        /// Message name.
        message: &'static str,
        /// Field name.
        field: &'static str,
        /// Raw bits seen.
        raw: u32,
    },
}

/// A CANSimple node id (`axis.config.can.node_id`), always 0..=63.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(u8);

impl NodeId {
    /// A node id, checked to fit in 6 bits.
    pub const fn new(raw: u8) -> Result<Self, EncodeError> {
        if raw > MAX_NODE_ID {
            Err(EncodeError::NodeOutOfRange(raw))
        } else {
            Ok(NodeId(raw))
        }
    }

    /// The raw value (0..=63).
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// The command ids this codec implements (the low 5 bits of the id).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Cmd {
    /// 0x01, drive → host, cyclic (100 ms by default) or on request.
    Heartbeat = 0x01,
    /// 0x02, host → drive: disarm now, with `ESTOP_REQUESTED`.
    Estop = 0x02,
    /// 0x07, host → drive: request an axis state.
    SetAxisState = 0x07,
    /// 0x09, drive → host, cyclic (10 ms by default) or on request.
    GetEncoderEstimates = 0x09,
    /// 0x0B, host → drive: control and input mode.
    SetControllerMode = 0x0B,
    /// 0x0C, host → drive: position setpoint with feedforwards.
    SetInputPos = 0x0C,
    /// 0x18, host → drive: clear errors (and optionally blink the LED).
    ClearErrors = 0x18,
}

impl Cmd {
    /// Every implemented command, in id order.
    pub const ALL: [Cmd; 7] = [
        Cmd::Heartbeat,
        Cmd::Estop,
        Cmd::SetAxisState,
        Cmd::GetEncoderEstimates,
        Cmd::SetControllerMode,
        Cmd::SetInputPos,
        Cmd::ClearErrors,
    ];

    /// The command id (0..=31).
    pub const fn id(self) -> u8 {
        self as u8
    }

    /// The command with this id, if implemented.
    pub fn from_id(cmd: u8) -> Option<Cmd> {
        Cmd::ALL.into_iter().find(|c| c.id() == cmd)
    }

    /// The message name as in ODrive's DBC.
    pub const fn name(self) -> &'static str {
        match self {
            Cmd::Heartbeat => "Heartbeat",
            Cmd::Estop => "Estop",
            Cmd::SetAxisState => "Set_Axis_State",
            Cmd::GetEncoderEstimates => "Get_Encoder_Estimates",
            Cmd::SetControllerMode => "Set_Controller_Mode",
            Cmd::SetInputPos => "Set_Input_Pos",
            Cmd::ClearErrors => "Clear_Errors",
        }
    }

    /// The data length the DBC gives the message.
    pub const fn dbc_len(self) -> u8 {
        match self {
            Cmd::Estop => 0,
            Cmd::ClearErrors => 1,
            _ => 8,
        }
    }

    /// Bytes the message's fields cover: the shortest payload decoded.
    pub const fn min_len(self) -> u8 {
        match self {
            Cmd::Estop | Cmd::ClearErrors => 0,
            Cmd::SetAxisState => 4,
            Cmd::Heartbeat => 7,
            _ => 8,
        }
    }

    /// Whether the drive answers a remote frame on this id.
    pub const fn requestable(self) -> bool {
        matches!(self, Cmd::Heartbeat | Cmd::GetEncoderEstimates)
    }
}

/// The 11-bit arbitration id `node_id << 5 | cmd_id`.
pub const fn arbitration_id(node: NodeId, cmd: Cmd) -> StandardId {
    StandardId::literal(((node.0 as u16) << 5) | cmd as u16)
}

/// Splits an 11-bit id into (node id, command id).
pub const fn split_id(raw: u16) -> (u8, u8) {
    (((raw >> 5) & 0x3F) as u8, (raw & 0x1F) as u8)
}

macro_rules! wire_enum {
    ($(#[$m:meta])* $name:ident : $field:literal { $($(#[$vm:meta])* $v:ident = $n:literal,)* }) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        #[repr(u8)]
        pub enum $name { $($(#[$vm])* $v = $n,)* }

        impl $name {
            /// Every value, in wire order.
            pub const ALL: &'static [$name] = &[$($name::$v,)*];

            /// The wire value.
            pub const fn raw(self) -> u32 {
                self as u32
            }

            /// The variant's name (`ClosedLoopControl`); ODrive's own
            /// spelling is its SCREAMING_SNAKE form (`CLOSED_LOOP_CONTROL`).
            pub const fn name(self) -> &'static str {
                match self { $($name::$v => stringify!($v),)* }
            }

            fn from_raw(message: &'static str, raw: u32) -> Result<Self, DecodeError> {
                $name::ALL.iter().copied().find(|v| v.raw() == raw).ok_or(
                    DecodeError::UnknownValue {
                        message,
                        field: $field,
                        raw,
                        max: $name::ALL.len() as u32 - 1,
                    },
                )
            }
        }
    };
}

wire_enum! {
    /// `AxisState` (`Axis_State`, `Axis_Requested_State`), values of the
    /// 0.6.10 DBC.
    AxisState: "axis_state" {
        /// 0.
        Undefined = 0,
        /// 1: motor disarmed.
        Idle = 1,
        /// 2.
        StartupSequence = 2,
        /// 3.
        FullCalibrationSequence = 3,
        /// 4.
        MotorCalibration = 4,
        /// 5.
        SensorlessControl = 5,
        /// 6.
        EncoderIndexSearch = 6,
        /// 7.
        EncoderOffsetCalibration = 7,
        /// 8: the position/velocity/torque loop runs.
        ClosedLoopControl = 8,
        /// 9.
        LockinSpin = 9,
        /// 10.
        EncoderDirFind = 10,
        /// 11.
        Homing = 11,
        /// 12.
        EncoderHallPolarityCalibration = 12,
        /// 13.
        EncoderHallPhaseCalibration = 13,
        /// 14.
        AnticoggingCalibration = 14,
    }
}

wire_enum! {
    /// `ControlMode` (`Control_Mode`), values of the 0.6.10 DBC.
    ControlMode: "control_mode" {
        /// 0.
        VoltageControl = 0,
        /// 1.
        TorqueControl = 1,
        /// 2.
        VelocityControl = 2,
        /// 3: what anguilla uses.
        PositionControl = 3,
    }
}

wire_enum! {
    /// `InputMode` (`Input_Mode`), values of the 0.6.10 DBC.
    InputMode: "input_mode" {
        /// 0.
        Inactive = 0,
        /// 1: setpoints go straight to the controller (what anguilla uses).
        Passthrough = 1,
        /// 2.
        VelRamp = 2,
        /// 3.
        PosFilter = 3,
        /// 4.
        MixChannels = 4,
        /// 5.
        TrapTraj = 5,
        /// 6.
        TorqueRamp = 6,
        /// 7.
        Mirror = 7,
        /// 8.
        Tuning = 8,
    }
}

/// Heartbeat (0x01): the drive's error bits and state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Heartbeat {
    /// `Axis_Error`: the active error bits (`ODriveError`, e.g.
    /// 0x0100_0000 `WATCHDOG_TIMER_EXPIRED`, 0x0200_0000 `ESTOP_REQUESTED`).
    pub axis_error: u32,
    /// `Axis_State`: the current state.
    pub axis_state: AxisState,
    /// `Procedure_Result` (`ProcedureResult`: 0 SUCCESS, 1 BUSY, ...),
    /// carried raw.
    pub procedure_result: u8,
    /// `Trajectory_Done_Flag`: bit 0 of byte 6.
    pub trajectory_done: bool,
}

/// Get_Encoder_Estimates (0x09): position and velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EncoderEstimates {
    /// `Pos_Estimate`, turns.
    pub pos: f32,
    /// `Vel_Estimate`, turns/s.
    pub vel: f32,
}

/// Set_Input_Pos (0x0C): a position setpoint with feedforwards.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputPos {
    /// `Input_Pos`, turns.
    pub input_pos: f32,
    /// `Vel_FF`, turns/s; sent as i16 counts of 0.001 turns/s
    /// ([`FF_MIN`]..=[`FF_MAX`]), rounded to the nearest count.
    pub vel_ff: f32,
    /// `Torque_FF`, Nm; sent as i16 counts of 0.001 Nm, rounded.
    pub torque_ff: f32,
}

/// What a CANSimple frame says.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Body {
    /// 0x01, drive → host.
    Heartbeat(Heartbeat),
    /// 0x02, host → drive.
    Estop,
    /// 0x07, host → drive: `Axis_Requested_State` (u32 on the wire).
    SetAxisState(AxisState),
    /// 0x09, drive → host.
    EncoderEstimates(EncoderEstimates),
    /// 0x0B, host → drive.
    SetControllerMode {
        /// `Control_Mode` (u32 on the wire).
        control_mode: ControlMode,
        /// `Input_Mode` (u32 on the wire).
        input_mode: InputMode,
    },
    /// 0x0C, host → drive.
    SetInputPos(InputPos),
    /// 0x18, host → drive.
    ClearErrors {
        /// `Identify`: also blink the drive's LED.
        identify: bool,
    },
    /// A remote frame asking for a message ([`Cmd::requestable`]).
    Request(Cmd),
}

impl Body {
    /// The command id this body travels on.
    pub const fn cmd(&self) -> Cmd {
        match self {
            Body::Heartbeat(_) => Cmd::Heartbeat,
            Body::Estop => Cmd::Estop,
            Body::SetAxisState(_) => Cmd::SetAxisState,
            Body::EncoderEstimates(_) => Cmd::GetEncoderEstimates,
            Body::SetControllerMode { .. } => Cmd::SetControllerMode,
            Body::SetInputPos(_) => Cmd::SetInputPos,
            Body::ClearErrors { .. } => Cmd::ClearErrors,
            Body::Request(c) => *c,
        }
    }
}

/// One CANSimple message: the node it is for or from, and what it says.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Message {
    /// The drive axis's node id.
    pub node: NodeId,
    /// The payload.
    pub body: Body,
}

fn finite(message: &'static str, field: &'static str, value: f32) -> Result<f32, EncodeError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(EncodeError::NotFinite {
            message,
            field,
            value,
        })
    }
}

/// A feedforward as i16 counts of [`FF_SCALE`], rounded to nearest.
fn ff_counts(field: &'static str, value: f32) -> Result<i16, EncodeError> {
    const MESSAGE: &str = "Set_Input_Pos";
    let value = finite(MESSAGE, field, value)?;
    let counts = (value * FF_COUNTS_PER_UNIT).round();
    if counts < i16::MIN as f32 || counts > i16::MAX as f32 {
        return Err(EncodeError::FeedforwardOutOfRange {
            message: MESSAGE,
            field,
            value,
        });
    }
    Ok(counts as i16)
}

impl Message {
    /// The frame carrying this message: a classic data frame of the DBC's
    /// length, or a remote frame (DLC of the answer) for a request.
    pub fn encode(&self) -> Result<Frame, EncodeError> {
        let cmd = self.body.cmd();
        let id = Id::Standard(arbitration_id(self.node, cmd));
        let mut d = [0u8; 8];
        match self.body {
            Body::Request(c) => {
                if !c.requestable() {
                    return Err(EncodeError::NotRequestable(c));
                }
                return Ok(Frame::new_remote(id, c.dbc_len()).expect("a DLC of 8 or less"));
            }
            Body::Heartbeat(h) => {
                d[0..4].copy_from_slice(&h.axis_error.to_le_bytes());
                d[4] = h.axis_state as u8;
                d[5] = h.procedure_result;
                d[6] = h.trajectory_done as u8;
            }
            Body::Estop => {}
            Body::SetAxisState(s) => d[0..4].copy_from_slice(&s.raw().to_le_bytes()),
            Body::EncoderEstimates(e) => {
                const M: &str = "Get_Encoder_Estimates";
                d[0..4].copy_from_slice(&finite(M, "pos", e.pos)?.to_le_bytes());
                d[4..8].copy_from_slice(&finite(M, "vel", e.vel)?.to_le_bytes());
            }
            Body::SetControllerMode {
                control_mode,
                input_mode,
            } => {
                d[0..4].copy_from_slice(&control_mode.raw().to_le_bytes());
                d[4..8].copy_from_slice(&input_mode.raw().to_le_bytes());
            }
            Body::SetInputPos(p) => {
                let pos = finite("Set_Input_Pos", "input_pos", p.input_pos)?;
                let vel_ff = ff_counts("vel_ff", p.vel_ff)?;
                let torque_ff = ff_counts("torque_ff", p.torque_ff)?;
                d[0..4].copy_from_slice(&pos.to_le_bytes());
                d[4..6].copy_from_slice(&vel_ff.to_le_bytes());
                d[6..8].copy_from_slice(&torque_ff.to_le_bytes());
            }
            Body::ClearErrors { identify } => d[0] = identify as u8,
        }
        Ok(Frame::new(id, &d[..cmd.dbc_len() as usize]).expect("8 bytes or less"))
    }
}

fn u32_at(d: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([d[at], d[at + 1], d[at + 2], d[at + 3]])
}

fn f32_at(
    message: &'static str,
    field: &'static str,
    d: &[u8],
    at: usize,
) -> Result<f32, DecodeError> {
    let raw = u32_at(d, at);
    let v = f32::from_bits(raw);
    if v.is_finite() {
        Ok(v)
    } else {
        Err(DecodeError::NotFinite {
            message,
            field,
            raw,
        })
    }
}

/// A feedforward count's value: the f32 nearest to `counts × 0.001` (one
/// correctly rounded division, so it is what a DBC reader's `raw × 0.001`
/// rounds to).
pub const fn ff_value(counts: i16) -> f32 {
    counts as f32 / FF_COUNTS_PER_UNIT
}

fn i16_at(d: &[u8], at: usize) -> i16 {
    i16::from_le_bytes([d[at], d[at + 1]])
}

/// The message a classic 11-bit frame carries.
pub fn decode(frame: &Frame) -> Result<Message, DecodeError> {
    let raw = frame
        .id()
        .as_standard()
        .ok_or(DecodeError::ExtendedId(frame.id().raw()))?;
    let (node, cmd_id) = split_id(raw);
    let node = NodeId(node);
    let cmd = Cmd::from_id(cmd_id).ok_or(DecodeError::UnknownCmd {
        id: raw,
        cmd: cmd_id,
    })?;
    match frame.kind() {
        Kind::Fd { .. } => return Err(DecodeError::FdFrame(raw)),
        Kind::Remote { .. } => {
            return if cmd.requestable() {
                Ok(Message {
                    node,
                    body: Body::Request(cmd),
                })
            } else {
                Err(DecodeError::NotRequestable(cmd))
            };
        }
        Kind::Data => {}
    }
    let d = frame.data();
    let name = cmd.name();
    if d.len() < cmd.min_len() as usize {
        return Err(DecodeError::TooShort {
            message: name,
            len: d.len() as u8,
            min: cmd.min_len(),
        });
    }
    let body = match cmd {
        Cmd::Heartbeat => Body::Heartbeat(Heartbeat {
            axis_error: u32_at(d, 0),
            axis_state: AxisState::from_raw(name, d[4] as u32)?,
            procedure_result: d[5],
            trajectory_done: d[6] & 1 != 0,
        }),
        Cmd::Estop => Body::Estop,
        Cmd::SetAxisState => Body::SetAxisState(AxisState::from_raw(name, u32_at(d, 0))?),
        Cmd::GetEncoderEstimates => Body::EncoderEstimates(EncoderEstimates {
            pos: f32_at(name, "pos", d, 0)?,
            vel: f32_at(name, "vel", d, 4)?,
        }),
        Cmd::SetControllerMode => Body::SetControllerMode {
            control_mode: ControlMode::from_raw(name, u32_at(d, 0))?,
            input_mode: InputMode::from_raw(name, u32_at(d, 4))?,
        },
        Cmd::SetInputPos => Body::SetInputPos(InputPos {
            input_pos: f32_at(name, "input_pos", d, 0)?,
            vel_ff: ff_value(i16_at(d, 4)),
            torque_ff: ff_value(i16_at(d, 6)),
        }),
        Cmd::ClearErrors => Body::ClearErrors {
            identify: match d.first().copied().unwrap_or(0) {
                0 => false,
                1 => true,
                other => {
                    return Err(DecodeError::UnknownValue {
                        message: name,
                        field: "identify",
                        raw: other as u32,
                        max: 1,
                    });
                }
            },
        },
    };
    Ok(Message { node, body })
}

/// The cyclic traffic of `axes` ODrive axes (classic CAN) for the bus
/// budget: per period a Set_Input_Pos to each; each axis sends
/// Get_Encoder_Estimates every 10 ms and a Heartbeat every 100 ms whatever
/// the control rate.
pub fn traffic(axes: u32) -> Vec<crate::budget::BudgetLine> {
    use crate::budget::{BudgetLine, Cadence};
    use crate::odrive::{
        AxisState, Body, EncoderEstimates, Heartbeat as OdHb, InputPos, Message as Od,
        NodeId as OdNode,
    };
    let node = OdNode::new(1).expect("1 is a node id");
    let enc = |body| Od { node, body }.encode().expect("encodes");
    let pos = enc(Body::SetInputPos(InputPos {
        input_pos: 0.0,
        vel_ff: 0.0,
        torque_ff: 0.0,
    }));
    let est = enc(Body::EncoderEstimates(EncoderEstimates {
        pos: 0.0,
        vel: 0.0,
    }));
    let hb = enc(Body::Heartbeat(OdHb {
        axis_error: 0,
        axis_state: AxisState::ClosedLoopControl,
        procedure_result: 0,
        trajectory_done: false,
    }));
    vec![
        BudgetLine::of("Set_Input_Pos", &pos, Cadence::PerPeriod(axes)),
        BudgetLine::of(
            "Get_Encoder_Estimates",
            &est,
            Cadence::PerSecond(axes as f64 * 100.0),
        ),
        BudgetLine::of("Heartbeat", &hb, Cadence::PerSecond(axes as f64 * 10.0)),
    ]
}

#[cfg(test)]
mod tests;
