//! `[recording]`: what is written to disk.

use serde::{Deserialize, Serialize};

/// `[recording]`: what is written to disk.
#[derive(Debug, Clone, PartialEq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct RecordingConfig {
    /// Directory for the session recording; empty records nothing.
    pub dir: String,
}

/// `[recording]` in the commented default file ([`super::default_toml`]).
pub(super) fn write_default(d: &RecordingConfig, w: &mut dyn FnMut(String)) {
    w("[recording]".into());
    w("# Directory for the session recording (candump log + state records); empty: none.".into());
    w(format!("dir = {:?}", d.dir));
    w(String::new());
}
