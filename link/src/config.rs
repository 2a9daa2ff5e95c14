//! `[link]` of anguilla's configuration file, owned by the crate that uses
//! it: its keys, defaults and checks. The whole file's configuration
//! (`anguilla::config`, in the root package) reads it beside the daemon's
//! sections (so `anguilla config check` checks it too) and writes its
//! commented defaults; the daemon accepts it unread.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

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
    /// The robot as a ROS 2 node on rmw_zenoh's wire (docs/ros2.md).
    pub ros2: bool,
    /// `ROS_DOMAIN_ID` of the ROS 2 node.
    pub ros2_domain: u32,
    /// The ROS 2 node's namespace: `/` or `/name`.
    pub ros2_namespace: String,
    /// The ROS 2 node's name.
    pub ros2_node: String,
    /// The ROS 2 distribution: `jazzy` (and later) or `humble`.
    pub ros2_distro: String,
    /// Most messages a second of each ROS 2 topic (Hz), unless
    /// `ros2-rates` names it.
    pub ros2_rate: f64,
    /// Most messages a second of the topics it names (Hz).
    pub ros2_rates: BTreeMap<String, f64>,
    /// The fastest forward speed a ROS 2 `cmd_vel` may ask for (m/s):
    /// `linear.x` becomes the amplitude whose steady speed it is (the
    /// model's); faster than this, or than full amplitude swims, is
    /// clamped and reported.
    pub ros2_max_speed: f64,
    /// The undulation frequency a ROS 2 `cmd_vel` swims at (Hz).
    pub ros2_frequency: f64,
    /// The ROS 2 node takes position fixes: `pose_fix`
    /// (`geometry_msgs/msg/PoseStamped`) and `odom_fix`
    /// (`nav_msgs/msg/Odometry`), handed to the daemon's `[sensor.usbl]`
    /// (its `udp:` source) with their age from their stamps. Needs
    /// `inbound` to hold `command`: a fix steers a path as a command does.
    pub ros2_pose: bool,
    /// The frame the fixes' headers must name (the estimate's frame, its
    /// origin where the estimate started, moved by `[sensor.usbl]
    /// offset`).
    pub ros2_pose_frame: String,
    /// A fix's horizontal standard deviation (m) when its message says
    /// none (a `PoseStamped`, an `Odometry` with a zero covariance).
    pub ros2_pose_sigma: f64,
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
            ros2: false,
            ros2_domain: 0,
            ros2_namespace: "/".into(),
            ros2_node: "anguilla".into(),
            ros2_distro: "jazzy".into(),
            ros2_rate: 20.0,
            ros2_rates: BTreeMap::from([("diagnostics".to_string(), 1.0)]),
            ros2_max_speed: 0.4,
            ros2_frequency: 1.0,
            ros2_pose: false,
            ros2_pose_frame: "odom".into(),
            ros2_pose_sigma: 0.01,
        }
    }
}

impl LinkConfig {
    /// Checks `[link]`: every key in range, and the TLS files together.
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
        range("link.ros2-rate", l.ros2_rate, 0.1, 500.0, "0.1 ..= 500 Hz")?;
        for (topic, &rate) in &l.ros2_rates {
            if !crate::ros2::TOPICS.iter().any(|(n, _)| n == topic) {
                return Err(ConfigError::Derived(format!(
                    "link.ros2-rates names {topic:?}, which the ROS 2 node does not publish \
                     (its topics: {})",
                    crate::ros2::TOPICS.map(|(n, _)| n).join(", ")
                )));
            }
            if !(rate.is_finite() && (0.1..=500.0).contains(&rate)) {
                return Err(ConfigError::Derived(format!(
                    "link.ros2-rates.{topic} = {rate} is out of range (expected 0.1 ..= 500 Hz)"
                )));
            }
        }
        if !crate::ros2::DISTROS.contains(&l.ros2_distro.as_str()) {
            return Err(ConfigError::Range {
                key: "link.ros2-distro",
                value: format!("{:?}", l.ros2_distro),
                expected: "\"jazzy\" (also for Kilted and later) or \"humble\"",
            });
        }
        range(
            "link.ros2-max-speed",
            l.ros2_max_speed,
            0.01,
            10.0,
            "0.01 ..= 10 m/s",
        )?;
        range(
            "link.ros2-frequency",
            l.ros2_frequency,
            0.05,
            10.0,
            "0.05 ..= 10 Hz",
        )?;
        range(
            "link.ros2-pose-sigma",
            l.ros2_pose_sigma,
            1e-4,
            100.0,
            "0.0001 ..= 100 m",
        )?;
        if l.ros2_pose_frame.is_empty() {
            return Err(ConfigError::Range {
                key: "link.ros2-pose-frame",
                value: "\"\"".into(),
                expected: "a frame's name, e.g. \"odom\"",
            });
        }
        if l.ros2_pose && !l.inbound.iter().any(|n| n == "command") {
            return Err(ConfigError::Derived(
                "link.ros2-pose = true needs \"command\" in link.inbound (a position fix \
                 steers a path as a command does)"
                    .into(),
            ));
        }
        // rmw_zenoh, as DDS: 0..=232 (the ports of DDS's domains).
        if l.ros2_domain > 232 {
            return Err(ConfigError::Range {
                key: "link.ros2-domain",
                value: l.ros2_domain.to_string(),
                expected: "0 ..= 232 (ROS_DOMAIN_ID)",
            });
        }
        let name_ok = |n: &str| {
            !n.is_empty()
                && !n.starts_with(|c: char| c.is_ascii_digit())
                && n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        };
        if !name_ok(&l.ros2_node) {
            return Err(ConfigError::Range {
                key: "link.ros2-node",
                value: format!("{:?}", l.ros2_node),
                expected: "a ROS 2 name: letters, digits and _, not starting with a digit",
            });
        }
        let ns = &l.ros2_namespace;
        if !(ns == "/" || ns.starts_with('/') && ns[1..].split('/').all(name_ok)) {
            return Err(ConfigError::Range {
                key: "link.ros2-namespace",
                value: format!("{ns:?}"),
                expected: "\"/\" or \"/name\" (ROS 2 names: letters, digits, _), no trailing /",
            });
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

/// Why `[link]` is not valid.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ConfigError {
    /// A value is outside its accepted range.
    #[error("configuration key '{key}' = {value} is out of range (expected {expected})")]
    Range {
        /// The dotted key, e.g. `link.state-rate`.
        key: &'static str,
        /// The value given.
        value: String,
        /// The accepted range.
        expected: &'static str,
    },
    /// Keys that are each valid but do not go together; the text names them.
    #[error("configuration: {0}")]
    Derived(String),
}

fn range(
    key: &'static str,
    value: f64,
    min: f64,
    max: f64,
    expected: &'static str,
) -> Result<(), ConfigError> {
    if value.is_finite() && value >= min && value <= max {
        Ok(())
    } else {
        // As the daemon's configuration writes a number: short when huge
        // or tiny.
        let value = if value.is_finite() && value != 0.0 && !(1e-4..1e6).contains(&value.abs()) {
            format!("{value:e}")
        } else {
            format!("{value}")
        };
        Err(ConfigError::Range {
            key,
            value,
            expected,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_is_valid_and_each_check_names_its_key() {
        LinkConfig::default().validate().unwrap();
        let bad = |f: &dyn Fn(&mut LinkConfig)| {
            let mut c = LinkConfig::default();
            f(&mut c);
            c.validate().unwrap_err().to_string()
        };
        assert!(bad(&|c| c.state_rate = 0.0).contains("'link.state-rate'"));
        assert!(bad(&|c| c.state_rate = 1e9).contains("= 1e9 "), "short");
        assert!(bad(&|c| c.max_clients = 99).contains("'link.max-clients'"));
        assert!(bad(&|c| c.idle_timeout = 1.0).contains("'link.idle-timeout'"));
        assert!(bad(&|c| c.ros2_rate = 0.0).contains("'link.ros2-rate'"));
        assert!(bad(&|c| c.ros2_distro = "rolling".into()).contains("'link.ros2-distro'"));
        let e = bad(&|c| {
            c.ros2_rates.insert("cmd_vel".into(), 10.0);
        });
        assert!(
            e.contains("\"cmd_vel\", which the ROS 2 node does not publish"),
            "{e}"
        );
        let e = bad(&|c| {
            c.ros2_rates.insert("imu".into(), f64::NAN);
        });
        assert!(e.contains("link.ros2-rates.imu = NaN"), "{e}");
        assert!(bad(&|c| c.ros2_domain = 233).contains("'link.ros2-domain'"));
        assert!(bad(&|c| c.ros2_max_speed = 0.0).contains("'link.ros2-max-speed'"));
        assert!(bad(&|c| c.ros2_pose_sigma = 0.0).contains("'link.ros2-pose-sigma'"));
        assert!(bad(&|c| c.ros2_pose_frame.clear()).contains("'link.ros2-pose-frame'"));
        assert!(
            bad(&|c| {
                c.ros2_pose = true;
                c.inbound = vec!["estop".into()];
            })
            .contains("needs \"command\"")
        );
        assert!(bad(&|c| c.ros2_frequency = f64::INFINITY).contains("'link.ros2-frequency'"));
        for n in ["", "1eel", "my-eel", "a/b"] {
            assert!(
                bad(&|c| c.ros2_node = n.into()).contains("'link.ros2-node'"),
                "{n:?}"
            );
        }
        for ns in ["", "eel", "/eel/", "//", "/my eel"] {
            assert!(
                bad(&|c| c.ros2_namespace = ns.into()).contains("'link.ros2-namespace'"),
                "{ns:?}"
            );
        }
        let mut ok = LinkConfig {
            ros2_namespace: "/fleet/eel_2".into(),
            ..LinkConfig::default()
        };
        ok.validate().unwrap();
        ok.ros2_namespace = "/".into();
        ok.validate().unwrap();
        assert!(bad(&|c| c.listen.clear()).contains("'link.listen'"));
        assert!(bad(&|c| c.inbound.push("swim".into())).contains("'link.inbound'"));
        assert!(bad(&|c| c.ca = "ca.pem".into()).contains("go together"));
    }
}
