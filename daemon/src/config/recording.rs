//! `[recording]`: what is written to disk, and how much of the disk it
//! may take.

use serde::{Deserialize, Serialize};

use super::error::{ConfigError, fmt_f, range};

/// `[recording]`: what is written to disk.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct RecordingConfig {
    /// Directory for the session recording; empty records nothing.
    pub dir: String,
    /// The compression of `session.mcap`'s chunks: `zstd` or `none`.
    pub compression: String,
    /// Most megabytes (10⁶ bytes) all sessions in `dir` may take: the
    /// oldest go first, never the current one. 0: no limit.
    pub max_total: f64,
    /// Sessions older than this many days are deleted (not the current
    /// one). 0: kept for ever.
    pub keep_days: f64,
    /// A session does not start with less free space (MB) on `dir`'s
    /// file system, and one that reaches it ends cleanly. 0: no guard.
    pub min_free: f64,
}

impl Default for RecordingConfig {
    fn default() -> Self {
        Self {
            dir: String::new(),
            compression: "zstd".into(),
            max_total: 0.0,
            keep_days: 0.0,
            min_free: 100.0,
        }
    }
}

/// The compressions `[recording] compression` accepts.
pub const COMPRESSIONS: [&str; 2] = ["zstd", "none"];

impl RecordingConfig {
    /// Checks `[recording]`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !COMPRESSIONS.contains(&self.compression.as_str()) {
            return Err(ConfigError::Range {
                key: "recording.compression",
                value: format!("{:?}", self.compression),
                expected: "\"zstd\" or \"none\"",
            });
        }
        range(
            "recording.max-total",
            self.max_total,
            0.0,
            1e9,
            "0 (no limit) ..= 1e9 MB",
        )?;
        range(
            "recording.keep-days",
            self.keep_days,
            0.0,
            36500.0,
            "0 (for ever) ..= 36500 days",
        )?;
        range(
            "recording.min-free",
            self.min_free,
            0.0,
            1e9,
            "0 (no guard) ..= 1e9 MB",
        )?;
        if self.max_total > 0.0 && self.max_total < 10.0 {
            return Err(ConfigError::Derived(format!(
                "recording.max-total = {} MB leaves no room for one session (at least 10 MB, or 0 \
                 for no limit)",
                fmt_f(self.max_total)
            )));
        }
        Ok(())
    }
}

/// `[recording]` in the commented default file ([`super::sections_toml`]).
pub(super) fn write_default(d: &RecordingConfig, w: &mut dyn FnMut(String)) {
    w("[recording]".into());
    w("# Directory for the session recording (candump log + state records); empty: none.".into());
    w(format!("dir = {:?}", d.dir));
    w("# session.mcap's chunks compressed: \"zstd\" or \"none\".".into());
    w(format!("compression = {:?}", d.compression));
    w("# Retention: most megabytes all sessions in dir may take, the oldest deleted".into());
    w("# first (never the current one; 0: no limit), and the days a session is kept".into());
    w("# (0: for ever). A session does not start with less than min-free MB free on".into());
    w("# dir's file system, and one that reaches it ends cleanly (0: no guard).".into());
    w(format!("max-total = {}", fmt_f(d.max_total)));
    w(format!("keep-days = {}", fmt_f(d.keep_days)));
    w(format!("min-free = {}", fmt_f(d.min_free)));
    w(String::new());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_recording_check_names_its_key() {
        RecordingConfig::default().validate().unwrap();
        let bad = |f: &dyn Fn(&mut RecordingConfig)| {
            let mut c = RecordingConfig::default();
            f(&mut c);
            c.validate().unwrap_err().to_string()
        };
        assert!(bad(&|c| c.compression = "lz5".into()).contains("'recording.compression'"));
        assert!(bad(&|c| c.max_total = -1.0).contains("'recording.max-total'"));
        assert!(bad(&|c| c.max_total = 5.0).contains("no room for one session"));
        assert!(bad(&|c| c.keep_days = f64::NAN).contains("'recording.keep-days'"));
        assert!(bad(&|c| c.min_free = 1e12).contains("'recording.min-free'"));
    }
}
