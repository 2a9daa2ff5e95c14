//! The whole configuration file: the daemon's sections
//! ([`anguilla_daemon::config`]) and those of the other processes that
//! read the same file, `[link]` (`anguilla link`, its section the link
//! crate's [`LinkConfig`]) and `[foxglove]` (`anguilla foxglove`,
//! [`FoxgloveConfig`]). The daemon accepts those two unread
//! ([`anguilla_daemon::config::OTHER_SECTIONS`]); the tools that read them
//! and `anguilla config check` load the file here, so a bad `[link]` key
//! is named as a bad `[control]` key is. [`default_toml`] and
//! [`robot_toml`] write the whole commented file.
//!
//! ```
//! let cfg = anguilla::config::Config::from_toml("[link]\nstate-rate = 25.0\n", "example")?;
//! assert_eq!(cfg.link.state_rate, 25.0);
//! assert_eq!(cfg.daemon.robot.joints, 12);
//! # Ok::<(), anguilla_daemon::config::ConfigError>(())
//! ```

use std::path::Path;

use anguilla_daemon::config::{self as daemon, ConfigError, read_file};
pub use anguilla_link::config::LinkConfig;
use serde::Deserialize;

mod foxglove;
mod link;
#[cfg(test)]
mod tests;

pub use foxglove::FoxgloveConfig;

/// The whole file: what the daemon reads, and the other processes'
/// sections.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Config {
    /// The daemon's sections (with the other sections as written, unread:
    /// [`anguilla_daemon::config::Config::other_sections`]).
    pub daemon: daemon::Config,
    /// `[link]`.
    pub link: LinkConfig,
    /// `[foxglove]`.
    pub foxglove: FoxgloveConfig,
}

/// The sections of [`anguilla_daemon::config::OTHER_SECTIONS`], read from
/// the whole text (the daemon's sections passed over), so that toml names
/// the line of a bad key.
#[derive(Deserialize, Default)]
#[serde(rename_all = "kebab-case", default)]
struct OtherSections {
    foxglove: FoxgloveConfig,
    link: LinkConfig,
}

impl Config {
    /// Parses and validates the whole file's text: the daemon's sections,
    /// then `[link]` and `[foxglove]`; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let daemon = daemon::Config::from_toml(text, origin)?;
        let others: OtherSections = toml::from_str(text).map_err(|e| ConfigError::Parse {
            origin: origin.to_string(),
            message: e.to_string(),
        })?;
        let cfg = Config {
            daemon,
            link: others.link,
            foxglove: others.foxglove,
        };
        cfg.validate_others()?;
        Ok(cfg)
    }

    /// Reads, parses and validates a file.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let (text, origin) = read_file(path)?;
        Self::from_toml(&text, &origin)
    }

    /// Checks every section; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.daemon.validate()?;
        self.validate_others()
    }

    fn validate_others(&self) -> Result<(), ConfigError> {
        self.foxglove.validate()?;
        self.link.validate().map_err(link::error)?;
        if self.link.ros2_pose {
            self.pose_fix_target()?;
        }
        Ok(())
    }

    /// Where the ROS 2 node sends its position fixes (`[link] ros2-pose`):
    /// the daemon's `[sensor.usbl]` source, which must be `udp:` (this
    /// machine's loopback when it is bound to every address).
    pub fn pose_fix_target(&self) -> Result<std::net::SocketAddr, ConfigError> {
        use anguilla_daemon::sensors::Source;
        let source = self.daemon.sensor.usbl.as_ref().map(|u| u.source.as_str());
        let target = source
            .and_then(|s| Source::parse(s).ok())
            .and_then(|s| s.send_to());
        target.ok_or_else(|| {
            ConfigError::Derived(format!(
                "link.ros2-pose = true needs [sensor.usbl] with a \"udp:ADDRESS:PORT\" source \
                 (where the daemon reads position fixes; it has {})",
                source.map_or("no [sensor.usbl]".to_string(), |s| format!(
                    "source = {s:?}"
                ))
            ))
        })
    }
}

/// The whole default configuration as a commented TOML file (`anguilla
/// config default`).
pub fn default_toml() -> String {
    write_toml(
        &Config::default(),
        &[
            "# anguilla daemon configuration. Every key is optional; these are the defaults.",
            "# Keys are kebab-case; an unknown key or an out-of-range value is an error.",
        ],
    )
}

/// The configuration a robot's tether computer starts from: the daemon's
/// [`anguilla_daemon::config::robot_config`], the other sections at their
/// defaults.
pub fn robot_config() -> Config {
    Config {
        daemon: daemon::robot_config(),
        ..Config::default()
    }
}

/// [`robot_config`] as a commented TOML file: the Debian package's
/// `/etc/anguilla/anguilla.toml` (`anguilla config default --robot`).
pub fn robot_toml() -> String {
    write_toml(
        &robot_config(),
        &[
            "# anguilla daemon configuration for this robot (/etc/anguilla/anguilla.toml).",
            "# Set [bus] spec below: the daemon (`systemctl start anguilla`) refuses to start",
            "# until it names the robot's bus. Every other key is optional: these are the",
            "# defaults of `anguilla config default`, but for [realtime] (SCHED_FIFO 80,",
            "# memory locked) and [recording] (sessions in /var/lib/anguilla/recordings, at",
            "# most 16 GB of them, 90 days, 2 GB always left free: a 32 GB card).",
            "# Keys are kebab-case; an unknown key or an out-of-range value is an error.",
            "# `anguilla config check /etc/anguilla/anguilla.toml` checks an edit.",
        ],
    )
}

/// `d` as a commented TOML file, under `header`'s lines: the daemon's
/// sections, then `[foxglove]` and `[link]`.
fn write_toml(d: &Config, header: &[&str]) -> String {
    let mut o = String::new();
    for line in header {
        o.push_str(line);
        o.push('\n');
    }
    o.push('\n');
    o.push_str(&daemon::sections_toml(&d.daemon));
    let mut w = |s: String| {
        o.push_str(&s);
        o.push('\n');
    };
    foxglove::write_default(&d.foxglove, &mut w);
    link::write_default(&d.link, &mut w);
    o
}
