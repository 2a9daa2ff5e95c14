//! CANopen (CiA 301 application layer, CiA 402 drive profile): the wire
//! codec subset a master needs to drive bought CiA 402 servo drives (e.g.
//! Maxon EPOS4), beside anguilla's own [`crate::message`].
//!
//! Sources: CiA 301 v4.2 (CANopen application layer and communication
//! profile): its "pre-defined connection set" for the COB-IDs, its SDO
//! initiate download / upload and abort protocols for the SDO command byte
//! (client command specifier `ccs`, server `scs`, `n`, `e`, `s` bits), its
//! SDO abort-code table, its EMCY write protocol and emergency error-code
//! table, its NMT node-control and heartbeat protocols; CiA 402-2 (drives
//! and motion control, the "power drive system" finite state machine) for
//! the statusword and controlword bit patterns and the object indices.
//! This module only encodes and decodes; it keeps no state (a node's SDO
//! transaction or state machine stepping belongs to the caller).
//!
//! | COB-ID          | message                  | dir             | bytes | layout (byte offsets, little-endian)                  |
//! |-----------------|--------------------------|-----------------|-------|-------------------------------------------------------|
//! | 0x000           | NMT                      | master → nodes  | 2     | 0 command, 1 node (0 = all)                           |
//! | 0x080           | SYNC                     | master → nodes  | 0..=1 | optional counter                                      |
//! | 0x080 + n       | EMCY                     | node → all      | 8     | 0 error code u16, 2 error register u8, 3..8 vendor    |
//! | 0x180..0x480 + n| TPDO1..4                 | node → master   | 0..=8 | as mapped (raw here)                                  |
//! | 0x200..0x500 + n| RPDO1..4                 | master → node   | 0..=8 | as mapped (raw here)                                  |
//! | 0x580 + n       | SDO server → client      | node → master   | 8     | 0 command, 1 index u16, 3 subindex, 4 data/abort u32  |
//! | 0x600 + n       | SDO client → server      | master → node   | 8     | same                                                  |
//! | 0x700 + n       | heartbeat / boot-up      | node → all      | 1     | 0 NMT state                                           |
//!
//! Node ids are 1..=127. Only classic 11-bit data frames are decoded: remote
//! frames (node guarding), the TIME object (0x100) and LSS (0x7E4/0x7E5)
//! are outside this subset and are decode errors, as are SDO block
//! transfers. SDO transfers are expedited (1..=4 bytes in the initiate
//! message) or segmented (initiate, then 7-byte segments with an
//! alternating toggle bit: [`SdoRequest::DownloadSegment`],
//! [`SdoRequest::UploadSegment`] and their responses).
//! PDO payloads are kept raw: what they mean depends on the node's mapping.
//! Encoding cannot fail — every field is range-checked when its value is
//! built ([`NodeId::new`], [`SdoData::new`], [`PdoData::new`]).
//!
//! ```
//! use anguilla_protocol::canopen::{decode, Message, NodeId, Object, SdoData, SdoRequest, cia402};
//! // Write the controlword (0x6040:00) of node 1 with "shutdown" (0x0006).
//! let m = Message::SdoRequest {
//!     node: NodeId::new(1)?,
//!     sdo: SdoRequest::Download {
//!         object: Object::new(cia402::CONTROLWORD, 0),
//!         data: SdoData::new(&cia402::Command::Shutdown.word().to_le_bytes())?,
//!     },
//! };
//! let f = m.encode();
//! assert_eq!(f.to_string(), "601#2B40600006000000");
//! assert_eq!(decode(&f)?, m);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::frame::{Frame, Id, Kind, StandardId};

/// The largest CANopen node id.
pub const MAX_NODE_ID: u8 = 127;
/// Every SDO frame carries 8 bytes.
pub const SDO_LEN: u8 = 8;
/// Every EMCY frame carries 8 bytes.
pub const EMCY_LEN: u8 = 8;

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

/// A CANopen node id, always 1..=127.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(u8);

impl NodeId {
    /// A node id, checked to be 1..=127.
    pub const fn new(raw: u8) -> Result<Self, EncodeError> {
        if raw == 0 || raw > MAX_NODE_ID {
            Err(EncodeError::NodeOutOfRange(raw))
        } else {
            Ok(NodeId(raw))
        }
    }

    /// The raw value (1..=127).
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// A PDO number (1..=4 in the predefined connection set).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Pdo {
    /// PDO 1.
    One = 1,
    /// PDO 2.
    Two = 2,
    /// PDO 3.
    Three = 3,
    /// PDO 4.
    Four = 4,
}

impl Pdo {
    /// Every PDO number.
    pub const ALL: [Pdo; 4] = [Pdo::One, Pdo::Two, Pdo::Three, Pdo::Four];

    /// The TPDO function code base: 0x180, 0x280, 0x380, 0x480.
    pub const fn tpdo_base(self) -> u16 {
        0x080 + 0x100 * self as u16
    }

    /// The RPDO function code base: 0x200, 0x300, 0x400, 0x500.
    pub const fn rpdo_base(self) -> u16 {
        0x100 + 0x100 * self as u16
    }
}

/// The communication objects of the predefined connection set (CiA 301
/// pre-defined connection set), as [`classify`] finds them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Function {
    /// 0x000, broadcast.
    Nmt,
    /// 0x080, broadcast.
    Sync,
    /// 0x080 + node.
    Emcy(NodeId),
    /// Transmit PDO, node → master.
    Tpdo(Pdo, NodeId),
    /// Receive PDO, master → node.
    Rpdo(Pdo, NodeId),
    /// 0x580 + node: SDO server → client (the node's answers).
    SdoTx(NodeId),
    /// 0x600 + node: SDO client → server (the master's requests).
    SdoRx(NodeId),
    /// 0x700 + node: heartbeat and boot-up.
    Heartbeat(NodeId),
}

impl Function {
    /// The COB-ID of this object in the predefined connection set.
    pub const fn cob_id(self) -> StandardId {
        let raw = match self {
            Function::Nmt => 0x000,
            Function::Sync => 0x080,
            Function::Emcy(n) => 0x080 + n.0 as u16,
            Function::Tpdo(p, n) => p.tpdo_base() + n.0 as u16,
            Function::Rpdo(p, n) => p.rpdo_base() + n.0 as u16,
            Function::SdoTx(n) => 0x580 + n.0 as u16,
            Function::SdoRx(n) => 0x600 + n.0 as u16,
            Function::Heartbeat(n) => 0x700 + n.0 as u16,
        };
        StandardId::literal(raw)
    }
}

/// The object a COB-ID names: function code `id >> 7`, node `id & 0x7F`.
pub fn classify(cob_id: u16) -> Result<Function, DecodeError> {
    let unknown = DecodeError::UnknownCobId(cob_id);
    if cob_id > 0x7FF {
        return Err(unknown);
    }
    let node = (cob_id & 0x7F) as u8;
    let fc = cob_id >> 7;
    if node == 0 {
        return match fc {
            0 => Ok(Function::Nmt),
            1 => Ok(Function::Sync),
            _ => Err(unknown),
        };
    }
    let n = NodeId(node);
    let pdo = |i: u16| Pdo::ALL[i as usize - 1];
    Ok(match fc {
        1 => Function::Emcy(n),
        3 | 5 | 7 | 9 => Function::Tpdo(pdo((fc - 1) / 2), n),
        4 | 6 | 8 | 10 => Function::Rpdo(pdo((fc - 2) / 2), n),
        11 => Function::SdoTx(n),
        12 => Function::SdoRx(n),
        14 => Function::Heartbeat(n),
        _ => return Err(unknown),
    })
}

macro_rules! wire_enum {
    ($(#[$m:meta])* $name:ident : $field:literal, $expected:literal { $($(#[$vm:meta])* $v:ident = $n:literal,)* }) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        #[repr(u8)]
        pub enum $name { $($(#[$vm])* $v = $n,)* }

        impl $name {
            /// Every value, in wire order.
            pub const ALL: &'static [$name] = &[$($name::$v,)*];

            /// The wire value.
            pub const fn raw(self) -> u8 {
                self as u8
            }

            fn from_raw(message: &'static str, raw: u8) -> Result<Self, DecodeError> {
                $name::ALL.iter().copied().find(|v| v.raw() == raw).ok_or(
                    DecodeError::UnknownValue {
                        message,
                        field: $field,
                        raw: raw as u32,
                        expected: $expected,
                    },
                )
            }
        }
    };
}

wire_enum! {
    /// NMT commands (CiA 301 NMT node control, byte 0 of COB-ID 0x000).
    NmtCommand: "command", "0x01, 0x02, 0x80, 0x81 or 0x82" {
        /// 0x01: start remote node (→ operational).
        Start = 0x01,
        /// 0x02: stop remote node (→ stopped).
        Stop = 0x02,
        /// 0x80: enter pre-operational.
        EnterPreOperational = 0x80,
        /// 0x81: reset node (application and communication).
        ResetNode = 0x81,
        /// 0x82: reset communication.
        ResetCommunication = 0x82,
    }
}

wire_enum! {
    /// NMT states in a heartbeat (CiA 301 heartbeat protocol, byte 0 of 0x700 + n).
    NmtState: "state", "0x00, 0x04, 0x05 or 0x7F" {
        /// 0x00: the boot-up message, sent once on entering pre-operational.
        BootUp = 0x00,
        /// 0x04.
        Stopped = 0x04,
        /// 0x05: PDOs flow.
        Operational = 0x05,
        /// 0x7F: SDO and NMT only.
        PreOperational = 0x7F,
    }
}

macro_rules! abort_codes {
    ($($(#[$vm:meta])* $v:ident = $n:literal, $text:literal;)*) => {
        /// SDO abort codes (CiA 301's abort-code table); codes outside the table are
        /// kept raw in [`AbortCode::Other`].
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum AbortCode {
            $($(#[$vm])* $v,)*
            /// A code outside CiA 301's table (vendor-specific or newer).
            Other(u32),
        }

        impl AbortCode {
            /// Every named code, in table order.
            pub const NAMED: &'static [AbortCode] = &[$(AbortCode::$v,)*];

            /// The u32 on the wire.
            pub const fn raw(self) -> u32 {
                match self {
                    $(AbortCode::$v => $n,)*
                    AbortCode::Other(raw) => raw,
                }
            }

            /// The named code for `raw`, or [`AbortCode::Other`].
            pub const fn from_raw(raw: u32) -> Self {
                match raw {
                    $($n => AbortCode::$v,)*
                    other => AbortCode::Other(other),
                }
            }

            /// CiA 301's description (`"unknown abort code"` for `Other`).
            pub const fn description(self) -> &'static str {
                match self {
                    $(AbortCode::$v => $text,)*
                    AbortCode::Other(_) => "unknown abort code",
                }
            }
        }
    };
}

abort_codes! {
    /// 0x0503_0000.
    ToggleBitNotAlternated = 0x0503_0000, "toggle bit not alternated";
    /// 0x0504_0000.
    Timeout = 0x0504_0000, "SDO protocol timed out";
    /// 0x0504_0001.
    InvalidCommandSpecifier = 0x0504_0001, "client/server command specifier not valid or unknown";
    /// 0x0504_0002.
    InvalidBlockSize = 0x0504_0002, "invalid block size (block mode only)";
    /// 0x0504_0003.
    InvalidSequenceNumber = 0x0504_0003, "invalid sequence number (block mode only)";
    /// 0x0504_0004.
    CrcError = 0x0504_0004, "CRC error (block mode only)";
    /// 0x0504_0005.
    OutOfMemory = 0x0504_0005, "out of memory";
    /// 0x0601_0000.
    UnsupportedAccess = 0x0601_0000, "unsupported access to an object";
    /// 0x0601_0001.
    ReadWriteOnly = 0x0601_0001, "attempt to read a write only object";
    /// 0x0601_0002.
    WriteReadOnly = 0x0601_0002, "attempt to write a read only object";
    /// 0x0602_0000.
    ObjectDoesNotExist = 0x0602_0000, "object does not exist in the object dictionary";
    /// 0x0604_0041.
    NotMappable = 0x0604_0041, "object cannot be mapped to the PDO";
    /// 0x0604_0042.
    PdoLengthExceeded = 0x0604_0042, "the number and length of the objects to be mapped would exceed PDO length";
    /// 0x0604_0043.
    ParameterIncompatible = 0x0604_0043, "general parameter incompatibility reason";
    /// 0x0604_0047.
    InternalIncompatible = 0x0604_0047, "general internal incompatibility in the device";
    /// 0x0606_0000.
    HardwareError = 0x0606_0000, "access failed due to a hardware error";
    /// 0x0607_0010.
    LengthMismatch = 0x0607_0010, "data type does not match, length of service parameter does not match";
    /// 0x0607_0012.
    LengthTooHigh = 0x0607_0012, "data type does not match, length of service parameter too high";
    /// 0x0607_0013.
    LengthTooLow = 0x0607_0013, "data type does not match, length of service parameter too low";
    /// 0x0609_0011.
    SubIndexDoesNotExist = 0x0609_0011, "sub-index does not exist";
    /// 0x0609_0030.
    InvalidValue = 0x0609_0030, "invalid value for parameter (download only)";
    /// 0x0609_0031.
    ValueTooHigh = 0x0609_0031, "value of parameter written too high (download only)";
    /// 0x0609_0032.
    ValueTooLow = 0x0609_0032, "value of parameter written too low (download only)";
    /// 0x0609_0036.
    MaxLessThanMin = 0x0609_0036, "maximum value is less than minimum value";
    /// 0x060A_0023.
    ResourceNotAvailable = 0x060A_0023, "resource not available: SDO connection";
    /// 0x0800_0000.
    GeneralError = 0x0800_0000, "general error";
    /// 0x0800_0020.
    CannotStore = 0x0800_0020, "data cannot be transferred or stored to the application";
    /// 0x0800_0021.
    LocalControl = 0x0800_0021, "data cannot be transferred or stored to the application because of local control";
    /// 0x0800_0022.
    DeviceState = 0x0800_0022, "data cannot be transferred or stored to the application because of the present device state";
    /// 0x0800_0023.
    NoObjectDictionary = 0x0800_0023, "object dictionary dynamic generation fails or no object dictionary is present";
    /// 0x0800_0024.
    NoDataAvailable = 0x0800_0024, "no data available";
}

/// An object dictionary entry: index and subindex.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Object {
    /// Index (e.g. 0x6040).
    pub index: u16,
    /// Subindex.
    pub sub: u8,
}

impl Object {
    /// The entry `index:sub`.
    pub const fn new(index: u16, sub: u8) -> Self {
        Object { index, sub }
    }
}

/// `data` in an array of `N` bytes with its length, if it holds
/// `min..=N` bytes (else an error naming `message` and the range).
fn short<const N: usize>(
    data: &[u8],
    message: &'static str,
    min: usize,
) -> Result<(u8, [u8; N]), EncodeError> {
    if data.len() < min || data.len() > N {
        return Err(EncodeError::PayloadLength {
            message,
            len: data.len(),
            min: min as u8,
            max: N as u8,
        });
    }
    let mut bytes = [0u8; N];
    bytes[..data.len()].copy_from_slice(data);
    Ok((data.len() as u8, bytes))
}

/// The 1..=4 bytes of an expedited SDO transfer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SdoData {
    len: u8,
    bytes: [u8; 4],
}

impl SdoData {
    /// 1..=4 bytes, little-endian as the object's type is.
    pub fn new(data: &[u8]) -> Result<Self, EncodeError> {
        let (len, bytes) = short::<4>(data, "expedited SDO", 1)?;
        Ok(SdoData { len, bytes })
    }

    /// The bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes[..self.len as usize]
    }

    /// The bytes as an unsigned little-endian number (zero-extended).
    pub const fn as_u32(&self) -> u32 {
        u32::from_le_bytes(self.bytes)
    }
}

/// The 0..=8 bytes of a PDO, raw (their meaning is the node's mapping).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct PdoData {
    len: u8,
    bytes: [u8; 8],
}

impl PdoData {
    /// 0..=8 bytes.
    pub fn new(data: &[u8]) -> Result<Self, EncodeError> {
        let (len, bytes) = short::<8>(data, "PDO", 0)?;
        Ok(PdoData { len, bytes })
    }

    /// The bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes[..self.len as usize]
    }
}

/// The 0..=7 bytes of one segment of a segmented SDO transfer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SegmentData {
    len: u8,
    bytes: [u8; 7],
}

impl SegmentData {
    /// The most bytes a segment carries.
    pub const MAX: usize = 7;

    /// 0..=7 bytes.
    pub fn new(data: &[u8]) -> Result<Self, EncodeError> {
        let (len, bytes) = short::<{ SegmentData::MAX }>(data, "SDO segment", 0)?;
        Ok(SegmentData { len, bytes })
    }

    /// The bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes[..self.len as usize]
    }
}

/// An SDO request, client (master) → server (node), on 0x600 + node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SdoRequest {
    /// Expedited initiate download (write): `ccs` 1, `e` = `s` = 1; command
    /// byte 0x23/0x27/0x2B/0x2F for 4/3/2/1 bytes.
    Download {
        /// Entry written.
        object: Object,
        /// Value.
        data: SdoData,
    },
    /// Initiate segmented download (write of more than 4 bytes): `ccs` 1,
    /// `e` = 0; command byte 0x21 with the size, 0x20 without.
    DownloadSegmented {
        /// Entry written.
        object: Object,
        /// Byte count, if indicated (`s` = 1).
        size: Option<u32>,
    },
    /// One download segment: `ccs` 0, toggle bit 4 (0 for the first
    /// segment, then alternating), `n` = 7 − len in bits 1-3, `c` (last) in
    /// bit 0; data in bytes 1..=7.
    DownloadSegment {
        /// The toggle bit.
        toggle: bool,
        /// The segment's bytes.
        data: SegmentData,
        /// No more segments follow (`c`).
        last: bool,
    },
    /// Initiate upload (read): command byte 0x40.
    Upload {
        /// Entry read.
        object: Object,
    },
    /// Request the next upload segment: `ccs` 3, toggle bit 4 (command byte
    /// 0x60 or 0x70).
    UploadSegment {
        /// The toggle bit.
        toggle: bool,
    },
    /// Abort transfer: command byte 0x80.
    Abort {
        /// Entry of the transfer.
        object: Object,
        /// Why.
        code: AbortCode,
    },
}

/// An SDO response, server (node) → client (master), on 0x580 + node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SdoResponse {
    /// Initiate download response (write done): command byte 0x60.
    DownloadAck {
        /// Entry written.
        object: Object,
    },
    /// Expedited initiate upload response: `scs` 2, `e` = `s` = 1; command
    /// byte 0x43/0x47/0x4B/0x4F for 4/3/2/1 bytes.
    Upload {
        /// Entry read.
        object: Object,
        /// Value.
        data: SdoData,
    },
    /// Segmented initiate upload response (`e` = 0): the value is longer
    /// than 4 bytes; command byte 0x41 with the size, 0x40 without. The
    /// client then asks for [`SdoRequest::UploadSegment`]s.
    UploadSegmented {
        /// Entry read.
        object: Object,
        /// Byte count, if indicated (`s` = 1).
        size: Option<u32>,
    },
    /// Download segment response: `scs` 1, the segment's toggle bit 4
    /// (command byte 0x20 or 0x30).
    DownloadSegmentAck {
        /// The toggle bit of the segment acknowledged.
        toggle: bool,
    },
    /// One upload segment: `scs` 0, toggle bit 4, `n` = 7 − len in bits
    /// 1-3, `c` (last) in bit 0; data in bytes 1..=7.
    UploadSegment {
        /// The toggle bit (that of the request answered).
        toggle: bool,
        /// The segment's bytes.
        data: SegmentData,
        /// No more segments follow (`c`).
        last: bool,
    },
    /// Abort transfer: command byte 0x80.
    Abort {
        /// Entry of the transfer.
        object: Object,
        /// Why.
        code: AbortCode,
    },
}

/// An emergency message (CiA 301 EMCY write protocol).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Emcy {
    /// Emergency error code (0x0000: error reset / no error).
    pub code: u16,
    /// The error register (object 0x1001).
    pub register: u8,
    /// Manufacturer-specific error field.
    pub manufacturer: [u8; 5],
}

/// The class of an emergency error code (CiA 301's emergency error-code table, the high
/// nibble or byte; CiA 402 codes refine these, e.g. 0x2310 over-current,
/// 0x3210 DC-link over-voltage, 0x8611 following error).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EmcyClass {
    /// 0x00xx: error reset or no error.
    NoError,
    /// 0x10xx: generic error.
    Generic,
    /// 0x2xxx: current (CiA 402: 0x23xx device output side, e.g.
    /// 0x2310 continuous over-current).
    Current,
    /// 0x3xxx: voltage (CiA 402: 0x32xx DC link, 0x3210 over-voltage,
    /// 0x3220 under-voltage).
    Voltage,
    /// 0x4xxx: temperature.
    Temperature,
    /// 0x5xxx: device hardware.
    DeviceHardware,
    /// 0x6xxx: device software.
    DeviceSoftware,
    /// 0x7xxx: additional modules (CiA 402: 0x73xx sensors/encoders).
    AdditionalModules,
    /// 0x8xxx: monitoring (0x81xx communication, 0x8130 heartbeat or life
    /// guard; CiA 402: 0x86xx positioning controller, 0x8611 following
    /// error).
    Monitoring,
    /// 0x9xxx: external error.
    External,
    /// 0xF0xx: additional functions.
    AdditionalFunctions,
    /// 0xFFxx: device specific.
    DeviceSpecific,
    /// Any other code (0x01xx..0x0Fxx, 0xAxxx..0xExxx, 0xF1xx..0xFExx).
    Unassigned,
}

impl Emcy {
    /// The class of [`Emcy::code`].
    pub const fn class(&self) -> EmcyClass {
        match self.code >> 8 {
            0x00 => EmcyClass::NoError,
            0x10 => EmcyClass::Generic,
            0xF0 => EmcyClass::AdditionalFunctions,
            0xFF => EmcyClass::DeviceSpecific,
            _ => match self.code >> 12 {
                0x2 => EmcyClass::Current,
                0x3 => EmcyClass::Voltage,
                0x4 => EmcyClass::Temperature,
                0x5 => EmcyClass::DeviceHardware,
                0x6 => EmcyClass::DeviceSoftware,
                0x7 => EmcyClass::AdditionalModules,
                0x8 => EmcyClass::Monitoring,
                0x9 => EmcyClass::External,
                _ => EmcyClass::Unassigned,
            },
        }
    }
}

/// One CANopen message of the implemented subset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Message {
    /// NMT node control on 0x000.
    Nmt {
        /// The command.
        command: NmtCommand,
        /// Addressed node; `None` is node byte 0, all nodes.
        node: Option<NodeId>,
    },
    /// SYNC on 0x080.
    Sync {
        /// The optional counter byte (CiA 301 v4.2: 1..=240 when the
        /// producer's overflow value 0x1019 is set; carried as is).
        counter: Option<u8>,
    },
    /// EMCY on 0x080 + node.
    Emcy {
        /// Producer.
        node: NodeId,
        /// Contents.
        emcy: Emcy,
    },
    /// A transmit PDO, node → master.
    Tpdo {
        /// Producer.
        node: NodeId,
        /// Which.
        pdo: Pdo,
        /// Raw mapped bytes.
        data: PdoData,
    },
    /// A receive PDO, master → node.
    Rpdo {
        /// Consumer.
        node: NodeId,
        /// Which.
        pdo: Pdo,
        /// Raw mapped bytes.
        data: PdoData,
    },
    /// An SDO request on 0x600 + node.
    SdoRequest {
        /// Server node.
        node: NodeId,
        /// Request.
        sdo: SdoRequest,
    },
    /// An SDO response on 0x580 + node.
    SdoResponse {
        /// Server node.
        node: NodeId,
        /// Response.
        sdo: SdoResponse,
    },
    /// Heartbeat (or boot-up, [`NmtState::BootUp`]) on 0x700 + node.
    Heartbeat {
        /// Producer.
        node: NodeId,
        /// Its NMT state.
        state: NmtState,
    },
}

fn sdo_header(d: &mut [u8; 8], command: u8, object: Object) {
    d[0] = command;
    d[1..3].copy_from_slice(&object.index.to_le_bytes());
    d[3] = object.sub;
}

/// The expedited command byte: `cs << 5 | n << 2 | e << 1 | s`, n = 4 − len.
fn expedited(cs: u8, data: &SdoData, d: &mut [u8; 8]) -> u8 {
    d[4..8].copy_from_slice(&data.bytes);
    (cs << 5) | ((4 - data.len) << 2) | 0b11
}

/// A segment's command byte, `cs << 5 | t << 4 | n << 1 | c` with n = 7 −
/// len; its data goes to bytes 1..=7 (the rest stays zero).
fn segment(cs: u8, toggle: bool, data: &SegmentData, last: bool, d: &mut [u8; 8]) -> u8 {
    d[1..1 + data.len as usize].copy_from_slice(data.bytes());
    (cs << 5) | (toggle as u8) << 4 | (7 - data.len) << 1 | last as u8
}

/// The data of a segment: `n` (bits 1-3) counts the unused bytes.
fn segment_data(d: &[u8]) -> SegmentData {
    let len = 7 - ((d[0] >> 1) & 0b111) as usize;
    SegmentData::new(&d[1..1 + len]).expect("0..=7 bytes")
}

impl Message {
    /// The object this message travels on.
    pub const fn function(&self) -> Function {
        match *self {
            Message::Nmt { .. } => Function::Nmt,
            Message::Sync { .. } => Function::Sync,
            Message::Emcy { node, .. } => Function::Emcy(node),
            Message::Tpdo { node, pdo, .. } => Function::Tpdo(pdo, node),
            Message::Rpdo { node, pdo, .. } => Function::Rpdo(pdo, node),
            Message::SdoRequest { node, .. } => Function::SdoRx(node),
            Message::SdoResponse { node, .. } => Function::SdoTx(node),
            Message::Heartbeat { node, .. } => Function::Heartbeat(node),
        }
    }

    /// The classic data frame carrying this message.
    pub fn encode(&self) -> Frame {
        let id = Id::Standard(self.function().cob_id());
        let mut d = [0u8; 8];
        let len = match *self {
            Message::Nmt { command, node } => {
                d[0] = command.raw();
                d[1] = node.map_or(0, NodeId::get);
                2
            }
            Message::Sync { counter } => {
                d[0] = counter.unwrap_or(0);
                counter.is_some() as usize
            }
            Message::Emcy { emcy, .. } => {
                d[0..2].copy_from_slice(&emcy.code.to_le_bytes());
                d[2] = emcy.register;
                d[3..8].copy_from_slice(&emcy.manufacturer);
                8
            }
            Message::Tpdo { data, .. } | Message::Rpdo { data, .. } => {
                d = data.bytes;
                data.len as usize
            }
            Message::SdoRequest { sdo, .. } => {
                match sdo {
                    SdoRequest::Download { object, data } => {
                        let c = expedited(1, &data, &mut d);
                        sdo_header(&mut d, c, object);
                    }
                    SdoRequest::DownloadSegmented { object, size } => {
                        sdo_header(&mut d, 0x20 | size.is_some() as u8, object);
                        d[4..8].copy_from_slice(&size.unwrap_or(0).to_le_bytes());
                    }
                    SdoRequest::DownloadSegment { toggle, data, last } => {
                        d[0] = segment(0, toggle, &data, last, &mut d);
                    }
                    SdoRequest::Upload { object } => sdo_header(&mut d, 0x40, object),
                    SdoRequest::UploadSegment { toggle } => d[0] = 0x60 | (toggle as u8) << 4,
                    SdoRequest::Abort { object, code } => {
                        sdo_header(&mut d, 0x80, object);
                        d[4..8].copy_from_slice(&code.raw().to_le_bytes());
                    }
                }
                8
            }
            Message::SdoResponse { sdo, .. } => {
                match sdo {
                    SdoResponse::DownloadAck { object } => sdo_header(&mut d, 0x60, object),
                    SdoResponse::Upload { object, data } => {
                        let c = expedited(2, &data, &mut d);
                        sdo_header(&mut d, c, object);
                    }
                    SdoResponse::UploadSegmented { object, size } => {
                        sdo_header(&mut d, 0x40 | size.is_some() as u8, object);
                        d[4..8].copy_from_slice(&size.unwrap_or(0).to_le_bytes());
                    }
                    SdoResponse::DownloadSegmentAck { toggle } => d[0] = 0x20 | (toggle as u8) << 4,
                    SdoResponse::UploadSegment { toggle, data, last } => {
                        d[0] = segment(0, toggle, &data, last, &mut d);
                    }
                    SdoResponse::Abort { object, code } => {
                        sdo_header(&mut d, 0x80, object);
                        d[4..8].copy_from_slice(&code.raw().to_le_bytes());
                    }
                }
                8
            }
            Message::Heartbeat { state, .. } => {
                d[0] = state.raw();
                1
            }
        };
        Frame::new(id, &d[..len]).expect("8 bytes or less")
    }
}

fn length(message: &'static str, len: usize, min: u8, max: u8) -> Result<(), DecodeError> {
    if len < min as usize || len > max as usize {
        Err(DecodeError::Length {
            message,
            len: len as u8,
            min,
            max,
        })
    } else {
        Ok(())
    }
}

fn u32_at(d: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([d[at], d[at + 1], d[at + 2], d[at + 3]])
}

fn object_at(d: &[u8]) -> Object {
    Object::new(u16::from_le_bytes([d[1], d[2]]), d[3])
}

/// The data of an expedited transfer: `n` counts the unused bytes when
/// `s` = 1; with `s` = 0 the size is not indicated and all 4 are taken.
fn expedited_data(d: &[u8]) -> SdoData {
    let len = if d[0] & 1 == 1 {
        4 - ((d[0] >> 2) & 0b11) as usize
    } else {
        4
    };
    SdoData::new(&d[4..4 + len]).expect("1..=4 bytes")
}

fn sdo_request(d: &[u8]) -> Result<SdoRequest, DecodeError> {
    const M: &str = "SDO request";
    let object = object_at(d);
    Ok(match d[0] >> 5 {
        1 if d[0] & 0b10 != 0 => SdoRequest::Download {
            object,
            data: expedited_data(d),
        },
        1 => SdoRequest::DownloadSegmented {
            object,
            size: (d[0] & 1 == 1).then(|| u32_at(d, 4)),
        },
        0 => SdoRequest::DownloadSegment {
            toggle: d[0] & 0x10 != 0,
            data: segment_data(d),
            last: d[0] & 1 == 1,
        },
        2 => SdoRequest::Upload { object },
        3 => SdoRequest::UploadSegment {
            toggle: d[0] & 0x10 != 0,
        },
        4 => SdoRequest::Abort {
            object,
            code: AbortCode::from_raw(u32_at(d, 4)),
        },
        _ => {
            return Err(DecodeError::SdoCommand {
                message: M,
                command: d[0],
                expected: "a download 0x2_, download segment 0x0_/0x1_, upload 0x40, \
                           upload segment 0x60/0x70 or abort 0x80",
            });
        }
    })
}

fn sdo_response(d: &[u8]) -> Result<SdoResponse, DecodeError> {
    const M: &str = "SDO response";
    let object = object_at(d);
    Ok(match d[0] >> 5 {
        3 => SdoResponse::DownloadAck { object },
        2 if d[0] & 0b10 != 0 => SdoResponse::Upload {
            object,
            data: expedited_data(d),
        },
        2 => SdoResponse::UploadSegmented {
            object,
            size: (d[0] & 1 == 1).then(|| u32_at(d, 4)),
        },
        1 => SdoResponse::DownloadSegmentAck {
            toggle: d[0] & 0x10 != 0,
        },
        0 => SdoResponse::UploadSegment {
            toggle: d[0] & 0x10 != 0,
            data: segment_data(d),
            last: d[0] & 1 == 1,
        },
        4 => SdoResponse::Abort {
            object,
            code: AbortCode::from_raw(u32_at(d, 4)),
        },
        _ => {
            return Err(DecodeError::SdoCommand {
                message: M,
                command: d[0],
                expected: "a download response 0x60, segment response 0x20/0x30, \
                           upload response 0x4_, upload segment 0x0_/0x1_ or abort 0x80",
            });
        }
    })
}

/// The message a classic 11-bit data frame carries.
pub fn decode(frame: &Frame) -> Result<Message, DecodeError> {
    let raw = frame
        .id()
        .as_standard()
        .ok_or(DecodeError::ExtendedId(frame.id().raw()))?;
    match frame.kind() {
        Kind::Fd { .. } => return Err(DecodeError::FdFrame(raw)),
        Kind::Remote { .. } => return Err(DecodeError::RemoteFrame(raw)),
        Kind::Data => {}
    }
    let d = frame.data();
    Ok(match classify(raw)? {
        Function::Nmt => {
            const M: &str = "NMT";
            length(M, d.len(), 2, 2)?;
            Message::Nmt {
                command: NmtCommand::from_raw(M, d[0])?,
                node: match d[1] {
                    0 => None,
                    n => Some(NodeId::new(n).map_err(|_| DecodeError::UnknownValue {
                        message: M,
                        field: "node",
                        raw: n as u32,
                        expected: "0 (all) or a node id 1..=127",
                    })?),
                },
            }
        }
        Function::Sync => {
            length("SYNC", d.len(), 0, 1)?;
            Message::Sync {
                counter: d.first().copied(),
            }
        }
        Function::Emcy(node) => {
            length("EMCY", d.len(), EMCY_LEN, EMCY_LEN)?;
            Message::Emcy {
                node,
                emcy: Emcy {
                    code: u16::from_le_bytes([d[0], d[1]]),
                    register: d[2],
                    manufacturer: [d[3], d[4], d[5], d[6], d[7]],
                },
            }
        }
        Function::Tpdo(pdo, node) => Message::Tpdo {
            node,
            pdo,
            data: PdoData::new(d).expect("a classic frame holds 8 bytes or less"),
        },
        Function::Rpdo(pdo, node) => Message::Rpdo {
            node,
            pdo,
            data: PdoData::new(d).expect("a classic frame holds 8 bytes or less"),
        },
        Function::SdoRx(node) => {
            length("SDO request", d.len(), SDO_LEN, SDO_LEN)?;
            Message::SdoRequest {
                node,
                sdo: sdo_request(d)?,
            }
        }
        Function::SdoTx(node) => {
            length("SDO response", d.len(), SDO_LEN, SDO_LEN)?;
            Message::SdoResponse {
                node,
                sdo: sdo_response(d)?,
            }
        }
        Function::Heartbeat(node) => {
            const M: &str = "heartbeat";
            length(M, d.len(), 1, 1)?;
            Message::Heartbeat {
                node,
                state: NmtState::from_raw(M, d[0])?,
            }
        }
    })
}

/// CiA 402 (drives and motion control): object indices, the statusword's
/// drive states and the controlword's commands.
pub mod cia402 {
    use super::DecodeError;

    /// 0x1006 communication cycle period (u32, µs; CiA 301).
    pub const COMMUNICATION_CYCLE_PERIOD: u16 = 0x1006;
    /// 0x1016 consumer heartbeat time (array of u32: node << 16 | ms; CiA 301).
    pub const HEARTBEAT_CONSUMER: u16 = 0x1016;
    /// 0x1017 producer heartbeat time (u16, ms; CiA 301).
    pub const HEARTBEAT_PRODUCER: u16 = 0x1017;
    /// 0x6040 controlword (u16).
    pub const CONTROLWORD: u16 = 0x6040;
    /// 0x6041 statusword (u16).
    pub const STATUSWORD: u16 = 0x6041;
    /// 0x6060 modes of operation (i8; 8 = cyclic synchronous position).
    pub const MODES_OF_OPERATION: u16 = 0x6060;
    /// 0x6061 modes of operation display (i8).
    pub const MODES_OF_OPERATION_DISPLAY: u16 = 0x6061;
    /// 0x6064 position actual value (i32, increments).
    pub const POSITION_ACTUAL: u16 = 0x6064;
    /// 0x606C velocity actual value (i32).
    pub const VELOCITY_ACTUAL: u16 = 0x606C;
    /// 0x6076 motor rated torque (u32, mNm): the unit of the torque objects.
    pub const RATED_TORQUE: u16 = 0x6076;
    /// 0x6077 torque actual value (i16, ‰ of rated torque).
    pub const TORQUE_ACTUAL: u16 = 0x6077;
    /// 0x607A target position (i32).
    pub const TARGET_POSITION: u16 = 0x607A;
    /// 0x60B1 velocity offset (i32).
    pub const VELOCITY_OFFSET: u16 = 0x60B1;
    /// 0x60B2 torque offset (i16, ‰ of rated torque).
    pub const TORQUE_OFFSET: u16 = 0x60B2;
    /// 0x60C2 interpolation time period (record: sub 1 value u8, sub 2
    /// index i8, period = value × 10^index s).
    pub const INTERPOLATION_TIME_PERIOD: u16 = 0x60C2;
    /// 0x6060 value of cyclic synchronous position mode.
    pub const MODE_CSP: i8 = 8;

    /// A PDO mapping entry (CiA 301: index << 16 | sub << 8 | bit length).
    pub const fn mapping_entry(index: u16, sub: u8, bits: u8) -> u32 {
        (index as u32) << 16 | (sub as u32) << 8 | bits as u32
    }

    /// RPDO1 as anguilla's master maps it (`docs/drives.md`): controlword,
    /// target position, torque offset — 8 bytes, little-endian.
    pub const CSP_RPDO1: [u32; 3] = [
        mapping_entry(CONTROLWORD, 0, 16),
        mapping_entry(TARGET_POSITION, 0, 32),
        mapping_entry(TORQUE_OFFSET, 0, 16),
    ];

    /// TPDO1 as anguilla's master maps it: statusword, position actual,
    /// torque actual — 8 bytes, little-endian.
    pub const CSP_TPDO1: [u32; 3] = [
        mapping_entry(STATUSWORD, 0, 16),
        mapping_entry(POSITION_ACTUAL, 0, 32),
        mapping_entry(TORQUE_ACTUAL, 0, 16),
    ];

    /// What RPDO1 ([`CSP_RPDO1`]) carries to a drive each period.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct CspCommand {
        /// 0x6040.
        pub controlword: u16,
        /// 0x607A, increments.
        pub target: i32,
        /// 0x60B2, ‰ of the rated torque.
        pub torque_offset: i16,
    }

    /// What TPDO1 ([`CSP_TPDO1`]) reports at each SYNC.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct CspStatus {
        /// 0x6041.
        pub statusword: u16,
        /// 0x6064, increments.
        pub position: i32,
        /// 0x6077, ‰ of the rated torque.
        pub torque: i16,
    }

    fn pack(a: u16, b: i32, c: i16) -> super::PdoData {
        let mut d = [0u8; 8];
        d[0..2].copy_from_slice(&a.to_le_bytes());
        d[2..6].copy_from_slice(&b.to_le_bytes());
        d[6..8].copy_from_slice(&c.to_le_bytes());
        super::PdoData::new(&d).expect("8 bytes")
    }

    fn unpack(data: &super::PdoData) -> Option<(u16, i32, i16)> {
        let d: &[u8; 8] = data.bytes().try_into().ok()?;
        Some((
            u16::from_le_bytes([d[0], d[1]]),
            i32::from_le_bytes([d[2], d[3], d[4], d[5]]),
            i16::from_le_bytes([d[6], d[7]]),
        ))
    }

    impl CspCommand {
        /// The RPDO's 8 bytes.
        pub fn to_pdo(self) -> super::PdoData {
            pack(self.controlword, self.target, self.torque_offset)
        }

        /// From an RPDO's bytes; `None` unless exactly 8.
        pub fn from_pdo(data: &super::PdoData) -> Option<Self> {
            let (controlword, target, torque_offset) = unpack(data)?;
            Some(CspCommand {
                controlword,
                target,
                torque_offset,
            })
        }
    }

    impl CspStatus {
        /// The TPDO's 8 bytes.
        pub fn to_pdo(self) -> super::PdoData {
            pack(self.statusword, self.position, self.torque)
        }

        /// From a TPDO's bytes; `None` unless exactly 8.
        pub fn from_pdo(data: &super::PdoData) -> Option<Self> {
            let (statusword, position, torque) = unpack(data)?;
            Some(CspStatus {
                statusword,
                position,
                torque,
            })
        }
    }

    /// The states of the CiA 402 power drive system state machine.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
    pub enum DriveState {
        /// Statusword `xxxx xxxx x0xx 0000`.
        NotReadyToSwitchOn,
        /// `xxxx xxxx x1xx 0000`.
        SwitchOnDisabled,
        /// `xxxx xxxx x01x 0001`.
        ReadyToSwitchOn,
        /// `xxxx xxxx x01x 0011`.
        SwitchedOn,
        /// `xxxx xxxx x01x 0111`: power on, setpoints followed.
        OperationEnabled,
        /// `xxxx xxxx x00x 0111`.
        QuickStopActive,
        /// `xxxx xxxx x0xx 1111`.
        FaultReactionActive,
        /// `xxxx xxxx x0xx 1000`.
        Fault,
    }

    impl DriveState {
        /// Every state.
        pub const ALL: [DriveState; 8] = [
            DriveState::NotReadyToSwitchOn,
            DriveState::SwitchOnDisabled,
            DriveState::ReadyToSwitchOn,
            DriveState::SwitchedOn,
            DriveState::OperationEnabled,
            DriveState::QuickStopActive,
            DriveState::FaultReactionActive,
            DriveState::Fault,
        ];

        /// The state bits' (mask, value) pattern: bits 0-3 and 6 (mask
        /// 0x4F) where bit 5 (quick stop) is free, bits 0-3, 5, 6 (mask
        /// 0x6F) otherwise.
        pub const fn pattern(self) -> (u16, u16) {
            match self {
                DriveState::NotReadyToSwitchOn => (0x4F, 0x00),
                DriveState::SwitchOnDisabled => (0x4F, 0x40),
                DriveState::ReadyToSwitchOn => (0x6F, 0x21),
                DriveState::SwitchedOn => (0x6F, 0x23),
                DriveState::OperationEnabled => (0x6F, 0x27),
                DriveState::QuickStopActive => (0x6F, 0x07),
                DriveState::FaultReactionActive => (0x4F, 0x0F),
                DriveState::Fault => (0x4F, 0x08),
            }
        }

        /// The state a statusword (0x6041) reports.
        pub fn from_statusword(word: u16) -> Result<DriveState, DecodeError> {
            DriveState::ALL
                .into_iter()
                .find(|s| {
                    let (mask, value) = s.pattern();
                    word & mask == value
                })
                .ok_or(DecodeError::Statusword(word))
        }

        /// The next controlword command on the way from this state to
        /// [`DriveState::OperationEnabled`], or `None` where the drive moves
        /// on its own (not ready to switch on, fault reaction active) and
        /// the master waits. In Operation enabled it is Enable operation
        /// (keep sending it). Fault reset acts on a rising edge of bit 7:
        /// the word sent before it must have had bit 7 clear.
        pub const fn next_toward_enabled(self) -> Option<Command> {
            match self {
                DriveState::NotReadyToSwitchOn | DriveState::FaultReactionActive => None,
                DriveState::SwitchOnDisabled => Some(Command::Shutdown),
                DriveState::ReadyToSwitchOn => Some(Command::SwitchOn),
                DriveState::SwitchedOn | DriveState::OperationEnabled => {
                    Some(Command::EnableOperation)
                }
                DriveState::QuickStopActive => Some(Command::DisableVoltage),
                DriveState::Fault => Some(Command::FaultReset),
            }
        }
    }

    /// Controlword (0x6040) state-machine commands, bits 0-3 and 7.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
    #[repr(u16)]
    pub enum Command {
        /// 0x0000: → switch on disabled.
        DisableVoltage = 0x00,
        /// 0x0002: → quick stop active (from operation enabled).
        QuickStop = 0x02,
        /// 0x0006: → ready to switch on.
        Shutdown = 0x06,
        /// 0x0007: → switched on.
        SwitchOn = 0x07,
        /// 0x000F: → operation enabled.
        EnableOperation = 0x0F,
        /// 0x0080: fault → switch on disabled (on the rising edge).
        FaultReset = 0x80,
    }

    impl Command {
        /// The controlword value.
        pub const fn word(self) -> u16 {
            self as u16
        }
    }
}

pub mod eds;

#[cfg(test)]
mod tests;
