//! `[link]`: remote operation over Zenoh (`anguilla link`, its own process).

use serde::{Deserialize, Serialize};

use super::{Config, ConfigError, fmt_f, range};

/// `[link]`: remote operation over Zenoh (`anguilla link`, docs/remote.md).
/// The daemon ignores it: the link is its own process.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct LinkConfig {
    /// Zenoh endpoints the link listens on: `local` (the prefix's Unix
    /// socket, for the link's user and group only), `tls/0.0.0.0:7447`;
    /// plain `tcp/` only on loopback and with `insecure-loopback`.
    pub listen: Vec<String>,
    /// Accept plain `tcp/` on loopback, which every local user can reach
    /// (no authentication). Warned at every start.
    pub insecure_loopback: bool,
    /// Most states a second sent on the link (Hz); a change of mode,
    /// cause or holder is sent at once.
    pub state_rate: f64,
    /// Most remote clients with a session at once.
    pub max_clients: u32,
    /// A remote session silent this long is closed (s).
    pub idle_timeout: f64,
    /// TLS: the robot's CA certificate (PEM); operators' certificates must
    /// be signed by it.
    pub ca: String,
    /// TLS: the robot's certificate (PEM), signed by `ca`.
    pub cert: String,
    /// TLS: the robot's private key (PEM).
    pub key: String,
    /// What remote clients may send: `command`, `estop`.
    pub inbound: Vec<String>,
    /// What the link publishes: `state`.
    pub outbound: Vec<String>,
}

/// Names a `[link]` allowlist may hold, inbound and outbound.
pub const LINK_INBOUND: [&str; 2] = ["command", "estop"];
/// See [`LINK_INBOUND`].
pub const LINK_OUTBOUND: [&str; 1] = ["state"];

impl Default for LinkConfig {
    fn default() -> Self {
        Self {
            listen: vec!["local".into()],
            insecure_loopback: false,
            state_rate: 50.0,
            max_clients: 8,
            idle_timeout: 10.0,
            ca: String::new(),
            cert: String::new(),
            key: String::new(),
            inbound: LINK_INBOUND.iter().map(|s| s.to_string()).collect(),
            outbound: LINK_OUTBOUND.iter().map(|s| s.to_string()).collect(),
        }
    }
}

impl LinkConfig {
    /// Checks `[link]`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let l = self;
        range(
            "link.state-rate",
            l.state_rate,
            0.1,
            1000.0,
            "0.1 ..= 1000 Hz",
        )?;
        range(
            "link.max-clients",
            f64::from(l.max_clients),
            1.0,
            f64::from(anguilla_ipc::MAX_TOOLS as u32 / 2),
            "1 ..= 16 (half the daemon's tool slots)",
        )?;
        range(
            "link.idle-timeout",
            l.idle_timeout,
            6.0,
            3600.0,
            "6 ..= 3600 s (three of the tools' 2 s hellos)",
        )?;
        if l.listen.is_empty() {
            return Err(ConfigError::Range {
                key: "link.listen",
                value: "[]".into(),
                expected: "at least one endpoint, e.g. \"local\"",
            });
        }
        for (key, list, allowed, expected) in [
            (
                "link.inbound",
                &l.inbound,
                &LINK_INBOUND[..],
                "names among \"command\", \"estop\"",
            ),
            (
                "link.outbound",
                &l.outbound,
                &LINK_OUTBOUND[..],
                "names among \"state\"",
            ),
        ] {
            if let Some(bad) = list.iter().find(|n| !allowed.contains(&n.as_str())) {
                return Err(ConfigError::Range {
                    key,
                    value: format!("{bad:?}"),
                    expected,
                });
            }
        }
        let tls = [&l.ca, &l.cert, &l.key];
        if tls.iter().any(|p| !p.is_empty()) && tls.iter().any(|p| p.is_empty()) {
            return Err(ConfigError::Derived(
                "link.ca, link.cert and link.key go together: give all three (TLS) or none".into(),
            ));
        }
        Ok(())
    }
}

/// `[link]` in the commented default file ([`super::default_toml`]).
pub(super) fn write_default(d: &Config, w: &mut dyn FnMut(String)) {
    w("[link]".into());
    w("# Remote operation over Zenoh: `anguilla link` (its own process; the daemon".into());
    w("# ignores this section; docs/remote.md). Endpoints it listens on: \"local\",".into());
    w("# a Unix socket in /tmp/anguilla/<prefix>/link/ (mode 0770: the link's user and".into());
    w("# group, the operators, only); \"tls/HOST:PORT\" with the robot's CA, certificate".into());
    w("# and key (`anguilla link certs` makes them); plain \"tcp/...\" on loopback only,".into());
    w("# and only with insecure-loopback = true (every local user can reach it).".into());
    w(format!("listen = {:?}", d.link.listen));
    w(format!("insecure-loopback = {}", d.link.insecure_loopback));
    w("# Most states a second on the link (Hz); mode, cause or holder changes go at once.".into());
    w(format!("state-rate = {}", fmt_f(d.link.state_rate)));
    w("# Most remote clients with a session at once; a silent one is closed after".into());
    w("# idle-timeout (s).".into());
    w(format!("max-clients = {}", d.link.max_clients));
    w(format!("idle-timeout = {}", fmt_f(d.link.idle_timeout)));
    w("# TLS with mutual authentication: PEM files (paths relative to the working".into());
    w("# directory); empty: none.".into());
    w("ca = \"\"".into());
    w("cert = \"\"".into());
    w("key = \"\"".into());
    w("# The allowlist: what remote clients may send (\"command\", \"estop\"), and".into());
    w("# what the link publishes (\"state\"). A watch-only link: inbound = [\"estop\"].".into());
    w(format!("inbound = {:?}", d.link.inbound));
    w(format!("outbound = {:?}", d.link.outbound));
}
