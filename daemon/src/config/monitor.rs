//! `[monitor]`: the live torque residual, and when it raises an alarm.

use serde::{Deserialize, Serialize};

use super::error::{ConfigError, fmt_f, range};

/// `[monitor]`: per joint and axis, the measured torque less the model's
/// prediction, low-passed and divided by the prediction's low-passed
/// magnitude (plus a floor); an alarm (not a fault) when it stays beyond
/// the band.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct MonitorConfig {
    /// Time constant of the low-pass (s).
    pub residual_tau: f64,
    /// |normalised residual| beyond which a joint is alarmed.
    pub residual_band: f64,
    /// How long the residual must stay beyond the band (s).
    pub residual_hold: f64,
    /// Added to the prediction's magnitude before dividing (N·m): a joint
    /// the model says carries nothing is judged against this.
    pub residual_floor: f64,
}

impl Default for MonitorConfig {
    fn default() -> Self {
        Self {
            residual_tau: 0.5,
            residual_band: 1.5,
            residual_hold: 0.5,
            residual_floor: 0.1,
        }
    }
}

impl MonitorConfig {
    /// Checks `[monitor]`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let m = self;
        range(
            "monitor.residual-tau",
            m.residual_tau,
            0.01,
            60.0,
            "0.01 ..= 60 s",
        )?;
        range(
            "monitor.residual-band",
            m.residual_band,
            0.01,
            100.0,
            "0.01 ..= 100",
        )?;
        range(
            "monitor.residual-hold",
            m.residual_hold,
            0.0,
            60.0,
            "0 ..= 60 s",
        )?;
        range(
            "monitor.residual-floor",
            m.residual_floor,
            0.001,
            10.0,
            "0.001 ..= 10 N·m",
        )?;
        Ok(())
    }
}

/// `[monitor]` in the commented default file ([`super::sections_toml`]).
pub(super) fn write_default(d: &MonitorConfig, w: &mut dyn FnMut(String)) {
    w("[monitor]".into());
    w("# The torque residual, per joint and axis: measured minus predicted torque,".into());
    w("# low-passed over residual-tau (s), divided by the prediction's low-passed".into());
    w("# magnitude plus residual-floor (N·m). Beyond ±residual-band for residual-hold".into());
    w("# (s) it raises an operator alarm naming the joint and the sign (a snag,".into());
    w("# fouling, a failing actuator, a tether pulling); not a fault.".into());
    w(format!("residual-tau = {}", fmt_f(d.residual_tau)));
    w(format!("residual-band = {}", fmt_f(d.residual_band)));
    w(format!("residual-hold = {}", fmt_f(d.residual_hold)));
    w(format!("residual-floor = {}", fmt_f(d.residual_floor)));
    w(String::new());
}
