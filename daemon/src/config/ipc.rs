//! `[ipc]`: the operator interface.

use serde::{Deserialize, Serialize};

use super::error::ConfigError;

/// `[ipc]`: the operator interface.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct IpcConfig {
    /// Prefix of the iceoryx2 service names.
    pub prefix: String,
}

impl Default for IpcConfig {
    fn default() -> Self {
        Self {
            prefix: "anguilla".to_string(),
        }
    }
}

impl IpcConfig {
    /// Checks `[ipc]`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let p = &self.prefix;
        // The services' names and the E-stop socket's path come from it.
        if anguilla_ipc::estop::socket_path(p).is_err() {
            return Err(ConfigError::Range {
                key: "ipc.prefix",
                value: format!("{p:?}"),
                expected: "names of letters, digits, '-' and '_' joined by '/', \
                           at most 80 characters",
            });
        }
        Ok(())
    }
}

/// `[ipc]` in the commented default file ([`super::sections_toml`]).
pub(super) fn write_default(d: &IpcConfig, w: &mut dyn FnMut(String)) {
    w("[ipc]".into());
    w("# Prefix of the iceoryx2 services (<prefix>/state, /state-ready, /command,".into());
    w("# /command-ready).".into());
    w(format!("prefix = {:?}", d.prefix));
    w(String::new());
}
