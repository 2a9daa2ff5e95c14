//! `[sensor]`: the head sensor and how its samples become an estimate.

use serde::{Deserialize, Serialize};

use super::{Config, ConfigError, fmt_f, range};

/// `[sensor]`: the head sensor (IMU and pressure; protocol/README.md
/// "The head sensor") and how its samples become an estimate.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct SensorConfig {
    /// The sensor's node id, 1..=63 and none of the joints'; 0: no sensor.
    pub node: u8,
    /// Its sample rate (Hz), for the bus budget: 100..=200.
    pub rate_hz: u16,
    /// A sensor silent this long is lost (s).
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
        }
    }
}

impl Config {
    /// The head sensor of the built-in simulated robot: with `[sensor]
    /// node = 0` (the default) and anguilla drives, the sensor goes on the
    /// first id no joint uses (13 with the default 12 joints), so heading
    /// and depth hold work out of the box. A real bus keeps "no sensor"
    /// unless the key is set. Returns the id chosen, or `None` (a sensor
    /// already configured, a bought family, no free id, or a configuration
    /// that the sensor's traffic would not fit: then it is left as it was).
    pub fn fit_builtin_sensor(&mut self) -> Option<u8> {
        if self.sensor.node != 0 || self.robot.drive != anguilla_protocol::Family::Anguilla {
            return None;
        }
        let joints = self.node_ids();
        let id = (1..=63u8).find(|id| !joints.contains(id))?;
        self.sensor.node = id;
        if self.validate().is_err() {
            self.sensor.node = 0;
            return None;
        }
        Some(id)
    }

    /// Checks `[sensor]`, with what it shares with `[robot]` (the family,
    /// the joints' ids).
    pub(super) fn validate_sensor(&self) -> Result<(), ConfigError> {
        let s = &self.sensor;
        if s.node != 0 {
            range(
                "sensor.node",
                s.node as f64,
                1.0,
                63.0,
                "0 (none) or 1 ..= 63",
            )?;
            if self.robot.drive != anguilla_protocol::Family::Anguilla {
                return Err(ConfigError::Derived(format!(
                    "sensor.node = {} needs robot.drive = \"anguilla\": the head sensor's \
                     frames (0x240 + id ..) share identifiers with {} drives' traffic; \
                     set sensor.node = 0",
                    s.node, self.robot.drive
                )));
            }
            if self.node_ids().contains(&s.node) {
                return Err(ConfigError::Derived(format!(
                    "sensor.node = {} is also a joint's node id (robot.node-ids {:?}); \
                     the sensor needs an id of its own",
                    s.node,
                    self.node_ids()
                )));
            }
        }
        let (lo, hi) = anguilla_protocol::message::HEAD_SENSOR_RATE_HZ;
        range(
            "sensor.rate-hz",
            s.rate_hz as f64,
            lo as f64,
            hi as f64,
            "100 ..= 200 Hz",
        )?;
        range("sensor.timeout", s.timeout, 0.02, 5.0, "0.02 ..= 5 s")?;
        range(
            "sensor.water-density",
            s.water_density,
            900.0,
            1100.0,
            "900 ..= 1100 kg/m³",
        )?;
        range(
            "sensor.surface-pressure",
            s.surface_pressure,
            50_000.0,
            120_000.0,
            "50000 ..= 120000 Pa",
        )?;
        range(
            "sensor.max-rate-innovation",
            s.max_rate_innovation,
            0.05,
            10.0,
            "0.05 ..= 10 rad/s",
        )?;
        range(
            "sensor.roll-alarm",
            s.roll_alarm,
            5.0,
            180.0,
            "5 ..= 180 deg",
        )?;
        Ok(())
    }
}

/// `[sensor]` in the commented default file ([`super::default_toml`]).
pub(super) fn write_default(d: &Config, w: &mut dyn FnMut(String)) {
    w("[sensor]".into());
    w("# The head sensor's node id (IMU + pressure, protocol/README.md): 1..=63, none of".into());
    w("# the joints'; anguilla drives only. 0: no sensor (heading/depth hold refused).".into());
    w(format!("node = {}", d.sensor.node));
    w("# Its sample rate (Hz, 100..=200, for the bus budget); silent this long, it is".into());
    w("# lost (s).".into());
    w(format!("rate-hz = {}", d.sensor.rate_hz));
    w(format!("timeout = {}", fmt_f(d.sensor.timeout)));
    w("# Depth = (pressure - surface-pressure) / (water-density · 9.81): kg/m³, Pa.".into());
    w(format!("water-density = {}", fmt_f(d.sensor.water_density)));
    w(format!(
        "surface-pressure = {}",
        fmt_f(d.sensor.surface_pressure)
    ));
    w("# The gyro's rates may differ from the model's prediction by this much".into());
    w("# (rad/s, low-passed) before the estimate is implausible and a hold lets go.".into());
    w(format!(
        "max-rate-innovation = {}",
        fmt_f(d.sensor.max_rate_innovation)
    ));
    w("# |roll| beyond which the operator is alarmed (deg).".into());
    w(format!("roll-alarm = {}", fmt_f(d.sensor.roll_alarm)));
    w(String::new());
}
