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
//! ```
//! use anguilla_protocol::candump::{Reader, Writer};
//! let log = "(1700000000.123456) can0 123#DEADBEEF\n(1700000000.200000) can0 040##10700\n";
//! let entries: Result<Vec<_>, _> = Reader::new(log.as_bytes()).collect();
//! let entries = entries?;
//! assert_eq!(entries[0].frame.data(), &[0xDE, 0xAD, 0xBE, 0xEF]);
//! let mut out = Vec::new();
//! let mut w = Writer::new(&mut out);
//! for e in &entries { w.write(e)?; }
//! assert_eq!(String::from_utf8(out).unwrap(), log);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use core::fmt;
use std::io::{self, BufRead, Write};

use crate::frame::{Frame, FrameError, Id};

/// Longest interface name (Linux `IFNAMSIZ` - 1).
pub const MAX_INTERFACE_LEN: usize = 15;

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

/// One line of a candump log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LogEntry {
    /// When the frame was seen.
    pub timestamp: Timestamp,
    /// On which interface.
    pub interface: Interface,
    /// The frame.
    pub frame: Frame,
}

impl fmt::Display for LogEntry {
    /// The `candump -l` line, without the newline.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "({}.{:06}) {} {}",
            self.timestamp.secs, self.timestamp.micros, self.interface, self.frame
        )
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
    #[error("unexpected text after the frame (expected end of line)")]
    TrailingText,
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

fn hex_bytes<'a>(s: &[u8], out: &'a mut [u8; 64]) -> Result<&'a [u8], LogErrorKind> {
    if !s.len().is_multiple_of(2) || s.len() / 2 > 64 {
        return Err(if s.len() / 2 > 64 {
            LogErrorKind::BadLength(FrameError::BadFdLength(s.len() / 2))
        } else {
            LogErrorKind::BadData
        });
    }
    for (i, pair) in s.chunks_exact(2).enumerate() {
        let hi = hex_nibble(pair[0]).ok_or(LogErrorKind::BadData)?;
        let lo = hex_nibble(pair[1]).ok_or(LogErrorKind::BadData)?;
        out[i] = hi << 4 | lo;
    }
    Ok(&out[..s.len() / 2])
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
/// `12345678##1DEAD`).
pub fn parse_frame(s: &str) -> Result<Frame, LogErrorKind> {
    let (id_str, rest) = s.split_once('#').ok_or(LogErrorKind::MissingSeparator)?;
    let hex_id = |t: &str| -> Result<u32, LogErrorKind> {
        if !t.bytes().all(|b| hex_nibble(b).is_some()) {
            return Err(LogErrorKind::BadId);
        }
        u32::from_str_radix(t, 16).map_err(|_| LogErrorKind::BadId)
    };
    let id = match id_str.len() {
        3 => Id::standard(hex_id(id_str)? as u16).map_err(|_| LogErrorKind::BadId)?,
        8 => Id::extended(hex_id(id_str)?).map_err(|_| LogErrorKind::BadId)?,
        _ => return Err(LogErrorKind::BadId),
    };
    let rest = rest.as_bytes();
    let mut buf = [0u8; 64];
    match rest.first() {
        Some(b'R') | Some(b'r') => {
            let dlc = match &rest[1..] {
                [] => 0,
                [d @ b'0'..=b'8'] => d - b'0',
                _ => return Err(LogErrorKind::BadRemoteDlc),
            };
            Frame::new_remote(id, dlc).map_err(LogErrorKind::BadLength)
        }
        Some(b'#') => {
            let flags = rest
                .get(1)
                .and_then(|&c| hex_nibble(c))
                .filter(|&f| f <= 7)
                .ok_or(LogErrorKind::BadFdFlags)?;
            let data = hex_bytes(&rest[2..], &mut buf)?;
            let frame = Frame::new_fd(id, data, flags & 1 == 1).map_err(LogErrorKind::BadLength)?;
            Ok(frame.with_esi(flags & 2 == 2))
        }
        _ => {
            let data = hex_bytes(rest, &mut buf)?;
            Frame::new(id, data).map_err(LogErrorKind::BadLength)
        }
    }
}

/// Parses one `candump -l` line (without its newline).
pub fn parse_line(line: &str) -> Result<LogEntry, LogErrorKind> {
    let mut fields = line.split_ascii_whitespace();
    let timestamp = parse_timestamp(fields.next().ok_or(LogErrorKind::BadTimestamp)?)?;
    let interface = Interface::new(fields.next().ok_or(LogErrorKind::BadInterface)?)?;
    let frame = parse_frame(fields.next().ok_or(LogErrorKind::MissingFrame)?)?;
    // Newer can-utils may append a direction marker (`R` / `T`); accept it.
    match (fields.next(), fields.next()) {
        (None, _) | (Some("R" | "T"), None) => Ok(LogEntry {
            timestamp,
            interface,
            frame,
        }),
        _ => Err(LogErrorKind::TrailingText),
    }
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
            match self.inner.read_until(b'\n', &mut self.buf) {
                Ok(0) => {
                    self.done = true;
                    return None;
                }
                Ok(_) => {}
                Err(e) => {
                    self.done = true;
                    return Some(Err(LogError {
                        line,
                        kind: LogErrorKind::Io(e.kind()),
                    }));
                }
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
            (0u16..=0x7FF).prop_map(Id::Standard),
            (0u32..=0x1FFF_FFFF).prop_map(Id::Extended),
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
            frames in prop::collection::vec((arb_frame(), any::<u32>(), 0u32..1_000_000, "[a-z]{1,5}[0-9]{0,2}"), 1..20)
        ) {
            let entries: Vec<LogEntry> = frames
                .iter()
                .map(|(frame, secs, micros, iface)| LogEntry {
                    timestamp: Timestamp { secs: *secs as u64, micros: *micros },
                    interface: Interface::new(iface).unwrap(),
                    frame: *frame,
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
        assert_eq!(e[0].frame.id(), Id::Standard(0x123));
        assert_eq!(e[1].frame.id(), Id::Extended(0x1234_5678));
        assert_eq!(e[2].timestamp.micros, 500_000);
        assert_eq!(e[3].frame.dlc(), 8);
        assert!(e[4].frame.is_fd());
        assert_eq!(
            e[5].frame.kind(),
            crate::frame::Kind::Fd {
                brs: true,
                esi: false
            }
        );
        assert_eq!(
            e[6].frame.kind(),
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
