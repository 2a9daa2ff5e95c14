//! A simulated USBL: the robot's true nose position, sampled at a rate,
//! with Gaussian noise, some fixes lost, and each sent a latency after it
//! was measured, as a position-fix sentence
//! ([`anguilla_protocol::position_fix`]) in a UDP datagram, which is how
//! a USBL's topside unit hands its fixes on. The daemon's `[sensor.usbl]`
//! reads it like a real one.
//!
//! Noise, rate, latency and dropouts are [`UsblSimConfig`]'s; the
//! defaults ([`UsblSimConfig::typical`]) are a short-baseline tank or
//! harbour system: 1 Hz, σ 0.3 m per axis, 10 % of fixes lost.

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anguilla_protocol::position_fix::Fix;

use crate::rng::Rng;

/// The simulated USBL's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct UsblSimConfig {
    /// Where its datagrams go.
    pub target: SocketAddr,
    /// Fixes a second (> 0).
    pub rate_hz: f64,
    /// The noise's standard deviation per axis (m), also the σ each fix
    /// states.
    pub sigma: f64,
    /// From measurement to sending (s), less than a fix's period.
    pub latency: f64,
    /// The fraction of fixes lost (0..1).
    pub dropout: f64,
    /// The noise's seed.
    pub seed: u64,
}

impl UsblSimConfig {
    /// 1 Hz, σ 0.3 m, 10 % lost, sent `latency` s after measurement to
    /// `target`.
    pub fn typical(target: SocketAddr, latency: f64) -> Self {
        Self {
            target,
            rate_hz: 1.0,
            sigma: 0.3,
            latency,
            dropout: 0.1,
            seed: 0x05B1,
        }
    }
}

/// A simulated sensor off the bus, sending a sentence to a UDP address at
/// a rate on its own thread until dropped: the USBL's and the DVL's
/// ([`crate::dvl`]) common part.
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

/// The simulated USBL, running on its own thread until dropped.
pub struct SimUsbl(Sender);

impl SimUsbl {
    /// Starts sending fixes of `truth()` (the nose's x, y in m).
    pub fn spawn(
        cfg: UsblSimConfig,
        truth: impl Fn() -> [f64; 2] + Send + 'static,
    ) -> io::Result<SimUsbl> {
        let sigma = cfg.sigma;
        let schedule = Schedule {
            name: "USBL",
            target: cfg.target,
            rate_hz: cfg.rate_hz,
            latency: cfg.latency,
            dropout: cfg.dropout,
            seed: cfg.seed,
        };
        Sender::start(schedule, move |rng| {
            let [x, y] = truth();
            let fix = Fix {
                x: x + sigma * rng.normal(),
                y: y + sigma * rng.normal(),
                sigma,
                age: 0.0,
            };
            Some(fix.sentence())
        })
        .map(SimUsbl)
    }

    /// Starts sending fixes of `robot`'s true nose position.
    pub fn beside(cfg: UsblSimConfig, robot: &crate::robot::RunningSim) -> io::Result<SimUsbl> {
        let truth = robot.truth_reader();
        Self::spawn(cfg, move || {
            let p = truth().position;
            [p[0], p[1]]
        })
    }

    /// Fixes sent so far.
    pub fn sent(&self) -> u64 {
        self.0.sent()
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

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_protocol::position_fix::parse;

    #[test]
    fn fixes_arrive_noisy_around_the_truth() {
        let rx = UdpSocket::bind("127.0.0.1:0").expect("a port");
        rx.set_read_timeout(Some(Duration::from_secs(10)))
            .expect("a timeout");
        let cfg = UsblSimConfig {
            rate_hz: 50.0,
            dropout: 0.0,
            ..UsblSimConfig::typical(rx.local_addr().expect("its address"), 0.005)
        };
        let usbl = SimUsbl::spawn(cfg, || [10.0, -5.0]).expect("started");
        let mut buf = [0u8; 256];
        let (mut sx, mut sy) = (0.0, 0.0);
        for _ in 0..20 {
            let n = rx.recv(&mut buf).expect("a fix");
            let f = parse(&buf[..n]).expect("a sentence");
            assert_eq!(f.sigma, 0.3);
            assert!((f.x - 10.0).abs() < 2.0 && (f.y + 5.0).abs() < 2.0, "{f:?}");
            sx += f.x;
            sy += f.y;
        }
        // The mean of 20: σ 0.3 / √20 ≈ 0.07 m.
        assert!((sx / 20.0 - 10.0).abs() < 0.4 && (sy / 20.0 + 5.0).abs() < 0.4);
        // Counted once its send returned, which may be after the datagram
        // arrived (CI, under load): wait for the count, not for time.
        let end = Instant::now() + Duration::from_secs(10);
        while usbl.sent() < 20 && Instant::now() < end {
            std::thread::sleep(Duration::from_millis(1));
        }
        assert!(usbl.sent() >= 20, "{} sent", usbl.sent());
        let e = SimUsbl::spawn(
            UsblSimConfig::typical(rx.local_addr().expect("its address"), 2.0),
            || [0.0; 2],
        )
        .err()
        .expect("a latency longer than the period");
        assert!(e.to_string().contains("latency shorter"), "{e}");
        assert!(e.to_string().starts_with("simulated USBL"), "{e}");
    }
}
