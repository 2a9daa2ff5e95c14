//! A sensor that is not on the CAN bus: its sentences
//! ([`anguilla_protocol::position_fix`]) arrive over UDP (one a datagram)
//! or a serial line (one a line), are read by a thread of its own, and
//! reach the control loop through a bounded lock-free channel ([`SLOT`]
//! readings): the period takes one a period, never waits. Readings the
//! full channel has no room for, and malformed sentences, are counted
//! (nothing is lost unsaid). The USBL ([`super::usbl`]) and the DVL
//! ([`super::dvl`]) read their sources with it.

use std::io::{self, Read};
use std::net::{SocketAddr, UdpSocket};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use anguilla_ipc::{SensorEntry, SensorHealth, SensorKind};
use anguilla_protocol::position_fix::{FixError, MAX_LEN};
use anguilla_protocol::time::Nanos;
use crossbeam_channel::{Receiver, Sender, TrySendError};

use super::Sensor;
use crate::config::ConfigError;

/// A kind of sensor off the bus, as its section of `[sensor]` reads: what
/// the configuration checks, the commented default file, the replay, the
/// estimate and the built-in robot's simulated counterpart need of it,
/// whatever the kind ([`crate::config::SensorConfig::off_bus`] lists the
/// configured ones). A kind's module implements it for its section.
pub trait OffBusSection: std::fmt::Debug {
    /// Its kind: `[sensor.NAME]` is its section, NAME its
    /// [`SensorKind::name`] (and the simulated counterpart's).
    fn kind(&self) -> SensorKind;
    /// Its `source` key: `udp:ADDRESS:PORT` or `serial:PATH:BAUD`.
    fn source(&self) -> &str;
    /// From the measurement to the sentence's arrival (s).
    fn latency(&self) -> f64;
    /// Whether it gives positions (the estimate then judges the position
    /// by its fixes' age: [`anguilla_ipc::PositionHealth`]).
    fn gives_position(&self) -> bool {
        false
    }
    /// Why it needs the head sensor, for the refusal of a configuration
    /// without one.
    fn needs_head(&self) -> &'static str;
    /// Checks its keys (named `sensor.NAME.KEY` in the error).
    fn validate(&self) -> Result<(), ConfigError>;
    /// Its section in the commented default file, commented out.
    fn write_default(&self, w: &mut dyn FnMut(String));
    /// Opens its source and starts its reader thread.
    fn open(&self, now: Nanos) -> io::Result<Box<dyn Sensor>>;
}

/// Readings the channel from the reader thread holds.
pub const SLOT: usize = 4;
/// How often the reader thread looks whether it should stop.
const POLL: Duration = Duration::from_millis(200);

/// Where an off-bus sensor's sentences come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    /// A UDP socket bound to this address.
    Udp(SocketAddr),
    /// A serial port at a baud rate.
    Serial(String, u32),
}

impl Source {
    /// Reads `udp:ADDRESS:PORT` or `serial:PATH:BAUD`.
    pub fn parse(text: &str) -> Result<Source, String> {
        let expected = "expected \"udp:ADDRESS:PORT\" or \"serial:PATH:BAUD\"";
        if let Some(addr) = text.strip_prefix("udp:") {
            return addr
                .parse()
                .map(Source::Udp)
                .map_err(|e| format!("\"{text}\": {e} ({expected})"));
        }
        if let Some((path, baud)) = text
            .strip_prefix("serial:")
            .and_then(|rest| rest.rsplit_once(':'))
        {
            return match baud.parse::<u32>() {
                Ok(b) if b > 0 && !path.is_empty() => Ok(Source::Serial(path.into(), b)),
                _ => Err(format!("\"{text}\": no path or baud rate ({expected})")),
            };
        }
        Err(format!("\"{text}\" ({expected})"))
    }

    /// Where a sender on this machine sends to reach a `udp:` source (the
    /// loopback when the source is bound to every address); none for a
    /// serial source.
    pub fn send_to(&self) -> Option<SocketAddr> {
        let &Source::Udp(mut addr) = self else {
            return None;
        };
        if addr.ip().is_unspecified() {
            addr.set_ip(if addr.is_ipv4() {
                std::net::Ipv4Addr::LOCALHOST.into()
            } else {
                std::net::Ipv6Addr::LOCALHOST.into()
            });
        }
        Some(addr)
    }
}

/// What the reader thread counts, and its stop flag.
#[derive(Debug, Default)]
struct Shared {
    malformed: AtomicU64,
    dropped: AtomicU64,
    stop: AtomicBool,
}

/// A sentence's reading: what the sensor measured.
pub type Parse<T> = fn(&[u8]) -> Result<T, FixError>;

/// An off-bus sensor's source, read by its own thread.
pub struct Reader<T> {
    rx: Receiver<T>,
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
}

impl<T: Send + 'static> Reader<T> {
    /// Opens `source` (`udp:ADDRESS:PORT` or `serial:PATH:BAUD`) and starts
    /// its reader thread, named `name`, which reads each sentence with
    /// `parse`.
    pub fn open(source: &str, name: &'static str, parse: Parse<T>) -> io::Result<Self> {
        let parsed =
            Source::parse(source).map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
        let (tx, rx) = crossbeam_channel::bounded(SLOT);
        let shared = Arc::new(Shared::default());
        let named = |e: io::Error| io::Error::new(e.kind(), format!("{source}: {e}"));
        let d = Deliver {
            tx,
            shared: shared.clone(),
            parse,
            name,
        };
        let thread = std::thread::Builder::new().name(format!("anguilla-{name}"));
        let thread = match parsed {
            Source::Udp(addr) => {
                let sock = UdpSocket::bind(addr).map_err(named)?;
                sock.set_read_timeout(Some(POLL)).map_err(named)?;
                thread.spawn(move || read_udp(&sock, &d))?
            }
            Source::Serial(path, baud) => {
                let port = serialport::new(&path, baud)
                    .timeout(POLL)
                    .open()
                    .map_err(|e| named(e.into()))?;
                thread.spawn(move || read_lines(port, &d))?
            }
        };
        Ok(Self {
            rx,
            shared,
            thread: Some(thread),
        })
    }

    /// The oldest reading waiting, if any (one a period: the others wait
    /// in the channel).
    pub fn take(&self) -> Option<T> {
        self.rx.try_recv().ok()
    }

    /// Malformed sentences since start.
    pub fn malformed(&self) -> u64 {
        self.shared.malformed.load(Ordering::Relaxed)
    }

    /// Readings the full channel had no room for, since start.
    pub fn dropped(&self) -> u64 {
        self.shared.dropped.load(Ordering::Relaxed)
    }
}

impl<T> Drop for Reader<T> {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// An off-bus sensor's health: error while the newest sentence was
/// malformed (more malformed than when the last reading was taken); before
/// the first reading waiting, silent once `timeout` has passed five times
/// over; silent when the last reading (measured at `last`) is older than
/// `timeout` + `latency`; ok otherwise.
pub fn judge(
    now: Nanos,
    started: Nanos,
    last: Option<Nanos>,
    timeout: Nanos,
    latency: Nanos,
    malformed_since: bool,
) -> SensorHealth {
    match last {
        _ if malformed_since => SensorHealth::Error,
        None if now.saturating_sub(started) > timeout * 5 => SensorHealth::Silent,
        None => SensorHealth::Waiting,
        Some(at) if now.saturating_sub(at) > timeout + latency => SensorHealth::Silent,
        Some(_) => SensorHealth::Ok,
    }
}

/// An off-bus sensor's reading side, as the control loop sees it: one
/// reading a period from its [`Reader`], stamped with its arrival less the
/// latency (and less the age the reading says, [`Line::aged`]), the last
/// one kept, and the health ([`judge`]).
pub struct Line<T> {
    reader: Reader<T>,
    latency: Nanos,
    /// How old a reading says it is (s) when it arrives.
    age: fn(&T) -> f64,
    timeout: Nanos,
    started: Nanos,
    now: Nanos,
    /// The last reading, as sent, and when it was measured.
    last: Option<(Nanos, T)>,
    received: u32,
    malformed_at_reading: u64,
    health: SensorHealth,
}

impl<T: Copy + Send + 'static> Line<T> {
    /// Opens `source` ([`Reader::open`]) for a sensor whose readings
    /// arrive `latency` s after they were measured and which is silent
    /// after `timeout` s without one.
    pub fn open(
        source: &str,
        name: &'static str,
        parse: Parse<T>,
        latency: f64,
        timeout: f64,
        now: Nanos,
    ) -> io::Result<Self> {
        Ok(Self {
            reader: Reader::open(source, name, parse)?,
            latency: Nanos::from_secs_f64(latency),
            age: |_| 0.0,
            timeout: Nanos::from_secs_f64(timeout),
            started: now,
            now,
            last: None,
            received: 0,
            malformed_at_reading: 0,
            health: SensorHealth::Waiting,
        })
    }

    /// Readings that say their own age (s, at arrival) are stamped that
    /// much earlier still: a fix of the ROS 2 node's `pose_fix`, aged from
    /// its message's stamp.
    pub fn aged(mut self, age: fn(&T) -> f64) -> Self {
        self.age = age;
        self
    }

    /// One period at `now`: the reading taken, if one waited, with the
    /// time it was measured; the health judged.
    pub fn step(&mut self, now: Nanos) -> Option<(Nanos, T)> {
        self.now = now;
        let age = self.age;
        let taken = self.reader.take().map(|r| {
            let at = now
                .saturating_sub(self.latency)
                .saturating_sub(Nanos::from_secs_f64(age(&r)));
            self.last = Some((at, r));
            self.received = self.received.saturating_add(1);
            self.malformed_at_reading = self.reader.malformed();
            (at, r)
        });
        self.health = judge(
            now,
            self.started,
            self.last.map(|(at, _)| at),
            self.timeout,
            self.latency,
            self.reader.malformed() > self.malformed_at_reading,
        );
        taken
    }

    /// The health after the last [`Line::step`].
    pub fn health(&self) -> SensorHealth {
        self.health
    }

    /// Readings taken since start.
    #[cfg(test)]
    pub fn received(&self) -> u32 {
        self.received
    }

    /// The sensor's entry: the readings taken, then the last reading's
    /// three `values` as sent (zeros before the first), its age (s), and
    /// the malformed and dropped sentences.
    pub fn fill(&self, entry: &mut SensorEntry, values: impl Fn(&T) -> [f64; 3]) {
        entry.samples = self.received;
        let ([a, b, c], age) = match &self.last {
            Some((at, r)) => (values(r), self.now.saturating_sub(*at).as_secs_f64()),
            None => ([0.0; 3], 0.0),
        };
        let v = [
            a,
            b,
            c,
            age,
            self.reader.malformed() as f64,
            self.reader.dropped() as f64,
        ];
        for (slot, x) in entry.values.iter_mut().zip(v) {
            *slot = x as f32;
        }
    }

    /// The reader (its counters).
    #[cfg(test)]
    pub fn reader(&self) -> &Reader<T> {
        &self.reader
    }
}

/// Where the reader thread puts what it reads.
struct Deliver<T> {
    tx: Sender<T>,
    shared: Arc<Shared>,
    parse: Parse<T>,
    name: &'static str,
}

/// One sentence: to the channel if it reads and there is room.
fn deliver<T>(bytes: &[u8], d: &Deliver<T>) {
    let (tx, shared) = (&d.tx, &d.shared);
    match (d.parse)(bytes) {
        Ok(reading) => match tx.try_send(reading) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) => {
                shared.dropped.fetch_add(1, Ordering::Relaxed);
            }
            Err(TrySendError::Disconnected(_)) => shared.stop.store(true, Ordering::Relaxed),
        },
        Err(e) => {
            let n = shared.malformed.fetch_add(1, Ordering::Relaxed);
            if n.is_multiple_of(100) {
                tracing::warn!("{}: malformed sentence ({} so far): {e}", d.name, n + 1);
            }
        }
    }
}

fn read_udp<T>(sock: &UdpSocket, d: &Deliver<T>) {
    let mut buf = [0u8; 2 * MAX_LEN];
    while !d.shared.stop.load(Ordering::Relaxed) {
        match sock.recv(&mut buf) {
            // A datagram longer than the buffer arrives cut: too long.
            Ok(n) if n == buf.len() => deliver(&buf, d),
            Ok(n) => deliver(&buf[..n], d),
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) => {}
            // An ICMP error from an earlier send, an interrupted call.
            Err(_) => std::thread::sleep(POLL / 4),
        }
    }
}

fn read_lines<T>(mut port: impl Read, d: &Deliver<T>) {
    let mut line = [0u8; MAX_LEN + 1];
    let mut len = 0;
    let mut buf = [0u8; 64];
    while !d.shared.stop.load(Ordering::Relaxed) {
        let n = match port.read(&mut buf) {
            Ok(0) => return,
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                continue;
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => {
                tracing::warn!("{}: the serial line failed: {e}", d.name);
                return;
            }
        };
        for &b in &buf[..n] {
            if b == b'\n' {
                deliver(&line[..len.min(line.len())], d);
                len = 0;
            } else if len < line.len() {
                line[len] = b;
                len += 1;
            } else {
                // Too long: counted at its end as one malformed sentence.
                len = line.len();
            }
        }
    }
}

/// Steps an off-bus sensor `s` (its reader thread delivers meanwhile)
/// until `done`, or 10 s of wall time (a busy machine): a wait for a
/// state, polled every 2 ms, 10 ms of the daemon's clock a step.
#[cfg(test)]
pub(super) fn step_until<S: super::Sensor>(s: &mut S, now: &mut Nanos, done: impl Fn(&S) -> bool) {
    let t0 = std::time::Instant::now();
    while !done(s) && t0.elapsed() < Duration::from_secs(10) {
        *now += Nanos::from_millis(10);
        s.step(*now, *now, 0.01, &crate::nav::Prediction::still());
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_protocol::position_fix::{Fix, parse};

    #[test]
    fn serial_lines_are_cut_and_read() {
        let (tx, rx) = crossbeam_channel::bounded(SLOT);
        let d = Deliver {
            tx,
            shared: Arc::new(Shared::default()),
            parse,
            name: "test",
        };
        let good = Fix {
            x: -1.0,
            y: 2.5,
            sigma: 0.2,
            age: 0.0,
        }
        .sentence();
        let mut bytes = good.clone().into_bytes();
        bytes.extend([b'$'; 300]);
        bytes.push(b'\n');
        bytes.extend(good.as_bytes());
        read_lines(&bytes[..], &d);
        assert_eq!(rx.try_iter().count(), 2);
        assert_eq!(
            d.shared.malformed.load(Ordering::Relaxed),
            1,
            "the long line"
        );
    }
}
