//! `[model]`: the feedforward model's discretization, ballast and
//! hydrodynamic coefficients.

use anguilla_model::{AxialDrag, Body};
use serde::{Deserialize, Serialize};

use super::error::{ConfigError, fmt_f, range};

/// `[model]`: the feedforward model's discretization, ballast and
/// hydrodynamic coefficients (the paper's by default; `anguilla calibrate`
/// fits them to recorded swims, docs/calibration.md).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct ModelConfig {
    /// Space nodes along the body.
    pub nodes: usize,
    /// How far below each section's axis the body's centre of mass lies
    /// (m): its ballast, which rights it in roll and pitch. 0: the paper's
    /// body, which rolls freely under a pitch curvature.
    pub ballast: f64,
    /// The nose's pressure-drag coefficient `c_p` of (22).
    #[serde(rename = "c-p")]
    pub c_p: f64,
    /// The nose's axial added-mass coefficient `k` of (23).
    pub k: f64,
    /// The angular (roll) drag coefficient `c_1` of (24).
    pub c1: f64,
    /// The lateral drag coefficient `c_2` (along `t2`) of (24).
    pub c2: f64,
    /// The vertical drag coefficient `c_3` (along `t3`) of (24).
    pub c3: f64,
    /// The factor on the skin-friction law (41) (1: the paper's).
    pub friction: f64,
    /// The drives' own reflected inertia at the joint (kg·m²), added to
    /// the feed-forward as `J θ̈` (0: none; `anguilla calibrate --write`
    /// writes the one it fits).
    pub drive_inertia: f64,
    /// The drives' own viscous friction (N·m·s/rad), added to the
    /// feed-forward as `b θ̇`.
    pub drive_friction: f64,
    /// How late the drives' measured torque follows the one they act
    /// (s): the torque predicted against the measured one is the model's
    /// `lag` earlier.
    pub drive_lag: f64,
}

impl Default for ModelConfig {
    fn default() -> Self {
        let p = Body::paper();
        Self {
            nodes: 25,
            ballast: anguilla_model::TYPICAL_BALLAST,
            c_p: p.c_p,
            k: p.k_nose,
            c1: p.c1,
            c2: p.c2,
            c3: p.c3,
            friction: 1.0,
            drive_inertia: 0.0,
            drive_friction: 0.0,
            drive_lag: 0.0,
        }
    }
}

/// The coefficients' ranges: `[model]`'s and `anguilla calibrate`'s.
pub const COEFFICIENT_MAX: f64 = 100.0;

impl ModelConfig {
    /// Checks `[model]`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        range("model.nodes", self.nodes as f64, 5.0, 2000.0, "5 ..= 2000")?;
        range("model.ballast", self.ballast, 0.0, 0.05, "0 ..= 0.05 m")?;
        for (key, v) in [
            ("model.c-p", self.c_p),
            ("model.k", self.k),
            ("model.c1", self.c1),
            ("model.c2", self.c2),
            ("model.c3", self.c3),
            ("model.friction", self.friction),
        ] {
            range(key, v, 0.0, COEFFICIENT_MAX, "0 ..= 100")?;
        }
        range(
            "model.drive-inertia",
            self.drive_inertia,
            0.0,
            1.0,
            "0 ..= 1 kg·m²",
        )?;
        range(
            "model.drive-friction",
            self.drive_friction,
            0.0,
            10.0,
            "0 ..= 10 N·m·s/rad",
        )?;
        range("model.drive-lag", self.drive_lag, 0.0, 0.1, "0 ..= 0.1 s")?;
        Ok(())
    }

    /// The model's body: the paper's geometry and density with this
    /// ballast and these coefficients.
    pub fn body(&self) -> Body {
        Body {
            ballast: self.ballast,
            c_p: self.c_p,
            k_nose: self.k,
            c1: self.c1,
            c2: self.c2,
            c3: self.c3,
            axial: AxialDrag::SkinFriction {
                scale: self.friction,
            },
            ..Body::paper()
        }
    }
}

/// `[model]` in the commented default file ([`super::sections_toml`]).
pub(super) fn write_default(d: &ModelConfig, w: &mut dyn FnMut(String)) {
    w("[model]".into());
    w("# Space nodes of the feedforward model along the body. 5..=2000".into());
    w(format!("nodes = {}", d.nodes));
    w("# The body's ballast: its centre of mass this far below each section's axis (m),".into());
    w("# which rights it in roll and pitch (the built-in simulated robot is built the".into());
    w("# same). 0: the paper's body, which rolls freely under pitch curvature. 0..=0.05".into());
    w(format!("ballast = {}", fmt_f(d.ballast)));
    w("# Hydrodynamic coefficients (the paper's, section 7.3; each 0..=100): nose".into());
    w("# pressure drag c-p (22) and added mass k (23); roll, lateral and vertical".into());
    w("# drag c1, c2, c3 (24); a factor on the skin-friction law (41). `anguilla".into());
    w("# calibrate` fits them to recorded swims (docs/calibration.md).".into());
    w(format!("c-p = {}", fmt_f(d.c_p)));
    w(format!("k = {}", fmt_f(d.k)));
    w(format!("c1 = {}", fmt_f(d.c1)));
    w(format!("c2 = {}", fmt_f(d.c2)));
    w(format!("c3 = {}", fmt_f(d.c3)));
    w(format!("friction = {}", fmt_f(d.friction)));
    w("# The drives' own reflected inertia (kg·m², 0..=1) and viscous friction".into());
    w("# (N·m·s/rad, 0..=10), added to the torque feed-forward as J·θ̈ + b·θ̇, and how".into());
    w("# late their measured torque follows (s, 0..=0.1). `anguilla calibrate` fits them.".into());
    w(format!("drive-inertia = {}", fmt_f(d.drive_inertia)));
    w(format!("drive-friction = {}", fmt_f(d.drive_friction)));
    w(format!("drive-lag = {}", fmt_f(d.drive_lag)));
    w(String::new());
}
