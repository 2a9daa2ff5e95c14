//! A DVL (`[sensor.dvl]`): a Doppler velocity log measuring the robot's
//! velocity over ground while it has bottom lock. Its velocity sentences
//! (`$ANVEL`, [`anguilla_protocol::position_fix`]) arrive over UDP or a
//! serial line and are read as a USBL's are (`offbus.rs`). Each
//! becomes an [`Observation::VelocityOverGround`] stamped with its arrival
//! less `latency`, turned by `rotation` into the estimate's frame: the
//! velocity over ground less the model's velocity through the water is
//! the current, which the estimate learns from it without a position fix.
//!
//! Without bottom lock (too high above the bottom, or near the surface,
//! where bubbles blind it) a DVL sends nothing: the sensor goes silent
//! after `timeout`, and the estimate dead-reckons with the current it has.
//!
//! With the built-in simulated robot, a `udp:` source is sent velocities
//! by its simulated DVL (`anguilla_sim::offbus::dvl`).

use std::io;

use anguilla_ipc::{SensorEntry, SensorHealth, SensorKind};
use anguilla_protocol::Frame;
use anguilla_protocol::position_fix::{Velocity, parse_velocity};
use anguilla_protocol::time::Nanos;
use serde::{Deserialize, Serialize};

use super::Sensor;
use super::observation::Observation;
use super::offbus::{Line, OffBusSection, Source};
use crate::config::{ConfigError, fmt_f, range};
use crate::nav::Prediction;

/// `[sensor.dvl]`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct DvlConfig {
    /// Where the sentences come from: `udp:ADDRESS:PORT` (bound; one
    /// sentence a datagram) or `serial:PATH:BAUD` (one a line).
    pub source: String,
    /// From the measurement to the sentence's arrival (s), 0..=10.
    pub latency: f64,
    /// A DVL without a velocity this long is silent (s), 0.1..=600: no
    /// bottom lock.
    pub timeout: f64,
    /// The angle from the DVL's frame to the estimate's (deg,
    /// counter-clockwise): a velocity `(vx, vy)` is turned by it.
    pub rotation: f64,
}

impl Default for DvlConfig {
    fn default() -> Self {
        Self {
            source: "udp:127.0.0.1:14661".into(),
            latency: 0.05,
            timeout: 2.0,
            rotation: 0.0,
        }
    }
}

impl OffBusSection for DvlConfig {
    fn kind(&self) -> SensorKind {
        SensorKind::Dvl
    }

    fn source(&self) -> &str {
        &self.source
    }

    fn needs_head(&self) -> &'static str {
        "its velocity is compared with the model's, turned by the estimated heading"
    }

    fn latency(&self) -> f64 {
        self.latency
    }

    fn open(&self, now: Nanos) -> io::Result<Box<dyn Sensor>> {
        Ok(Box::new(Dvl::open(self, now)?))
    }

    fn validate(&self) -> Result<(), ConfigError> {
        Source::parse(&self.source)
            .map_err(|e| ConfigError::Derived(format!("sensor.dvl.source = {e}")))?;
        range("sensor.dvl.latency", self.latency, 0.0, 10.0, "0 ..= 10 s")?;
        range(
            "sensor.dvl.timeout",
            self.timeout,
            0.1,
            600.0,
            "0.1 ..= 600 s",
        )?;
        range(
            "sensor.dvl.rotation",
            self.rotation,
            -360.0,
            360.0,
            "-360 ..= 360 deg",
        )
    }

    /// The section in the commented default file (commented out: no DVL
    /// by default).
    fn write_default(&self, w: &mut dyn FnMut(String)) {
        w("# A DVL off the bus (docs/autopilot.md, \"Position\"): uncomment to use one.".into());
        w(
            "# Its \"$ANVEL,vx,vy,sigma*HH\" sentences (velocity over ground, m/s) come from"
                .into(),
        );
        w("# \"udp:ADDRESS:PORT\" (bound) or \"serial:PATH:BAUD\"; latency (s) from".into());
        w("# measurement to arrival; silent after timeout (s): no bottom lock; rotation".into());
        w(
            "# (deg) turns its frame into the estimate's. The built-in robot simulates one on"
                .into(),
        );
        w("# a udp: source.".into());
        w("# [sensor.dvl]".into());
        w(format!("# source = \"{}\"", self.source));
        w(format!("# latency = {}", fmt_f(self.latency)));
        w(format!("# timeout = {}", fmt_f(self.timeout)));
        w(format!("# rotation = {}", fmt_f(self.rotation)));
    }
}

/// The DVL.
pub struct Dvl {
    line: Line<Velocity>,
    /// cos and sin of `rotation`.
    turn: (f64, f64),
    pending: Option<Observation>,
}

impl Dvl {
    /// Opens `cfg`'s source and starts its reader thread.
    pub fn open(cfg: &DvlConfig, now: Nanos) -> io::Result<Dvl> {
        let (s, c) = cfg.rotation.to_radians().sin_cos();
        Ok(Dvl {
            line: Line::open(
                &cfg.source,
                "dvl",
                parse_velocity,
                cfg.latency,
                cfg.timeout,
                now,
            )?,
            turn: (c, s),
            pending: None,
        })
    }
}

impl Sensor for Dvl {
    fn kind(&self) -> SensorKind {
        SensorKind::Dvl
    }

    /// Off the bus: 0, which no frame carries to it.
    fn id(&self) -> u8 {
        0
    }

    fn ingest(&mut self, _now: Nanos, _frame: &Frame) -> bool {
        false
    }

    fn step(&mut self, now: Nanos, _bus: Nanos, _dt: f64, _pred: &Prediction) {
        if let Some((at, v)) = self.line.step(now) {
            let (c, s) = self.turn;
            self.pending = Some(Observation::VelocityOverGround {
                at,
                vx: c * v.vx - s * v.vy,
                vy: s * v.vx + c * v.vy,
                sigma: v.sigma,
            });
        }
    }

    fn health(&self) -> SensorHealth {
        self.line.health()
    }

    fn observation(&mut self) -> Option<Observation> {
        self.pending.take()
    }

    /// vx, vy and σ of the last velocity as sent, its age (s), and the
    /// malformed and dropped sentences ([`SensorKind::Dvl`]'s values).
    fn fill(&self, entry: &mut SensorEntry) {
        self.line.fill(entry, |v| [v.vx, v.vy, v.sigma]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensors::offbus::step_until;
    use std::net::UdpSocket;

    #[test]
    fn velocities_over_udp_become_observations_turned_into_the_estimates_frame() {
        let probe = UdpSocket::bind("127.0.0.1:0").expect("a port");
        let addr = probe.local_addr().expect("its address");
        drop(probe);
        let cfg = DvlConfig {
            source: format!("udp:{addr}"),
            rotation: 90.0,
            ..DvlConfig::default()
        };
        let mut d = Dvl::open(&cfg, Nanos::ZERO).expect("bound");
        let tx = UdpSocket::bind("127.0.0.1:0").expect("a sender");
        let v = Velocity {
            vx: 0.5,
            vy: 0.0,
            sigma: 0.01,
        };
        tx.send_to(v.sentence().as_bytes(), addr).expect("sent");
        let mut now = Nanos::ZERO;
        step_until(&mut d, &mut now, |d| d.line.received() > 0);
        assert_eq!(d.health(), SensorHealth::Ok);
        let Some(Observation::VelocityOverGround { at, vx, vy, sigma }) = d.observation() else {
            panic!("a velocity");
        };
        assert!(
            vx.abs() < 1e-12 && (vy - 0.5).abs() < 1e-12,
            "turned 90°: {vx} {vy}"
        );
        assert_eq!(sigma, 0.01);
        assert_eq!(at, now.saturating_sub(Nanos::from_millis(50)));
        // No bottom lock, nothing sent: silent after the timeout (2 s)
        // past the reading's time.
        let t = now;
        while now.saturating_sub(t) < Nanos::from_millis(2100) {
            now += Nanos::from_millis(100);
            d.step(now, now, 0.1, &Prediction::still());
        }
        assert_eq!(d.health(), SensorHealth::Silent);
        // A position fix is not a velocity: malformed, an error.
        let fix = anguilla_protocol::position_fix::Fix {
            x: 1.0,
            y: 1.0,
            sigma: 1.0,
            age: 0.0,
        };
        tx.send_to(fix.sentence().as_bytes(), addr).expect("sent");
        step_until(&mut d, &mut now, |d| d.health() == SensorHealth::Error);
        assert_eq!(d.health(), SensorHealth::Error);
        let mut e = SensorEntry::default();
        d.fill(&mut e);
        assert_eq!((e.samples, e.values[0], e.values[4]), (1, 0.5, 1.0));
        let bad = DvlConfig {
            rotation: 400.0,
            ..DvlConfig::default()
        };
        let e = bad.validate().expect_err("a bad rotation").to_string();
        assert!(e.contains("sensor.dvl.rotation"), "{e}");
    }
}
