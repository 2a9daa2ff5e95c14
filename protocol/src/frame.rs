//! CAN frames as small `Copy` values with validating constructors.
//!
//! A [`Frame`] is what crosses a bus: an identifier (11-bit standard or 29-bit
//! extended), a kind (classic data, classic remote, or CAN FD) and up to 64
//! data bytes. Constructors check every field, so a `Frame` that exists is
//! always valid: a standard id fits in 11 bits (an [`Id`] holds a
//! [`StandardId`] or an [`ExtendedId`], whose values are private and
//! range-checked), a classic frame carries at most 8 bytes, an FD frame
//! carries one of the lengths a DLC can express.

use core::fmt;

/// Largest standard (11-bit) identifier.
pub const MAX_STANDARD_ID: u16 = 0x7FF;
/// Largest extended (29-bit) identifier.
pub const MAX_EXTENDED_ID: u32 = 0x1FFF_FFFF;
/// Most data bytes in a classic CAN frame.
pub const MAX_CLASSIC_LEN: usize = 8;
/// Most data bytes in a CAN FD frame.
pub const MAX_FD_LEN: usize = 64;

/// The data lengths a CAN FD frame can carry, indexed by DLC (0..=15).
pub const FD_LENGTHS: [u8; 16] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64];

/// What was wrong with the fields of a frame being built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// A standard identifier above 0x7FF.
    #[error("standard CAN id 0x{0:X} is out of range (expected 0x000..=0x7FF)")]
    StandardIdOutOfRange(u32),
    /// An extended identifier above 0x1FFFFFFF.
    #[error("extended CAN id 0x{0:X} is out of range (expected 0x00000000..=0x1FFFFFFF)")]
    ExtendedIdOutOfRange(u32),
    /// A classic frame with more than 8 data bytes.
    #[error("classic CAN frame of {0} bytes (expected 0..=8)")]
    ClassicTooLong(usize),
    /// An FD frame whose length no DLC expresses.
    #[error("CAN FD frame of {0} bytes (expected one of 0-8, 12, 16, 20, 24, 32, 48, 64)")]
    BadFdLength(usize),
    /// A remote frame with a DLC above 8.
    #[error("remote frame DLC {0} (expected 0..=8)")]
    BadRemoteDlc(u8),
}

/// An 11-bit CAN identifier (CAN 2.0A), always in 0x000..=0x7FF: the value
/// is private and every constructor checks it, as `embedded-can`'s
/// `StandardId` does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct StandardId(u16);

impl StandardId {
    /// Identifier 0x000 (the highest priority).
    pub const ZERO: Self = StandardId(0);
    /// Identifier 0x7FF (the lowest priority).
    pub const MAX: Self = StandardId(MAX_STANDARD_ID);

    /// A standard id, checked to fit in 11 bits.
    pub const fn new(raw: u16) -> Result<Self, FrameError> {
        if raw > MAX_STANDARD_ID {
            Err(FrameError::StandardIdOutOfRange(raw as u32))
        } else {
            Ok(StandardId(raw))
        }
    }

    /// A standard id from a literal: `const ID: StandardId =
    /// StandardId::literal(0x123);`. Out of range, it fails to compile in a
    /// constant and panics elsewhere, so give it only literals and use
    /// [`StandardId::new`] for values from outside.
    pub const fn literal(raw: u16) -> Self {
        match Self::new(raw) {
            Ok(id) => id,
            Err(_) => panic!("standard CAN id out of range (expected 0x000..=0x7FF)"),
        }
    }

    /// The 11 identifier bits.
    pub const fn as_raw(self) -> u16 {
        self.0
    }
}

/// A 29-bit CAN identifier (CAN 2.0B), always in 0x00000000..=0x1FFFFFFF:
/// the value is private and every constructor checks it, as
/// `embedded-can`'s `ExtendedId` does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ExtendedId(u32);

impl ExtendedId {
    /// Identifier 0x00000000.
    pub const ZERO: Self = ExtendedId(0);
    /// Identifier 0x1FFFFFFF.
    pub const MAX: Self = ExtendedId(MAX_EXTENDED_ID);

    /// An extended id, checked to fit in 29 bits.
    pub const fn new(raw: u32) -> Result<Self, FrameError> {
        if raw > MAX_EXTENDED_ID {
            Err(FrameError::ExtendedIdOutOfRange(raw))
        } else {
            Ok(ExtendedId(raw))
        }
    }

    /// An extended id from a literal (see [`StandardId::literal`]): out of
    /// range, it fails to compile in a constant and panics elsewhere.
    pub const fn literal(raw: u32) -> Self {
        match Self::new(raw) {
            Ok(id) => id,
            Err(_) => panic!("extended CAN id out of range (expected 0x00000000..=0x1FFFFFFF)"),
        }
    }

    /// The 29 identifier bits.
    pub const fn as_raw(self) -> u32 {
        self.0
    }
}

/// A CAN identifier, standard (11-bit) or extended (29-bit). Its variants
/// hold [`StandardId`] / [`ExtendedId`], which cannot be built out of
/// range, so an `Id` that exists is always valid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Id {
    /// An 11-bit identifier (CAN 2.0A).
    Standard(StandardId),
    /// A 29-bit identifier (CAN 2.0B).
    Extended(ExtendedId),
}

impl Id {
    /// A standard id, checked to fit in 11 bits.
    pub const fn standard(raw: u16) -> Result<Self, FrameError> {
        match StandardId::new(raw) {
            Ok(id) => Ok(Id::Standard(id)),
            Err(e) => Err(e),
        }
    }

    /// An extended id, checked to fit in 29 bits.
    pub const fn extended(raw: u32) -> Result<Self, FrameError> {
        match ExtendedId::new(raw) {
            Ok(id) => Ok(Id::Extended(id)),
            Err(e) => Err(e),
        }
    }

    /// A standard id from a literal ([`StandardId::literal`]).
    pub const fn standard_literal(raw: u16) -> Self {
        Id::Standard(StandardId::literal(raw))
    }

    /// An extended id from a literal ([`ExtendedId::literal`]).
    pub const fn extended_literal(raw: u32) -> Self {
        Id::Extended(ExtendedId::literal(raw))
    }

    /// The raw identifier bits.
    pub const fn raw(self) -> u32 {
        match self {
            Id::Standard(r) => r.0 as u32,
            Id::Extended(r) => r.0,
        }
    }

    /// The 11 bits of a standard id; `None` for an extended id.
    pub const fn as_standard(self) -> Option<u16> {
        match self {
            Id::Standard(r) => Some(r.0),
            Id::Extended(_) => None,
        }
    }

    /// Whether this is a 29-bit identifier.
    pub const fn is_extended(self) -> bool {
        matches!(self, Id::Extended(_))
    }

    /// Arbitration priority key: lower wins the bus. A standard id beats an
    /// extended id with the same 11 leading bits (its SRR/IDE bits are
    /// dominant where the extended frame's are recessive).
    pub const fn arbitration_key(self) -> u64 {
        // Bits in wire order: base id (11), SRR/RTR, IDE, extension (18).
        match self {
            Id::Standard(r) => (r.0 as u64) << 20,
            Id::Extended(r) => {
                let base = (r.0 >> 18) as u64;
                let ext = (r.0 & 0x3FFFF) as u64;
                (base << 20) | (1 << 19) | (1 << 18) | ext
            }
        }
    }
}

impl From<StandardId> for Id {
    fn from(id: StandardId) -> Self {
        Id::Standard(id)
    }
}

impl From<ExtendedId> for Id {
    fn from(id: ExtendedId) -> Self {
        Id::Extended(id)
    }
}

impl fmt::Display for Id {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Id::Standard(r) => write!(f, "{:03X}", r.0),
            Id::Extended(r) => write!(f, "{:08X}", r.0),
        }
    }
}

/// The kind of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    /// A classic CAN data frame (0..=8 bytes).
    Data,
    /// A classic remote transmission request; `dlc` is the requested length.
    Remote {
        /// The data length code carried by the request (0..=8).
        dlc: u8,
    },
    /// A CAN FD frame.
    Fd {
        /// Bit-rate switch: the data phase runs at the data bit rate.
        brs: bool,
        /// Error state indicator of the transmitter (error-passive when set).
        esi: bool,
    },
}

/// One CAN or CAN FD frame. Always valid once built; 72 bytes, `Copy`.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Frame {
    id: Id,
    kind: Kind,
    len: u8,
    data: [u8; MAX_FD_LEN],
}

impl Frame {
    /// A classic data frame with up to 8 bytes.
    pub fn new(id: Id, data: &[u8]) -> Result<Self, FrameError> {
        if data.len() > MAX_CLASSIC_LEN {
            return Err(FrameError::ClassicTooLong(data.len()));
        }
        Ok(Self::raw(id, Kind::Data, data))
    }

    /// A classic data frame on a standard id; panics never, errors on bad input.
    pub fn new_standard(id: u16, data: &[u8]) -> Result<Self, FrameError> {
        Self::new(Id::standard(id)?, data)
    }

    /// A CAN FD frame; `data.len()` must be a length a DLC expresses
    /// (see [`FD_LENGTHS`]; pad with [`fd_padded_len`] first if needed).
    pub fn new_fd(id: Id, data: &[u8], brs: bool) -> Result<Self, FrameError> {
        if data.len() > MAX_FD_LEN || !FD_LENGTHS.contains(&(data.len() as u8)) {
            return Err(FrameError::BadFdLength(data.len()));
        }
        Ok(Self::raw(id, Kind::Fd { brs, esi: false }, data))
    }

    /// A remote frame requesting `dlc` bytes (0..=8).
    pub fn new_remote(id: Id, dlc: u8) -> Result<Self, FrameError> {
        if dlc as usize > MAX_CLASSIC_LEN {
            return Err(FrameError::BadRemoteDlc(dlc));
        }
        Ok(Self {
            id,
            kind: Kind::Remote { dlc },
            len: 0,
            data: [0; MAX_FD_LEN],
        })
    }

    fn raw(id: Id, kind: Kind, data: &[u8]) -> Self {
        let mut buf = [0u8; MAX_FD_LEN];
        buf[..data.len()].copy_from_slice(data);
        Self {
            id,
            kind,
            len: data.len() as u8,
            data: buf,
        }
    }

    /// Returns the same frame with the FD error-state indicator set as given
    /// (no effect on classic frames).
    pub fn with_esi(mut self, esi_flag: bool) -> Self {
        if let Kind::Fd { brs, .. } = self.kind {
            self.kind = Kind::Fd { brs, esi: esi_flag };
        }
        self
    }

    /// The identifier.
    pub const fn id(&self) -> Id {
        self.id
    }

    /// The kind (data, remote, FD).
    pub const fn kind(&self) -> Kind {
        self.kind
    }

    /// Whether this is a CAN FD frame.
    pub const fn is_fd(&self) -> bool {
        matches!(self.kind, Kind::Fd { .. })
    }

    /// Whether this is a remote frame.
    pub const fn is_remote(&self) -> bool {
        matches!(self.kind, Kind::Remote { .. })
    }

    /// The data bytes (empty for a remote frame).
    pub fn data(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }

    /// Number of data bytes (0 for a remote frame).
    pub const fn len(&self) -> usize {
        self.len as usize
    }

    /// Whether the frame carries no data bytes.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The data length code on the wire.
    pub fn dlc(&self) -> u8 {
        match self.kind {
            Kind::Remote { dlc } => dlc,
            Kind::Data => self.len,
            Kind::Fd { .. } => fd_dlc(self.len as usize).unwrap_or(15),
        }
    }
}

impl fmt::Debug for Frame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Frame({self})")
    }
}

impl fmt::Display for Frame {
    /// can-utils `cansend` notation: `123#DEADBEEF`, `123#R`, `123##1DEAD`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.id)?;
        match self.kind {
            Kind::Remote { dlc } => {
                write!(f, "#R")?;
                if dlc > 0 {
                    write!(f, "{dlc}")?;
                }
                Ok(())
            }
            Kind::Data => {
                write!(f, "#")?;
                for b in self.data() {
                    write!(f, "{b:02X}")?;
                }
                Ok(())
            }
            Kind::Fd { brs, esi } => {
                let flags = (brs as u8) | ((esi as u8) << 1);
                write!(f, "##{flags:X}")?;
                for b in self.data() {
                    write!(f, "{b:02X}")?;
                }
                Ok(())
            }
        }
    }
}

/// The DLC of an FD frame of `len` bytes, if `len` is one a DLC expresses.
pub fn fd_dlc(len: usize) -> Option<u8> {
    FD_LENGTHS
        .iter()
        .position(|&l| l as usize == len)
        .map(|p| p as u8)
}

/// The smallest FD length that holds `len` bytes (`None` above 64).
pub fn fd_padded_len(len: usize) -> Option<usize> {
    FD_LENGTHS.iter().map(|&l| l as usize).find(|&l| l >= len)
}

/// Error classes of Linux's `linux/can/error.h`: the bits of an error
/// frame's class (its CAN id without `CAN_ERR_FLAG`), with can-utils' names.
pub mod error_class {
    /// TX timeout (by netdevice driver).
    pub const TX_TIMEOUT: u32 = 0x001;
    /// Lost arbitration (data\[0\]: the bit).
    pub const LOSTARB: u32 = 0x002;
    /// Controller problems (data\[1\]: [`super::controller`] bits).
    pub const CRTL: u32 = 0x004;
    /// Protocol violations (data\[2\] type, data\[3\] location).
    pub const PROT: u32 = 0x008;
    /// Transceiver status (data\[4\]).
    pub const TRX: u32 = 0x010;
    /// No acknowledge on transmission.
    pub const ACK: u32 = 0x020;
    /// Bus off.
    pub const BUSOFF: u32 = 0x040;
    /// Bus error (may flood).
    pub const BUSERROR: u32 = 0x080;
    /// Controller restarted after bus off.
    pub const RESTARTED: u32 = 0x100;
    /// Error counters (data\[6\] TX, data\[7\] RX).
    pub const CNT: u32 = 0x200;
    /// Each class bit with the name can-utils prints for it.
    pub const NAMES: [(u32, &str); 10] = [
        (TX_TIMEOUT, "tx-timeout"),
        (LOSTARB, "lost-arbitration"),
        (CRTL, "controller-problem"),
        (PROT, "protocol-violation"),
        (TRX, "transceiver-status"),
        (ACK, "no-acknowledgement-on-tx"),
        (BUSOFF, "bus-off"),
        (BUSERROR, "bus-error"),
        (RESTARTED, "restarted-after-bus-off"),
        (CNT, "error-counter-tx-rx"),
    ];
}

/// Controller-problem bits (data\[1\] of an [`error_class::CRTL`] error
/// frame), with can-utils' names.
pub mod controller {
    /// RX buffer overflow.
    pub const RX_OVERFLOW: u8 = 0x01;
    /// TX buffer overflow.
    pub const TX_OVERFLOW: u8 = 0x02;
    /// Reached warning level for RX errors.
    pub const RX_WARNING: u8 = 0x04;
    /// Reached warning level for TX errors.
    pub const TX_WARNING: u8 = 0x08;
    /// Reached error-passive status for RX.
    pub const RX_PASSIVE: u8 = 0x10;
    /// Reached error-passive status for TX.
    pub const TX_PASSIVE: u8 = 0x20;
    /// Recovered to error-active state.
    pub const ACTIVE: u8 = 0x40;
    /// Each bit with the name can-utils prints for it.
    pub const NAMES: [(u8, &str); 7] = [
        (RX_OVERFLOW, "rx-overflow"),
        (TX_OVERFLOW, "tx-overflow"),
        (RX_WARNING, "rx-error-warning"),
        (TX_WARNING, "tx-error-warning"),
        (RX_PASSIVE, "rx-error-passive"),
        (TX_PASSIVE, "tx-error-passive"),
        (ACTIVE, "back-to-error-active"),
    ];
}

/// Linux's `CAN_ERR_FLAG`: bit 29 of a `can_id`, set on an error frame.
pub const CAN_ERR_FLAG: u32 = 0x2000_0000;

/// An error frame: SocketCAN's report of a bus or controller error (not a
/// frame on the wire; nothing sends one). Its class is the 29-bit CAN id
/// without [`CAN_ERR_FLAG`]; up to 8 data bytes give the details. candump
/// and python-can log it as `20000080#0000000000000000` (class, flag set).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct ErrorFrame {
    class: u32,
    len: u8,
    data: [u8; MAX_CLASSIC_LEN],
}

impl ErrorFrame {
    /// An error frame of `class` (29 bits, without [`CAN_ERR_FLAG`]) and up
    /// to 8 data bytes.
    pub fn new(class: u32, data: &[u8]) -> Result<Self, FrameError> {
        if class > MAX_EXTENDED_ID {
            return Err(FrameError::ExtendedIdOutOfRange(class));
        }
        if data.len() > MAX_CLASSIC_LEN {
            return Err(FrameError::ClassicTooLong(data.len()));
        }
        let mut buf = [0u8; MAX_CLASSIC_LEN];
        buf[..data.len()].copy_from_slice(data);
        Ok(Self {
            class,
            len: data.len() as u8,
            data: buf,
        })
    }

    /// The error class bits ([`error_class`]).
    pub const fn class(&self) -> u32 {
        self.class
    }

    /// The detail bytes.
    pub fn data(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }

    /// What happened, in can-utils' words: `bus-error`,
    /// `controller-problem{rx-error-passive}`, `error-counter-tx-rx{{96}{0}}`;
    /// unknown class bits as hex.
    pub fn describe(&self) -> String {
        let byte = |i: usize| self.data().get(i).copied().unwrap_or(0);
        let mut parts: Vec<String> = Vec::new();
        for (bit, name) in error_class::NAMES {
            if self.class & bit == 0 {
                continue;
            }
            let detail = match bit {
                error_class::LOSTARB => format!("{{at bit {}}}", byte(0)),
                error_class::CRTL => {
                    let names: Vec<&str> = controller::NAMES
                        .iter()
                        .filter(|(b, _)| byte(1) & b != 0)
                        .map(|(_, n)| *n)
                        .collect();
                    format!("{{{}}}", names.join(","))
                }
                error_class::CNT => format!("{{{{{}}}{{{}}}}}", byte(6), byte(7)),
                _ => String::new(),
            };
            parts.push(format!("{name}{detail}"));
        }
        let known = error_class::NAMES.iter().fold(0, |m, (b, _)| m | b);
        if self.class & !known != 0 {
            parts.push(format!("unknown class 0x{:X}", self.class & !known));
        }
        if parts.is_empty() {
            parts.push("no class".into());
        }
        parts.join(",")
    }
}

impl fmt::Debug for ErrorFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ErrorFrame({self})")
    }
}

impl fmt::Display for ErrorFrame {
    /// can-utils' notation: the class with [`CAN_ERR_FLAG`] in 8 hex digits,
    /// `#`, the data (`20000080#0000000000000000`).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:08X}#", self.class | CAN_ERR_FLAG)?;
        for b in self.data() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every way to make an id checks its range, so `Frame::new(Id::..)`
    /// can no longer carry 0xFFFF as a standard id.
    #[test]
    fn every_id_constructor_rejects_out_of_range_values() {
        let std_err = Err(FrameError::StandardIdOutOfRange(0x800));
        let ext_err = Err(FrameError::ExtendedIdOutOfRange(0x2000_0000));
        assert_eq!(StandardId::new(0x800), std_err);
        assert_eq!(
            StandardId::new(0xFFFF).map(StandardId::as_raw),
            Err(FrameError::StandardIdOutOfRange(0xFFFF))
        );
        assert_eq!(Id::standard(0x800), std_err.map(Id::Standard));
        assert_eq!(ExtendedId::new(0x2000_0000), ext_err);
        assert_eq!(Id::extended(0x2000_0000), ext_err.map(Id::Extended));
        assert_eq!(
            Id::extended(u32::MAX),
            Err(FrameError::ExtendedIdOutOfRange(u32::MAX))
        );
        assert_eq!(
            Frame::new_standard(0xFFFF, &[]),
            Err(FrameError::StandardIdOutOfRange(0xFFFF))
        );
        for bad in [0x800u16, 0x1000, u16::MAX] {
            assert!(std::panic::catch_unwind(|| StandardId::literal(bad)).is_err());
            assert!(std::panic::catch_unwind(|| Id::standard_literal(bad)).is_err());
        }
        for bad in [0x2000_0000u32, u32::MAX] {
            assert!(std::panic::catch_unwind(|| ExtendedId::literal(bad)).is_err());
            assert!(std::panic::catch_unwind(|| Id::extended_literal(bad)).is_err());
        }
        // The edges are in range, and every constructor agrees on them.
        const TOP: StandardId = StandardId::literal(0x7FF);
        assert_eq!(TOP, StandardId::MAX);
        assert_eq!(Id::standard(0x7FF), Ok(Id::Standard(TOP)));
        assert_eq!(Id::standard_literal(0), Id::Standard(StandardId::ZERO));
        assert_eq!(ExtendedId::new(0x1FFF_FFFF), Ok(ExtendedId::MAX));
        assert_eq!(Id::extended_literal(0x1FFF_FFFF), Id::from(ExtendedId::MAX));
        assert_eq!(Id::from(StandardId::MAX).raw(), 0x7FF);
        assert_eq!(Id::extended_literal(5).as_standard(), None);
        assert_eq!(Id::standard_literal(5).as_standard(), Some(5));
    }

    /// A frame gives back the id it was built with, whichever constructor
    /// built the id, for the edges of both ranges and every frame kind.
    #[test]
    fn frames_round_trip_their_ids() {
        let ids = [
            Id::Standard(StandardId::ZERO),
            Id::standard(0x123).unwrap(),
            Id::standard_literal(0x7FF),
            Id::Extended(ExtendedId::ZERO),
            Id::extended(0x1234_5678).unwrap(),
            Id::extended_literal(0x1FFF_FFFF),
        ];
        for id in ids {
            let frames = [
                Frame::new(id, &[1, 2]).unwrap(),
                Frame::new_remote(id, 3).unwrap(),
                Frame::new_fd(id, &[0; 12], true).unwrap(),
            ];
            for f in frames {
                assert_eq!(f.id(), id, "{f}");
                let again = match id {
                    Id::Standard(s) => Id::standard(s.as_raw()),
                    Id::Extended(e) => Id::extended(e.as_raw()),
                };
                assert_eq!(again, Ok(f.id()));
                assert_eq!(f.id().raw(), id.raw());
            }
        }
    }

    #[test]
    fn lengths_are_checked() {
        let id = Id::standard_literal(0x123);
        assert!(Frame::new(id, &[0; 8]).is_ok());
        assert_eq!(Frame::new(id, &[0; 9]), Err(FrameError::ClassicTooLong(9)));
        assert!(Frame::new_fd(id, &[0; 12], true).is_ok());
        assert_eq!(
            Frame::new_fd(id, &[0; 10], true),
            Err(FrameError::BadFdLength(10))
        );
        assert!(Frame::new_remote(id, 9).is_err());
        assert_eq!(fd_padded_len(9), Some(12));
        assert_eq!(fd_padded_len(65), None);
        assert_eq!(fd_dlc(64), Some(15));
    }

    #[test]
    fn display_matches_cansend_notation() {
        let f = Frame::new(Id::standard_literal(0x123), &[0xDE, 0xAD]).unwrap();
        assert_eq!(f.to_string(), "123#DEAD");
        let r = Frame::new_remote(Id::extended_literal(0x1234), 2).unwrap();
        assert_eq!(r.to_string(), "00001234#R2");
        let fd = Frame::new_fd(Id::standard_literal(0x10), &[1], true).unwrap();
        assert_eq!(fd.to_string(), "010##101");
    }

    #[test]
    fn error_frames_print_as_can_utils_does() {
        let e = ErrorFrame::new(error_class::BUSERROR, &[0; 8]).unwrap();
        assert_eq!(e.to_string(), "20000080#0000000000000000");
        assert_eq!(e.describe(), "bus-error");
        let e = ErrorFrame::new(
            error_class::CRTL | error_class::CNT,
            &[
                0,
                controller::RX_PASSIVE | controller::TX_WARNING,
                0,
                0,
                0,
                0,
                96,
                3,
            ],
        )
        .unwrap();
        assert_eq!(
            e.describe(),
            "controller-problem{tx-error-warning,rx-error-passive},error-counter-tx-rx{{96}{3}}"
        );
        assert_eq!(
            ErrorFrame::new(0x400, &[]).unwrap().describe(),
            "unknown class 0x400"
        );
        assert!(ErrorFrame::new(0x2000_0000, &[]).is_err());
        assert!(ErrorFrame::new(1, &[0; 9]).is_err());
    }

    #[test]
    fn standard_wins_arbitration_over_extended_with_same_base() {
        let s = Id::standard_literal(0x100);
        let e = Id::extended_literal(0x100 << 18);
        assert!(s.arbitration_key() < e.arbitration_key());
        assert!(Id::standard_literal(0x0FF).arbitration_key() < s.arbitration_key());
    }
}
