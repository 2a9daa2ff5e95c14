//! SLCAN (Lawicel ASCII) serial adapters: CANable, USBtin, CANUSB.
//!
//! [`SlcanBus`] drives an adapter through the `serialport` crate: it closes
//! the channel, sets the bit rate (`S0`..`S8`), optionally turns timestamps
//! on (`Z1`), opens (`O`, or `L` listen-only) and then exchanges frame lines.
//! It polls the `F` status flags every `status_interval` while receiving,
//! and maps them to [`BusState`]. After bus-off, `send` fails until the
//! channel recovers: automatically, with exponential back-off, by closing
//! and reopening the port and the channel (the only recovery these adapters
//! offer), or when the caller calls [`Bus::reopen`].
//!
//! [`emulator::SlcanEmulator`] plays the adapter's side for any [`Bus`], on
//! a pseudo-terminal, so tests (and the simulated robot) can be reached
//! through the real serial driver.

pub mod codec;
pub mod emulator;

use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

use serialport::{ClearBuffer, SerialPort, TTYPort};

use crate::backoff::Backoff;
use crate::{
    Bus, BusCounters, BusState, Capabilities, Frame, LinkError, LostReason, OpenError, OpenResult,
    Received, Result, TimestampBase, Unsendable,
};
use codec::{Bitrate, Command, LineReader, MAX_LINE, Reply, Token};

/// Frames held between reads.
const RX_CAPACITY: usize = 1024;

/// Options of an SLCAN adapter (`slcan:PATH@BITRATE?baud=..&timestamps=..`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SlcanConfig {
    /// The spec string, for messages (defaults to the canonical form).
    pub spec: String,
    /// Serial device path.
    pub path: String,
    /// CAN bit rate.
    pub bitrate: Bitrate,
    /// Serial baud rate (ignored by USB CDC adapters; default 115200).
    pub baud: u32,
    /// Ask the adapter for millisecond timestamps (`Z1`).
    pub timestamps: bool,
    /// Open listen-only (`L`): receive, never send or acknowledge.
    pub listen_only: bool,
    /// Send and accept CAN FD frames with the CANable 2.0 slcan extension
    /// (`d/D/b/B`); the adapter must support it and have its data bit rate
    /// set beforehand.
    pub fd: bool,
    /// How often to poll the status flags (`F`) while receiving.
    pub status_interval: Option<Duration>,
    /// How long to wait for the adapter's answer to a setup command.
    pub reply_timeout: Duration,
    /// The shorter answer timeout used by automatic recovery, which runs
    /// inside `send`/`recv`: it bounds how long one attempt can block.
    pub recovery_reply_timeout: Duration,
    /// Recover from bus-off and disconnection by itself (close, reopen,
    /// with back-off) inside `send`/`recv`. Each attempt blocks for the
    /// setup exchange: three or four round trips to the adapter, each
    /// bounded by `recovery_reply_timeout`. Turn it off to call
    /// [`Bus::reopen`] at a time of your choosing instead.
    pub auto_recover: bool,
}

impl SlcanConfig {
    /// Defaults: 115200 baud, no timestamps, status every 100 ms, 500 ms
    /// reply timeout.
    pub fn new(path: &str, bitrate: Bitrate) -> Self {
        Self {
            spec: format!("slcan:{path}@{}", bitrate.bps()),
            path: path.to_owned(),
            bitrate,
            baud: 115_200,
            timestamps: false,
            listen_only: false,
            fd: false,
            status_interval: Some(Duration::from_millis(100)),
            reply_timeout: Duration::from_millis(500),
            recovery_reply_timeout: Duration::from_millis(20),
            auto_recover: true,
        }
    }
}

/// What the receive side has learnt; separate from the reader so both can
/// be borrowed at once.
#[derive(Debug)]
struct RxSide {
    rx: VecDeque<Received>,
    state: BusState,
    counters: BusCounters,
}

impl RxSide {
    fn token(&mut self, t: Token<'_>) {
        match t {
            Token::Line(line) => match codec::parse_reply(line) {
                Ok(Reply::Frame { frame, timestamp }) => {
                    if self.rx.len() >= RX_CAPACITY {
                        self.counters.rx_overruns += 1;
                    } else {
                        self.rx.push_back(Received {
                            frame,
                            timestamp: timestamp.map(|ms| Duration::from_millis(u64::from(ms))),
                        });
                    }
                }
                Ok(Reply::Status(flags)) => {
                    let new = flags.state();
                    if new == BusState::BusOff && self.state != BusState::BusOff {
                        self.counters.bus_off_count += 1;
                    }
                    if flags.overrun() {
                        self.counters.rx_overruns += 1;
                    }
                    // Bus-off is left only by reopening the channel.
                    if self.state != BusState::BusOff {
                        self.state = new;
                    }
                }
                Ok(Reply::Ack | Reply::TxAck | Reply::Version(_) | Reply::Serial(_)) => {}
                Ok(Reply::Bell) | Err(_) => self.counters.errors += 1,
            },
            Token::Bell | Token::Error(_) => self.counters.errors += 1,
        }
    }
}

/// An SLCAN serial adapter; implements [`Bus`].
pub struct SlcanBus {
    config: SlcanConfig,
    port: Option<TTYPort>,
    reader: LineReader,
    side: RxSide,
    last_status: Instant,
    backoff: Backoff,
}

impl std::fmt::Debug for SlcanBus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "SlcanBus({})", self.config.spec)
    }
}

/// Whether `port` has bytes (or a hang-up) to read within `timeout`.
pub(crate) fn wait_readable(port: &TTYPort, timeout: Duration) -> bool {
    use nix::poll::{PollFd, PollFlags, PollTimeout, poll};
    use std::os::fd::{AsRawFd, BorrowedFd};
    // SAFETY: the descriptor belongs to `port`, which outlives this call.
    let fd = unsafe { BorrowedFd::borrow_raw(port.as_raw_fd()) };
    let ms = timeout.as_micros().div_ceil(1000).min(i32::MAX as u128) as i32;
    let mut fds = [PollFd::new(fd, PollFlags::POLLIN)];
    match poll(
        &mut fds,
        PollTimeout::try_from(ms).unwrap_or(PollTimeout::MAX),
    ) {
        Ok(n) => n > 0,
        // EINTR and friends: report readable and let `read` tell.
        Err(_) => true,
    }
}

/// Reads and discards up to the end of the adapter's answer to `V` (a line
/// starting with `V`), or until `max` passes (adapters that reject `V`).
fn discard_until_version(port: &mut TTYPort, reader: &mut LineReader, max: Duration) {
    let t0 = Instant::now();
    let mut buf = [0u8; 256];
    let mut found = false;
    while !found {
        let left = max.saturating_sub(t0.elapsed());
        if left.is_zero() || !wait_readable(port, left) {
            return;
        }
        let _ = port.set_timeout(Duration::ZERO);
        let n = match port.read(&mut buf) {
            Ok(n) if n > 0 => n,
            _ => return,
        };
        // Lines after the marker in the same read answer nothing we sent
        // yet (frames of a channel being closed): dropping them is fine.
        reader.feed(&buf[..n], &mut |t| {
            if let Token::Line([b'V', ..]) = t {
                found = true;
            }
        });
    }
}

fn escape(bytes: &[u8]) -> String {
    bytes.escape_ascii().to_string()
}

fn command_text(cmd: &Command) -> String {
    let mut b = [0; MAX_LINE];
    let n = codec::encode_command(cmd, &mut b);
    escape(&b[..n.saturating_sub(1)])
}

impl SlcanBus {
    /// Opens the device and sets the adapter up.
    pub fn open(config: &SlcanConfig) -> OpenResult<Self> {
        let mut bus = SlcanBus {
            config: config.clone(),
            port: None,
            reader: LineReader::new(),
            side: RxSide {
                rx: VecDeque::with_capacity(RX_CAPACITY),
                state: BusState::ErrorActive,
                counters: BusCounters::default(),
            },
            last_status: Instant::now(),
            backoff: Backoff::new(),
        };
        bus.connect(config.reply_timeout)?;
        Ok(bus)
    }

    fn open_port(&self) -> OpenResult<TTYPort> {
        let c = &self.config;
        serialport::new(&c.path, c.baud)
            .timeout(Duration::from_millis(10))
            .open_native()
            .map_err(|e| {
                let io: io::Error = e.into();
                match io.kind() {
                    io::ErrorKind::NotFound => OpenError::MissingDevice {
                        spec: c.spec.clone(),
                        path: c.path.clone(),
                    },
                    io::ErrorKind::PermissionDenied => OpenError::PermissionDenied {
                        spec: c.spec.clone(),
                        path: c.path.clone(),
                    },
                    _ => OpenError::Io {
                        spec: format!("{} ({})", c.spec, c.path),
                        source: io,
                    },
                }
            })
    }

    /// Opens the port and runs the setup sequence.
    fn connect(&mut self, reply_timeout: Duration) -> OpenResult<()> {
        self.port = None;
        let mut port = self.open_port()?;
        self.reader.reset();
        // Close a channel left open by a previous user (or by us), and ask
        // for the version as a marker: everything before its answer (late
        // frames, answers to status polls and to this `C`, ok or BEL) is
        // discarded, so it is not taken for the answer to a setup command.
        port.write_all(b"C\rV\r")
            .map_err(|e| OpenError::io(&self.config.spec, e))?;
        // The reader keeps its place in the byte stream, so the next
        // command sees whole lines.
        discard_until_version(&mut port, &mut self.reader, reply_timeout);
        self.command(
            &mut port,
            &Command::Bitrate(self.config.bitrate),
            reply_timeout,
        )?;
        if self.config.timestamps {
            self.command(&mut port, &Command::Timestamps(true), reply_timeout)?;
        }
        let open = if self.config.listen_only {
            Command::ListenOnly
        } else {
            Command::Open
        };
        self.command(&mut port, &open, reply_timeout)?;
        self.side.rx.clear();
        self.side.state = BusState::ErrorActive;
        self.last_status = Instant::now();
        self.port = Some(port);
        Ok(())
    }

    /// Sends a setup command and waits for its answer.
    fn command(&mut self, port: &mut TTYPort, cmd: &Command, timeout: Duration) -> OpenResult<()> {
        let spec = &self.config.spec;
        let mut b = [0; MAX_LINE];
        let n = codec::encode_command(cmd, &mut b);
        port.write_all(&b[..n])
            .map_err(|e| OpenError::io(spec, e))?;
        let deadline = Instant::now() + timeout;
        let mut outcome: Option<OpenResult<()>> = None;
        let mut buf = [0u8; 256];
        while outcome.is_none() {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(OpenError::AdapterTimeout {
                    spec: spec.clone(),
                    command: command_text(cmd),
                    timeout_ms: timeout.as_millis() as u64,
                });
            }
            let _ = port.set_timeout(left);
            let got = match port.read(&mut buf) {
                Ok(0) => {
                    return Err(OpenError::Disconnected {
                        spec: spec.clone(),
                        reason: LostReason::EndOfFile,
                    });
                }
                Ok(k) => k,
                Err(e) if transient(&e) => {
                    continue;
                }
                Err(e) => return Err(OpenError::io(spec, e)),
            };
            self.reader.feed(&buf[..got], &mut |t| {
                if outcome.is_some() {
                    return;
                }
                let rejected = || OpenError::AdapterRejected {
                    spec: spec.clone(),
                    command: command_text(cmd),
                };
                match t {
                    Token::Bell => outcome = Some(Err(rejected())),
                    Token::Line(line) => match codec::parse_reply(line) {
                        Ok(Reply::Ack) => outcome = Some(Ok(())),
                        // Frames and late answers during setup are dropped.
                        Ok(_) => {}
                        Err(e) => {
                            outcome = Some(Err(OpenError::AdapterGarbage {
                                spec: spec.clone(),
                                command: command_text(cmd),
                                detail: format!("{e}: \"{}\"", escape(line)),
                            }))
                        }
                    },
                    Token::Error(e) => {
                        outcome = Some(Err(OpenError::AdapterGarbage {
                            spec: spec.clone(),
                            command: command_text(cmd),
                            detail: e.to_string(),
                        }))
                    }
                }
            });
        }
        outcome.unwrap_or(Ok(()))
    }

    /// Drops the port (the state becomes [`BusState::Gone`]); allocates
    /// nothing.
    fn disconnected(&mut self, reason: LostReason) -> LinkError {
        self.port = None;
        LinkError::Disconnected(reason)
    }

    /// While bus-off or disconnected, tries to reconnect when the back-off
    /// allows. Returns whether the port is usable.
    fn recover(&mut self) -> bool {
        if self.port.is_some() && self.side.state != BusState::BusOff {
            return true;
        }
        if !self.config.auto_recover || !self.backoff.due() {
            return false;
        }
        if self.connect(self.config.recovery_reply_timeout).is_ok() {
            self.side.counters.reopens += 1;
            self.backoff.recovered();
            true
        } else {
            false
        }
    }

    fn poll_status(&mut self) -> Result<()> {
        let Some(every) = self.config.status_interval else {
            return Ok(());
        };
        if self.last_status.elapsed() < every {
            return Ok(());
        }
        self.last_status = Instant::now();
        let Some(port) = self.port.as_mut() else {
            return Ok(());
        };
        match port.write_all(b"F\r") {
            Ok(()) => Ok(()),
            // The line is full (the adapter is not reading yet): a full
            // queue, as for a frame, not a lost adapter; ask next time.
            Err(e) if transient(&e) => Ok(()),
            Err(e) => Err(self.disconnected(LostReason::Io((&e).into()))),
        }
    }

    /// Reads what is there (waiting up to `timeout`) into the queue.
    fn fill(&mut self, timeout: Duration) -> Result<()> {
        let Some(port) = self.port.as_mut() else {
            return Ok(());
        };
        let mut buf = [0u8; 512];
        // Wait with poll(2) ourselves: a timed-out `serialport` read builds
        // an error holding a `String`, which the control period must not.
        if !wait_readable(port, timeout) {
            return Ok(());
        }
        let _ = port.set_timeout(Duration::ZERO);
        match port.read(&mut buf) {
            Ok(0) => Err(self.disconnected(LostReason::EndOfFile)),
            Ok(n) => {
                let side = &mut self.side;
                self.reader.feed(&buf[..n], &mut |t| side.token(t));
                if side.state == BusState::BusOff {
                    // Nothing queued before the fault may leave late.
                    let _ = port.clear(ClearBuffer::Output);
                }
                Ok(())
            }
            Err(e) if transient(&e) => Ok(()),
            Err(e) => Err(self.disconnected(LostReason::Io((&e).into()))),
        }
    }

    fn pop(&mut self) -> Option<Received> {
        let r = self.side.rx.pop_front()?;
        self.side.counters.rx += 1;
        Some(r)
    }
}

impl Drop for SlcanBus {
    fn drop(&mut self) {
        if let Some(port) = self.port.as_mut() {
            let _ = port.write_all(b"C\r");
        }
    }
}

impl Bus for SlcanBus {
    fn send(&mut self, frame: &Frame) -> Result<()> {
        if self.config.listen_only {
            return Err(LinkError::Unsupported(Unsendable::ListenOnly));
        }
        if frame.is_fd() && !self.config.fd {
            return Err(LinkError::Unsupported(Unsendable::FdNotEnabled));
        }
        if !self.recover() {
            return Err(if self.side.state == BusState::BusOff {
                LinkError::BusOff
            } else {
                self.disconnected(LostReason::Reconnecting)
            });
        }
        let mut b = [0; MAX_LINE];
        let n = codec::encode_frame(frame, None, &mut b);
        let Some(port) = self.port.as_mut() else {
            return Err(LinkError::BusOff);
        };
        match port.write_all(&b[..n]) {
            Ok(()) => {
                self.side.counters.tx += 1;
                Ok(())
            }
            Err(e) if e.kind() == io::ErrorKind::TimedOut => {
                self.side.counters.tx_dropped += 1;
                Err(LinkError::TxQueueFull)
            }
            Err(e) => Err(self.disconnected(LostReason::Io((&e).into()))),
        }
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<Received>> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(r) = self.pop() {
                return Ok(Some(r));
            }
            self.recover();
            self.poll_status()?;
            let left = deadline.saturating_duration_since(Instant::now());
            if self.port.is_none() {
                if left.is_zero() {
                    return Ok(None);
                }
                // Disconnected: wait out the back-off (bounded by `left`).
                std::thread::park_timeout(left.min(Backoff::MIN));
                continue;
            }
            self.fill(left.min(Duration::from_millis(50)))?;
            if left.is_zero() {
                return Ok(self.pop());
            }
        }
    }

    fn state(&self) -> BusState {
        if self.port.is_none() {
            BusState::Gone
        } else {
            self.side.state
        }
    }

    fn counters(&self) -> BusCounters {
        self.side.counters
    }

    fn capabilities(&self) -> Capabilities {
        Capabilities {
            // Whether an adapter accepts the FD extension cannot be asked.
            fd: self.config.fd,
            remote: true,
            timestamps: if self.config.timestamps {
                TimestampBase::AdapterMillis
            } else {
                TimestampBase::None
            },
            simulated_faults: false,
        }
    }

    /// Discards bytes not yet written to the adapter. Frames already in the
    /// adapter's own queue are beyond reach; [`Bus::reopen`] (close/open)
    /// clears them on adapters that reset their queue on `C`.
    fn flush_tx(&mut self) -> Result<()> {
        if let Some(port) = self.port.as_mut() {
            port.clear(ClearBuffer::Output)
                .map_err(|e| LinkError::io(&e.into()))?;
        }
        Ok(())
    }

    fn reopen(&mut self) -> OpenResult<()> {
        if let Some(port) = self.port.as_mut() {
            let _ = port.clear(ClearBuffer::Output);
        }
        self.port = None;
        self.side.rx.clear();
        self.side.counters.reopens += 1;
        self.connect(self.config.reply_timeout)?;
        self.backoff.reset();
        Ok(())
    }

    fn spec(&self) -> &str {
        &self.config.spec
    }
}

/// A serial read or write that found nothing to do this time (a timeout,
/// no data yet, a signal): try again. Every other error is the line's loss.
fn transient(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
    )
}
