//! `[sensor]`: the head sensor and how its samples become an estimate.

use serde::{Deserialize, Serialize};

use super::error::fmt_f;
use crate::sensors::OffBusSection;
use crate::sensors::dvl::DvlConfig;
use crate::sensors::usbl::UsblConfig;

/// `[sensor]`: the head sensor (IMU and pressure; protocol/README.md
/// "The head sensor") and how its samples become an estimate.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct SensorConfig {
    /// The sensor's node id, 1..=63 and none of the joints'; 0: no sensor.
    pub node: u8,
    /// Its sample rate (Hz), for the bus budget: 100..=200.
    pub rate_hz: u16,
    /// A sensor silent this long is lost (s), counted on the bus's clock:
    /// periods in which no frame at all arrived do not count
    /// (docs/autopilot.md, "Health and the safe state").
    pub timeout: f64,
    /// Water density (kg/m³): depth = (pressure − surface-pressure) / (ρ g).
    pub water_density: f64,
    /// Atmospheric pressure at the surface (Pa).
    pub surface_pressure: f64,
    /// |body rate − the model's predicted rate|, low-passed, beyond which
    /// the estimate is implausible (rad/s).
    pub max_rate_innovation: f64,
    /// |roll| beyond which the robot is alarmed as rolled over (deg).
    pub roll_alarm: f64,
    /// An IMU in the tail (the head sensor's protocol, at the same rate and
    /// timeout): its node id, 1..=63, none of the joints' nor the head
    /// sensor's; 0: none. Shown to the operator and recorded; the estimate
    /// and the autopilot use the head sensor alone.
    pub tail_imu: u8,
    /// A USBL or another position sensor off the bus (`[sensor.usbl]`,
    /// its module's section); none if absent.
    pub usbl: Option<UsblConfig>,
    /// A DVL off the bus (`[sensor.dvl]`, its module's section); none if
    /// absent.
    pub dvl: Option<DvlConfig>,
}

impl Default for SensorConfig {
    fn default() -> Self {
        Self {
            node: 0,
            rate_hz: 100,
            timeout: 0.1,
            water_density: 1000.0,
            surface_pressure: 101_325.0,
            max_rate_innovation: 1.0,
            roll_alarm: 60.0,
            tail_imu: 0,
            usbl: None,
            dvl: None,
        }
    }
}

impl SensorConfig {
    /// The sensors off the bus configured, each as its section: the one
    /// list the checks, the estimate, the replay and the built-in robot's
    /// simulated counterparts go through. A further kind off the bus is a
    /// field above and a line here (and in [`Self::without_off_bus`]).
    pub fn off_bus(&self) -> impl Iterator<Item = &dyn OffBusSection> {
        // Every field named: a new one is a compile error here until it
        // is listed or said not to be off the bus.
        let Self {
            node: _,
            rate_hz: _,
            timeout: _,
            water_density: _,
            surface_pressure: _,
            max_rate_innovation: _,
            roll_alarm: _,
            tail_imu: _,
            usbl,
            dvl,
        } = self;
        [
            usbl.as_ref().map(|s| s as &dyn OffBusSection),
            dvl.as_ref().map(|s| s as &dyn OffBusSection),
        ]
        .into_iter()
        .flatten()
    }

    /// The same with no sensor off the bus (a replay: their readings are
    /// not among a session's inputs, and the running daemon may hold
    /// their sources).
    pub fn without_off_bus(&self) -> SensorConfig {
        SensorConfig {
            usbl: None,
            dvl: None,
            ..self.clone()
        }
    }

    /// The same with every kind off the bus at its defaults (the
    /// commented default file lists them all).
    pub fn with_every_off_bus(&self) -> SensorConfig {
        SensorConfig {
            usbl: Some(UsblConfig::default()),
            dvl: Some(DvlConfig::default()),
            ..self.clone()
        }
    }
}

/// `[sensor]` in the commented default file ([`super::sections_toml`]).
pub(super) fn write_default(d: &SensorConfig, w: &mut dyn FnMut(String)) {
    w("[sensor]".into());
    w("# The head sensor's node id (IMU + pressure, protocol/README.md): 1..=63, none of".into());
    w("# the joints'; anguilla drives only. 0: no sensor (heading/depth hold refused).".into());
    w(format!("node = {}", d.node));
    w("# Its sample rate (Hz, 100..=200, for the bus budget); silent this long, it is".into());
    w("# lost (s).".into());
    w(format!("rate-hz = {}", d.rate_hz));
    w(format!("timeout = {}", fmt_f(d.timeout)));
    w("# Depth = (pressure - surface-pressure) / (water-density · 9.81): kg/m³, Pa.".into());
    w(format!("water-density = {}", fmt_f(d.water_density)));
    w(format!("surface-pressure = {}", fmt_f(d.surface_pressure)));
    w("# The gyro's rates may differ from the model's prediction by this much".into());
    w("# (rad/s, low-passed) before the estimate is implausible and a hold lets go.".into());
    w(format!(
        "max-rate-innovation = {}",
        fmt_f(d.max_rate_innovation)
    ));
    w("# |roll| beyond which the operator is alarmed (deg).".into());
    w(format!("roll-alarm = {}", fmt_f(d.roll_alarm)));
    w("# An IMU in the tail (the same protocol, rate and timeout): its node id, 1..=63,".into());
    w("# none of the joints' nor node; shown and recorded, not used by the autopilot.".into());
    w("# 0: none.".into());
    w(format!("tail-imu = {}", d.tail_imu));
    w(String::new());
    for section in d.with_every_off_bus().off_bus() {
        section.write_default(w);
        w(String::new());
    }
}
