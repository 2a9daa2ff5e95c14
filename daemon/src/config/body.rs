//! A simulated body's file (`anguilla sim --body FILE`, `anguilla run
//! --sim-body FILE`): the body the simulated robot swims with, its own and
//! not the daemon's `[model]` — a robot that is not the model, for
//! `anguilla calibrate` (docs/calibration.md).
//!
//! TOML, kebab-case keys, every key optional (the daemon's default
//! `[model]` body); an unknown key or a value out of range is an error
//! naming the key and the accepted range:
//!
//! ```toml
//! c-p = 0.036          # nose pressure drag (22)
//! k = 0.32             # nose added mass (23)
//! c1 = 0.0             # roll drag (24)
//! c2 = 1.98            # lateral drag (24)
//! c3 = 0.5             # vertical drag (24)
//! friction = 1.0       # factor on the skin friction (41), drag = "paper"
//! drag = "paper"       # or "quadratic": -rho/2 axial-drag P v|v| per length
//! axial-drag = 0.006   # drag = "quadratic" only
//! density = 1000.0     # the body's density (kg/m³; water's is 1000)
//! ballast = 0.02       # centre of mass below the axis (m)
//! ```

use anguilla_model::{AxialDrag, Body};
use serde::{Deserialize, Serialize};
use std::path::Path;

use super::error::{ConfigError, range, read_file};
use super::model::{COEFFICIENT_MAX, ModelConfig};

/// The axial drag law of a simulated body.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum DragLaw {
    /// The paper's skin friction (41), times `friction`.
    #[default]
    Paper,
    /// Quadratic drag, `axial-drag` its coefficient: no scale of (41)
    /// matches it, so the model cannot represent this body exactly.
    Quadratic,
}

/// A simulated body's file.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct BodyFile {
    /// Nose pressure drag `c_p` (22).
    #[serde(rename = "c-p")]
    pub c_p: f64,
    /// Nose added mass `k` (23).
    pub k: f64,
    /// Roll drag `c_1` (24).
    pub c1: f64,
    /// Lateral drag `c_2` (24).
    pub c2: f64,
    /// Vertical drag `c_3` (24).
    pub c3: f64,
    /// Factor on (41) (with the paper's law).
    pub friction: f64,
    /// The axial drag law.
    pub drag: DragLaw,
    /// The quadratic law's coefficient.
    pub axial_drag: f64,
    /// The body's density (kg/m³).
    pub density: f64,
    /// The ballast (m).
    pub ballast: f64,
}

impl Default for BodyFile {
    fn default() -> Self {
        let m = ModelConfig::default();
        Self {
            c_p: m.c_p,
            k: m.k,
            c1: m.c1,
            c2: m.c2,
            c3: m.c3,
            friction: m.friction,
            drag: DragLaw::Paper,
            axial_drag: 0.006,
            density: 1000.0,
            ballast: m.ballast,
        }
    }
}

impl BodyFile {
    /// Parses and checks a body file's text; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let b: BodyFile = toml::from_str(text).map_err(|e| ConfigError::Parse {
            origin: origin.to_string(),
            message: e.to_string(),
        })?;
        b.validate()?;
        Ok(b)
    }

    /// Reads, parses and checks a body file.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let (text, origin) = read_file(path)?;
        Self::from_toml(&text, &origin)
    }

    /// Checks every key's range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for (key, v) in [
            ("c-p", self.c_p),
            ("k", self.k),
            ("c1", self.c1),
            ("c2", self.c2),
            ("c3", self.c3),
            ("friction", self.friction),
            ("axial-drag", self.axial_drag),
        ] {
            range(key, v, 0.0, COEFFICIENT_MAX, "0 ..= 100")?;
        }
        range("density", self.density, 900.0, 1100.0, "900 ..= 1100 kg/m³")?;
        range("ballast", self.ballast, 0.0, 0.05, "0 ..= 0.05 m")?;
        Ok(())
    }

    /// The body: the model's of these coefficients and ballast
    /// ([`ModelConfig::body`]), with this density and axial law.
    pub fn body(&self) -> Body {
        let model = ModelConfig {
            c_p: self.c_p,
            k: self.k,
            c1: self.c1,
            c2: self.c2,
            c3: self.c3,
            friction: self.friction,
            ballast: self.ballast,
            ..ModelConfig::default()
        };
        let mut body = model.body();
        body.rho_body = self.density;
        if self.drag == DragLaw::Quadratic {
            body.axial = AxialDrag::Quadratic { c: self.axial_drag };
        }
        body
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The documented example parses to what it says; the default file is
    /// the daemon's default model body; bad keys and values are named.
    #[test]
    fn body_files_parse_and_bad_ones_are_named() {
        let doc = include_str!("body.rs")
            .lines()
            .skip_while(|l| !l.starts_with("//! ```toml"))
            .skip(1)
            .take_while(|l| !l.starts_with("//! ```"))
            .map(|l| l.trim_start_matches("//!").trim_start())
            .collect::<Vec<_>>()
            .join("\n");
        let b = BodyFile::from_toml(&doc, "doc").unwrap();
        assert_eq!(b, BodyFile::default());
        assert_eq!(b.body(), ModelConfig::default().body());
        let q = BodyFile::from_toml("drag = \"quadratic\"\naxial-drag = 0.01\nc2 = 2.5", "t")
            .unwrap()
            .body();
        assert_eq!(q.axial, AxialDrag::Quadratic { c: 0.01 });
        assert_eq!(q.c2, 2.5);
        for (text, needle) in [
            (
                "c2 = -1.0",
                "'c2' = -1 is out of range (expected 0 ..= 100)",
            ),
            ("density = 2000.0", "'density'"),
            ("drag = \"linear\"", "unknown variant `linear`"),
            ("mass = 3.0", "unknown field `mass`"),
            ("ballast = 0.5", "'ballast'"),
        ] {
            let e = BodyFile::from_toml(text, "body.toml")
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle), "{text}: {e}");
        }
    }
}
