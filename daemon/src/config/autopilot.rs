//! `[autopilot]`: heading and depth hold (docs/autopilot.md).

use serde::{Deserialize, Serialize};

use super::error::{ConfigError, fmt_f, range};

/// `[autopilot]`: heading and depth hold (docs/autopilot.md).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct AutopilotConfig {
    /// Heading error to turn-rate gain (1/s).
    pub heading_gain: f64,
    /// Heading integral gain (1/s²).
    pub heading_integral: f64,
    /// Largest turn rate the autopilot asks for (deg/s).
    pub max_turn_rate: f64,
    /// Depth error to dive-rate gain (1/s).
    pub depth_gain: f64,
    /// Depth integral gain (1/s²).
    pub depth_integral: f64,
    /// Steepest dive or climb the autopilot asks for (deg of pitch).
    pub max_dive_angle: f64,
    /// The pitch error's weight beside the model's curvature for the
    /// wanted pitch (a ballasted body, `model.ballast` > 0; dimensionless),
    /// or its gain to a pitch rate (an unballasted one; 1/s).
    pub pitch_gain: f64,
    /// Deepest depth a hold accepts (m).
    pub max_depth: f64,
    /// A position fix older than this makes the position stale (s).
    pub fix_stale: f64,
    /// A position fix older than this makes the position lost (s).
    pub fix_lost: f64,
}

impl Default for AutopilotConfig {
    fn default() -> Self {
        Self {
            heading_gain: 0.8,
            heading_integral: 0.05,
            max_turn_rate: 30.0,
            depth_gain: 0.4,
            depth_integral: 0.05,
            max_dive_angle: 30.0,
            pitch_gain: 0.3,
            max_depth: 10.0,
            fix_stale: 5.0,
            fix_lost: 30.0,
        }
    }
}

impl AutopilotConfig {
    /// Checks `[autopilot]`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let a = self;
        for (key, v, lo, hi, expected) in [
            (
                "autopilot.heading-gain",
                a.heading_gain,
                0.01,
                10.0,
                "0.01 ..= 10 1/s",
            ),
            (
                "autopilot.heading-integral",
                a.heading_integral,
                0.0,
                10.0,
                "0 ..= 10 1/s²",
            ),
            (
                "autopilot.max-turn-rate",
                a.max_turn_rate,
                1.0,
                180.0,
                "1 ..= 180 deg/s",
            ),
            (
                "autopilot.depth-gain",
                a.depth_gain,
                0.01,
                10.0,
                "0.01 ..= 10 1/s",
            ),
            (
                "autopilot.depth-integral",
                a.depth_integral,
                0.0,
                10.0,
                "0 ..= 10 1/s²",
            ),
            (
                "autopilot.max-dive-angle",
                a.max_dive_angle,
                1.0,
                80.0,
                "1 ..= 80 deg",
            ),
            (
                "autopilot.pitch-gain",
                a.pitch_gain,
                0.01,
                20.0,
                "0.01 ..= 20 1/s",
            ),
            (
                "autopilot.max-depth",
                a.max_depth,
                0.1,
                1000.0,
                "0.1 ..= 1000 m",
            ),
            (
                "autopilot.fix-stale",
                a.fix_stale,
                0.1,
                600.0,
                "0.1 ..= 600 s",
            ),
            (
                "autopilot.fix-lost",
                a.fix_lost,
                0.1,
                3600.0,
                "0.1 ..= 3600 s",
            ),
        ] {
            range(key, v, lo, hi, expected)?;
        }
        if a.fix_lost < a.fix_stale {
            return Err(ConfigError::Derived(format!(
                "autopilot.fix-lost = {} s is before fix-stale = {} s (expected fix-lost >= \
                 fix-stale: a fix is stale before it is lost)",
                fmt_f(a.fix_lost),
                fmt_f(a.fix_stale)
            )));
        }
        Ok(())
    }
}

/// `[autopilot]` in the commented default file ([`super::sections_toml`]).
pub(super) fn write_default(d: &AutopilotConfig, w: &mut dyn FnMut(String)) {
    w("[autopilot]".into());
    w("# Heading hold: turn rate = heading-gain · error (+ integral), at most".into());
    w("# max-turn-rate; the model turns it into a turn curvature (docs/autopilot.md).".into());
    w(format!("heading-gain = {}", fmt_f(d.heading_gain)));
    w(format!("heading-integral = {}", fmt_f(d.heading_integral)));
    w(format!("max-turn-rate = {}", fmt_f(d.max_turn_rate)));
    w("# Depth hold: dive rate = depth-gain · error (+ integral), flown at a pitch of at".into());
    w("# most max-dive-angle (deg); the model's curvature for that pitch, plus pitch-gain".into());
    w("# times the pitch error (ballasted body; unballasted: pitch rate per error, 1/s);".into());
    w("# holds to max-depth (m).".into());
    w(format!("depth-gain = {}", fmt_f(d.depth_gain)));
    w(format!("depth-integral = {}", fmt_f(d.depth_integral)));
    w(format!("max-dive-angle = {}", fmt_f(d.max_dive_angle)));
    w(format!("pitch-gain = {}", fmt_f(d.pitch_gain)));
    w(format!("max-depth = {}", fmt_f(d.max_depth)));
    w("# The position's health (docs/autopilot.md, \"Position\"): a position fix older".into());
    w("# than fix-stale (s) makes it stale, older than fix-lost lost (a warning and an".into());
    w("# error in the log and the recording).".into());
    w(format!("fix-stale = {}", fmt_f(d.fix_stale)));
    w(format!("fix-lost = {}", fmt_f(d.fix_lost)));
    w(String::new());
}
