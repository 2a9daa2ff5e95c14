//! A simulated DVL: the robot's true velocity over ground, sampled at a
//! rate, with Gaussian noise, some readings lost, none without bottom lock
//! (the nose shallower than [`DvlSimConfig::min_depth`]: near the surface
//! the beams see bubbles, not the bottom), each sent a latency after it
//! was measured, as a velocity sentence
//! ([`anguilla_protocol::position_fix::Velocity`]) in a UDP datagram. The
//! daemon's `[sensor.dvl]` reads it like a real one.
//!
//! The defaults ([`DvlSimConfig::typical`]) are a small DVL's (a Water
//! Linked A50 or a Nortek Nucleus class): 5 Hz, σ 0.01 m/s per axis, 5 %
//! of readings lost, no lock above 0.3 m depth.

use std::io;
use std::net::SocketAddr;

use anguilla_protocol::position_fix::Velocity;

use super::sender::{Schedule, Sender};

/// The simulated DVL's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct DvlSimConfig {
    /// Where its datagrams go.
    pub target: SocketAddr,
    /// Readings a second (> 0).
    pub rate_hz: f64,
    /// The noise's standard deviation per axis (m/s), also the σ each
    /// reading states.
    pub sigma: f64,
    /// From measurement to sending (s), less than a reading's period.
    pub latency: f64,
    /// The fraction of readings lost (0..1).
    pub dropout: f64,
    /// Shallower than this (m), no bottom lock: nothing is sent.
    pub min_depth: f64,
    /// The noise's seed.
    pub seed: u64,
}

impl DvlSimConfig {
    /// 5 Hz, σ 0.01 m/s, 5 % lost, no lock above 0.3 m, sent `latency` s
    /// after measurement to `target`.
    pub fn typical(target: SocketAddr, latency: f64) -> Self {
        Self {
            target,
            rate_hz: 5.0,
            sigma: 0.01,
            latency,
            dropout: 0.05,
            min_depth: 0.3,
            seed: 0xD71,
        }
    }
}

/// The simulated DVL, running on its own thread until dropped.
pub struct SimDvl(pub(super) Sender);

impl SimDvl {
    /// Starts sending the velocity of `truth()`: the nose's velocity over
    /// ground (x, y in m/s) and its depth (m).
    pub fn spawn(
        cfg: DvlSimConfig,
        truth: impl Fn() -> ([f64; 2], f64) + Send + 'static,
    ) -> io::Result<SimDvl> {
        let (sigma, min_depth) = (cfg.sigma, cfg.min_depth);
        let schedule = Schedule {
            name: "DVL",
            target: cfg.target,
            rate_hz: cfg.rate_hz,
            latency: cfg.latency,
            dropout: cfg.dropout,
            seed: cfg.seed,
        };
        Sender::start(schedule, move |rng| {
            let ([vx, vy], depth) = truth();
            let (nx, ny) = (rng.normal(), rng.normal());
            (depth >= min_depth).then(|| {
                Velocity {
                    vx: vx + sigma * nx,
                    vy: vy + sigma * ny,
                    sigma,
                }
                .sentence()
            })
        })
        .map(SimDvl)
    }

    /// Starts sending `robot`'s true velocity over ground.
    pub fn beside(cfg: DvlSimConfig, robot: &crate::robot::RunningSim) -> io::Result<SimDvl> {
        let truth = robot.truth_reader();
        Self::spawn(cfg, move || {
            let t = truth();
            ([t.velocity[0], t.velocity[1]], t.depth)
        })
    }

    /// Readings sent so far.
    pub fn sent(&self) -> u64 {
        self.0.sent()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_protocol::position_fix::parse_velocity;
    use std::net::UdpSocket;
    use std::sync::Arc;
    use std::sync::atomic::{AtomicU64, Ordering};
    use std::time::Duration;

    /// Readings arrive noisy around the truth while the nose is deep
    /// enough; none while it is shallower than `min_depth`.
    #[test]
    fn velocities_arrive_with_bottom_lock_only() {
        let rx = UdpSocket::bind("127.0.0.1:0").expect("a port");
        rx.set_read_timeout(Some(Duration::from_secs(10)))
            .expect("a timeout");
        let cfg = DvlSimConfig {
            rate_hz: 100.0,
            dropout: 0.0,
            ..DvlSimConfig::typical(rx.local_addr().expect("its address"), 0.001)
        };
        // Deep (1 m) for the first 20 readings, then at 0.1 m.
        let calls = Arc::new(AtomicU64::new(0));
        let c = calls.clone();
        let dvl = SimDvl::spawn(cfg, move || {
            let n = c.fetch_add(1, Ordering::Relaxed);
            ([0.4, -0.1], if n < 20 { 1.0 } else { 0.1 })
        })
        .expect("started");
        let mut buf = [0u8; 256];
        let mut sum = 0.0;
        for _ in 0..20 {
            let n = rx.recv(&mut buf).expect("a reading");
            let v = parse_velocity(&buf[..n]).expect("a sentence");
            assert_eq!(v.sigma, 0.01);
            assert!(
                (v.vx - 0.4).abs() < 0.1 && (v.vy + 0.1).abs() < 0.1,
                "{v:?}"
            );
            sum += v.vx;
        }
        assert!((sum / 20.0 - 0.4).abs() < 0.02);
        // Shallow: the next readings are not sent (wait for the calls).
        let end = std::time::Instant::now() + Duration::from_secs(10);
        while calls.load(Ordering::Relaxed) < 40 && std::time::Instant::now() < end {
            std::thread::sleep(Duration::from_millis(5));
        }
        assert!(calls.load(Ordering::Relaxed) >= 40);
        assert_eq!(dvl.sent(), 20, "nothing sent without bottom lock");
    }
}
