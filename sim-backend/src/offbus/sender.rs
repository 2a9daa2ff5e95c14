//! What every simulated sensor off the bus shares: a thread sending a
//! sentence to a UDP address at a rate, with its latency and dropouts.

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::rng::Rng;

/// A simulated sensor off the bus, sending a sentence to a UDP address at
/// a rate on its own thread until dropped: every kind's common part.
pub(crate) struct Sender {
    stop: Arc<AtomicBool>,
    sent: Arc<AtomicU64>,
    thread: Option<JoinHandle<()>>,
}

/// When and where a [`Sender`] sends.
pub(crate) struct Schedule {
    /// The thread's name.
    pub name: &'static str,
    /// Where its datagrams go.
    pub target: SocketAddr,
    /// Readings a second (> 0).
    pub rate_hz: f64,
    /// From measurement to sending (s), less than a period.
    pub latency: f64,
    /// The fraction of readings lost (0..1).
    pub dropout: f64,
    /// The noise's seed.
    pub seed: u64,
}

impl Sender {
    /// Starts sending what `measure` makes each period (`None`: nothing
    /// this time, as a DVL without bottom lock).
    pub(crate) fn start(
        s: Schedule,
        mut measure: impl FnMut(&mut Rng) -> Option<String> + Send + 'static,
    ) -> io::Result<Self> {
        if !(s.rate_hz > 0.0 && s.latency >= 0.0 && s.latency * s.rate_hz < 1.0) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "simulated {}: rate {} Hz with latency {} s (expected a rate > 0 and a \
                     latency shorter than a reading's period)",
                    s.name, s.rate_hz, s.latency
                ),
            ));
        }
        let local: SocketAddr = if s.target.is_ipv4() {
            ([127, 0, 0, 1], 0).into()
        } else {
            (std::net::Ipv6Addr::LOCALHOST, 0).into()
        };
        let sock = UdpSocket::bind(local)?;
        let stop = Arc::new(AtomicBool::new(false));
        let sent = Arc::new(AtomicU64::new(0));
        let (st, se) = (stop.clone(), sent.clone());
        let thread = std::thread::Builder::new()
            .name(format!("sim-{}", s.name))
            .spawn(move || run(&s, &sock, &mut measure, &st, &se))?;
        Ok(Self {
            stop,
            sent,
            thread: Some(thread),
        })
    }

    /// Sentences sent so far.
    pub(crate) fn sent(&self) -> u64 {
        self.sent.load(Ordering::Relaxed)
    }
}

impl Drop for Sender {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Sleeps until `until`, in slices, unless stopped; `false` if stopped.
fn sleep_until(until: Instant, stop: &AtomicBool) -> bool {
    loop {
        if stop.load(Ordering::Relaxed) {
            return false;
        }
        let now = Instant::now();
        if now >= until {
            return true;
        }
        std::thread::sleep((until - now).min(Duration::from_millis(50)));
    }
}

fn run(
    s: &Schedule,
    sock: &UdpSocket,
    measure: &mut dyn FnMut(&mut Rng) -> Option<String>,
    stop: &AtomicBool,
    sent: &AtomicU64,
) {
    let mut rng = Rng::new(s.seed);
    let period = Duration::from_secs_f64(1.0 / s.rate_hz);
    let latency = Duration::from_secs_f64(s.latency);
    let mut next = Instant::now() + period;
    while sleep_until(next, stop) {
        let measured = next;
        next += period;
        let sentence = measure(&mut rng);
        if rng.uniform() < s.dropout {
            continue;
        }
        let Some(sentence) = sentence else {
            continue;
        };
        if !sleep_until(measured + latency, stop) {
            return;
        }
        if sock.send_to(sentence.as_bytes(), s.target).is_ok() {
            sent.fetch_add(1, Ordering::Relaxed);
        }
    }
}
