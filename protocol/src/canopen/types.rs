//! The CANopen vocabulary: node ids, function codes and COB-IDs, SDO
//! objects and transfers, PDO and EMCY payloads, NMT, and [`Message`], one
//! variant per frame the master and the drives exchange.

use super::error::{DecodeError, EncodeError};
use crate::frame::StandardId;

/// The largest CANopen node id.
pub const MAX_NODE_ID: u8 = 127;
/// Every SDO frame carries 8 bytes.
pub const SDO_LEN: u8 = 8;
/// Every EMCY frame carries 8 bytes.
pub const EMCY_LEN: u8 = 8;

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

            pub(super) fn from_raw(message: &'static str, raw: u8) -> Result<Self, DecodeError> {
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
    pub(super) len: u8,
    pub(super) bytes: [u8; 4],
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
    pub(super) len: u8,
    pub(super) bytes: [u8; 8],
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
    pub(super) len: u8,
    pub(super) bytes: [u8; 7],
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
