//! Why a message could not be encoded or decoded: [`EncodeError`] and
//! [`DecodeError`], each naming the field and what was expected.

use super::variant::Variant;
use crate::frame::FrameError;

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
