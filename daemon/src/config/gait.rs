//! `[gait]`: the parametric gait and how fast its parameters may change.

use serde::{Deserialize, Serialize};

use super::error::{ConfigError, fmt_f, range, three_numbers};

/// `[gait]`: the parametric gait and how fast its parameters may change.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct GaitConfig {
    /// Wavelength λ of the body wave (m).
    pub wavelength: f64,
    /// Amplitude polynomial f_a(X) = a0 + a1·X + a2·X² at full amplitude (1/m).
    #[serde(deserialize_with = "three_numbers")]
    pub amplitude_polynomial: [f64; 3],
    /// Largest frequency an operator may ask for (Hz).
    pub max_frequency: f64,
    /// Largest |turn curvature| an operator may ask for (1/m).
    pub max_turn: f64,
    /// Largest |pitch curvature| an operator may ask for (1/m).
    pub max_pitch: f64,
    /// Fastest change of the amplitude fraction (1/s).
    pub amplitude_rate: f64,
    /// Largest acceleration of the amplitude fraction (1/s²).
    pub amplitude_accel: f64,
    /// Fastest change of the frequency (Hz/s).
    pub frequency_rate: f64,
    /// Largest acceleration of the frequency (Hz/s²).
    pub frequency_accel: f64,
    /// Fastest change of the turn and pitch curvatures (1/m/s).
    pub curvature_rate: f64,
    /// Largest acceleration of the turn and pitch curvatures (1/m/s²).
    pub curvature_accel: f64,
}

impl Default for GaitConfig {
    fn default() -> Self {
        // The paper's F1 gait (Table 1) at full amplitude.
        Self {
            wavelength: 1.0,
            amplitude_polynomial: [1.0, 0.5, 2.0],
            max_frequency: 2.0,
            max_turn: 2.0,
            max_pitch: 1.0,
            amplitude_rate: 0.5,
            amplitude_accel: 1.0,
            frequency_rate: 0.5,
            frequency_accel: 1.0,
            curvature_rate: 1.0,
            curvature_accel: 2.0,
        }
    }
}

impl GaitConfig {
    /// Checks `[gait]`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let g = self;
        range("gait.wavelength", g.wavelength, 0.1, 10.0, "0.1 ..= 10 m")?;
        for (i, a) in g.amplitude_polynomial.iter().enumerate() {
            let key = [
                "gait.amplitude-polynomial[0]",
                "gait.amplitude-polynomial[1]",
                "gait.amplitude-polynomial[2]",
            ][i];
            range(key, *a, -20.0, 20.0, "-20 ..= 20 1/m")?;
        }
        range(
            "gait.max-frequency",
            g.max_frequency,
            0.05,
            10.0,
            "0.05 ..= 10 Hz",
        )?;
        range("gait.max-turn", g.max_turn, 0.0, 10.0, "0 ..= 10 1/m")?;
        range("gait.max-pitch", g.max_pitch, 0.0, 10.0, "0 ..= 10 1/m")?;
        for (key, v) in [
            ("gait.amplitude-rate", g.amplitude_rate),
            ("gait.amplitude-accel", g.amplitude_accel),
            ("gait.frequency-rate", g.frequency_rate),
            ("gait.frequency-accel", g.frequency_accel),
            ("gait.curvature-rate", g.curvature_rate),
            ("gait.curvature-accel", g.curvature_accel),
        ] {
            range(key, v, 1e-3, 1e3, "0.001 ..= 1000")?;
        }
        Ok(())
    }
}

/// `[gait]` in the commented default file ([`super::sections_toml`]).
pub(super) fn write_default(d: &GaitConfig, w: &mut dyn FnMut(String)) {
    w("[gait]".into());
    w("# Body wave length (m); amplitude polynomial a0 + a1·X + a2·X² (1/m) at full".into());
    w("# amplitude: the paper's F1 gait.".into());
    w(format!("wavelength = {}", fmt_f(d.wavelength)));
    let [a0, a1, a2] = d.amplitude_polynomial;
    w(format!(
        "amplitude-polynomial = [{}, {}, {}]",
        fmt_f(a0),
        fmt_f(a1),
        fmt_f(a2)
    ));
    w("# Largest frequency (Hz), turn and pitch curvatures (1/m) an operator may ask for.".into());
    w(format!("max-frequency = {}", fmt_f(d.max_frequency)));
    w(format!("max-turn = {}", fmt_f(d.max_turn)));
    w(format!("max-pitch = {}", fmt_f(d.max_pitch)));
    w(
        "# Trapezoidal shaping of parameter changes: rate (per s) and acceleration (per s²)."
            .into(),
    );
    w(format!("amplitude-rate = {}", fmt_f(d.amplitude_rate)));
    w(format!("amplitude-accel = {}", fmt_f(d.amplitude_accel)));
    w(format!("frequency-rate = {}", fmt_f(d.frequency_rate)));
    w(format!("frequency-accel = {}", fmt_f(d.frequency_accel)));
    w(format!("curvature-rate = {}", fmt_f(d.curvature_rate)));
    w(format!("curvature-accel = {}", fmt_f(d.curvature_accel)));
    w(String::new());
}
