//! The SLCAN (Lawicel ASCII) line codec: pure, allocation-free.
//!
//! Host → adapter commands ([`Command`]), one per line ending in `\r`:
//!
//! | line | meaning |
//! |---|---|
//! | `S0`..`S8` | bit rate 10k, 20k, 50k, 100k, 125k, 250k, 500k, 800k, 1M |
//! | `sXXYY` | SJA1000 bus timing registers BTR0/BTR1 |
//! | `O` / `L` / `C` | open / open listen-only / close the channel |
//! | `V` / `N` / `F` | version / serial number / status flags |
//! | `Z0` / `Z1` | millisecond timestamps off / on |
//! | `tIIILDD..` / `TIIIIIIIILDD..` | data frame, standard / extended id |
//! | `rIIIL` / `RIIIIIIIIL` | remote frame |
//! | `dIIIL..` `DIIIIIIIIL..` / `bIIIL..` `BIIIIIIIIL..` | CAN FD frame without / with bit-rate switch; `L` is the FD DLC `0`..`F` (CANable 2.0 slcan FD extension) |
//!
//! Adapter → host replies ([`Reply`]): `\r` (ok), `\x07` (BEL: error),
//! `z\r` / `Z\r` (frame queued), `Fxx\r` (status flags, hex),
//! `Vxxxx\r`, `Nxxxx\r`, and received frames in the same `t/T/r/R/d/D/b/B`
//! notation followed by 4 hex digits of milliseconds when timestamps are on.
//!
//! Garbage never panics: [`LineReader`] caps line length and resynchronises
//! at the next `\r`; the parsers return a [`CodecError`].

use anguilla_protocol::frame::{FD_LENGTHS, Id, Kind, MAX_FD_LEN};

use crate::{BusState, Frame};

/// Longest line: `B` + 8 id + 1 DLC + 128 data + 4 timestamp + `\r` = 143.
pub const MAX_LINE: usize = 160;

/// The BEL byte with which an adapter rejects a command.
pub const BEL: u8 = 0x07;

/// What is wrong with an SLCAN line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum CodecError {
    /// The line starts with a byte that is no command or reply.
    #[error("unknown SLCAN line starting with byte 0x{0:02X}")]
    Unknown(u8),
    /// A hex digit was expected.
    #[error("bad hex digit 0x{0:02X}")]
    BadHex(u8),
    /// The line has the wrong length for its kind.
    #[error("line of {got} bytes where {expected} were expected")]
    BadLength {
        /// Expected length (without `\r`).
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// The DLC does not fit the frame kind.
    #[error("bad DLC {0}")]
    BadDlc(u8),
    /// The identifier is out of range.
    #[error("identifier 0x{0:X} out of range")]
    BadId(u32),
    /// The bit-rate code is not `0`..`8`.
    #[error("bad bit-rate code '{0}' (expected S0..S8)")]
    BadBitrate(u8),
    /// A line longer than [`MAX_LINE`]; skipped up to the next `\r`.
    #[error("line longer than {MAX_LINE} bytes")]
    LineTooLong,
    /// Bytes followed by BEL, not by `\r`.
    #[error("unterminated bytes before BEL")]
    Unterminated,
}

/// The standard SLCAN bit rates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[allow(missing_docs)]
pub enum Bitrate {
    B10k,
    B20k,
    B50k,
    B100k,
    B125k,
    B250k,
    B500k,
    B800k,
    B1M,
}

impl Bitrate {
    const ALL: [(Bitrate, u32); 9] = [
        (Bitrate::B10k, 10_000),
        (Bitrate::B20k, 20_000),
        (Bitrate::B50k, 50_000),
        (Bitrate::B100k, 100_000),
        (Bitrate::B125k, 125_000),
        (Bitrate::B250k, 250_000),
        (Bitrate::B500k, 500_000),
        (Bitrate::B800k, 800_000),
        (Bitrate::B1M, 1_000_000),
    ];
    /// The accepted rates, for messages.
    pub const ACCEPTED: &'static str =
        "10000, 20000, 50000, 100000, 125000, 250000, 500000, 800000, 1000000";

    /// The rate for this many bit/s, if SLCAN has a code for it.
    pub fn from_bps(bps: u32) -> Option<Self> {
        Self::ALL.iter().find(|(_, b)| *b == bps).map(|(r, _)| *r)
    }
    /// Bits per second.
    pub fn bps(self) -> u32 {
        Self::ALL[self.code() as usize].1
    }
    /// The digit of the `Sn` command.
    pub fn code(self) -> u8 {
        Self::ALL.iter().position(|(r, _)| *r == self).unwrap_or(8) as u8
    }
    /// The rate of an `Sn` digit.
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.get(code as usize).map(|(r, _)| *r)
    }
}

/// The `F` status flag byte (Lawicel/SJA1000 layout).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StatusFlags(pub u8);

impl StatusFlags {
    /// Receive FIFO full.
    pub const RX_FIFO_FULL: u8 = 1 << 0;
    /// Transmit FIFO full.
    pub const TX_FIFO_FULL: u8 = 1 << 1;
    /// Error warning (an error counter reached 96).
    pub const ERROR_WARNING: u8 = 1 << 2;
    /// Data overrun: frames were lost.
    pub const DATA_OVERRUN: u8 = 1 << 3;
    /// Error passive.
    pub const ERROR_PASSIVE: u8 = 1 << 5;
    /// Arbitration lost.
    pub const ARBITRATION_LOST: u8 = 1 << 6;
    /// Bus error. Adapters differ; anguilla (and its emulator) read it as
    /// bus-off, the conservative choice: the reaction (close, reopen, purge)
    /// is safe for either meaning.
    pub const BUS_ERROR: u8 = 1 << 7;

    /// The controller state these flags imply.
    pub fn state(self) -> BusState {
        if self.0 & Self::BUS_ERROR != 0 {
            BusState::BusOff
        } else if self.0 & Self::ERROR_PASSIVE != 0 {
            BusState::ErrorPassive
        } else {
            BusState::ErrorActive
        }
    }
    /// Whether frames were lost in the adapter.
    pub fn overrun(self) -> bool {
        self.0 & (Self::DATA_OVERRUN | Self::RX_FIFO_FULL) != 0
    }
}

/// A host → adapter command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    /// `Sn`: standard bit rate.
    Bitrate(Bitrate),
    /// `sXXYY`: SJA1000 BTR0 and BTR1.
    Btr(u8, u8),
    /// `O`: open the channel.
    Open,
    /// `L`: open listen-only.
    ListenOnly,
    /// `C`: close the channel.
    Close,
    /// `V`: version.
    Version,
    /// `N`: serial number.
    SerialNumber,
    /// `F`: status flags.
    Status,
    /// `Z0`/`Z1`: timestamps.
    Timestamps(bool),
    /// A frame to transmit.
    Transmit(Frame),
}

/// An adapter → host reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reply {
    /// `\r`: command accepted.
    Ack,
    /// `\x07`: command rejected.
    Bell,
    /// `z\r` or `Z\r`: frame queued for transmission.
    TxAck,
    /// A received frame, with the adapter's millisecond counter if enabled.
    Frame {
        /// The frame.
        frame: Frame,
        /// Milliseconds (0..60000) when timestamps are on.
        timestamp: Option<u16>,
    },
    /// `Fxx\r`.
    Status(StatusFlags),
    /// `Vxxxx\r`.
    Version([u8; 4]),
    /// `Nxxxx\r`.
    Serial([u8; 4]),
}

const HEX: &[u8; 16] = b"0123456789ABCDEF";

fn hex_val(b: u8) -> Result<u8, CodecError> {
    match b {
        b'0'..=b'9' => Ok(b - b'0'),
        b'A'..=b'F' => Ok(b - b'A' + 10),
        b'a'..=b'f' => Ok(b - b'a' + 10),
        _ => Err(CodecError::BadHex(b)),
    }
}

fn hex_u32(s: &[u8]) -> Result<u32, CodecError> {
    s.iter()
        .try_fold(0u32, |acc, &b| Ok((acc << 4) | u32::from(hex_val(b)?)))
}

struct Out<'a> {
    buf: &'a mut [u8; MAX_LINE],
    n: usize,
}

impl Out<'_> {
    fn push(&mut self, b: u8) {
        self.buf[self.n] = b;
        self.n += 1;
    }
    fn hex(&mut self, v: u32, digits: usize) {
        for i in (0..digits).rev() {
            self.push(HEX[((v >> (4 * i)) & 0xF) as usize]);
        }
    }
}

/// Writes a frame line (with `\r`) into `out`; returns its length.
/// `timestamp` is appended as 4 hex digits (adapter side, `Z1`).
pub fn encode_frame(frame: &Frame, timestamp: Option<u16>, out: &mut [u8; MAX_LINE]) -> usize {
    let mut o = Out { buf: out, n: 0 };
    let ext = frame.id().is_extended();
    let letter = match (frame.kind(), ext) {
        (Kind::Data, false) => b't',
        (Kind::Data, true) => b'T',
        (Kind::Remote { .. }, false) => b'r',
        (Kind::Remote { .. }, true) => b'R',
        (Kind::Fd { brs: false, .. }, false) => b'd',
        (Kind::Fd { brs: false, .. }, true) => b'D',
        (Kind::Fd { brs: true, .. }, false) => b'b',
        (Kind::Fd { brs: true, .. }, true) => b'B',
    };
    o.push(letter);
    o.hex(frame.id().raw(), if ext { 8 } else { 3 });
    o.hex(u32::from(frame.dlc()), 1);
    for &b in frame.data() {
        o.hex(u32::from(b), 2);
    }
    if let Some(ts) = timestamp {
        o.hex(u32::from(ts), 4);
    }
    o.push(b'\r');
    o.n
}

/// Writes a command line (with `\r`) into `out`; returns its length.
pub fn encode_command(cmd: &Command, out: &mut [u8; MAX_LINE]) -> usize {
    let mut o = Out { buf: out, n: 0 };
    match *cmd {
        Command::Transmit(ref f) => return encode_frame(f, None, out),
        Command::Bitrate(r) => {
            o.push(b'S');
            o.push(b'0' + r.code());
        }
        Command::Btr(b0, b1) => {
            o.push(b's');
            o.hex(u32::from(b0), 2);
            o.hex(u32::from(b1), 2);
        }
        Command::Open => o.push(b'O'),
        Command::ListenOnly => o.push(b'L'),
        Command::Close => o.push(b'C'),
        Command::Version => o.push(b'V'),
        Command::SerialNumber => o.push(b'N'),
        Command::Status => o.push(b'F'),
        Command::Timestamps(on) => {
            o.push(b'Z');
            o.push(if on { b'1' } else { b'0' });
        }
    }
    o.push(b'\r');
    o.n
}

/// Parses a frame line (without `\r`), with an optional 4-digit timestamp.
pub fn parse_frame(line: &[u8]) -> Result<(Frame, Option<u16>), CodecError> {
    let Some(&letter) = line.first() else {
        return Err(CodecError::BadLength {
            expected: 5,
            got: 0,
        });
    };
    let (ext, kind) = match letter {
        b't' => (false, 0),
        b'T' => (true, 0),
        b'r' => (false, 1),
        b'R' => (true, 1),
        b'd' => (false, 2),
        b'D' => (true, 2),
        b'b' => (false, 3),
        b'B' => (true, 3),
        other => return Err(CodecError::Unknown(other)),
    };
    let id_len = if ext { 8 } else { 3 };
    let head = 1 + id_len + 1;
    if line.len() < head {
        return Err(CodecError::BadLength {
            expected: head,
            got: line.len(),
        });
    }
    let raw = hex_u32(&line[1..1 + id_len])?;
    let id = if ext {
        Id::extended(raw).map_err(|_| CodecError::BadId(raw))?
    } else {
        Id::standard(raw as u16)
            .ok()
            .filter(|_| raw <= 0x7FF)
            .ok_or(CodecError::BadId(raw))?
    };
    let dlc = hex_val(line[head - 1])?;
    let len = match kind {
        0 | 1 if dlc > 8 => return Err(CodecError::BadDlc(dlc)),
        0 => dlc as usize,
        1 => 0,
        _ => FD_LENGTHS[dlc as usize] as usize,
    };
    let body = &line[head..];
    let ts = match body.len() {
        n if n == 2 * len => None,
        n if n == 2 * len + 4 => Some(hex_u32(&body[2 * len..])? as u16),
        n => {
            return Err(CodecError::BadLength {
                expected: head + 2 * len,
                got: head + n,
            });
        }
    };
    let mut data = [0u8; MAX_FD_LEN];
    for (i, d) in data.iter_mut().enumerate().take(len) {
        *d = (hex_val(body[2 * i])? << 4) | hex_val(body[2 * i + 1])?;
    }
    let frame = match kind {
        0 => Frame::new(id, &data[..len]),
        1 => Frame::new_remote(id, dlc),
        k => Frame::new_fd(id, &data[..len], k == 3),
    }
    .map_err(|_| CodecError::BadDlc(dlc))?;
    Ok((frame, ts))
}

fn exact(line: &[u8], n: usize) -> Result<(), CodecError> {
    if line.len() == n {
        Ok(())
    } else {
        Err(CodecError::BadLength {
            expected: n,
            got: line.len(),
        })
    }
}

/// Parses a host command line (without `\r`).
pub fn parse_command(line: &[u8]) -> Result<Command, CodecError> {
    let Some(&c) = line.first() else {
        return Err(CodecError::BadLength {
            expected: 1,
            got: 0,
        });
    };
    let simple = |cmd| exact(line, 1).map(|_| cmd);
    match c {
        b'S' => {
            exact(line, 2)?;
            let code = line[1].wrapping_sub(b'0');
            Bitrate::from_code(code)
                .map(Command::Bitrate)
                .ok_or(CodecError::BadBitrate(line[1]))
        }
        b's' => {
            exact(line, 5)?;
            Ok(Command::Btr(
                hex_u32(&line[1..3])? as u8,
                hex_u32(&line[3..5])? as u8,
            ))
        }
        b'O' => simple(Command::Open),
        b'L' => simple(Command::ListenOnly),
        b'C' => simple(Command::Close),
        b'V' => simple(Command::Version),
        b'N' => simple(Command::SerialNumber),
        b'F' => simple(Command::Status),
        b'Z' => {
            exact(line, 2)?;
            match line[1] {
                b'0' => Ok(Command::Timestamps(false)),
                b'1' => Ok(Command::Timestamps(true)),
                b => Err(CodecError::BadHex(b)),
            }
        }
        _ => parse_frame(line).map(|(f, _)| Command::Transmit(f)),
    }
}

fn four(line: &[u8]) -> Result<[u8; 4], CodecError> {
    exact(line, 5)?;
    Ok([line[1], line[2], line[3], line[4]])
}

/// Parses an adapter reply line (without `\r`; an empty line is [`Reply::Ack`]).
pub fn parse_reply(line: &[u8]) -> Result<Reply, CodecError> {
    match line.first() {
        None => Ok(Reply::Ack),
        Some(b'z' | b'Z') if line.len() == 1 => Ok(Reply::TxAck),
        Some(b'F') => {
            exact(line, 3)?;
            Ok(Reply::Status(StatusFlags(hex_u32(&line[1..3])? as u8)))
        }
        Some(b'V') => four(line).map(Reply::Version),
        Some(b'N') => four(line).map(Reply::Serial),
        Some(_) => parse_frame(line).map(|(frame, timestamp)| Reply::Frame { frame, timestamp }),
    }
}

/// A unit cut from the byte stream by [`LineReader`].
#[derive(Debug, PartialEq, Eq)]
pub enum Token<'a> {
    /// A complete line, without its `\r`.
    Line(&'a [u8]),
    /// A BEL byte.
    Bell,
    /// A malformed stretch of bytes, skipped.
    Error(CodecError),
}

/// Cuts a byte stream into lines at `\r`, BEL as its own token; ignores
/// `\n`; a line longer than [`MAX_LINE`] is reported once and skipped up to
/// the next `\r`. Fixed buffer, no allocation.
#[derive(Debug, Clone)]
pub struct LineReader {
    buf: [u8; MAX_LINE],
    len: usize,
    overflow: bool,
}

impl Default for LineReader {
    fn default() -> Self {
        Self::new()
    }
}

impl LineReader {
    /// An empty reader.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_LINE],
            len: 0,
            overflow: false,
        }
    }

    /// Forgets any partial line.
    pub fn reset(&mut self) {
        self.len = 0;
        self.overflow = false;
    }

    /// Feeds bytes; calls `f` for every token completed.
    pub fn feed(&mut self, bytes: &[u8], f: &mut dyn FnMut(Token<'_>)) {
        for &b in bytes {
            match b {
                b'\r' => {
                    if self.overflow {
                        self.overflow = false;
                    } else {
                        f(Token::Line(&self.buf[..self.len]));
                    }
                    self.len = 0;
                }
                BEL => {
                    if self.len > 0 && !self.overflow {
                        f(Token::Error(CodecError::Unterminated));
                    }
                    self.reset();
                    f(Token::Bell);
                }
                b'\n' => {}
                _ if self.overflow => {}
                _ if self.len == MAX_LINE => {
                    self.overflow = true;
                    self.len = 0;
                    f(Token::Error(CodecError::LineTooLong));
                }
                _ => {
                    self.buf[self.len] = b;
                    self.len += 1;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(f: &Frame, ts: Option<u16>) -> Vec<u8> {
        let mut b = [0; MAX_LINE];
        let n = encode_frame(f, ts, &mut b);
        b[..n].to_vec()
    }

    #[test]
    fn encodes_the_lawicel_examples() {
        let f = Frame::new_standard(0x123, &[0xDE, 0xAD]).unwrap();
        assert_eq!(line(&f, None), b"t1232DEAD\r");
        let f = Frame::new(Id::extended(0x1ABCDEF).unwrap(), &[]).unwrap();
        assert_eq!(line(&f, Some(0x1234)), b"T01ABCDEF01234\r");
        let f = Frame::new_remote(Id::standard(0x7FF).unwrap(), 8).unwrap();
        assert_eq!(line(&f, None), b"r7FF8\r");
        let f = Frame::new_fd(Id::standard(0x10).unwrap(), &[0xAA; 12], true).unwrap();
        assert_eq!(
            line(&f, None),
            [b"b0109".as_slice(), &[b'A'; 24], b"\r"].concat()
        );
        let mut b = [0; MAX_LINE];
        let n = encode_command(&Command::Bitrate(Bitrate::B1M), &mut b);
        assert_eq!(&b[..n], b"S8\r");
    }

    #[test]
    fn parses_replies_and_rejects_garbage() {
        assert_eq!(parse_reply(b""), Ok(Reply::Ack));
        assert_eq!(parse_reply(b"z"), Ok(Reply::TxAck));
        assert_eq!(parse_reply(b"FA0"), Ok(Reply::Status(StatusFlags(0xA0))));
        assert_eq!(StatusFlags(0xA0).state(), BusState::BusOff);
        assert_eq!(StatusFlags(0x20).state(), BusState::ErrorPassive);
        let Ok(Reply::Frame { frame, timestamp }) = parse_reply(b"t1232DEADEA5F") else {
            panic!()
        };
        assert_eq!(frame.data(), &[0xDE, 0xAD]);
        assert_eq!(timestamp, Some(0xEA5F));
        assert_eq!(parse_reply(b"t8001"), Err(CodecError::BadId(0x800)));
        assert_eq!(parse_reply(b"t1239"), Err(CodecError::BadDlc(9)));
        assert!(parse_reply(b"t1232DEA").is_err());
        assert!(parse_reply(b"t12G0").is_err());
        assert!(parse_reply(b"?").is_err());
        assert!(parse_command(b"S9").is_err());
        assert_eq!(parse_command(b"Z1"), Ok(Command::Timestamps(true)));
    }

    #[test]
    fn line_reader_resyncs_after_garbage() {
        let mut r = LineReader::new();
        let mut out = Vec::new();
        let mut junk = vec![b'x'; 500];
        junk.extend_from_slice(b"\rt1230\r\x07ab\x07\r");
        r.feed(&junk, &mut |t| {
            out.push(match t {
                Token::Line(l) => format!("L{}", String::from_utf8_lossy(l)),
                Token::Bell => "BEL".into(),
                Token::Error(e) => format!("E{e}"),
            })
        });
        assert_eq!(
            out,
            vec![
                format!("Eline longer than {MAX_LINE} bytes"),
                "Lt1230".into(),
                "BEL".into(),
                "Eunterminated bytes before BEL".into(),
                "BEL".into(),
                "L".into(),
            ]
        );
    }

    mod props {
        use super::super::*;
        use proptest::prelude::*;

        fn any_id() -> impl Strategy<Value = Id> {
            prop_oneof![
                (0u16..=0x7FF).prop_map(|r| Id::standard(r).unwrap()),
                (0u32..=0x1FFF_FFFF).prop_map(|r| Id::extended(r).unwrap()),
            ]
        }

        pub(super) fn any_frame() -> impl Strategy<Value = Frame> {
            prop_oneof![
                (any_id(), proptest::collection::vec(any::<u8>(), 0..=8))
                    .prop_map(|(id, d)| Frame::new(id, &d).unwrap()),
                (any_id(), 0u8..=8).prop_map(|(id, dlc)| Frame::new_remote(id, dlc).unwrap()),
                (any_id(), 0usize..16, any::<bool>(), any::<[u8; 64]>()).prop_map(
                    |(id, dlc, brs, d)| {
                        Frame::new_fd(id, &d[..FD_LENGTHS[dlc] as usize], brs).unwrap()
                    }
                ),
            ]
        }

        proptest! {
            #[test]
            fn frames_roundtrip(f in any_frame(), ts in proptest::option::of(0u16..60_000)) {
                let mut b = [0; MAX_LINE];
                let n = encode_frame(&f, ts, &mut b);
                prop_assert_eq!(b[n - 1], b'\r');
                prop_assert_eq!(parse_reply(&b[..n - 1]), Ok(Reply::Frame { frame: f, timestamp: ts }));
                if ts.is_none() {
                    prop_assert_eq!(parse_command(&b[..n - 1]), Ok(Command::Transmit(f)));
                }
            }

            #[test]
            fn commands_roundtrip(code in 0u8..9, b0: u8, b1: u8, on: bool) {
                for cmd in [
                    Command::Bitrate(Bitrate::from_code(code).unwrap()),
                    Command::Btr(b0, b1),
                    Command::Timestamps(on),
                    Command::Open, Command::ListenOnly, Command::Close,
                    Command::Version, Command::SerialNumber, Command::Status,
                ] {
                    let mut b = [0; MAX_LINE];
                    let n = encode_command(&cmd, &mut b);
                    prop_assert_eq!(parse_command(&b[..n - 1]), Ok(cmd));
                }
            }

            #[test]
            fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
                let mut r = LineReader::new();
                r.feed(&bytes, &mut |t| {
                    if let Token::Line(l) = t {
                        assert!(l.len() <= MAX_LINE);
                        let _ = parse_reply(l);
                        let _ = parse_command(l);
                    }
                });
            }
        }
    }
}
