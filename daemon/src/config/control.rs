//! `[control]`: the loop and the supervisor.

use serde::{Deserialize, Serialize};

use super::error::{ConfigError, fmt_f, range};

/// What to do with an actuator fault or a lost heartbeat.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FaultPolicyConfig {
    /// Stop swimming and keep the healthy actuators holding straight.
    Hold,
    /// Disable every actuator at once.
    Disable,
}

/// `[control]`: the loop and the supervisor.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct ControlConfig {
    /// Control rate (Hz); 0 means the highest the bus carries at `bus.max-load`.
    pub rate_hz: f64,
    /// The holder's silence that stops a swim (s).
    pub command_timeout: f64,
    /// The holder's silence that releases its control (s).
    pub control_release_timeout: f64,
    /// Time for every node to report enabled (s).
    pub enable_timeout: f64,
    /// A node's heartbeat older than this is lost (s).
    pub heartbeat_timeout: f64,
    /// A node that answers none of this many SYNCs (control periods) is
    /// faulted, whatever its heartbeats say ("no feedback").
    pub feedback_timeout: u32,
    /// The nodes' watchdog, written to them before every enable (s); 0 means
    /// five control periods, at least 100 ms.
    pub node_watchdog: f64,
    /// Reaction to an actuator fault or a lost heartbeat.
    pub fault_policy: FaultPolicyConfig,
}

impl Default for ControlConfig {
    fn default() -> Self {
        Self {
            rate_hz: 0.0,
            command_timeout: 0.5,
            control_release_timeout: 3.0,
            enable_timeout: 1.0,
            heartbeat_timeout: 0.35,
            feedback_timeout: 100,
            node_watchdog: 0.0,
            fault_policy: FaultPolicyConfig::Hold,
        }
    }
}

/// The liveness and operator timeouts of the built-in simulated robot
/// (s; [`Config::relax_for_builtin`](super::Config::relax_for_builtin)).
pub const BUILTIN_TIMEOUT: f64 = 2.0;

impl ControlConfig {
    /// Checks `[control]` alone (its rate against the bus: [`Config::control_rate`](super::Config::control_rate)).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let c = self;
        if c.rate_hz != 0.0 {
            // The model's step is 1 / rate: at most MAX_DT (0.05 s).
            range(
                "control.rate-hz",
                c.rate_hz,
                1.0 / anguilla_model::MAX_DT,
                5000.0,
                "0 (automatic) or 20 ..= 5000",
            )?;
        }
        range(
            "control.command-timeout",
            c.command_timeout,
            0.02,
            10.0,
            "0.02 ..= 10 s",
        )?;
        range(
            "control.control-release-timeout",
            c.control_release_timeout,
            c.command_timeout,
            600.0,
            "control.command-timeout ..= 600 s",
        )?;
        range(
            "control.enable-timeout",
            c.enable_timeout,
            0.01,
            30.0,
            "0.01 ..= 30 s",
        )?;
        range(
            "control.heartbeat-timeout",
            c.heartbeat_timeout,
            0.01,
            10.0,
            "0.01 ..= 10 s",
        )?;
        range(
            "control.feedback-timeout",
            f64::from(c.feedback_timeout),
            2.0,
            10_000.0,
            "2 ..= 10000 control periods",
        )?;
        if c.node_watchdog != 0.0 {
            range(
                "control.node-watchdog",
                c.node_watchdog,
                0.002,
                1.0,
                "0 (automatic) or 0.002 ..= 1 s",
            )?;
        }
        Ok(())
    }
}

/// `[control]` in the commented default file ([`super::sections_toml`]).
pub(super) fn write_default(d: &ControlConfig, w: &mut dyn FnMut(String)) {
    w("[control]".into());
    w("# Control rate (Hz). 0: the highest rate the bus carries within bus.max-load.".into());
    w("# Else 20..=5000, and its bus load at most bus.max-load (checked).".into());
    w(format!("rate-hz = {}", fmt_f(d.rate_hz)));
    w("# The controlling operator must send a command at least this often (s),".into());
    w("# or the swim stops smoothly. 0.02..=10".into());
    w(format!("command-timeout = {}", fmt_f(d.command_timeout)));
    w("# Silence after which the operator's control is released (s).".into());
    w(format!(
        "control-release-timeout = {}",
        fmt_f(d.control_release_timeout)
    ));
    w("# Time allowed for every node to report enabled (s).".into());
    w(format!("enable-timeout = {}", fmt_f(d.enable_timeout)));
    w("# A node whose heartbeat is older than this is lost (s).".into());
    w(format!(
        "heartbeat-timeout = {}",
        fmt_f(d.heartbeat_timeout)
    ));
    w("# A node that answers none of this many SYNCs (control periods) is faulted,".into());
    w("# \"no feedback\", whatever its heartbeats say. ODrive axes answer every".into());
    w("# encoder_msg_rate_ms (10 ms by default): keep this above that in periods.".into());
    w(format!("feedback-timeout = {}", d.feedback_timeout));
    w("# The nodes' watchdog, written to them before every enable (s): a node that".into());
    w("# applies no setpoint for this long takes its safe action. 0: five periods,".into());
    w("# at least 100 ms.".into());
    w(format!("node-watchdog = {}", fmt_f(d.node_watchdog)));
    w("# On an actuator fault or a lost node: \"hold\" (stop swimming, healthy joints".into());
    w("# hold straight) or \"disable\" (every actuator off at once).".into());
    w("fault-policy = \"hold\"".into());
    w(String::new());
}
