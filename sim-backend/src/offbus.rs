//! The simulated sensors off the bus: each sends its sentences
//! ([`anguilla_protocol::position_fix`]) in UDP datagrams to the address
//! its daemon-side section reads (`[sensor.NAME] source = "udp:…"`), at
//! its rate, with its noise, latency and dropouts, from the body's truth:
//!
//! - [`usbl`]: a USBL's position fixes of the nose;
//! - [`dvl`]: a DVL's velocity over ground while it has bottom lock.
//!
//! [`SimSensorConfig`] is the one list of them, by the kind's name (the
//! daemon's `SensorKind` name): the built-in robot starts the counterpart
//! of each off-bus section the daemon has, and `anguilla sim --sensor
//! NAME=ADDRESS:PORT[@LATENCY]` starts any of them beside a robot on a
//! bus ([`SimSensors`]). A further kind is a module here and a variant of
//! [`SimSensorConfig`].

pub mod dvl;
mod sender;
pub mod usbl;

use std::io;
use std::net::SocketAddr;

use crate::robot::RunningSim;
use dvl::{DvlSimConfig, SimDvl};
use sender::Sender;
use usbl::{SimUsbl, UsblSimConfig};

/// One simulated sensor off the bus, with its settings.
#[derive(Debug, Clone, PartialEq)]
pub enum SimSensorConfig {
    /// A USBL ([`usbl`]).
    Usbl(UsblSimConfig),
    /// A DVL ([`dvl`]).
    Dvl(DvlSimConfig),
}

impl SimSensorConfig {
    /// Every kind's name, as `[sensor.NAME]` and `--sensor NAME=…` say it.
    pub const NAMES: [&'static str; 2] = ["usbl", "dvl"];

    /// The kind named `name` with its typical settings
    /// ([`UsblSimConfig::typical`], [`DvlSimConfig::typical`]), sending to
    /// `target` `latency` s after each measurement (`None`: the kind's
    /// usual latency); `None` for a name no kind has.
    pub fn typical(name: &str, target: SocketAddr, latency: Option<f64>) -> Option<Self> {
        Some(match name {
            "usbl" => Self::Usbl(UsblSimConfig::typical(target, latency.unwrap_or(0.3))),
            "dvl" => Self::Dvl(DvlSimConfig::typical(target, latency.unwrap_or(0.05))),
            _ => return None,
        })
    }

    /// `NAME=ADDRESS:PORT[@LATENCY]` (`anguilla sim --sensor`), or what was
    /// wrong with it and what was expected.
    pub fn parse(text: &str) -> Result<Self, String> {
        let expected = format!(
            "expected NAME=ADDRESS:PORT[@LATENCY] with NAME one of {}, e.g. \
             usbl=127.0.0.1:14660@0.3",
            Self::NAMES.join(", ")
        );
        let Some((name, rest)) = text.split_once('=') else {
            return Err(format!("no '=' ({expected})"));
        };
        let (addr, latency) = match rest.split_once('@') {
            Some((a, l)) => {
                let l: f64 = l.parse().map_err(|_| {
                    format!("latency '{l}' is not a number of seconds ({expected})")
                })?;
                (a, Some(l))
            }
            None => (rest, None),
        };
        let target: SocketAddr = addr
            .parse()
            .map_err(|_| format!("'{addr}' is not ADDRESS:PORT ({expected})"))?;
        Self::typical(name, target, latency)
            .ok_or_else(|| format!("no simulated sensor '{name}' ({expected})"))
    }

    /// Its kind's name.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Usbl(_) => "usbl",
            Self::Dvl(_) => "dvl",
        }
    }

    /// As `--sensor` would say it (for errors).
    pub fn describe(&self) -> String {
        let (target, latency) = match self {
            Self::Usbl(c) => (c.target, c.latency),
            Self::Dvl(c) => (c.target, c.latency),
        };
        format!("--sensor {}={target}@{latency}", self.name())
    }

    /// Starts it beside `robot`, sending what its truth gives.
    fn beside(&self, robot: &RunningSim) -> io::Result<Sender> {
        Ok(match self {
            Self::Usbl(c) => SimUsbl::beside(c.clone(), robot)?.0,
            Self::Dvl(c) => SimDvl::beside(c.clone(), robot)?.0,
        })
    }
}

/// Simulated sensors off the bus beside a robot, each on its own thread
/// until dropped.
#[derive(Default)]
pub struct SimSensors(Vec<(&'static str, Sender)>);

impl SimSensors {
    /// Starts each of `sensors` beside `robot`; on an error, those started
    /// are stopped and the one that failed is named.
    pub fn beside(
        sensors: &[SimSensorConfig],
        robot: &RunningSim,
    ) -> Result<Self, (SimSensorConfig, io::Error)> {
        let mut started = Vec::with_capacity(sensors.len());
        for s in sensors {
            started.push((s.name(), s.beside(robot).map_err(|e| (s.clone(), e))?));
        }
        Ok(Self(started))
    }

    /// Sentences the sensors named `name` have sent (0 without one).
    pub fn sent(&self, name: &str) -> u64 {
        self.0
            .iter()
            .filter(|(n, _)| *n == name)
            .map(|(_, s)| s.sent())
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sensor_argument_names_what_is_wrong() {
        let u = SimSensorConfig::parse("usbl=127.0.0.1:9@0.2").expect("a USBL");
        assert_eq!(u.name(), "usbl");
        assert_eq!(u.describe(), "--sensor usbl=127.0.0.1:9@0.2");
        let d = SimSensorConfig::parse("dvl=[::1]:9").expect("a DVL");
        assert!(
            matches!(&d, SimSensorConfig::Dvl(c) if c.latency == 0.05),
            "{d:?}"
        );
        for (bad, says) in [
            ("usbl", "no '='"),
            ("sonar=127.0.0.1:9", "no simulated sensor 'sonar'"),
            ("usbl=nowhere", "'nowhere' is not ADDRESS:PORT"),
            ("usbl=127.0.0.1:9@soon", "latency 'soon'"),
        ] {
            let e = SimSensorConfig::parse(bad).expect_err(bad);
            assert!(e.contains(says) && e.contains("usbl, dvl"), "{bad}: {e}");
        }
        for name in SimSensorConfig::NAMES {
            let c = SimSensorConfig::typical(name, ([127, 0, 0, 1], 9).into(), None);
            assert_eq!(c.map(|c| c.name()), Some(name));
        }
    }
}
