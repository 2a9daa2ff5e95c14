//! The codec: [`Message::encode`] and [`decode`], with one encoder and one
//! decoder per message side by side (the decoder mirrors the encoder, field
//! for field), their errors, and [`encode_setpoints`] for a control
//! period. Bits are read and written only through the layouts' signals
//! ([`common`], [`classic`], [`fd`]) that the message-definition table
//! ([`definitions`](super::definitions())) lists.

use super::definitions::{MessageDef, definition};
use super::{
    Addressing, Axis, AxisFeedback, AxisSetpoint, Command, ConfigParam, ConfigResult, ErrorBits,
    Feedback, Function, GROUP_SLOTS, HeadAttitude, HeadDepth, HeadSample, HeadVector, Heartbeat,
    MAX_NODE_ID, Message, NodeId, NodeSet, NodeState, SafeAction, SensorErrors, SensorStatus,
    Setpoint, SetpointGroup, Target, Variant, classic, common, fd, function_name,
};
use crate::frame::{Frame, FrameError, Id, Kind};
use crate::signal::{Mux, Signal};

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

// ---------------------------------------------------------------------------
// Field access: every bit is read and written through a layout's `Signal`.

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

/// A frame being decoded, past the checks every message shares (standard
/// id, frame kind, known function, length): what each message's decoder
/// reads.
#[derive(Clone, Copy)]
struct Incoming<'a> {
    /// The 11-bit identifier.
    id: u16,
    /// Its low six bits: node (0 = all) or setpoint group.
    low: u8,
    /// The data bytes.
    data: &'a [u8],
    /// The node ids accepted.
    nodes: NodeSet,
    /// The variant decoded for.
    variant: Variant,
    /// The message's definition.
    def: &'static MessageDef,
}

impl Incoming<'_> {
    fn message(&self) -> &'static str {
        self.def.name
    }

    /// The node the identifier names, if it is in the accepted set.
    fn node(&self) -> Result<NodeId, DecodeError> {
        if self.nodes.contains(self.low) {
            Ok(NodeId(self.low))
        } else {
            Err(DecodeError::UnknownNode {
                message: self.message(),
                node: self.low,
            })
        }
    }

    /// Every node (low bits 0) or one accepted node.
    fn target(&self) -> Result<Target, DecodeError> {
        if self.low == 0 {
            Ok(Target::All)
        } else {
            self.node().map(Target::Node)
        }
    }

    /// The raw value of `s`, checked to be in its range.
    fn get_raw(&self, s: &Signal) -> Result<i64, DecodeError> {
        let raw = s.get(self.data);
        if raw < s.raw_min() || raw > s.raw_max() {
            return Err(DecodeError::ValueOutOfRange {
                message: self.message(),
                signal: s.name,
                raw,
                min: s.raw_min(),
                max: s.raw_max(),
            });
        }
        Ok(raw)
    }

    /// The physical value of `s`, checked to be in its range.
    fn get(&self, s: &Signal) -> Result<f32, DecodeError> {
        Ok(s.to_physical(self.get_raw(s)?) as f32)
    }

    fn reserved_zero<'a>(
        &self,
        signals: impl Iterator<Item = &'a Signal>,
    ) -> Result<(), DecodeError> {
        check_reserved(self.data, signals, self.message())
    }

    fn wrong_length(&self, expected: usize) -> DecodeError {
        DecodeError::WrongLength {
            message: self.message(),
            len: self.data.len() as u8,
            expected: expected as u8,
        }
    }
}

// ---------------------------------------------------------------------------
// Encode and decode: the entry points.

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
            Message::HeadAttitude(_) => Function::HeadAttitude,
            Message::HeadRates(_) => Function::HeadRates,
            Message::HeadAccel(_) => Function::HeadAccel,
            Message::HeadDepth(_) => Function::HeadDepth,
            Message::HeadSample(_) => Function::HeadSample,
        }
    }

    /// The frame for this message on `variant`. Never allocates.
    ///
    /// Each message has its own encoder below, beside its decoder; each
    /// writes the fields into a zeroed buffer and returns the identifier's
    /// low bits (all but the setpoint group have the definition's length).
    pub fn encode(&self, variant: Variant) -> Result<Frame, EncodeError> {
        let function = self.function();
        let def = definition(variant, function).ok_or(EncodeError::NotInVariant {
            message: function_name(function),
            variant,
        })?;
        let mut buf = [0u8; 64];
        let b = &mut buf;
        let fixed = |low: u8| (low, def.len as usize);
        let (low, len) = match self {
            Message::EStop(target) => fixed(encode_estop(*target)),
            Message::Sync { counter } => fixed(encode_sync(b, *counter)),
            Message::Command { target, command } => fixed(encode_command(b, *target, *command)),
            Message::Setpoint(sp) => fixed(encode_setpoint(b, sp)?),
            Message::SetpointGroup(g) => encode_setpoint_group(b, g)?,
            Message::Feedback(fb) => fixed(encode_feedback(b, variant, fb)?),
            Message::Heartbeat(hb) => fixed(encode_heartbeat(b, hb)?),
            Message::ConfigWrite { node, param } => fixed(encode_config_write(b, *node, param)?),
            Message::ConfigAck {
                node,
                param,
                result,
            } => fixed(encode_config_ack(b, *node, param, *result)?),
            Message::HeadAttitude(a) => fixed(encode_head_attitude(b, a)?),
            Message::HeadRates(v) => fixed(encode_head_vector(b, &classic::HEAD_RATES, v)?),
            Message::HeadAccel(v) => fixed(encode_head_vector(b, &classic::HEAD_ACCEL, v)?),
            Message::HeadDepth(d) => fixed(encode_head_depth(b, d)?),
            Message::HeadSample(h) => fixed(encode_head_sample_fd(b, h)?),
        };
        let id = function.can_id(low);
        Ok(match variant {
            Variant::Classic => Frame::new(id, &buf[..len])?,
            Variant::Fd => Frame::new_fd(id, &buf[..len], true)?,
        })
    }
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
///
/// The checks every message shares come first (standard id, data frame of
/// the variant's kind, known identifier, fixed length); then the message's
/// own decoder, the mirror of its encoder, reads the fields.
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
    let rx = Incoming {
        id,
        low,
        data: frame.data(),
        nodes,
        variant,
        def,
    };
    // Length: fixed, except the FD setpoint group (checked by its decoder).
    if def.addressing != Addressing::Group && rx.data.len() != def.len as usize {
        return Err(rx.wrong_length(def.len as usize));
    }
    match function {
        Function::EStop => decode_estop(&rx),
        Function::Sync => decode_sync(&rx),
        Function::Command => decode_command(&rx),
        Function::Setpoint => decode_setpoint(&rx),
        Function::SetpointGroup => decode_setpoint_group(&rx),
        Function::Feedback => decode_feedback(&rx),
        Function::Heartbeat => decode_heartbeat(&rx),
        Function::ConfigWrite => decode_config_write(&rx),
        Function::ConfigAck => decode_config_ack(&rx),
        Function::HeadAttitude => decode_head_attitude(&rx),
        Function::HeadRates => {
            decode_head_vector(&rx, &classic::HEAD_RATES).map(Message::HeadRates)
        }
        Function::HeadAccel => {
            decode_head_vector(&rx, &classic::HEAD_ACCEL).map(Message::HeadAccel)
        }
        Function::HeadDepth => decode_head_depth(&rx),
        Function::HeadSample => decode_head_sample_fd(&rx),
    }
}

// ---------------------------------------------------------------------------
// One encoder and one decoder per message, in identifier order.

/// EStop: no data; the target is the identifier.
fn encode_estop(target: Target) -> u8 {
    target.raw()
}

fn decode_estop(rx: &Incoming) -> Result<Message, DecodeError> {
    Ok(Message::EStop(rx.target()?))
}

/// Sync: the counter, broadcast.
fn encode_sync(buf: &mut [u8], counter: u16) -> u8 {
    common::SYNC_COUNTER.put(buf, counter as i64);
    0
}

fn decode_sync(rx: &Incoming) -> Result<Message, DecodeError> {
    if rx.low != 0 {
        return Err(DecodeError::UnknownId(rx.id));
    }
    Ok(Message::Sync {
        counter: common::SYNC_COUNTER.get(rx.data) as u16,
    })
}

/// Command: the command code, to every node or one.
fn encode_command(buf: &mut [u8], target: Target, command: Command) -> u8 {
    common::COMMAND.put(buf, command as i64);
    target.raw()
}

fn decode_command(rx: &Incoming) -> Result<Message, DecodeError> {
    let target = rx.target()?;
    let command = match rx.get_raw(&common::COMMAND)? {
        1 => Command::Enable,
        2 => Command::Disable,
        3 => Command::ClearFaults,
        raw => {
            return Err(DecodeError::ValueOutOfRange {
                message: rx.message(),
                signal: common::COMMAND.name,
                raw,
                min: 1,
                max: 3,
            });
        }
    };
    Ok(Message::Command { target, command })
}

/// Setpoint (classic): cycle tag and both axes of one node.
fn encode_setpoint(buf: &mut [u8], sp: &Setpoint) -> Result<u8, EncodeError> {
    put(buf, &classic::SP_CYCLE, sp.cycle as f64)?;
    for (a, v) in sp.axes.iter().enumerate() {
        put(buf, &classic::SP_POSITION[a], v.position as f64)?;
        put(buf, &classic::SP_VELOCITY[a], v.velocity as f64)?;
        put(buf, &classic::SP_TORQUE[a], v.torque as f64)?;
    }
    Ok(sp.node.0)
}

fn decode_setpoint(rx: &Incoming) -> Result<Message, DecodeError> {
    let node = rx.node()?;
    let mut axes = [AxisSetpoint::default(); 2];
    for (a, v) in axes.iter_mut().enumerate() {
        v.position = rx.get(&classic::SP_POSITION[a])?;
        v.velocity = rx.get(&classic::SP_VELOCITY[a])?;
        v.torque = rx.get(&classic::SP_TORQUE[a])?;
    }
    Ok(Message::Setpoint(Setpoint {
        node,
        cycle: classic::SP_CYCLE.get(rx.data) as u8,
        axes,
    }))
}

/// A slot-relative setpoint signal at slot `s` of a group frame.
fn in_slot(signal: Signal, s: usize) -> Signal {
    signal.in_slot(s as u8, fd::SLOT_BASE, fd::SLOT_BITS)
}

/// SetpointGroup (CAN FD): cycle tag, slot mask and the present slots; the
/// frame ends after the highest present slot. Returns the low bits (the
/// group) and the length.
fn encode_setpoint_group(buf: &mut [u8], g: &SetpointGroup) -> Result<(u8, usize), EncodeError> {
    if g.group as usize >= MAX_GROUPS {
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
            put(buf, &in_slot(fd::SLOT_POSITION[a], s), v.position as f64)?;
            put(buf, &in_slot(fd::SLOT_VELOCITY[a], s), v.velocity as f64)?;
            put(buf, &in_slot(fd::SLOT_TORQUE[a], s), v.torque as f64)?;
        }
    }
    if mask == 0 {
        return Err(EncodeError::EmptyGroup(g.group));
    }
    fd::GROUP_CYCLE.put(buf, g.cycle as i64);
    fd::GROUP_MASK.put(buf, mask);
    Ok((g.group, fd::group_len(64 - mask.leading_zeros() as usize)))
}

fn decode_setpoint_group(rx: &Incoming) -> Result<Message, DecodeError> {
    let group = rx.low;
    if group as usize >= MAX_GROUPS {
        return Err(DecodeError::UnknownId(rx.id));
    }
    if rx.data.len() < 2 {
        return Err(rx.wrong_length(fd::group_len(1)));
    }
    let mask = fd::GROUP_MASK.get(rx.data) as u8;
    if mask == 0 {
        return Err(DecodeError::EmptyGroup);
    }
    let slots_used = 8 - mask.leading_zeros() as usize;
    let expected = fd::group_len(slots_used);
    if rx.data.len() != expected {
        return Err(rx.wrong_length(expected));
    }
    let present = |s: &&Signal| match s.slot {
        Some(k) => mask >> k & 1 == 1,
        None => true,
    };
    rx.reserved_zero(fd::SETPOINT_GROUP.iter().filter(present))?;
    let mut slots = [None; GROUP_SLOTS];
    for (s, slot) in slots.iter_mut().enumerate() {
        if mask >> s & 1 == 0 {
            continue;
        }
        let raw_node = group as usize * GROUP_SLOTS + s + 1;
        if raw_node > MAX_NODE_ID as usize || !rx.nodes.contains(raw_node as u8) {
            return Err(DecodeError::UnknownNode {
                message: rx.message(),
                node: raw_node.min(255) as u8,
            });
        }
        let mut axes = [AxisSetpoint::default(); 2];
        for (a, v) in axes.iter_mut().enumerate() {
            v.position = rx.get(&in_slot(fd::SLOT_POSITION[a], s))?;
            v.velocity = rx.get(&in_slot(fd::SLOT_VELOCITY[a], s))?;
            v.torque = rx.get(&in_slot(fd::SLOT_TORQUE[a], s))?;
        }
        *slot = Some(axes);
    }
    Ok(Message::SetpointGroup(SetpointGroup {
        group,
        cycle: fd::GROUP_CYCLE.get(rx.data) as u8,
        slots,
    }))
}

/// The variant's feedback position, velocity and torque signals.
const fn feedback_signals(variant: Variant) -> ([Signal; 2], [Signal; 2], [Signal; 2]) {
    match variant {
        Variant::Classic => (
            classic::FB_POSITION,
            classic::FB_VELOCITY,
            classic::FB_TORQUE,
        ),
        Variant::Fd => (fd::FB_POSITION, fd::FB_VELOCITY, fd::FB_TORQUE),
    }
}

/// Feedback: status flags and both axes, in the variant's layout.
fn encode_feedback(buf: &mut [u8], variant: Variant, fb: &Feedback) -> Result<u8, EncodeError> {
    let (pos, vel, trq) = feedback_signals(variant);
    common::FB_ENABLED.put(buf, fb.enabled as i64);
    common::FB_FAULT.put(buf, fb.fault as i64);
    for (a, v) in fb.axes.iter().enumerate() {
        common::FB_LIMITED[a].put(buf, v.limited as i64);
        put(buf, &pos[a], v.position as f64)?;
        put(buf, &vel[a], v.velocity as f64)?;
        put(buf, &trq[a], v.torque as f64)?;
    }
    Ok(fb.node.0)
}

fn decode_feedback(rx: &Incoming) -> Result<Message, DecodeError> {
    let node = rx.node()?;
    rx.reserved_zero(rx.def.signals.iter())?;
    let (pos, vel, trq) = feedback_signals(rx.variant);
    let mut axes = [AxisFeedback::default(); 2];
    for (a, v) in axes.iter_mut().enumerate() {
        v.position = rx.get(&pos[a])?;
        v.velocity = rx.get(&vel[a])?;
        v.torque = rx.get(&trq[a])?;
        v.limited = common::FB_LIMITED[a].get(rx.data) == 1;
    }
    Ok(Message::Feedback(Feedback {
        node,
        enabled: common::FB_ENABLED.get(rx.data) == 1,
        fault: common::FB_FAULT.get(rx.data) == 1,
        axes,
    }))
}

/// Heartbeat: state, error bits, counters and temperature.
fn encode_heartbeat(buf: &mut [u8], hb: &Heartbeat) -> Result<u8, EncodeError> {
    common::HB_STATE.put(buf, hb.state as i64);
    if hb.errors.0 & !ErrorBits::ALL != 0 {
        return Err(EncodeError::ValueOutOfRange {
            signal: "Errors",
            value: hb.errors.0 as f64,
            min: 0.0,
            max: ErrorBits::ALL as f64,
        });
    }
    common::HB_ERRORS.put(buf, hb.errors.0 as i64);
    common::HB_COUNTER.put(buf, hb.counter as i64);
    common::HB_MISSED.put(buf, hb.missed_syncs as i64);
    put(buf, &common::HB_TEMPERATURE, hb.temperature as f64)?;
    Ok(hb.node.0)
}

fn decode_heartbeat(rx: &Incoming) -> Result<Message, DecodeError> {
    let node = rx.node()?;
    let state_raw = rx.get_raw(&common::HB_STATE)?;
    let state = NodeState::from_raw(state_raw).ok_or(DecodeError::ValueOutOfRange {
        message: rx.message(),
        signal: common::HB_STATE.name,
        raw: state_raw,
        min: 0,
        max: 4,
    })?;
    let errors = common::HB_ERRORS.get(rx.data);
    if errors & !(ErrorBits::ALL as i64) != 0 {
        return Err(DecodeError::ReservedBits {
            message: rx.message(),
            byte: 2,
        });
    }
    Ok(Message::Heartbeat(Heartbeat {
        node,
        state,
        errors: ErrorBits(errors as u16),
        counter: common::HB_COUNTER.get(rx.data) as u8,
        missed_syncs: common::HB_MISSED.get(rx.data) as u8,
        temperature: rx.get_raw(&common::HB_TEMPERATURE)? as i8,
    }))
}

/// ConfigWrite: axis (8 bits), then the parameter.
fn encode_config_write(
    buf: &mut [u8],
    node: NodeId,
    param: &ConfigParam,
) -> Result<u8, EncodeError> {
    common::CFG_AXIS.put(buf, param.axis() as i64);
    put_param(buf, param)?;
    Ok(node.0)
}

fn decode_config_write(rx: &Incoming) -> Result<Message, DecodeError> {
    let node = rx.node()?;
    let index = rx.get_raw(&common::CFG_PARAM)? as u8;
    rx.reserved_zero(active_config_signals(rx.def.signals, index))?;
    let param = decode_param(rx, &common::CFG_AXIS)?;
    Ok(Message::ConfigWrite { node, param })
}

/// ConfigAck: axis (4 bits) and result, then the parameter in effect.
fn encode_config_ack(
    buf: &mut [u8],
    node: NodeId,
    param: &ConfigParam,
    result: ConfigResult,
) -> Result<u8, EncodeError> {
    common::ACK_AXIS.put(buf, param.axis() as i64);
    common::ACK_RESULT.put(buf, result as i64);
    put_param(buf, param)?;
    Ok(node.0)
}

fn decode_config_ack(rx: &Incoming) -> Result<Message, DecodeError> {
    let node = rx.node()?;
    let index = rx.get_raw(&common::CFG_PARAM)? as u8;
    rx.reserved_zero(active_config_signals(rx.def.signals, index))?;
    let param = decode_param(rx, &common::ACK_AXIS)?;
    let result = match rx.get_raw(&common::ACK_RESULT)? {
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

/// The parameter index and value of a ConfigWrite or ConfigAck.
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

/// The mirror of [`put_param`]; `axis_sig` is the message's axis field.
fn decode_param(rx: &Incoming, axis_sig: &Signal) -> Result<ConfigParam, DecodeError> {
    let index = rx.get_raw(&common::CFG_PARAM)? as u8;
    let axis_raw = rx.get_raw(axis_sig)?;
    let axis = if axis_raw == 0 {
        Axis::Pitch
    } else {
        Axis::Yaw
    };
    let node_wide = index <= 1;
    if node_wide && axis_raw != 0 {
        return Err(DecodeError::ValueOutOfRange {
            message: rx.message(),
            signal: axis_sig.name,
            raw: axis_raw,
            min: 0,
            max: 0,
        });
    }
    Ok(match index {
        0 => ConfigParam::WatchdogTimeout {
            ms: rx.get_raw(&common::CFG_WATCHDOG)? as u16,
        },
        1 => ConfigParam::SafeAction(match rx.get_raw(&common::CFG_SAFE_ACTION)? {
            0 => SafeAction::Hold,
            1 => SafeAction::Limp,
            _ => SafeAction::Brake,
        }),
        2 => {
            if common::CFG_POS_MIN.get(rx.data) > common::CFG_POS_MAX.get(rx.data) {
                return Err(DecodeError::InvertedLimits);
            }
            ConfigParam::PositionLimits {
                axis,
                min: rx.get(&common::CFG_POS_MIN)?,
                max: rx.get(&common::CFG_POS_MAX)?,
            }
        }
        3 => ConfigParam::VelocityLimit {
            axis,
            max: rx.get(&common::CFG_VEL_MAX)?,
        },
        _ => ConfigParam::TorqueLimit {
            axis,
            max: rx.get(&common::CFG_TRQ_MAX)?,
        },
    })
}

/// HeadAttitude (classic): sample counter and quaternion.
fn encode_head_attitude(buf: &mut [u8], a: &HeadAttitude) -> Result<u8, EncodeError> {
    classic::HEAD_SAMPLE.put(buf, a.sample as i64);
    for (s, q) in classic::HEAD_QUATERNION.iter().zip(a.quaternion) {
        put(buf, s, q as f64)?;
    }
    Ok(a.node.0)
}

fn decode_head_attitude(rx: &Incoming) -> Result<Message, DecodeError> {
    let node = rx.node()?;
    let mut quaternion = [0.0; 4];
    for (q, s) in quaternion.iter_mut().zip(&classic::HEAD_QUATERNION) {
        *q = rx.get(s)?;
    }
    Ok(Message::HeadAttitude(HeadAttitude {
        node,
        sample: classic::HEAD_SAMPLE.get(rx.data) as u8,
        quaternion,
    }))
}

/// HeadRates / HeadAccel (classic): sample counter and three components.
fn encode_head_vector(
    buf: &mut [u8],
    signals: &[Signal; 3],
    v: &HeadVector,
) -> Result<u8, EncodeError> {
    classic::HEAD_SAMPLE.put(buf, v.sample as i64);
    for (s, x) in signals.iter().zip(v.xyz) {
        put(buf, s, x as f64)?;
    }
    Ok(v.node.0)
}

fn decode_head_vector(rx: &Incoming, signals: &[Signal; 3]) -> Result<HeadVector, DecodeError> {
    let node = rx.node()?;
    let mut xyz = [0.0; 3];
    for (x, s) in xyz.iter_mut().zip(signals) {
        *x = rx.get(s)?;
    }
    Ok(HeadVector {
        node,
        sample: classic::HEAD_SAMPLE.get(rx.data) as u8,
        xyz,
    })
}

/// The pressure, temperature, status and errors of a head sample, placed
/// by `sig` = (pressure, temperature, status, errors).
fn put_head_depth(
    buf: &mut [u8],
    sig: [&Signal; 4],
    pressure: u32,
    temperature: f32,
    status: SensorStatus,
    errors: SensorErrors,
) -> Result<(), EncodeError> {
    put(buf, sig[0], pressure as f64)?;
    put(buf, sig[1], temperature as f64)?;
    put(buf, sig[2], status.0 as f64)?;
    put(buf, sig[3], errors.0 as f64)
}

/// The mirror of [`put_head_depth`].
fn get_head_depth(
    rx: &Incoming,
    sig: [&Signal; 4],
) -> Result<(u32, f32, SensorStatus, SensorErrors), DecodeError> {
    Ok((
        rx.get_raw(sig[0])? as u32,
        rx.get(sig[1])?,
        SensorStatus(rx.get_raw(sig[2])? as u8),
        SensorErrors(rx.get_raw(sig[3])? as u8),
    ))
}

const CLASSIC_DEPTH: [&Signal; 4] = [
    &classic::HEAD_PRESSURE,
    &classic::HEAD_TEMPERATURE,
    &classic::HEAD_STATUS,
    &classic::HEAD_ERRORS,
];
const FD_DEPTH: [&Signal; 4] = [
    &fd::HEAD_PRESSURE,
    &fd::HEAD_TEMPERATURE,
    &fd::HEAD_STATUS,
    &fd::HEAD_ERRORS,
];

/// HeadDepth (classic): sample counter, pressure, temperature, status,
/// errors.
fn encode_head_depth(buf: &mut [u8], d: &HeadDepth) -> Result<u8, EncodeError> {
    classic::HEAD_SAMPLE.put(buf, d.sample as i64);
    put_head_depth(
        buf,
        CLASSIC_DEPTH,
        d.pressure,
        d.temperature,
        d.status,
        d.errors,
    )?;
    Ok(d.node.0)
}

fn decode_head_depth(rx: &Incoming) -> Result<Message, DecodeError> {
    let node = rx.node()?;
    let (pressure, temperature, status, errors) = get_head_depth(rx, CLASSIC_DEPTH)?;
    Ok(Message::HeadDepth(HeadDepth {
        node,
        sample: classic::HEAD_SAMPLE.get(rx.data) as u8,
        pressure,
        temperature,
        status,
        errors,
    }))
}

/// HeadSample (CAN FD): the whole sample in one frame.
fn encode_head_sample_fd(buf: &mut [u8], h: &HeadSample) -> Result<u8, EncodeError> {
    fd::HEAD_SAMPLE.put(buf, h.sample as i64);
    put_head_depth(buf, FD_DEPTH, h.pressure, h.temperature, h.status, h.errors)?;
    for (s, q) in fd::HEAD_QUATERNION.iter().zip(h.quaternion) {
        put(buf, s, q as f64)?;
    }
    for (s, x) in fd::HEAD_RATES.iter().zip(h.rates) {
        put(buf, s, x as f64)?;
    }
    for (s, x) in fd::HEAD_ACCEL.iter().zip(h.accel) {
        put(buf, s, x as f64)?;
    }
    Ok(h.node.0)
}

fn decode_head_sample_fd(rx: &Incoming) -> Result<Message, DecodeError> {
    let node = rx.node()?;
    rx.reserved_zero(rx.def.signals.iter())?;
    let (pressure, temperature, status, errors) = get_head_depth(rx, FD_DEPTH)?;
    let mut quaternion = [0.0; 4];
    for (q, s) in quaternion.iter_mut().zip(&fd::HEAD_QUATERNION) {
        *q = rx.get(s)?;
    }
    let (mut rates, mut accel) = ([0.0; 3], [0.0; 3]);
    for (x, s) in rates.iter_mut().zip(&fd::HEAD_RATES) {
        *x = rx.get(s)?;
    }
    for (x, s) in accel.iter_mut().zip(&fd::HEAD_ACCEL) {
        *x = rx.get(s)?;
    }
    Ok(Message::HeadSample(HeadSample {
        node,
        sample: fd::HEAD_SAMPLE.get(rx.data) as u8,
        quaternion,
        rates,
        accel,
        pressure,
        temperature,
        status,
        errors,
    }))
}

/// Encodes one head-sensor sample for `variant` and hands each frame to
/// `send`, without allocating: on CAN FD one [`HeadSample`] frame; on
/// classic CAN [`HeadAttitude`] (only when the status has
/// [`SensorStatus::ATTITUDE`]: a raw 6-axis IMU sends none), then
/// HeadRates, HeadAccel and last [`HeadDepth`], all with the same sample
/// counter. Nothing is sent if any field is out of range.
pub fn encode_head_sample(
    variant: Variant,
    h: &HeadSample,
    mut send: impl FnMut(Frame),
) -> Result<(), EncodeError> {
    match variant {
        Variant::Fd => send(Message::HeadSample(*h).encode(variant)?),
        Variant::Classic => {
            let (node, sample) = (h.node, h.sample);
            let attitude = Message::HeadAttitude(HeadAttitude {
                node,
                sample,
                quaternion: h.quaternion,
            });
            let frames = [
                attitude.encode(variant)?,
                Message::HeadRates(HeadVector {
                    node,
                    sample,
                    xyz: h.rates,
                })
                .encode(variant)?,
                Message::HeadAccel(HeadVector {
                    node,
                    sample,
                    xyz: h.accel,
                })
                .encode(variant)?,
                Message::HeadDepth(HeadDepth {
                    node,
                    sample,
                    pressure: h.pressure,
                    temperature: h.temperature,
                    status: h.status,
                    errors: h.errors,
                })
                .encode(variant)?,
            ];
            let skip = usize::from(!h.status.has(SensorStatus::ATTITUDE));
            for f in &frames[skip..] {
                send(*f);
            }
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// One control period's setpoints.
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
