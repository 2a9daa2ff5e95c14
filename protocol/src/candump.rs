//! can-utils `candump -l` log files: read and write.
//!
//! One frame per line: `(1700000000.123456) can0 123#DEADBEEF`, the
//! timestamp in seconds with (usually six) fractional digits, the interface
//! name, then the frame in `cansend` notation: 3 hex digits = standard id,
//! 8 = extended id; `#` then 0..=8 data bytes in hex; `#R` a remote frame
//! with an optional DLC digit; `##` a CAN FD frame, one hex flags nibble
//! (bit 0 BRS, bit 1 ESI, bit 2 FDF, which is ignored) and its data. This is
//! what `candump -l` writes and `canplayer`, python-can (`CanutilsLogReader`),
//! SavvyCAN and cantools (`cantools decode` of candump output) read.
//!
//! The reader takes every form can-utils (`candump -l`, `candump -L`,
//! `cansend` notation) and python-can (`CanutilsLogWriter`) write:
//! - error frames: 8 hex digits with bit 29 (`CAN_ERR_FLAG`) set, e.g.
//!   `20000080#0000000000000000` (an [`ErrorFrame`], not a frame);
//! - a trailing direction marker, ` R` (received) or ` T` (transmitted),
//!   which python-can writes on every frame and `candump -x` adds;
//! - a classic frame's raw DLC 9..=15 after 8 data bytes or `R8`:
//!   `123#1122334455667788_C`, `123#R8_C` (can-utils since 2021);
//! - `.` between data bytes (`cansend` notation);
//! - interface names padded with spaces (`candump -l` on several interfaces).
//!
//! CAN XL lines (`<5 hex digits>#<flags>:<sdt>:<af>#<data>`) are refused by
//! name: no anguilla bus carries CAN XL. Lines over [`MAX_LINE`] bytes are
//! an error for that line; reading goes on after them.
//!
//! ```
//! use anguilla_protocol::candump::{Reader, Writer};
//! let log = "(1700000000.123456) can0 123#DEADBEEF\n(1700000000.200000) can0 040##10700\n";
//! let entries: Result<Vec<_>, _> = Reader::new(log.as_bytes()).collect();
//! let entries = entries?;
//! assert_eq!(entries[0].frame().unwrap().data(), &[0xDE, 0xAD, 0xBE, 0xEF]);
//! let mut out = Vec::new();
//! let mut w = Writer::new(&mut out);
//! for e in &entries { w.write(e)?; }
//! assert_eq!(String::from_utf8(out).unwrap(), log);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use core::fmt;
use std::io::{self, BufRead, Read, Write};

use crate::frame::{CAN_ERR_FLAG, ErrorFrame, Frame, FrameError, Id, MAX_CLASSIC_LEN};

/// Longest interface name (Linux `IFNAMSIZ` - 1).
pub const MAX_INTERFACE_LEN: usize = 15;

/// Longest line the reader takes, in bytes (the longest valid line, an FD
/// frame of 64 bytes with a padded interface name, is under 200).
pub const MAX_LINE: usize = 1024;

/// A log timestamp: seconds and microseconds since the Unix epoch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Timestamp {
    /// Whole seconds.
    pub secs: u64,
    /// Microseconds, 0..=999_999.
    pub micros: u32,
}

impl Timestamp {
    /// Seconds as a float (for display and arithmetic, not for storage).
    pub fn as_secs_f64(self) -> f64 {
        self.secs as f64 + self.micros as f64 * 1e-6
    }
}

/// An interface name of up to 15 bytes, stored inline.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Interface {
    len: u8,
    bytes: [u8; MAX_INTERFACE_LEN],
}

impl Interface {
    /// An interface name: 1..=15 printable ASCII characters, no spaces.
    pub fn new(name: &str) -> Result<Self, LogErrorKind> {
        if name.is_empty() || name.len() > MAX_INTERFACE_LEN {
            return Err(LogErrorKind::BadInterface);
        }
        if !name.bytes().all(|b| b.is_ascii_graphic()) {
            return Err(LogErrorKind::BadInterface);
        }
        let mut bytes = [0u8; MAX_INTERFACE_LEN];
        bytes[..name.len()].copy_from_slice(name.as_bytes());
        Ok(Interface {
            len: name.len() as u8,
            bytes,
        })
    }

    /// The name.
    pub fn as_str(&self) -> &str {
        // Only ASCII is ever stored.
        core::str::from_utf8(&self.bytes[..self.len as usize]).unwrap_or("?")
    }
}

impl fmt::Debug for Interface {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.as_str())
    }
}

impl fmt::Display for Interface {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// What a log line records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Record {
    /// A frame that crossed the bus.
    Frame(Frame),
    /// SocketCAN's report of a bus or controller error.
    Error(ErrorFrame),
}

impl fmt::Display for Record {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Record::Frame(fr) => fr.fmt(f),
            Record::Error(e) => e.fmt(f),
        }
    }
}

/// The direction marker some writers append (`candump -x`, python-can).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// ` R`: received.
    Rx,
    /// ` T`: transmitted.
    Tx,
}

/// One line of a candump log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LogEntry {
    /// When the frame was seen.
    pub timestamp: Timestamp,
    /// On which interface.
    pub interface: Interface,
    /// The frame or error frame.
    pub record: Record,
    /// A classic frame's raw DLC 9..=15 (`_9`..`_F`), only on 8-byte data
    /// frames and `R8` remote frames; the frame itself says 8.
    pub len8_dlc: Option<u8>,
    /// The direction marker, if the line had one.
    pub direction: Option<Direction>,
}

impl LogEntry {
    /// An entry for a frame, without raw DLC or direction marker.
    pub fn new(timestamp: Timestamp, interface: Interface, frame: Frame) -> Self {
        LogEntry {
            timestamp,
            interface,
            record: Record::Frame(frame),
            len8_dlc: None,
            direction: None,
        }
    }

    /// The frame, unless the line is an error frame.
    pub fn frame(&self) -> Option<&Frame> {
        match &self.record {
            Record::Frame(f) => Some(f),
            Record::Error(_) => None,
        }
    }
}

impl fmt::Display for LogEntry {
    /// The `candump -l` line, without the newline.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "({}.{:06}) {} {}",
            self.timestamp.secs, self.timestamp.micros, self.interface, self.record
        )?;
        if let Some(dlc) = self.len8_dlc {
            write!(f, "_{dlc:X}")?;
        }
        match self.direction {
            Some(Direction::Rx) => f.write_str(" R"),
            Some(Direction::Tx) => f.write_str(" T"),
            None => Ok(()),
        }
    }
}

/// What was wrong with a log line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum LogErrorKind {
    /// Reading failed.
    #[error("read error: {0}")]
    Io(io::ErrorKind),
    /// The line is not valid UTF-8.
    #[error("invalid UTF-8 (expected an ASCII candump line)")]
    NotUtf8,
    /// No `(seconds.fraction)` at the start.
    #[error("bad timestamp (expected `(seconds.microseconds)`, e.g. `(1700000000.123456)`)")]
    BadTimestamp,
    /// Missing or over-long interface name.
    #[error("bad interface name (expected 1..=15 characters, e.g. `can0`)")]
    BadInterface,
    /// No frame after the interface.
    #[error("missing frame (expected `<id>#<data>` after the interface)")]
    MissingFrame,
    /// The identifier is not 3 or 8 hex digits, or out of range.
    #[error("bad CAN id (expected 3 hex digits up to 7FF, or 8 hex digits up to 1FFFFFFF)")]
    BadId,
    /// No `#` after the identifier.
    #[error("missing `#` after the id (expected `<id>#<data>`, `<id>#R`, `<id>##<flags><data>`)")]
    MissingSeparator,
    /// Data not pairs of hex digits.
    #[error("bad data (expected pairs of hex digits)")]
    BadData,
    /// Remote frame DLC not a digit 0..=8.
    #[error("bad remote frame DLC (expected `#R` or `#R0`..`#R8`)")]
    BadRemoteDlc,
    /// FD flags not one hex digit 0..=7.
    #[error("bad CAN FD flags (expected one hex digit 0..7 after `##`)")]
    BadFdFlags,
    /// Too many data bytes, or an FD length no DLC expresses.
    #[error("bad length: {0}")]
    BadLength(FrameError),
    /// Text after the frame.
    #[error("unexpected text after the frame (expected end of line, or ` R` / ` T`)")]
    TrailingText,
    /// An error frame that is not data bytes.
    #[error(
        "bad error frame (expected `<8 hex digits>#<0..=8 data bytes>`, e.g. `20000080#0000000000000000`)"
    )]
    BadErrorFrame,
    /// A raw DLC suffix that is not `_9`..`_F` after 8 bytes or `R8`.
    #[error("bad raw DLC (expected `_9`..`_F`, only after 8 data bytes or `R8`)")]
    BadRawDlc,
    /// A CAN XL frame.
    #[error("CAN XL frame (anguilla's buses carry classic CAN and CAN FD only)")]
    CanXl,
    /// An error frame or raw DLC where a plain frame is expected.
    #[error("expected a plain frame, found an error frame or a raw DLC")]
    NotAPlainFrame,
    /// A line longer than [`MAX_LINE`].
    #[error("line longer than {MAX_LINE} bytes (expected one candump line)")]
    LineTooLong,
}

/// A malformed line or read failure, with its 1-based line number.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("candump log line {line}: {kind}")]
pub struct LogError {
    /// 1-based line number.
    pub line: usize,
    /// What was wrong.
    pub kind: LogErrorKind,
}

fn hex_nibble(c: u8) -> Option<u8> {
    match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'a'..=b'f' => Some(c - b'a' + 10),
        b'A'..=b'F' => Some(c - b'A' + 10),
        _ => None,
    }
}

/// Data bytes as hex pairs, each optionally preceded by `.` (`cansend`
/// notation).
fn hex_bytes<'a>(s: &[u8], out: &'a mut [u8; 64]) -> Result<&'a [u8], LogErrorKind> {
    let mut n = 0;
    let mut i = 0;
    while i < s.len() {
        if s[i] == b'.' {
            i += 1;
        }
        let pair = s.get(i..i + 2).ok_or(LogErrorKind::BadData)?;
        let hi = hex_nibble(pair[0]).ok_or(LogErrorKind::BadData)?;
        let lo = hex_nibble(pair[1]).ok_or(LogErrorKind::BadData)?;
        if n == out.len() {
            let pairs = s.iter().filter(|&&c| c != b'.').count() / 2;
            return Err(LogErrorKind::BadLength(FrameError::BadFdLength(pairs)));
        }
        out[n] = hi << 4 | lo;
        n += 1;
        i += 2;
    }
    Ok(&out[..n])
}

fn parse_timestamp(s: &str) -> Result<Timestamp, LogErrorKind> {
    let inner = s
        .strip_prefix('(')
        .and_then(|s| s.strip_suffix(')'))
        .ok_or(LogErrorKind::BadTimestamp)?;
    let (secs, frac) = inner.split_once('.').ok_or(LogErrorKind::BadTimestamp)?;
    let digits = |t: &str| !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit());
    if !digits(secs) || !digits(frac) || frac.len() > 9 || secs.len() > 19 {
        return Err(LogErrorKind::BadTimestamp);
    }
    let secs: u64 = secs.parse().map_err(|_| LogErrorKind::BadTimestamp)?;
    let mut micros = 0u32;
    for i in 0..6 {
        let d = frac.as_bytes().get(i).map_or(0, |b| (b - b'0') as u32);
        micros = micros * 10 + d;
    }
    Ok(Timestamp { secs, micros })
}

/// Parses a frame in `cansend` / candump notation (`123#DEAD`, `123#R`,
/// `12345678##1DEAD`); an error frame or a raw DLC is refused
/// ([`LogErrorKind::NotAPlainFrame`]): see [`parse_record`].
pub fn parse_frame(s: &str) -> Result<Frame, LogErrorKind> {
    match parse_record(s)? {
        (Record::Frame(f), None) => Ok(f),
        _ => Err(LogErrorKind::NotAPlainFrame),
    }
}

/// Parses a frame or an error frame in candump notation, with the raw DLC
/// suffix of a classic 8-byte frame if present (`123#R8_C` gives `Some(12)`).
pub fn parse_record(s: &str) -> Result<(Record, Option<u8>), LogErrorKind> {
    let (id_str, rest) = s.split_once('#').ok_or(LogErrorKind::MissingSeparator)?;
    let hex_id = |t: &str| -> Result<u32, LogErrorKind> {
        if !t.bytes().all(|b| hex_nibble(b).is_some()) {
            return Err(LogErrorKind::BadId);
        }
        u32::from_str_radix(t, 16).map_err(|_| LogErrorKind::BadId)
    };
    let rest = rest.as_bytes();
    let mut buf = [0u8; 64];
    let id = match id_str.len() {
        3 => Id::standard(hex_id(id_str)? as u16).map_err(|_| LogErrorKind::BadId)?,
        // CAN XL: `PPPPP#FF:SS:AAAAAAAA#data` (VCID and priority, header).
        5 if hex_id(id_str).is_ok() && rest.get(2) == Some(&b':') => {
            return Err(LogErrorKind::CanXl);
        }
        8 => {
            let raw = hex_id(id_str)?;
            if raw & !(CAN_ERR_FLAG | crate::frame::MAX_EXTENDED_ID) != 0 {
                return Err(LogErrorKind::BadId);
            }
            if raw & CAN_ERR_FLAG != 0 {
                if matches!(rest.first(), Some(b'R' | b'r' | b'#')) {
                    return Err(LogErrorKind::BadErrorFrame);
                }
                let data = hex_bytes(rest, &mut buf)?;
                let e =
                    ErrorFrame::new(raw & !CAN_ERR_FLAG, data).map_err(LogErrorKind::BadLength)?;
                return Ok((Record::Error(e), None));
            }
            Id::extended(raw).map_err(|_| LogErrorKind::BadId)?
        }
        _ => return Err(LogErrorKind::BadId),
    };
    // A classic frame's raw DLC: `_9`..`_F` at the very end.
    let (body, len8_dlc) = match rest.iter().position(|&c| c == b'_') {
        Some(p) => {
            let dlc = match &rest[p + 1..] {
                [d] => hex_nibble(*d)
                    .filter(|&d| d > 8)
                    .ok_or(LogErrorKind::BadRawDlc)?,
                _ => return Err(LogErrorKind::BadRawDlc),
            };
            (&rest[..p], Some(dlc))
        }
        None => (rest, None),
    };
    let frame = match body.first() {
        Some(b'R') | Some(b'r') => {
            let dlc = match &body[1..] {
                [] => 0,
                [d @ b'0'..=b'8'] => d - b'0',
                _ => return Err(LogErrorKind::BadRemoteDlc),
            };
            Frame::new_remote(id, dlc).map_err(LogErrorKind::BadLength)?
        }
        Some(b'#') => {
            let flags = body
                .get(1)
                .and_then(|&c| hex_nibble(c))
                .filter(|&f| f <= 7)
                .ok_or(LogErrorKind::BadFdFlags)?;
            let data = hex_bytes(&body[2..], &mut buf)?;
            let frame = Frame::new_fd(id, data, flags & 1 == 1).map_err(LogErrorKind::BadLength)?;
            frame.with_esi(flags & 2 == 2)
        }
        _ => {
            let data = hex_bytes(body, &mut buf)?;
            Frame::new(id, data).map_err(LogErrorKind::BadLength)?
        }
    };
    if len8_dlc.is_some() && (frame.is_fd() || frame.dlc() as usize != MAX_CLASSIC_LEN) {
        return Err(LogErrorKind::BadRawDlc);
    }
    Ok((Record::Frame(frame), len8_dlc))
}

/// Parses one `candump -l` line (without its newline).
pub fn parse_line(line: &str) -> Result<LogEntry, LogErrorKind> {
    let mut fields = line.split_ascii_whitespace();
    let timestamp = parse_timestamp(fields.next().ok_or(LogErrorKind::BadTimestamp)?)?;
    let interface = Interface::new(fields.next().ok_or(LogErrorKind::BadInterface)?)?;
    let (record, len8_dlc) = parse_record(fields.next().ok_or(LogErrorKind::MissingFrame)?)?;
    let direction = match (fields.next(), fields.next()) {
        (None, _) => None,
        (Some("R"), None) => Some(Direction::Rx),
        (Some("T"), None) => Some(Direction::Tx),
        _ => return Err(LogErrorKind::TrailingText),
    };
    Ok(LogEntry {
        timestamp,
        interface,
        record,
        len8_dlc,
        direction,
    })
}

/// Reads a candump log: an iterator of entries or numbered errors. Blank
/// lines are skipped. After an I/O error the iterator ends.
pub struct Reader<R> {
    inner: R,
    line: usize,
    buf: Vec<u8>,
    done: bool,
}

impl<R: BufRead> Reader<R> {
    /// A reader over `inner`.
    pub fn new(inner: R) -> Self {
        Reader {
            inner,
            line: 0,
            buf: Vec::with_capacity(256),
            done: false,
        }
    }
}

impl<R: BufRead> Reader<R> {
    /// Reads up to `limit` bytes of a line into the buffer; a read error
    /// ends the reader.
    fn read_part(&mut self, limit: usize) -> Result<usize, LogErrorKind> {
        (&mut self.inner)
            .take(limit as u64)
            .read_until(b'\n', &mut self.buf)
            .map_err(|e| {
                self.done = true;
                LogErrorKind::Io(e.kind())
            })
    }
}

impl<R: BufRead> Iterator for Reader<R> {
    type Item = Result<LogEntry, LogError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if self.done {
                return None;
            }
            self.buf.clear();
            self.line += 1;
            let line = self.line;
            match self.read_part(MAX_LINE + 1) {
                Ok(0) => {
                    self.done = true;
                    return None;
                }
                Ok(_) => {}
                Err(kind) => return Some(Err(LogError { line, kind })),
            }
            if self.buf.len() > MAX_LINE && self.buf.last() != Some(&b'\n') {
                // Skip the rest of the over-long line, without holding it.
                loop {
                    self.buf.clear();
                    match self.read_part(MAX_LINE) {
                        Ok(0) => break,
                        Ok(_) if self.buf.last() == Some(&b'\n') => break,
                        Ok(_) => {}
                        Err(kind) => return Some(Err(LogError { line, kind })),
                    }
                }
                return Some(Err(LogError {
                    line,
                    kind: LogErrorKind::LineTooLong,
                }));
            }
            let Ok(text) = core::str::from_utf8(&self.buf) else {
                return Some(Err(LogError {
                    line,
                    kind: LogErrorKind::NotUtf8,
                }));
            };
            let text = text.trim_end_matches(['\n', '\r']);
            if text.trim().is_empty() {
                continue;
            }
            return Some(parse_line(text).map_err(|kind| LogError { line, kind }));
        }
    }
}

/// Writes `candump -l` lines.
pub struct Writer<W> {
    inner: W,
}

impl<W: Write> Writer<W> {
    /// A writer to `inner` (wrap files in a `BufWriter`).
    pub fn new(inner: W) -> Self {
        Writer { inner }
    }

    /// Writes one entry as a line.
    pub fn write(&mut self, entry: &LogEntry) -> io::Result<()> {
        writeln!(self.inner, "{entry}")
    }

    /// The inner writer (to flush or sync it).
    pub fn get_mut(&mut self) -> &mut W {
        &mut self.inner
    }

    /// Flushes and returns the inner writer.
    pub fn into_inner(mut self) -> io::Result<W> {
        self.inner.flush()?;
        Ok(self.inner)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn arb_frame() -> impl Strategy<Value = Frame> {
        let id = prop_oneof![
            (0u16..=0x7FF).prop_map(Id::standard_literal),
            (0u32..=0x1FFF_FFFF).prop_map(Id::extended_literal),
        ];
        let fd_len = prop::sample::select(crate::frame::FD_LENGTHS.to_vec());
        prop_oneof![
            (id.clone(), prop::collection::vec(any::<u8>(), 0..=8))
                .prop_map(|(id, d)| Frame::new(id, &d).unwrap()),
            (id.clone(), 0u8..=8).prop_map(|(id, dlc)| Frame::new_remote(id, dlc).unwrap()),
            (
                id,
                fd_len,
                prop::collection::vec(any::<u8>(), 64),
                any::<bool>(),
                any::<bool>()
            )
                .prop_map(|(id, len, d, brs, esi)| Frame::new_fd(
                    id,
                    &d[..len as usize],
                    brs
                )
                .unwrap()
                .with_esi(esi)),
        ]
    }

    proptest! {
        #[test]
        fn write_then_read_roundtrips(
            frames in prop::collection::vec((arb_frame(), any::<u32>(), 0u32..1_000_000, "[a-z]{1,5}[0-9]{0,2}", any::<u8>()), 1..20)
        ) {
            let entries: Vec<LogEntry> = frames
                .iter()
                .map(|(frame, secs, micros, iface, extra)| {
                    let mut e = LogEntry::new(
                        Timestamp { secs: *secs as u64, micros: *micros },
                        Interface::new(iface).unwrap(),
                        *frame,
                    );
                    e.direction = [None, Some(Direction::Rx), Some(Direction::Tx)][(extra % 3) as usize];
                    let eight = !frame.is_fd() && frame.dlc() == 8;
                    if eight && extra & 4 != 0 {
                        e.len8_dlc = Some(9 + (extra >> 3) % 7);
                    }
                    if extra & 0x40 != 0 {
                        let data = &frame.data()[..frame.len().min(8)];
                        e.record = Record::Error(ErrorFrame::new(frame.id().raw() & 0x3FF, data).unwrap());
                        e.len8_dlc = None;
                    }
                    e
                })
                .collect();
            let mut w = Writer::new(Vec::new());
            for e in &entries {
                w.write(e).unwrap();
            }
            let text = w.into_inner().unwrap();
            let back: Vec<LogEntry> = Reader::new(&text[..]).collect::<Result<_, _>>().unwrap();
            prop_assert_eq!(back, entries);
        }

        #[test]
        fn parse_line_never_panics(s in "\\PC*") {
            let _ = parse_line(&s);
        }
    }

    #[test]
    fn reads_the_can_utils_forms() {
        let log = "\
(1700000000.123456) can0 123#DEADBEEF
(1700000000.123457) vcan1 12345678#
(1700000000.5) can0 7FF#R
(1700000001.000000) can0 00000001#R8
(1700000002.000001) can0 010##1DEADBEEF
(1700000002.000001) can0 010##500 R

(1700000003.000000) can0 010##3
";
        let e: Vec<LogEntry> = Reader::new(log.as_bytes())
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(e.len(), 7);
        let f = |i: usize| *e[i].frame().unwrap();
        assert_eq!(f(0).id(), Id::standard_literal(0x123));
        assert_eq!(f(1).id(), Id::extended_literal(0x1234_5678));
        assert_eq!(e[2].timestamp.micros, 500_000);
        assert_eq!(f(3).dlc(), 8);
        assert!(f(4).is_fd());
        assert_eq!(e[5].direction, Some(Direction::Rx));
        assert_eq!(
            f(5).kind(),
            crate::frame::Kind::Fd {
                brs: true,
                esi: false
            }
        );
        assert_eq!(
            f(6).kind(),
            crate::frame::Kind::Fd {
                brs: true,
                esi: true
            }
        );
    }

    #[test]
    fn errors_name_the_line_and_the_problem() {
        let cases = [
            ("1700000000.1 can0 123#00", LogErrorKind::BadTimestamp),
            ("(1700000000.1)", LogErrorKind::BadInterface),
            ("(1700000000.1) can0", LogErrorKind::MissingFrame),
            ("(1700000000.1) can0 1234#00", LogErrorKind::BadId),
            ("(1700000000.1) can0 800#00", LogErrorKind::BadId),
            ("(1700000000.1) can0 123", LogErrorKind::MissingSeparator),
            ("(1700000000.1) can0 123#0", LogErrorKind::BadData),
            ("(1700000000.1) can0 123#XY", LogErrorKind::BadData),
            ("(1700000000.1) can0 123#R9", LogErrorKind::BadRemoteDlc),
            ("(1700000000.1) can0 123##G", LogErrorKind::BadFdFlags),
            (
                "(1700000000.1) can0 123#001122334455667788",
                LogErrorKind::BadLength(FrameError::ClassicTooLong(9)),
            ),
            (
                "(1700000000.1) can0 123##1001122334455667788",
                LogErrorKind::BadLength(FrameError::BadFdLength(9)),
            ),
            (
                "(1700000000.1) can0 123#00 extra",
                LogErrorKind::TrailingText,
            ),
            ("(1700000000.1) can0 123#00 R T", LogErrorKind::TrailingText),
            ("(1700000000.1) can0 40000000#00", LogErrorKind::BadId),
            (
                "(1700000000.1) can0 20000080#R",
                LogErrorKind::BadErrorFrame,
            ),
            (
                "(1700000000.1) can0 20000080##100",
                LogErrorKind::BadErrorFrame,
            ),
            (
                "(1700000000.1) can0 20000080#001122334455667788",
                LogErrorKind::BadLength(FrameError::ClassicTooLong(9)),
            ),
            ("(1700000000.1) can0 123#0011_C", LogErrorKind::BadRawDlc),
            (
                "(1700000000.1) can0 123#0011223344556677_8",
                LogErrorKind::BadRawDlc,
            ),
            ("(1700000000.1) can0 123#R7_C", LogErrorKind::BadRawDlc),
            (
                "(1700000000.1) can0 123##10011223344556677_C",
                LogErrorKind::BadRawDlc,
            ),
            ("(1700000000.1) can0 123#00.", LogErrorKind::BadData),
            (
                "(1700000000.1) can0 00123#80:00:11223344#AABB",
                LogErrorKind::CanXl,
            ),
        ];
        for (line, kind) in cases {
            let text = format!("(1.000000) can0 123#\n{line}\n");
            let results: Vec<_> = Reader::new(text.as_bytes()).collect();
            assert!(results[0].is_ok());
            assert_eq!(results[1], Err(LogError { line: 2, kind }), "{line}");
        }
        let msg = LogError {
            line: 7,
            kind: LogErrorKind::BadId,
        }
        .to_string();
        assert!(
            msg.starts_with("candump log line 7: bad CAN id (expected"),
            "{msg}"
        );
    }
}
