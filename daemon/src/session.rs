//! The session format: what the controller records of each period, and
//! the `session.log` lines that carry it (written by the recorder thread,
//! [`crate::record`], read by [`crate::replay`]). Like
//! `anguilla_protocol::candump`, it knows nothing of the controller.
//!
//! `session.log` lines (`#` starts a comment):
//!
//! ```text
//! anguilla-session 2        header
//! config <hex>              FNV-1a 64 of the configuration (as written to
//!                           config.toml): replay refuses another
//! start <ns>                the controller's creation time
//! C <ns> <origin> <node> <hex>
//!                           an operator request: the client port it came
//!                           on and that port's node (32 hex digits each;
//!                           0 for the E-stop socket), the CommandRequest's bytes
//!                           (layout 5 and 6 requests, from sessions recorded
//!                           before, are read as the present layout)
//! D <ns> <hex>              an iceoryx2 node that died (its id)
//! S <ns>                    shutdown requested at this time
//! P <ns> <bus state 0-3>    a period starts at this time (3: adapter gone)
//! R <frame>                 a frame received in this period (cansend notation)
//! T <frame>                 a frame sent
//! X <frame>                 a frame the bus refused to send (bus-off, an
//!                           interface gone down): not on the wire, so not
//!                           in bus.log
//! E                         shutdown: actuators disabled
//! stopped <text>            the recorder stopped here and the daemon went
//!                           on (the reason, e.g. below `[recording]
//!                           min-free`): the recording ends cleanly, and its
//!                           last period may be incomplete
//! ```
//!

use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

use anguilla_drivers::BusState;
use anguilla_protocol::candump;
use anguilla_protocol::frame::Frame;

use anguilla_ipc::vocabulary::Nanos;
use anguilla_ipc::{CommandRequest, Envelope, Raw as _};

/// One recorded event. `Copy`: sending it allocates nothing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Record {
    /// The controller was created at this time.
    Start(Nanos),
    /// A period starts; the bus state as the controller read it.
    Period {
        /// The period's time.
        now: Nanos,
        /// The bus state the period acts on (written as its
        /// [`BusState::code`]).
        bus: BusState,
    },
    /// An operator request handled at this time (before the next period).
    Command(Nanos, Envelope),
    /// A client's iceoryx2 node was found dead at this time.
    Dead(Nanos, u128),
    /// Shutdown requested at this time.
    Shutdown(Nanos),
    /// Shutdown: the actuators were disabled.
    End,
    /// A frame received.
    Rx(Nanos, Frame),
    /// A frame sent.
    Tx(Nanos, Frame),
    /// A frame the bus refused to send.
    Refused(Nanos, Frame),
}

fn hex(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() * 2);
    for b in bytes {
        let _ = write!(s, "{b:02x}");
    }
    s
}

fn unhex(s: &str) -> Option<Vec<u8>> {
    if !s.len().is_multiple_of(2) {
        return None;
    }
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(s.get(i..i + 2)?, 16).ok())
        .collect()
}

/// The first line of a `session.log` of this format.
pub const HEADER: &str = "anguilla-session 2";

/// Writes the header lines: the format and the fingerprint of the
/// configuration text the session runs with (as written to `config.toml`).
pub fn write_header(w: &mut impl Write, config_text: &str) -> std::io::Result<()> {
    writeln!(w, "{HEADER}")?;
    writeln!(w, "config {:016x}", fnv1a(config_text.as_bytes()))
}

/// Writes the `stopped` line: the recorder ends here, the daemon goes on;
/// `reason` says why (one line: line breaks become spaces).
pub fn write_stopped(w: &mut impl Write, reason: &str) -> std::io::Result<()> {
    let reason: String = reason
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .take(MAX_LINE / 2)
        .collect();
    writeln!(w, "stopped {reason}")
}

/// Writes `r` as its `session.log` line.
pub fn write_line(w: &mut impl Write, r: &Record) -> std::io::Result<()> {
    match *r {
        Record::Start(t) => writeln!(w, "start {t}"),
        Record::Period { now, bus } => writeln!(w, "P {now} {}", bus.code()),
        Record::Command(t, c) => writeln!(
            w,
            "C {t} {:032x} {:032x} {}",
            c.origin,
            c.node,
            hex(c.request.as_bytes())
        ),
        Record::Dead(t, id) => writeln!(w, "D {t} {id:032x}"),
        Record::Shutdown(t) => writeln!(w, "S {t}"),
        Record::End => writeln!(w, "E"),
        Record::Refused(_, f) => writeln!(w, "X {f}"),
        Record::Rx(_, f) => writeln!(w, "R {f}"),
        Record::Tx(_, f) => writeln!(w, "T {f}"),
    }
}

/// A `session.log` that cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// A line is malformed.
    #[error("{path}:{line}: {what}")]
    Line {
        /// The file.
        path: String,
        /// Line number (1-based).
        line: usize,
        /// What was wrong and what was expected.
        what: String,
    },
}

/// One period of a recording: its inputs and the frames the controller
/// sent in it.
#[derive(Debug, Default)]
pub struct PeriodIn {
    /// The period's time.
    pub now: Nanos,
    /// The bus state it acted on.
    pub bus: BusState,
    /// Inputs handled before it (commands, dead nodes, shutdown).
    pub before: Vec<Record>,
    /// Frames received in it.
    pub rx: Vec<Frame>,
    /// Frames the controller sent, `false` where the bus refused them.
    pub tx: Vec<(Frame, bool)>,
}

/// A parsed `session.log`.
pub struct Session {
    /// The controller's creation time.
    pub start: Nanos,
    /// The periods, in order.
    pub periods: Vec<PeriodIn>,
    /// Records after the last period (a shutdown request).
    pub trailing: Vec<Record>,
    /// Frames sent at shutdown, if the session ended with `E`.
    pub end: Option<Vec<(Frame, bool)>>,
    /// Without `E` or `stopped`: the number of the last line read (the
    /// recording was cut: the daemon killed, the disk full).
    pub cut_at: Option<usize>,
    /// The recorder stopped before the daemon (a `stopped` line): why.
    pub stopped: Option<String>,
    /// The recorded configuration's hash (sessions since it was added).
    pub config_hash: Option<u64>,
}

/// FNV-1a, 64 bits: a recording's fingerprint of its `config.toml`.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Longest `session.log` line read (the longest written is about 300 bytes).
pub const MAX_LINE: usize = 4096;

/// Reads `session.log` at `path`. A last line cut short (the recording
/// ended mid-write) is not an error: the session is then cut there.
pub fn parse(path: &Path) -> Result<Session, SessionError> {
    let p = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|source| SessionError::Read {
        path: p.clone(),
        source,
    })?;
    let err = |line: usize, what: String| SessionError::Line {
        path: p.clone(),
        line,
        what,
    };
    let mut start = None;
    let mut config_hash = None;
    let mut periods: Vec<PeriodIn> = Vec::new();
    let mut pending: Vec<Record> = Vec::new();
    let mut end: Option<Vec<(Frame, bool)>> = None;
    let mut stopped = None;
    let mut reader = std::io::BufReader::new(file);
    let mut buf = Vec::with_capacity(256);
    let mut n = 0;
    loop {
        use std::io::{BufRead as _, Read as _};
        buf.clear();
        let got = (&mut reader)
            .take(MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut buf)
            .map_err(|source| SessionError::Read {
                path: p.clone(),
                source,
            })?;
        if got == 0 {
            break;
        }
        n += 1;
        if buf.last() != Some(&b'\n') {
            if buf.len() > MAX_LINE {
                return Err(err(n, format!("a line longer than {MAX_LINE} bytes")));
            }
            // The last line, cut short: the recording ends before it.
            n -= 1;
            break;
        }
        let line = std::str::from_utf8(&buf).map_err(|_| err(n, "not UTF-8 text".into()))?;
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        if n == 1 {
            if line != HEADER {
                return Err(err(
                    n,
                    format!(
                        "'{line}' (expected the header 'anguilla-session 2'; sessions of \
                         format 1, recorded before requests carried their origin, do not replay)"
                    ),
                ));
            }
            continue;
        }
        let (tag, rest) = line.split_once(' ').unwrap_or((line, ""));
        let num = |s: &str, what: &str| {
            s.parse::<u64>()
                .map_err(|_| err(n, format!("{what} '{s}' is not a whole number")))
        };
        let time = |s: &str, what: &str| num(s, what).map(Nanos::from_nanos);
        match tag {
            "start" => start = Some(time(rest, "start time")?),
            "config" => {
                config_hash = Some(u64::from_str_radix(rest, 16).map_err(|_| {
                    err(n, format!("config hash '{rest}' (expected 16 hex digits)"))
                })?)
            }
            "C" => {
                let mut parts = rest.split(' ');
                let (Some(t), Some(origin), Some(node), Some(rest), None) = (
                    parts.next(),
                    parts.next(),
                    parts.next(),
                    parts.next(),
                    parts.next(),
                ) else {
                    return Err(err(
                        n,
                        "command: expected '<ns> <origin> <node> <hex>'".into(),
                    ));
                };
                let t = time(t, "command time")?;
                let id = |s: &str, what: &str| {
                    u128::from_str_radix(s, 16)
                        .map_err(|_| err(n, format!("{what} '{s}' (expected 32 hex digits)")))
                };
                let (origin, node) = (id(origin, "origin")?, id(node, "node id")?);
                let bytes =
                    unhex(rest).ok_or_else(|| err(n, "command: expected hex bytes".into()))?;
                // Sessions recorded before layout 7 carry layout-5 or -6 requests.
                let req = CommandRequest::from_bytes(&bytes).map(CommandRequest::from_older_layout);
                let req = req.ok_or_else(|| {
                    err(
                        n,
                        format!(
                            "command of {} bytes (expected {})",
                            bytes.len(),
                            core::mem::size_of::<CommandRequest>()
                        ),
                    )
                })?;
                pending.push(Record::Command(
                    t,
                    Envelope {
                        origin,
                        node,
                        request: req,
                    },
                ));
            }
            "D" => {
                let (t, rest) = rest
                    .split_once(' ')
                    .ok_or_else(|| err(n, "dead node: expected '<ns> <hex>'".into()))?;
                let t = time(t, "time")?;
                let id = u128::from_str_radix(rest, 16)
                    .map_err(|_| err(n, format!("node id '{rest}' (expected 32 hex digits)")))?;
                pending.push(Record::Dead(t, id));
            }
            "S" => pending.push(Record::Shutdown(time(rest, "shutdown time")?)),
            "P" => {
                let (t, b) = rest
                    .split_once(' ')
                    .ok_or_else(|| err(n, "period: expected '<ns> <bus state>'".into()))?;
                let code = num(b, "bus state")?;
                let bus = u8::try_from(code)
                    .ok()
                    .and_then(BusState::from_code)
                    .ok_or_else(|| err(n, format!("bus state {code} (expected 0, 1, 2 or 3)")))?;
                periods.push(PeriodIn {
                    now: time(t, "period time")?,
                    bus,
                    before: std::mem::take(&mut pending),
                    ..Default::default()
                });
            }
            "R" | "T" | "X" => {
                let f = candump::parse_frame(rest)
                    .map_err(|e| err(n, format!("frame '{rest}': {e}")))?;
                let sent = tag == "T";
                match (tag, end.as_mut(), periods.last_mut()) {
                    ("T" | "X", Some(e), _) => e.push((f, sent)),
                    ("R", _, Some(p)) => p.rx.push(f),
                    ("T" | "X", None, Some(p)) => p.tx.push((f, sent)),
                    _ => return Err(err(n, "a frame before the first period".into())),
                }
            }
            "E" => end = Some(Vec::new()),
            // Nothing follows it.
            "stopped" => {
                stopped = Some(rest.to_string());
                break;
            }
            other => {
                return Err(err(
                    n,
                    format!(
                        "unknown line tag '{other}' (expected config, start, C, D, S, P, R, T, X, E or stopped)"
                    ),
                ));
            }
        }
    }
    let start = start.ok_or_else(|| match &stopped {
        // Recording began with the daemon; its loop had not started yet.
        Some(why) => err(
            0,
            format!(
                "the recorder stopped before the control loop's first period ({why}): \
                 nothing was recorded to replay"
            ),
        ),
        None => err(0, "no 'start' line".into()),
    })?;
    let cut_at = (end.is_none() && stopped.is_none()).then_some(n);
    Ok(Session {
        start,
        periods,
        // Shutdown requests after the last period belong to the end.
        trailing: pending,
        end,
        cut_at,
        stopped,
        config_hash,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every bus state is written as the code the state snapshot publishes
    /// (named by `ipc::bus_state_name`) and reads back as itself.
    #[test]
    fn period_lines_carry_the_published_bus_state_codes() {
        let names: Vec<_> = BusState::ALL
            .iter()
            .map(|s| anguilla_ipc::bus_state_name(s.code()))
            .collect();
        assert_eq!(
            names,
            ["error-active", "error-passive", "bus-off", "adapter gone"]
        );
        let dir = std::env::temp_dir().join(format!("anguilla-session-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("session.log");
        let mut text = Vec::new();
        write_header(&mut text, "x = 1\n").unwrap();
        write_line(&mut text, &Record::Start(Nanos::from_nanos(5))).unwrap();
        for (i, s) in BusState::ALL.into_iter().enumerate() {
            write_line(
                &mut text,
                &Record::Period {
                    now: Nanos::from_nanos(10 + i as u64),
                    bus: s,
                },
            )
            .unwrap();
        }
        write_line(&mut text, &Record::End).unwrap();
        std::fs::write(&path, &text).unwrap();
        let session = parse(&path).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        let got: Vec<_> = session.periods.iter().map(|p| (p.now, p.bus)).collect();
        assert_eq!(
            got,
            BusState::ALL
                .into_iter()
                .enumerate()
                .map(|(i, s)| (Nanos::from_nanos(10 + i as u64), s))
                .collect::<Vec<_>>()
        );
        assert_eq!(session.config_hash, Some(fnv1a(b"x = 1\n")));
        assert!(session.end.is_some() && session.cut_at.is_none());
    }

    /// A `stopped` line ends the session with its reason: not cut (a
    /// kill), not shut down (`E`); a line break in the reason stays on the
    /// line.
    #[test]
    fn a_stopped_line_is_an_end_with_its_reason() {
        let dir = std::env::temp_dir().join(format!("anguilla-stopped-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("session.log");
        let mut text = Vec::new();
        write_header(&mut text, "x = 1\n").unwrap();
        write_line(&mut text, &Record::Start(Nanos::from_nanos(5))).unwrap();
        write_stopped(&mut text, "min-free: 3 MB free\non /x").unwrap();
        std::fs::write(&path, &text).unwrap();
        let session = parse(&path).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(
            session.stopped.as_deref(),
            Some("min-free: 3 MB free on /x")
        );
        assert!(session.cut_at.is_none() && session.end.is_none());
    }

    /// A recorder stopped before the loop's first record (min-free reached
    /// during the daemon's start-up) says so, with its reason, instead of
    /// "no 'start' line".
    #[test]
    fn a_session_stopped_before_its_start_says_why() {
        let dir = std::env::temp_dir().join(format!("anguilla-prestart-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("session.log");
        let mut text = Vec::new();
        write_header(&mut text, "x = 1\n").unwrap();
        write_stopped(&mut text, "min-free: 2 MB free").unwrap();
        std::fs::write(&path, &text).unwrap();
        let e = match parse(&path) {
            Ok(_) => panic!("a session without periods parsed"),
            Err(e) => e.to_string(),
        };
        let _ = std::fs::remove_dir_all(&dir);
        assert!(
            e.contains("stopped before the control loop's first period")
                && e.contains("min-free: 2 MB free"),
            "{e}"
        );
    }
}
