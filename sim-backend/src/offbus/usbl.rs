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
use std::net::SocketAddr;

use anguilla_protocol::position_fix::Fix;

use super::sender::{Schedule, Sender};

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

/// The simulated USBL, running on its own thread until dropped.
pub struct SimUsbl(pub(super) Sender);

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

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_protocol::position_fix::parse;
    use std::net::UdpSocket;
    use std::time::{Duration, Instant};

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
