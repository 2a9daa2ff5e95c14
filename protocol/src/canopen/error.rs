//! What was wrong with a CANopen value being encoded, or with a frame
//! being decoded, each naming the field and what was expected.

/// What was wrong with a value being built for encoding.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EncodeError {
    /// A node id outside 1..=127.
    #[error("CANopen node id {0} is out of range (expected 1..=127)")]
    NodeOutOfRange(u8),
    /// A payload of a length the message cannot carry.
    #[error("{message} payload of {len} bytes (expected {min}..={max})")]
    PayloadLength {
        /// Message name.
        message: &'static str,
        /// Length given.
        len: usize,
        /// Shortest accepted.
        min: u8,
        /// Longest accepted.
        max: u8,
    },
}

/// What was wrong with a received frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// A 29-bit identifier: the predefined connection set is 11-bit.
    #[error("extended id 0x{0:08X} (expected an 11-bit CANopen COB-ID)")]
    ExtendedId(u32),
    /// A CAN FD frame: CiA 301 is classic CAN.
    #[error("CAN FD frame on COB-ID 0x{0:03X} (expected a classic frame)")]
    FdFrame(u16),
    /// A remote frame (node guarding, RTR-requested PDOs): not in this subset.
    #[error("remote frame on COB-ID 0x{0:03X} (expected a data frame)")]
    RemoteFrame(u16),
    /// A COB-ID outside the predefined connection set this codec implements.
    #[error(
        "COB-ID 0x{0:03X} is not in the predefined connection set (expected NMT 0x000, \
         SYNC 0x080, or EMCY 0x080, TPDO 0x180/0x280/0x380/0x480, RPDO 0x200/0x300/0x400/0x500, \
         SDO 0x580/0x600, heartbeat 0x700 plus a node id 1..=127)"
    )]
    UnknownCobId(u16),
    /// A data length the message does not have.
    #[error("{message} of {len} bytes (expected {min}..={max})")]
    Length {
        /// Message name.
        message: &'static str,
        /// Length seen.
        len: u8,
        /// Shortest accepted.
        min: u8,
        /// Longest accepted.
        max: u8,
    },
    /// A field value outside the standard's value table.
    #[error("{message}.{field} value 0x{raw:02X} is unknown (expected {expected})")]
    UnknownValue {
        /// Message name.
        message: &'static str,
        /// Field name.
        field: &'static str,
        /// Raw value seen.
        raw: u32,
        /// The accepted values, in words.
        expected: &'static str,
    },
    /// An SDO command byte this codec does not implement (block transfers).
    #[error("{message} command byte 0x{command:02X} is not implemented (expected {expected})")]
    SdoCommand {
        /// Message name.
        message: &'static str,
        /// The command byte seen.
        command: u8,
        /// The accepted command bytes, in words.
        expected: &'static str,
    },
    /// A statusword whose state bits match no CiA 402 state.
    #[error(
        "statusword 0x{0:04X} matches no CiA 402 state (expected bits 0-3, 5, 6 to be one \
         of the state patterns)"
    )]
    Statusword(u16),
}
