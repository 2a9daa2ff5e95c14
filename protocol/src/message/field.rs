//! Field access: every bit of a message is read and written through a
//! layout's [`Signal`]; a frame being decoded is an [`Incoming`] that
//! checks its reserved bits and ranges as it is read.

use super::definitions::MessageDef;
use super::error::{DecodeError, EncodeError};
use super::node::{NodeId, NodeSet};
use super::types::Target;
use super::variant::Variant;
use crate::signal::{Mux, Signal};

pub(super) fn put(buf: &mut [u8], s: &Signal, value: f64) -> Result<(), EncodeError> {
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
pub(super) fn check_reserved<'a>(
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

pub(super) fn active_config_signals(
    signals: &[Signal],
    param: u8,
) -> impl Iterator<Item = &Signal> {
    signals.iter().filter(move |s| match s.mux {
        Mux::When(v) => v == param,
        _ => true,
    })
}

/// A frame being decoded, past the checks every message shares (standard
/// id, frame kind, known function, length): what each message's decoder
/// reads.
#[derive(Clone, Copy)]
pub(super) struct Incoming<'a> {
    /// The 11-bit identifier.
    pub(super) id: u16,
    /// Its low six bits: node (0 = all) or setpoint group.
    pub(super) low: u8,
    /// The data bytes.
    pub(super) data: &'a [u8],
    /// The node ids accepted.
    pub(super) nodes: NodeSet,
    /// The variant decoded for.
    pub(super) variant: Variant,
    /// The message's definition.
    pub(super) def: &'static MessageDef,
}

impl Incoming<'_> {
    pub(super) fn message(&self) -> &'static str {
        self.def.name
    }

    /// The node the identifier names, if it is in the accepted set.
    pub(super) fn node(&self) -> Result<NodeId, DecodeError> {
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
    pub(super) fn target(&self) -> Result<Target, DecodeError> {
        if self.low == 0 {
            Ok(Target::All)
        } else {
            self.node().map(Target::Node)
        }
    }

    /// The raw value of `s`, checked to be in its range.
    pub(super) fn get_raw(&self, s: &Signal) -> Result<i64, DecodeError> {
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
    pub(super) fn get(&self, s: &Signal) -> Result<f32, DecodeError> {
        Ok(s.to_physical(self.get_raw(s)?) as f32)
    }

    pub(super) fn reserved_zero<'a>(
        &self,
        signals: impl Iterator<Item = &'a Signal>,
    ) -> Result<(), DecodeError> {
        check_reserved(self.data, signals, self.message())
    }

    pub(super) fn wrong_length(&self, expected: usize) -> DecodeError {
        DecodeError::WrongLength {
            message: self.message(),
            len: self.data.len() as u8,
            expected: expected as u8,
        }
    }
}
