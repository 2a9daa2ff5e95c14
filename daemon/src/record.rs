//! Recording a session, and replaying it bit for bit.
//!
//! While recording (`recording.dir`), the controller hands every input and
//! output of every period to the recorder thread through a bounded channel
//! that never blocks (a full channel drops the record and counts it). The
//! recorder writes four files into a fresh directory, flushed and synced to
//! the disk every [`SYNC_INTERVAL`] and at the end (a recording that ends
//! early, the disk full or the daemon killed, replays as truncated):
//!
//! - `bus.log`: every frame in and out, in can-utils' `candump -l` format
//!   (interface `anguilla0`), so `canplayer`, python-can, SavvyCAN and
//!   cantools open it;
//! - `session.log`: the replay script, one line per event (below);
//! - `config.toml`: the configuration the daemon ran with;
//! - `state.bin`: every tenth [`StateSnapshot`], as its raw `#[repr(C)]`
//!   bytes (layout in `docs/ipc.md`).
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
//! D <ns> <hex>              an iceoryx2 node that died (its id)
//! S <ns>                    shutdown requested at this time
//! P <ns> <bus state 0-3>    a period starts at this time (3: adapter gone)
//! R <frame>                 a frame received in this period (cansend notation)
//! T <frame>                 a frame sent
//! X <frame>                 a frame the bus refused to send (bus-off, an
//!                           interface gone down): not on the wire, so not
//!                           in bus.log
//! E                         shutdown: actuators disabled
//! ```
//!
//! [`replay`] rebuilds the controller from `config.toml`, feeds it the
//! recorded inputs on a simulated clock and compares every frame it sends
//! with the recorded ones.

use std::fmt::Write as _;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anguilla_drivers::{Bus, BusCounters, BusState, Capabilities, Received, TimestampBase};
use anguilla_protocol::candump::{self, Interface, LogEntry, Timestamp};
use anguilla_protocol::frame::Frame;
use crossbeam_channel::Receiver;

use crate::config::{Config, ConfigError};
use crate::control::{Controller, SetupError};
use crate::ipc::{CommandRequest, Envelope, StateSnapshot};
use crate::supervisor::Nanos;

/// One recorded event. `Copy`: sending it allocates nothing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Record {
    /// The controller was created at this time.
    Start(Nanos),
    /// A period starts; the bus state as the controller read it.
    Period {
        /// The period's time.
        now: Nanos,
        /// 0 error-active, 1 error-passive, 2 bus-off, 3 adapter gone.
        bus: u8,
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

fn request_bytes(r: &CommandRequest) -> [u8; core::mem::size_of::<CommandRequest>()] {
    // SAFETY: CommandRequest is #[repr(C)], Copy, and has no padding (the
    // layout test in ipc.rs checks that its fields tile it exactly).
    unsafe { core::mem::transmute_copy(r) }
}

fn request_from(bytes: &[u8]) -> Option<CommandRequest> {
    if bytes.len() != core::mem::size_of::<CommandRequest>() {
        return None;
    }
    let mut r = CommandRequest::default();
    // SAFETY: same size, and every bit pattern is a valid CommandRequest
    // (integers and floats only).
    unsafe {
        core::ptr::copy_nonoverlapping(
            bytes.as_ptr(),
            &mut r as *mut CommandRequest as *mut u8,
            bytes.len(),
        );
    }
    Some(r)
}

fn snapshot_bytes(s: &StateSnapshot) -> &[u8] {
    // SAFETY: StateSnapshot is #[repr(C)] with no padding (tested in ipc.rs).
    unsafe {
        core::slice::from_raw_parts(
            s as *const StateSnapshot as *const u8,
            core::mem::size_of::<StateSnapshot>(),
        )
    }
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

/// Writes a recording; runs on its own thread until both channels close.
pub fn recorder(
    dir: PathBuf,
    cfg: Config,
    records: Receiver<Record>,
    mut states: Receiver<StateSnapshot>,
) -> std::io::Result<()> {
    std::fs::create_dir_all(&dir)?;
    let cfg_text = cfg.to_toml();
    std::fs::write(dir.join("config.toml"), &cfg_text)?;
    let mut session = BufWriter::new(std::fs::File::create(dir.join("session.log"))?);
    let mut bus = candump::Writer::new(BufWriter::new(std::fs::File::create(dir.join("bus.log"))?));
    let mut state = BufWriter::new(std::fs::File::create(dir.join("state.bin"))?);
    writeln!(session, "anguilla-session 2")?;
    // Which config.toml this session ran with: replay checks it.
    writeln!(session, "config {:016x}", fnv1a(cfg_text.as_bytes()))?;
    let epoch = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0);
    let iface = Interface::new("anguilla0").map_err(|_| std::io::ErrorKind::InvalidInput)?;
    let mut start = None;
    let stamp = |now: Nanos, start: Option<Nanos>| {
        let t = epoch + now.saturating_sub(start.unwrap_or(now));
        Timestamp {
            secs: t / 1_000_000_000,
            micros: ((t % 1_000_000_000) / 1000) as u32,
        }
    };
    // What is written reaches the disk at most SYNC_INTERVAL late: a power
    // cut or a kill loses at most that much (replay then says where the
    // recording ends).
    let ticks = crossbeam_channel::tick(SYNC_INTERVAL);
    let sync = |session: &mut BufWriter<std::fs::File>,
                bus: &mut candump::Writer<BufWriter<std::fs::File>>,
                state: &mut BufWriter<std::fs::File>| {
        for w in [&mut *session, bus.get_mut(), &mut *state] {
            w.flush()?;
            w.get_ref().sync_data()?;
        }
        std::io::Result::Ok(())
    };
    loop {
        crossbeam_channel::select! {
            recv(ticks) -> _ => sync(&mut session, &mut bus, &mut state)?,
            recv(records) -> r => {
                let Ok(r) = r else { break };
                match r {
                    Record::Start(t) => {
                        start = Some(t);
                        writeln!(session, "start {t}")?;
                    }
                    Record::Period { now, bus } => writeln!(session, "P {now} {bus}")?,
                    Record::Command(t, c) => writeln!(session, "C {t} {:032x} {:032x} {}", c.origin, c.node, hex(&request_bytes(&c.request)))?,
                    Record::Dead(t, id) => writeln!(session, "D {t} {id:032x}")?,
                    Record::Shutdown(t) => writeln!(session, "S {t}")?,
                    Record::End => writeln!(session, "E")?,
                    Record::Refused(_, f) => writeln!(session, "X {f}")?,
                    Record::Rx(now, f) | Record::Tx(now, f) => {
                        let tag = if matches!(r, Record::Rx(..)) { 'R' } else { 'T' };
                        writeln!(session, "{tag} {f}")?;
                        bus.write(&LogEntry::new(stamp(now, start), iface, f))?;
                    }
                }
            }
            recv(states) -> s => {
                match s {
                    Ok(s) => state.write_all(snapshot_bytes(&s))?,
                    // Closed: wait on the records alone from now on.
                    Err(_) => states = crossbeam_channel::never(),
                }
            }
        }
    }
    // Records are closed; take what is left of the states.
    for s in states.try_iter() {
        state.write_all(snapshot_bytes(&s))?;
    }
    sync(&mut session, &mut bus, &mut state)
}

/// How often the recorder flushes its files and syncs them to the disk.
pub const SYNC_INTERVAL: std::time::Duration = std::time::Duration::from_secs(1);

/// What is wrong with a recording, or with replaying it.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// A file could not be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// `config.toml` is not valid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A line of `session.log` is malformed.
    #[error("{path}:{line}: {what}")]
    Line {
        /// The file.
        path: String,
        /// Line number (1-based).
        line: usize,
        /// What was wrong and what was expected.
        what: String,
    },
    /// The controller could not be rebuilt.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// `config.toml` is not the configuration the session was recorded with.
    #[error(
        "{path} is not the configuration this session was recorded with (its fingerprint differs \
         from session.log's 'config' line); put the recorded one back to replay"
    )]
    ForeignConfig {
        /// The file.
        path: String,
    },
}

#[derive(Debug, Default)]
struct PeriodIn {
    now: Nanos,
    bus: u8,
    before: Vec<Record>,
    rx: Vec<Frame>,
    /// Frames the controller sent, `false` where the bus refused them.
    tx: Vec<(Frame, bool)>,
}

/// The outcome of a replay.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReplayReport {
    /// Periods replayed.
    pub periods: usize,
    /// Frames compared.
    pub frames: usize,
    /// The first difference, if any: (period index, what differed).
    pub mismatch: Option<(usize, String)>,
    /// When the recording has no end (the daemon was killed, the disk
    /// filled): the line it stops at. Its last period may be incomplete,
    /// so it is not compared; every period before it was.
    pub truncated_at: Option<usize>,
}

impl ReplayReport {
    /// Whether every frame matched bit for bit.
    pub fn identical(&self) -> bool {
        self.mismatch.is_none()
    }
}

/// A bus that replays recorded input and collects output.
struct ReplayBus {
    rx: std::collections::VecDeque<Frame>,
    /// What the recording says was sent, to refuse the same sends.
    expected: Vec<(Frame, bool)>,
    tx: Vec<(Frame, bool)>,
    state: BusState,
}

impl Bus for ReplayBus {
    fn send(&mut self, frame: &Frame) -> anguilla_drivers::Result<()> {
        // Refused where the recorded bus refused this frame at this point.
        let refused = self
            .expected
            .get(self.tx.len())
            .is_some_and(|&(f, sent)| !sent && f == *frame);
        self.tx.push((*frame, !refused));
        if refused {
            Err(anguilla_drivers::BusError::BusOff)
        } else {
            Ok(())
        }
    }
    fn recv(&mut self, _: std::time::Duration) -> anguilla_drivers::Result<Option<Received>> {
        Ok(self.rx.pop_front().map(|frame| Received {
            frame,
            timestamp: None,
        }))
    }
    fn state(&self) -> BusState {
        self.state
    }
    fn counters(&self) -> BusCounters {
        BusCounters::default()
    }
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            fd: true,
            remote: true,
            timestamps: TimestampBase::None,
            simulated_faults: false,
        }
    }
    fn flush_tx(&mut self) -> anguilla_drivers::Result<()> {
        Ok(())
    }
    fn reopen(&mut self) -> anguilla_drivers::Result<()> {
        Ok(())
    }
    fn spec(&self) -> &str {
        "replay"
    }
}

/// A parsed `session.log`.
struct Session {
    start: Nanos,
    periods: Vec<PeriodIn>,
    /// Records after the last period (a shutdown request).
    trailing: Vec<Record>,
    /// Frames sent at shutdown, if the session ended with `E`.
    end: Option<Vec<(Frame, bool)>>,
    /// Without `E`: the number of the last line read (the recording was cut).
    cut_at: Option<usize>,
    /// The recorded configuration's hash (sessions since it was added).
    config_hash: Option<u64>,
}

/// FNV-1a, 64 bits: a recording's fingerprint of its `config.toml`.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Longest `session.log` line read (the longest written is about 300 bytes).
pub const MAX_LINE: usize = 4096;

fn parse_session(path: &Path) -> Result<Session, ReplayError> {
    let p = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|source| ReplayError::Read {
        path: p.clone(),
        source,
    })?;
    let err = |line: usize, what: String| ReplayError::Line {
        path: p.clone(),
        line,
        what,
    };
    let mut start = None;
    let mut config_hash = None;
    let mut periods: Vec<PeriodIn> = Vec::new();
    let mut pending: Vec<Record> = Vec::new();
    let mut end: Option<Vec<(Frame, bool)>> = None;
    let mut reader = std::io::BufReader::new(file);
    let mut buf = Vec::with_capacity(256);
    let mut n = 0;
    loop {
        use std::io::{BufRead as _, Read as _};
        buf.clear();
        let got = (&mut reader)
            .take(MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut buf)
            .map_err(|source| ReplayError::Read {
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
            if line != "anguilla-session 2" {
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
        match tag {
            "start" => start = Some(num(rest, "start time")?),
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
                let t = num(t, "command time")?;
                let id = |s: &str, what: &str| {
                    u128::from_str_radix(s, 16)
                        .map_err(|_| err(n, format!("{what} '{s}' (expected 32 hex digits)")))
                };
                let (origin, node) = (id(origin, "origin")?, id(node, "node id")?);
                let bytes =
                    unhex(rest).ok_or_else(|| err(n, "command: expected hex bytes".into()))?;
                let req = request_from(&bytes).ok_or_else(|| {
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
                let t = num(t, "time")?;
                let id = u128::from_str_radix(rest, 16)
                    .map_err(|_| err(n, format!("node id '{rest}' (expected 32 hex digits)")))?;
                pending.push(Record::Dead(t, id));
            }
            "S" => pending.push(Record::Shutdown(num(rest, "shutdown time")?)),
            "P" => {
                let (t, b) = rest
                    .split_once(' ')
                    .ok_or_else(|| err(n, "period: expected '<ns> <bus state>'".into()))?;
                let bus = num(b, "bus state")?;
                if bus > 3 {
                    return Err(err(n, format!("bus state {bus} (expected 0, 1, 2 or 3)")));
                }
                periods.push(PeriodIn {
                    now: num(t, "period time")?,
                    bus: bus as u8,
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
            other => {
                return Err(err(
                    n,
                    format!(
                        "unknown line tag '{other}' (expected config, start, C, D, S, P, R, T, X or E)"
                    ),
                ));
            }
        }
    }
    let start = start.ok_or_else(|| err(0, "no 'start' line".into()))?;
    let cut_at = end.is_none().then_some(n);
    Ok(Session {
        start,
        periods,
        // Shutdown requests after the last period belong to the end.
        trailing: pending,
        end,
        cut_at,
        config_hash,
    })
}

/// Feeds one recorded input to the controller.
fn apply(ctl: &mut Controller, r: &Record) {
    match *r {
        Record::Command(t, env) => {
            ctl.command(t, &env);
        }
        Record::Dead(t, id) => {
            ctl.node_died(t, id);
        }
        Record::Shutdown(t) => ctl.begin_shutdown(t),
        _ => {}
    }
}

/// Replays the recording in `dir` and compares every frame sent.
pub fn replay(dir: &Path) -> Result<ReplayReport, ReplayError> {
    let cfg_path = dir.join("config.toml");
    let cfg = Config::load(&cfg_path)?;
    let Session {
        start,
        mut periods,
        trailing,
        end,
        cut_at,
        config_hash,
    } = parse_session(&dir.join("session.log"))?;
    // The configuration, not its spelling: comments and layout may differ.
    if let Some(h) = config_hash
        && h != fnv1a(cfg.to_toml().as_bytes())
    {
        return Err(ReplayError::ForeignConfig {
            path: cfg_path.display().to_string(),
        });
    }
    // A cut recording's last period may have lost frames: not compared.
    if cut_at.is_some() {
        periods.pop();
    }
    let mut ctl = Controller::new(&cfg, start)?;
    let mut bus = ReplayBus {
        rx: Default::default(),
        expected: Vec::new(),
        tx: Vec::new(),
        state: BusState::ErrorActive,
    };
    let mut report = ReplayReport {
        periods: 0,
        frames: 0,
        mismatch: None,
        truncated_at: cut_at,
    };
    let compare =
        |k: usize, expected: &[(Frame, bool)], got: &[(Frame, bool)], report: &mut ReplayReport| {
            let how = |sent: bool| if sent { "sent" } else { "refused" };
            for (i, ((e, es), (g, gs))) in expected.iter().zip(got).enumerate() {
                if e != g || es != gs {
                    report.mismatch = Some((
                        k,
                        format!(
                            "frame {i}: recorded {e} ({}), replayed {g} ({})",
                            how(*es),
                            how(*gs)
                        ),
                    ));
                    return;
                }
            }
            if expected.len() != got.len() {
                report.mismatch = Some((
                    k,
                    format!("{} frames recorded, {} replayed", expected.len(), got.len()),
                ));
                return;
            }
            report.frames += expected.len();
        };
    for (k, p) in periods.iter().enumerate() {
        for r in &p.before {
            apply(&mut ctl, r);
        }
        bus.rx = p.rx.iter().copied().collect();
        bus.expected.clone_from(&p.tx);
        bus.tx.clear();
        bus.state = match p.bus {
            1 => BusState::ErrorPassive,
            2 => BusState::BusOff,
            3 => BusState::Gone,
            _ => BusState::ErrorActive,
        };
        ctl.run_period(p.now, &mut bus);
        report.periods += 1;
        compare(k, &p.tx, &bus.tx, &mut report);
        if report.mismatch.is_some() {
            return Ok(report);
        }
    }
    for r in &trailing {
        apply(&mut ctl, r);
    }
    if let Some(end) = end {
        bus.expected.clone_from(&end);
        bus.tx.clear();
        ctl.disable_all(&mut bus);
        compare(periods.len(), &end, &bus.tx, &mut report);
    }
    Ok(report)
}
