//! `[foxglove]`: the live view (`anguilla foxglove`, its own process).

use serde::{Deserialize, Serialize};

use anguilla_daemon::config::{ConfigError, fmt_f, range};

/// `[foxglove]`: the live view (`anguilla foxglove`, its own process; the
/// daemon ignores this section).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct FoxgloveConfig {
    /// Accept operator commands that Foxglove clients publish on
    /// `/anguilla/command`; off: the view is read-only.
    pub commands: bool,
    /// Required with `commands`: the Foxglove WebSocket protocol has no
    /// authentication, so whoever reaches the port (any local user, on
    /// loopback) may drive; this says the owner accepts that. Warned at
    /// every start.
    pub insecure_commands: bool,
    /// Most viewers connected at once; one more is refused (HTTP 503)
    /// and the refusal logged.
    pub max_clients: u32,
    /// A viewer that subscribes to no channel (and advertises none) this
    /// long after connecting is closed (s); 0: never.
    pub subscribe_timeout: f64,
    /// A viewer that takes no byte of what is sent to it this long (once
    /// its socket's buffers are full) is closed, freeing its place (s);
    /// 0: never.
    pub read_timeout: f64,
}

impl Default for FoxgloveConfig {
    fn default() -> Self {
        Self {
            commands: false,
            insecure_commands: false,
            max_clients: 16,
            subscribe_timeout: 30.0,
            read_timeout: 10.0,
        }
    }
}

impl FoxgloveConfig {
    /// Checks `[foxglove]`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        range(
            "foxglove.max-clients",
            f64::from(self.max_clients),
            1.0,
            1024.0,
            "1 ..= 1024 viewers",
        )?;
        if self.subscribe_timeout != 0.0 {
            range(
                "foxglove.subscribe-timeout",
                self.subscribe_timeout,
                1.0,
                3600.0,
                "0 (never) or 1 ..= 3600 s",
            )?;
        }
        if self.read_timeout != 0.0 {
            range(
                "foxglove.read-timeout",
                self.read_timeout,
                1.0,
                3600.0,
                "0 (never) or 1 ..= 3600 s",
            )?;
        }
        Ok(())
    }
}

/// `[foxglove]` in the commented default file ([`super::default_toml`]).
pub(super) fn write_default(d: &FoxgloveConfig, w: &mut dyn FnMut(String)) {
    w("[foxglove]".into());
    w("# `anguilla foxglove` (its own process; the daemon ignores this section): accept".into());
    w("# operator commands Foxglove clients publish on /anguilla/command, each client".into());
    w("# its own operator under the daemon's authority and deadman rules. The".into());
    w("# WebSocket has no authentication: whoever reaches the port may then drive (any".into());
    w("# local user, on loopback), so commands also need insecure-commands = true.".into());
    w(format!("commands = {}", d.commands));
    w(format!("insecure-commands = {}", d.insecure_commands));
    w("# Most viewers connected at once; one more is refused (HTTP 503) and logged.".into());
    w(format!("max-clients = {}", d.max_clients));
    w("# A viewer that subscribes to no channel this long after connecting is closed".into());
    w("# (s); 0: never.".into());
    w(format!(
        "subscribe-timeout = {}",
        fmt_f(d.subscribe_timeout)
    ));
    w("# A viewer that reads nothing of what is sent to it this long (once its".into());
    w("# socket's buffers are full) is closed, freeing its place (s); 0: never.".into());
    w(format!("read-timeout = {}", fmt_f(d.read_timeout)));
    w(String::new());
}
