//! A USBL, or any position sensor that is not on the CAN bus
//! (`[sensor.usbl]`): its position-fix sentences
//! ([`anguilla_protocol::position_fix`]) arrive over UDP or a serial line,
//! are read by a thread of its own, and reach the control loop through a
//! bounded lock-free channel ([`SLOT`] fixes): the period takes what is
//! there and never waits. Each fix becomes an
//! [`Observation::PositionFix`] stamped with its arrival less
//! `latency`, moved by `offset` into the estimate's frame.
//!
//! Health: waiting before the first fix (silent once `timeout` has passed
//! five times over); silent when the last fix is older than `timeout`;
//! error when the newest sentence was malformed; ok otherwise. Malformed
//! sentences and fixes the full channel had no room for are counted and
//! shown (the sensor's values).
//!
//! With the built-in simulated robot, a `udp:` source is sent fixes by its
//! simulated USBL (`anguilla_sim::offbus::usbl`, not a dependency of this
//! crate: `anguilla run` starts it beside the robot).

use std::io;

use anguilla_ipc::{SensorEntry, SensorHealth, SensorKind};
use anguilla_protocol::Frame;
use anguilla_protocol::position_fix::{Fix, parse};
use anguilla_protocol::time::Nanos;
use serde::{Deserialize, Serialize};

use super::Sensor;
use super::observation::Observation;
use super::offbus::{Line, OffBusSection};
pub use super::offbus::{SLOT, Source};
use crate::config::{ConfigError, fmt_f, range};
use crate::nav::Prediction;

/// `[sensor.usbl]`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct UsblConfig {
    /// Where the sentences come from: `udp:ADDRESS:PORT` (bound; one
    /// sentence a datagram) or `serial:PATH:BAUD` (one a line).
    pub source: String,
    /// From the measurement to the sentence's arrival (s), 0..=10.
    pub latency: f64,
    /// A sensor without a fix this long is silent (s), 0.1..=600.
    pub timeout: f64,
    /// Where the estimate's origin is in the sensor's frame (m): a fix
    /// `(x, y)` is `(x − offset[0], y − offset[1])` to the estimate.
    pub offset: [f64; 2],
}

impl Default for UsblConfig {
    fn default() -> Self {
        Self {
            source: "udp:127.0.0.1:14660".into(),
            latency: 0.3,
            timeout: 5.0,
            offset: [0.0, 0.0],
        }
    }
}

impl OffBusSection for UsblConfig {
    fn kind(&self) -> SensorKind {
        SensorKind::Usbl
    }

    fn source(&self) -> &str {
        &self.source
    }

    fn needs_head(&self) -> &'static str {
        "a fix corrects the position the estimate dead-reckons with its heading"
    }

    fn latency(&self) -> f64 {
        self.latency
    }

    fn gives_position(&self) -> bool {
        true
    }

    fn open(&self, now: Nanos) -> io::Result<Box<dyn Sensor>> {
        Ok(Box::new(Usbl::open(self, now)?))
    }

    fn validate(&self) -> Result<(), ConfigError> {
        Source::parse(&self.source)
            .map_err(|e| ConfigError::Derived(format!("sensor.usbl.source = {e}")))?;
        range("sensor.usbl.latency", self.latency, 0.0, 10.0, "0 ..= 10 s")?;
        range(
            "sensor.usbl.timeout",
            self.timeout,
            0.1,
            600.0,
            "0.1 ..= 600 s",
        )?;
        for v in self.offset {
            range("sensor.usbl.offset", v, -1e6, 1e6, "finite metres")?;
        }
        Ok(())
    }

    /// The section in the commented default file (commented out: no USBL
    /// by default).
    fn write_default(&self, w: &mut dyn FnMut(String)) {
        w("# A USBL or another position sensor off the bus (docs/autopilot.md,".into());
        w("# \"Position\"): uncomment to use one. Its \"$ANFIX,x,y,sigma*HH\" sentences".into());
        w(
            "# come from \"udp:ADDRESS:PORT\" (bound) or \"serial:PATH:BAUD\"; latency (s) from"
                .into(),
        );
        w("# measurement to arrival; silent after timeout (s); offset (m): the estimate's".into());
        w(
            "# origin in the sensor's frame. The built-in robot simulates one on a udp: source."
                .into(),
        );
        w("# [sensor.usbl]".into());
        w(format!("# source = \"{}\"", self.source));
        w(format!("# latency = {}", fmt_f(self.latency)));
        w(format!("# timeout = {}", fmt_f(self.timeout)));
        w(format!(
            "# offset = [{}, {}]",
            fmt_f(self.offset[0]),
            fmt_f(self.offset[1])
        ));
    }
}

/// The USBL.
pub struct Usbl {
    line: Line<Fix>,
    offset: [f64; 2],
    pending: Option<Observation>,
}

impl Usbl {
    /// Opens `cfg`'s source and starts its reader thread.
    pub fn open(cfg: &UsblConfig, now: Nanos) -> io::Result<Usbl> {
        Ok(Usbl {
            line: Line::open(&cfg.source, "usbl", parse, cfg.latency, cfg.timeout, now)?
                .aged(|f| f.age),
            offset: cfg.offset,
            pending: None,
        })
    }
}

impl Sensor for Usbl {
    fn kind(&self) -> SensorKind {
        SensorKind::Usbl
    }

    /// Off the bus: 0, which no frame carries to it.
    fn id(&self) -> u8 {
        0
    }

    fn ingest(&mut self, _now: Nanos, _frame: &Frame) -> bool {
        false
    }

    /// One fix a period: the others wait in the channel, none is
    /// overwritten unseen.
    fn step(&mut self, now: Nanos, _bus: Nanos, _dt: f64, _pred: &Prediction) {
        if let Some((at, fix)) = self.line.step(now) {
            self.pending = Some(Observation::PositionFix {
                at,
                x: fix.x - self.offset[0],
                y: fix.y - self.offset[1],
                sigma: fix.sigma,
            });
        }
    }

    fn health(&self) -> SensorHealth {
        self.line.health()
    }

    fn observation(&mut self) -> Option<Observation> {
        self.pending.take()
    }

    /// x, y and σ of the last fix as sent, its age (s), and the malformed
    /// and dropped sentences ([`SensorKind::Usbl`]'s values).
    fn fill(&self, entry: &mut SensorEntry) {
        self.line.fill(entry, |f| [f.x, f.y, f.sigma]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::{SocketAddr, UdpSocket};
    use std::time::{Duration, Instant};

    use crate::sensors::offbus::step_until;

    #[test]
    fn sources_are_read_or_named() {
        assert_eq!(
            Source::parse("udp:127.0.0.1:5000"),
            Ok(Source::Udp(SocketAddr::from(([127, 0, 0, 1], 5000))))
        );
        assert_eq!(
            Source::parse("serial:/dev/ttyUSB0:115200"),
            Ok(Source::Serial("/dev/ttyUSB0".into(), 115_200))
        );
        for bad in [
            "udp:nowhere",
            "serial:/dev/ttyUSB0",
            "serial::9600",
            "tcp:1.2.3.4:5",
        ] {
            let e = Source::parse(bad).expect_err(bad);
            assert!(e.contains(bad) && e.contains("expected"), "{e}");
        }
        let mut cfg = UsblConfig {
            source: "usb".into(),
            ..UsblConfig::default()
        };
        let e = cfg.validate().expect_err("a bad source").to_string();
        assert!(e.contains("sensor.usbl.source"), "{e}");
        cfg.source = UsblConfig::default().source;
        cfg.latency = -1.0;
        let e = cfg.validate().expect_err("a bad latency").to_string();
        assert!(e.contains("sensor.usbl.latency"), "{e}");
    }

    #[test]
    fn fixes_over_udp_become_observations_and_garbage_is_counted() {
        // Bind a port, then let the USBL have it.
        let probe = UdpSocket::bind("127.0.0.1:0").expect("a port");
        let addr = probe.local_addr().expect("its address");
        drop(probe);
        let cfg = UsblConfig {
            source: format!("udp:{addr}"),
            latency: 0.5,
            offset: [1.0, 0.0],
            ..UsblConfig::default()
        };
        let mut u = Usbl::open(&cfg, Nanos::ZERO).expect("bound");
        let tx = UdpSocket::bind("127.0.0.1:0").expect("a sender");
        let mut now = Nanos::ZERO;
        assert_eq!(u.health(), SensorHealth::Waiting);
        tx.send_to(b"$ANFIX,1,2,3*00", addr).expect("sent");
        step_until(&mut u, &mut now, |u| u.health() == SensorHealth::Error);
        assert_eq!(u.health(), SensorHealth::Error, "a bad checksum");
        let fix = Fix {
            x: 3.0,
            y: 4.0,
            sigma: 0.5,
            age: 0.0,
        };
        tx.send_to(fix.sentence().as_bytes(), addr).expect("sent");
        step_until(&mut u, &mut now, |u| u.line.received() == 1);
        assert_eq!(u.health(), SensorHealth::Ok);
        let obs = u.observation().expect("an observation");
        let Observation::PositionFix { at, x, y, sigma } = obs else {
            panic!("a position fix: {obs:?}");
        };
        assert_eq!((x, y, sigma), (2.0, 4.0, 0.5), "moved by the offset");
        assert_eq!(at, now.saturating_sub(Nanos::from_millis(500)));
        assert_eq!(u.observation(), None, "taken once");
        let mut e = SensorEntry::default();
        u.fill(&mut e);
        assert_eq!((e.samples, e.values[0], e.values[4]), (1, 3.0, 1.0));
        // A fix that says its age (a bridge's, from its stamp) is that
        // much older again.
        let aged = Fix { age: 0.25, ..fix };
        tx.send_to(aged.sentence().as_bytes(), addr).expect("sent");
        step_until(&mut u, &mut now, |u| u.line.received() == 2);
        let Some(Observation::PositionFix { at, .. }) = u.observation() else {
            panic!("a position fix");
        };
        assert_eq!(at, now.saturating_sub(Nanos::from_millis(750)));
        // Silent after the timeout (5 s) past the fix's time.
        let t = now;
        while now.saturating_sub(t) < Nanos::from_millis(6000) {
            now += Nanos::from_millis(100);
            u.step(now, now, 0.1, &Prediction::still());
        }
        assert_eq!(u.health(), SensorHealth::Silent);
    }

    #[test]
    fn a_flood_never_blocks_the_period_and_is_counted() {
        let probe = UdpSocket::bind("127.0.0.1:0").expect("a port");
        let addr = probe.local_addr().expect("its address");
        drop(probe);
        let cfg = UsblConfig {
            source: format!("udp:{addr}"),
            ..UsblConfig::default()
        };
        let mut u = Usbl::open(&cfg, Nanos::ZERO).expect("bound");
        let tx = UdpSocket::bind("127.0.0.1:0").expect("a sender");
        let line = Fix {
            x: 1.0,
            y: 1.0,
            sigma: 1.0,
            age: 0.0,
        }
        .sentence();
        // No period takes them: the channel fills, the rest are dropped.
        for _ in 0..200 {
            let _ = tx.send_to(line.as_bytes(), addr);
        }
        let t0 = Instant::now();
        while u.line.reader().dropped() == 0 && t0.elapsed() < Duration::from_secs(10) {
            std::thread::sleep(Duration::from_millis(5));
        }
        assert!(u.line.reader().dropped() > 0);
        let now = Nanos::from_millis(10);
        u.step(now, now, 0.01, &Prediction::still());
        let dropped = u.line.reader().dropped();
        let received = u.line.received();
        assert!(
            u64::from(received) + dropped <= 200 && u64::from(received) < 200,
            "{received} taken, {dropped} dropped of 200"
        );
        assert!(u.observation().is_some());
    }
}
