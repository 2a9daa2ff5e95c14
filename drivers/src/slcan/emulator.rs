//! An SLCAN adapter emulator: makes any [`Bus`] look like a USB SLCAN
//! adapter (CANable-style) on a serial line, typically a pseudo-terminal.
//!
//! ```no_run
//! use anguilla_drivers::{open, slcan::emulator::{EmulatorConfig, SlcanEmulator}};
//! let node = open("mem:robot").unwrap();
//! let emu = SlcanEmulator::on_pty(node, EmulatorConfig::default()).unwrap();
//! // Any SLCAN tool (or `slcan:PATH@1000000`) can now open this path.
//! println!("{}", emu.path().unwrap());
//! let _node = emu.stop();
//! ```
//!
//! The emulator runs on its own thread until [`SlcanEmulator::stop`] (or
//! drop). It answers `S`/`s`/`Z` only while closed, `F` and frames only while
//! open, with BEL otherwise, like a Lawicel adapter; it acknowledges
//! transmitted frames with `z`/`Z`; `F` reports the bus state
//! (error-passive → bit 5, bus-off → bit 7). Opening a channel whose bus is
//! bus-off reopens the bus (adapters recover by close and open). Frames that
//! arrive from the bus while the channel is closed are discarded.

use std::io::{self, Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

use super::codec::{self, Command, LineReader, MAX_LINE, StatusFlags, Token};
use crate::{Bus, BusState};

/// How the emulated adapter behaves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EmulatorConfig {
    /// Answer to `V` (4 characters).
    pub version: [u8; 4],
    /// Answer to `N` (4 characters).
    pub serial: [u8; 4],
    /// Accept CAN FD frame commands (`d/D/b/B`).
    pub fd: bool,
    /// Answer BEL to every command (a broken or foreign adapter), for tests.
    pub reject_all: bool,
}

impl Default for EmulatorConfig {
    fn default() -> Self {
        Self {
            version: *b"1013",
            serial: *b"AN01",
            fd: false,
            reject_all: false,
        }
    }
}

/// Counters of the emulator thread.
#[derive(Debug, Default)]
pub struct EmulatorStats {
    /// Command lines handled.
    pub commands: AtomicU64,
    /// Commands answered with BEL.
    pub rejected: AtomicU64,
    /// Frames written to the host.
    pub frames_to_host: AtomicU64,
    /// Frames sent on the bus for the host.
    pub frames_from_host: AtomicU64,
    /// Frames from the bus discarded (channel closed or host not reading).
    pub discarded: AtomicU64,
}

/// Asks an emulator thread to stop; cheap to clone.
#[derive(Debug, Clone)]
pub struct StopHandle(Arc<AtomicBool>);

impl StopHandle {
    /// Requests the stop; the thread ends within one read timeout.
    pub fn stop(&self) {
        self.0.store(true, Ordering::Release);
    }
}

/// A running emulator; stops its thread on [`stop`](Self::stop) or drop.
pub struct SlcanEmulator {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<Box<dyn Bus>>>,
    path: Option<String>,
    stats: Arc<EmulatorStats>,
    /// Keeps the pty slave open so the master never sees a hang-up between
    /// two users of the path.
    _slave: Option<TTYPort>,
}

impl std::fmt::Debug for SlcanEmulator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "SlcanEmulator({:?})", self.path)
    }
}

struct Adapter<S> {
    port: S,
    bus: Box<dyn Bus>,
    config: EmulatorConfig,
    stats: Arc<EmulatorStats>,
    open: bool,
    listen_only: bool,
    timestamps: bool,
    epoch: Instant,
    last_overruns: u64,
}

impl<S: Read + Write> Adapter<S> {
    fn reply(&mut self, bytes: &[u8]) {
        // A host that does not read makes writes time out: drop the reply.
        let _ = self.port.write_all(bytes);
    }

    fn bel(&mut self) {
        self.stats.rejected.fetch_add(1, Ordering::Relaxed);
        self.reply(&[codec::BEL]);
    }

    fn handle(&mut self, line: &[u8]) {
        self.stats.commands.fetch_add(1, Ordering::Relaxed);
        if self.config.reject_all {
            return self.bel();
        }
        let Ok(cmd) = codec::parse_command(line) else {
            return self.bel();
        };
        match cmd {
            Command::Bitrate(_) | Command::Btr(..) | Command::Timestamps(_) if self.open => {
                self.bel()
            }
            Command::Bitrate(_) | Command::Btr(..) => self.reply(b"\r"),
            Command::Timestamps(on) => {
                self.timestamps = on;
                self.reply(b"\r")
            }
            Command::Open | Command::ListenOnly if self.open => self.bel(),
            Command::Open | Command::ListenOnly => {
                if self.bus.state() == BusState::BusOff {
                    let _ = self.bus.reopen();
                }
                let _ = self.bus.drain(&mut |_| {});
                self.last_overruns = self.bus.counters().rx_overruns;
                self.open = true;
                self.listen_only = cmd == Command::ListenOnly;
                self.reply(b"\r")
            }
            Command::Close if !self.open => self.bel(),
            Command::Close => {
                self.open = false;
                self.reply(b"\r")
            }
            Command::Version => {
                let mut r = *b"V0000\r";
                r[1..5].copy_from_slice(&self.config.version);
                self.reply(&r)
            }
            Command::SerialNumber => {
                let mut r = *b"N0000\r";
                r[1..5].copy_from_slice(&self.config.serial);
                self.reply(&r)
            }
            Command::Status if !self.open => self.bel(),
            Command::Status => {
                let mut flags = match self.bus.state() {
                    BusState::ErrorActive => 0,
                    BusState::ErrorPassive => StatusFlags::ERROR_PASSIVE,
                    BusState::BusOff | BusState::Gone => StatusFlags::BUS_ERROR,
                };
                let overruns = self.bus.counters().rx_overruns;
                if overruns != self.last_overruns {
                    flags |= StatusFlags::DATA_OVERRUN;
                    self.last_overruns = overruns;
                }
                const HEX: &[u8; 16] = b"0123456789ABCDEF";
                let r = [
                    b'F',
                    HEX[usize::from(flags >> 4)],
                    HEX[usize::from(flags & 0xF)],
                    b'\r',
                ];
                self.reply(&r)
            }
            Command::Transmit(f) => {
                if !self.open || self.listen_only || (f.is_fd() && !self.config.fd) {
                    return self.bel();
                }
                match self.bus.send(&f) {
                    Ok(()) => {
                        self.stats.frames_from_host.fetch_add(1, Ordering::Relaxed);
                        let ack: &[u8] = if f.id().is_extended() { b"Z\r" } else { b"z\r" };
                        self.reply(ack)
                    }
                    Err(_) => self.bel(),
                }
            }
        }
    }

    fn forward_bus(&mut self) {
        let mut out = [0u8; MAX_LINE];
        loop {
            let r = match self.bus.try_recv() {
                Ok(Some(r)) => r,
                _ => return,
            };
            if !self.open {
                self.stats.discarded.fetch_add(1, Ordering::Relaxed);
                continue;
            }
            let ts = self
                .timestamps
                .then(|| (self.epoch.elapsed().as_millis() % 60_000) as u16);
            let n = codec::encode_frame(&r.frame, ts, &mut out);
            match self.port.write_all(&out[..n]) {
                Ok(()) => {
                    self.stats.frames_to_host.fetch_add(1, Ordering::Relaxed);
                }
                Err(_) => {
                    self.stats.discarded.fetch_add(1, Ordering::Relaxed);
                }
            }
        }
    }

    fn run(mut self, stop: &AtomicBool) -> Box<dyn Bus> {
        let mut reader = LineReader::new();
        let mut buf = [0u8; 512];
        while !stop.load(Ordering::Acquire) {
            match self.port.read(&mut buf) {
                Ok(0) => {}
                Ok(n) => reader.feed(&buf[..n], &mut |t| match t {
                    Token::Line(l) => self.handle(l),
                    Token::Bell | Token::Error(_) => self.bel(),
                }),
                Err(e) if super::transient(&e) => {}
                Err(_) => {
                    // The line is gone (e.g. EIO): idle until stopped.
                    std::thread::park_timeout(Duration::from_millis(5));
                }
            }
            self.forward_bus();
        }
        self.bus
    }
}

/// A pty master whose read timeouts do not allocate (a timed-out
/// `serialport` read builds an error holding a `String`).
struct PtyMaster(TTYPort);

impl Read for PtyMaster {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if !super::wait_readable(&self.0, Duration::from_millis(2)) {
            return Err(io::ErrorKind::TimedOut.into());
        }
        self.0.read(buf)
    }
}

impl Write for PtyMaster {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.0.write(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.0.flush()
    }
}

impl SlcanEmulator {
    /// Runs an emulator on `port`, whose reads must time out (a few ms) so
    /// that bus frames are forwarded and stop requests are seen.
    pub fn spawn<S: Read + Write + Send + 'static>(
        port: S,
        bus: Box<dyn Bus>,
        config: EmulatorConfig,
    ) -> io::Result<Self> {
        let stop = Arc::new(AtomicBool::new(false));
        let stats = Arc::new(EmulatorStats::default());
        let adapter = Adapter {
            port,
            bus,
            config,
            stats: stats.clone(),
            open: false,
            listen_only: false,
            timestamps: false,
            epoch: Instant::now(),
            last_overruns: 0,
        };
        let s = stop.clone();
        let thread = std::thread::Builder::new()
            .name("slcan-emulator".into())
            .spawn(move || adapter.run(&s))?;
        Ok(Self {
            stop,
            thread: Some(thread),
            path: None,
            stats,
            _slave: None,
        })
    }

    /// Runs an emulator on a new pseudo-terminal; [`path`](Self::path) is
    /// the device to open (e.g. `slcan:/dev/pts/5@1000000`).
    pub fn on_pty(bus: Box<dyn Bus>, config: EmulatorConfig) -> io::Result<Self> {
        let (mut master, slave) = TTYPort::pair().map_err(io::Error::from)?;
        master
            .set_timeout(Duration::from_millis(2))
            .map_err(io::Error::from)?;
        let path = slave.name();
        let mut emu = Self::spawn(PtyMaster(master), bus, config)?;
        emu.path = path;
        emu._slave = Some(slave);
        Ok(emu)
    }

    /// The device path of the pty slave, if made by [`on_pty`](Self::on_pty).
    pub fn path(&self) -> Option<&str> {
        self.path.as_deref()
    }

    /// A handle that stops the emulator thread from anywhere (e.g. a signal
    /// handler's thread); [`stop`](Self::stop) or drop then joins it.
    pub fn stop_handle(&self) -> StopHandle {
        StopHandle(self.stop.clone())
    }

    /// Whether the thread is still running (false after a stop request).
    pub fn is_running(&self) -> bool {
        self.thread.as_ref().is_some_and(|t| !t.is_finished())
    }

    /// The emulator's counters.
    pub fn stats(&self) -> &EmulatorStats {
        &self.stats
    }

    /// Stops the thread and gives the bus back.
    pub fn stop(mut self) -> Box<dyn Bus> {
        self.stop.store(true, Ordering::Release);
        let t = self.thread.take().expect("running");
        match t.join() {
            Ok(bus) => bus,
            Err(p) => std::panic::resume_unwind(p),
        }
    }
}

impl Drop for SlcanEmulator {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
