//! `[limits]`: per-axis joint limits, applied to every setpoint.

use serde::{Deserialize, Serialize};

use super::error::{ConfigError, fmt_f, range};

/// `[limits]`: per-axis joint limits, applied to every setpoint.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct LimitsConfig {
    /// Largest |joint angle| (rad).
    pub angle: f64,
    /// Largest |joint velocity| (rad/s).
    pub velocity: f64,
    /// Largest |feedforward torque| (N·m).
    pub torque: f64,
}

impl Default for LimitsConfig {
    fn default() -> Self {
        Self {
            angle: 1.0,
            velocity: 8.0,
            torque: 4.0,
        }
    }
}

impl LimitsConfig {
    /// Checks `[limits]`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let l = self;
        range("limits.angle", l.angle, 0.01, 1.5, "0.01 ..= 1.5 rad")?;
        // The protocol carries at most ±10 rad/s and ±5 N·m.
        range(
            "limits.velocity",
            l.velocity,
            0.01,
            10.0,
            "0.01 ..= 10 rad/s",
        )?;
        range("limits.torque", l.torque, 0.0, 5.0, "0 ..= 5 N·m")?;
        Ok(())
    }
}

/// `[limits]` in the commented default file ([`super::sections_toml`]).
pub(super) fn write_default(d: &LimitsConfig, w: &mut dyn FnMut(String)) {
    w("[limits]".into());
    w("# Per-axis limits applied to every setpoint (clamped and counted).".into());
    w("# Angle (rad) 0.01..=1.5, velocity (rad/s) 0.01..=10, torque (N·m) 0..=5.".into());
    w(format!("angle = {}", fmt_f(d.angle)));
    w(format!("velocity = {}", fmt_f(d.velocity)));
    w(format!("torque = {}", fmt_f(d.torque)));
    w(String::new());
}
