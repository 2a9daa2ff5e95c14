//! What the sections share to check and print themselves: the error, the
//! range check, and how numbers are written.

use serde::Deserialize;

/// What went wrong loading a configuration.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read configuration file {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// The text is not valid TOML, has an unknown key or a value of the wrong type.
    #[error("configuration {origin}: {message}")]
    Parse {
        /// The file, or "text".
        origin: String,
        /// toml's message, which names the key and the line.
        message: String,
    },
    /// A value is outside its accepted range.
    #[error("configuration key '{key}' = {value} is out of range (expected {expected})")]
    Range {
        /// The dotted key, e.g. `control.rate-hz`.
        key: &'static str,
        /// The value given.
        value: String,
        /// The accepted range.
        expected: &'static str,
    },
    /// The keys are each in range, but together ask for what the bus or
    /// the model cannot do; the text names the keys and the figures.
    #[error("configuration: {0}")]
    Derived(String),
}

/// `Ok` when `value` is finite and in `min ..= max`; else
/// [`ConfigError::Range`] naming `key` and what was `expected`. Every
/// section checks its numbers with it, the other processes' sections too
/// (`anguilla::config`).
pub fn range(
    key: &'static str,
    value: f64,
    min: f64,
    max: f64,
    expected: &'static str,
) -> Result<(), ConfigError> {
    if value.is_finite() && value >= min && value <= max {
        Ok(())
    } else {
        Err(ConfigError::Range {
            key,
            value: fmt_number(value),
            expected,
        })
    }
}

/// Exactly three numbers (serde truncates a longer array into `[f64; 3]`
/// without a word, extra elements of any type included).
pub(super) fn three_numbers<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    let v: Vec<f64> = Vec::deserialize(d)?;
    <[f64; 3]>::try_from(v.as_slice()).map_err(|_| {
        serde::de::Error::custom(format!(
            "expected exactly three numbers [a0, a1, a2], got {}",
            v.len()
        ))
    })
}

/// Writes `v` readably: scientific notation when it is huge or tiny.
pub fn fmt_number(v: f64) -> String {
    if v.is_finite() && v != 0.0 && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// `v` as a TOML float, for the commented default file: always with a
/// decimal point or an exponent (`1.0`, not `1`, which TOML reads as an
/// integer).
pub fn fmt_f(v: f64) -> String {
    // TOML floats need a decimal point or exponent.
    let s = format!("{v}");
    if s.contains(['.', 'e', 'E']) || s.contains("inf") || s.contains("nan") {
        s
    } else {
        format!("{s}.0")
    }
}

/// A configuration file's text and its name for errors (`origin`), or the
/// error that names the file it could not read: what every `load` of a
/// TOML file here starts with.
pub fn read_file(path: &std::path::Path) -> Result<(String, String), ConfigError> {
    let origin = path.display().to_string();
    match std::fs::read_to_string(path) {
        Ok(text) => Ok((text, origin)),
        Err(source) => Err(ConfigError::Read {
            path: origin,
            source,
        }),
    }
}
