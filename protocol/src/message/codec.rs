//! The codec: [`Message::encode`] and [`decode`], with one encoder and one
//! decoder per message side by side (the decoder mirrors the encoder, field
//! for field), their errors, and [`encode_setpoints`] for a control
//! period (the errors are in `error.rs`). Bits are read and written only through the layouts' signals
//! ([`common`], [`classic`], [`fd`]) that the message-definition table
//! ([`definitions`](super::definitions())) lists.

use super::definitions::definition;
use super::error::{DecodeError, EncodeError};
use super::field::{Incoming, active_config_signals, put};
use super::head::{
    decode_head_attitude, decode_head_depth, decode_head_sample_fd, decode_head_vector,
    encode_head_attitude, encode_head_depth, encode_head_sample_fd, encode_head_vector,
};
use super::node::{MAX_NODE_ID, NodeId, NodeSet};
use super::types::{
    Addressing, Axis, AxisFeedback, AxisSetpoint, Command, ConfigParam, ConfigResult, ErrorBits,
    Feedback, Function, GROUP_SLOTS, Heartbeat, Message, NodeState, SafeAction, Setpoint,
    SetpointGroup, Target, function_name,
};
use super::variant::Variant;
use super::{classic, common, fd};
use crate::frame::{Frame, Id, Kind};
use crate::signal::Signal;

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
