//! `[model]`: the feedforward model's discretization.

use serde::{Deserialize, Serialize};

use super::error::{ConfigError, fmt_f, range};

/// `[model]`: the feedforward model's discretization.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct ModelConfig {
    /// Space nodes along the body.
    pub nodes: usize,
    /// How far below each section's axis the body's centre of mass lies
    /// (m): its ballast, which rights it in roll and pitch. 0: the paper's
    /// body, which rolls freely under a pitch curvature.
    pub ballast: f64,
}

impl Default for ModelConfig {
    fn default() -> Self {
        Self {
            nodes: 25,
            ballast: anguilla_model::TYPICAL_BALLAST,
        }
    }
}

impl ModelConfig {
    /// Checks `[model]`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        range("model.nodes", self.nodes as f64, 5.0, 2000.0, "5 ..= 2000")?;
        range("model.ballast", self.ballast, 0.0, 0.05, "0 ..= 0.05 m")?;
        Ok(())
    }
}

/// `[model]` in the commented default file ([`super::default_toml`]).
pub(super) fn write_default(d: &ModelConfig, w: &mut dyn FnMut(String)) {
    w("[model]".into());
    w("# Space nodes of the feedforward model along the body. 5..=2000".into());
    w(format!("nodes = {}", d.nodes));
    w("# The body's ballast: its centre of mass this far below each section's axis (m),".into());
    w("# which rights it in roll and pitch (the built-in simulated robot is built the".into());
    w("# same). 0: the paper's body, which rolls freely under pitch curvature. 0..=0.05".into());
    w(format!("ballast = {}", fmt_f(d.ballast)));
    w(String::new());
}
