//! The daemon's configuration: TOML, kebab-case keys, every key optional.
//!
//! A missing key takes the paper robot's default; an unknown key, a value of
//! the wrong type or one out of range is an error that names the key and the
//! accepted range. [`sections_toml`] writes the daemon's sections with a
//! comment on every key (the bulk of `anguilla config default`); a test
//! checks that they parse back to [`Config::default`], so the printed file
//! cannot drift from the defaults in the code.
//!
//! Each section lives in a file of its own, with its struct, its defaults,
//! its checks and its part of the commented default file; [`Config`]
//! gathers them and checks what they ask for together (the control rate
//! against the bus and the model). The same file holds sections that other
//! processes read ([`OTHER_SECTIONS`]: `[link]`, `[foxglove]`): the daemon
//! accepts them unread, and the root package's `anguilla::config` reads
//! the whole file (what `anguilla config check` checks).

use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

mod autopilot;
mod body;
mod bus;
mod control;
mod error;
mod gait;
mod guidance;
mod ipc;
mod limits;
mod model;
mod monitor;
mod realtime;
mod recording;
mod robot;
mod sections;
mod sensor;
#[cfg(test)]
mod tests;
mod whole;

pub use autopilot::AutopilotConfig;
pub use body::{BodyFile, DragLaw};
pub use bus::{BUS_BUILTIN, BUS_UNSET, BusConfig};
pub use control::{BUILTIN_TIMEOUT, ControlConfig, FaultPolicyConfig};
pub use error::{ConfigError, fmt_f, fmt_number, range, read_file};
pub use gait::GaitConfig;
pub use guidance::{GuidanceConfig, MAX_FENCE_VERTICES, polygon_area};
pub use ipc::IpcConfig;
pub use limits::LimitsConfig;
pub use model::{COEFFICIENT_MAX, ModelConfig};
pub use monitor::MonitorConfig;
pub use realtime::RealtimeConfig;
pub use recording::RecordingConfig;
pub use robot::{AxisConfig, AxisDefaults, AxisMap, RobotConfig};
pub use sections::OTHER_SECTIONS;
pub use sensor::SensorConfig;
pub use whole::BuiltinFit;

/// The daemon's configuration: its sections of the file.
#[derive(Debug, Clone, PartialEq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct Config {
    /// `[robot]`.
    pub robot: RobotConfig,
    /// `[control]`.
    pub control: ControlConfig,
    /// `[gait]`.
    pub gait: GaitConfig,
    /// `[limits]`.
    pub limits: LimitsConfig,
    /// `[bus]`.
    pub bus: BusConfig,
    /// `[realtime]`.
    pub realtime: RealtimeConfig,
    /// `[ipc]`.
    pub ipc: IpcConfig,
    /// `[recording]`.
    pub recording: RecordingConfig,
    /// `[model]`.
    pub model: ModelConfig,
    /// `[sensor]`.
    pub sensor: SensorConfig,
    /// `[autopilot]`.
    pub autopilot: AutopilotConfig,
    /// `[guidance]`.
    pub guidance: GuidanceConfig,
    /// `[monitor]`.
    pub monitor: MonitorConfig,
    /// The file's [`OTHER_SECTIONS`] as written, unread: the daemon has no
    /// use for them, but a recording's `config.toml` ([`Config::to_toml`])
    /// keeps them, so that `anguilla export --ros2` reads the session's
    /// `[link]`.
    #[serde(skip)]
    pub other_sections: toml::Table,
}

impl Config {
    /// The control rate (Hz): `control.rate-hz`, or with 0 the highest rate
    /// at which the configured bus carries the robot's traffic within
    /// `bus.max-load`. Checked by [`Config::validate`]: at least the
    /// model's slowest step (1 / `MAX_DT`), and within `bus.max-load`.
    pub fn control_rate(&self) -> Result<f64, ConfigError> {
        let rates = self.bitrates();
        let nodes = self.node_set();
        let bus_text = || {
            format!(
                "{} joints ({} drives) on {} at {} bit/s",
                self.robot.joints,
                self.robot.drive,
                self.bus.variant(),
                self.bus.bitrate
            )
        };
        let mut traffic = anguilla_protocol::budget::Traffic::of_family(self.robot.drive, nodes);
        if let anguilla_protocol::budget::Traffic::Anguilla(_, sensor) = &mut traffic
            && (self.sensor.node != 0 || self.sensor.tail_imu != 0)
        {
            *sensor = Some(anguilla_protocol::budget::Imus {
                rate_hz: self.sensor.rate_hz,
                count: u8::from(self.sensor.node != 0) + u8::from(self.sensor.tail_imu != 0),
            });
        }
        let max = anguilla_protocol::budget::max_rate_of(traffic, rates, self.bus.max_load)
            .map_err(|e| ConfigError::Derived(format!("bus budget: {e}")))?;
        let min = 1.0 / anguilla_model::MAX_DT;
        let rate = if self.control.rate_hz > 0.0 {
            self.control.rate_hz
        } else {
            if max < min {
                return Err(ConfigError::Derived(format!(
                    "control.rate-hz = 0 (automatic) finds no rate: {} within bus.max-load = {} \
                     allow {:.1} Hz, and the model needs at least {min} Hz (a step of at most \
                     {} s); raise bus.max-load or the bit rate, use CAN FD, or fewer joints",
                    bus_text(),
                    self.bus.max_load,
                    max,
                    anguilla_model::MAX_DT
                )));
            }
            max
        };
        let load = anguilla_protocol::budget::budget_of(traffic, rate, rates)
            .map_err(|e| ConfigError::Derived(format!("bus budget: {e}")))?
            .load;
        // The automatic rate sits exactly at the limit; allow rounding.
        if load > self.bus.max_load * (1.0 + 1e-9) {
            return Err(ConfigError::Derived(format!(
                "control.rate-hz = {} puts {:.0} % load on the bus ({}), above bus.max-load = {} \
                 ({:.0} %): at most {:.1} Hz, or 0 for the automatic rate",
                fmt_number(rate),
                load * 100.0,
                bus_text(),
                self.bus.max_load,
                self.bus.max_load * 100.0,
                max
            )));
        }
        Ok(rate)
    }

    /// The nodes' ids as a set, for the bus budget (ids out of range are
    /// left out; validation names them).
    pub fn node_set(&self) -> anguilla_protocol::NodeSet {
        anguilla_protocol::NodeSet::of(
            self.node_ids()
                .into_iter()
                .filter_map(|id| anguilla_protocol::NodeId::new(id).ok()),
        )
    }

    /// The bus's bit rates, as the budget arithmetic takes them.
    pub fn bitrates(&self) -> anguilla_protocol::budget::Bitrates {
        anguilla_protocol::budget::Bitrates {
            nominal: self.bus.bitrate,
            data: self.bus.fd.then_some(self.bus.data_bitrate),
        }
    }

    /// Parses and validates TOML text; `origin` names it in errors. The
    /// sections of [`OTHER_SECTIONS`] are taken out unread (into
    /// [`Config::other_sections`]); any other unknown section is an error
    /// naming it.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let parse_error = |e: toml::de::Error| ConfigError::Parse {
            origin: origin.to_string(),
            message: e.to_string(),
        };
        let mut other_sections = toml::Table::new();
        let document = toml::Deserializer::parse(text).map_err(parse_error)?;
        let mut cfg = Config::deserialize(sections::WithoutOthers {
            inner: document,
            kept: &mut other_sections,
        })
        .map_err(parse_error)?;
        cfg.other_sections = other_sections;
        cfg.validate()?;
        Ok(cfg)
    }

    /// The configuration as TOML (every key of the daemon's sections
    /// written, then the other sections as the file had them; used by
    /// recordings).
    pub fn to_toml(&self) -> String {
        let mut text = toml::to_string(self).unwrap_or_default();
        if !self.other_sections.is_empty() {
            text.push('\n');
            text.push_str(&toml::to_string(&self.other_sections).unwrap_or_default());
        }
        text
    }

    /// Reads, parses and validates a file.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let (text, origin) = read_file(path)?;
        Self::from_toml(&text, &origin)
    }

    /// Checks every section, then what they ask for together; the error
    /// names the first key out of range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.validate_robot()?;
        self.validate_sensor()?;
        self.autopilot.validate()?;
        self.guidance.validate()?;
        self.monitor.validate()?;
        self.control.validate()?;
        self.gait.validate()?;
        self.limits.validate()?;
        self.bus.validate()?;
        self.realtime.validate()?;
        self.ipc.validate()?;
        self.model.validate()?;
        self.recording.validate()?;
        // What the keys ask for together: a rate the bus and the model can
        // run (the same check `anguilla run` depends on).
        let rate = self.control_rate()?;
        self.validate_latencies(rate)
    }

    /// An off-bus sensor's latency against what the estimate can place
    /// (its history of [`crate::nav::position::HISTORY`] periods at the
    /// control `rate`) and the position's `fix-stale` (a fix is that old
    /// when it arrives).
    fn validate_latencies(&self, rate: f64) -> Result<(), ConfigError> {
        let kept = crate::nav::position::HISTORY as f64 / rate;
        for section in self.sensor.off_bus() {
            let (name, latency) = (section.kind().name(), section.latency());
            if latency >= kept / 2.0 {
                return Err(ConfigError::Derived(format!(
                    "sensor.{name}.latency = {} s: the estimate keeps {} s of its past at {} \
                     Hz (1024 periods), and a reading must arrive within half of it (expected \
                     a latency below {} s, or a slower control rate)",
                    fmt_f(latency),
                    fmt_f(kept),
                    fmt_f(rate),
                    fmt_f(kept / 2.0)
                )));
            }
            if section.gives_position() && latency >= self.autopilot.fix_stale {
                return Err(ConfigError::Derived(format!(
                    "sensor.{name}.latency = {} s is not below autopilot.fix-stale = {} s: every \
                     fix would arrive stale (expected fix-stale above the {}'s latency)",
                    fmt_f(latency),
                    fmt_f(self.autopilot.fix_stale),
                    name.to_uppercase()
                )));
            }
        }
        Ok(())
    }
}

/// Where the robot's configuration lives on a tether computer (the
/// Debian package's conffile, the systemd unit's `--config`).
pub const SYSTEM_FILE: &str = "/etc/anguilla/anguilla.toml";

/// Where the robot's sessions are recorded on a tether computer: the
/// unit's state directory (`StateDirectory=anguilla`).
pub const SYSTEM_RECORDINGS: &str = "/var/lib/anguilla/recordings";

/// The configuration a robot's tether computer starts from (the Debian
/// package's [`SYSTEM_FILE`]): the defaults but for the bus, left
/// [`BUS_UNSET`] for the operator to name; the loop at SCHED_FIFO 80 with
/// its memory locked; and sessions recorded in [`SYSTEM_RECORDINGS`],
/// bounded for a 32 GB card (16 GB of sessions at most, 90 days, 2 GB
/// always left free).
pub fn robot_config() -> Config {
    let mut c = Config::default();
    c.bus.spec = BUS_UNSET.into();
    c.realtime.fifo_priority = 80;
    c.realtime.lock_memory = true;
    c.recording.dir = SYSTEM_RECORDINGS.into();
    c.recording.max_total = 16_000.0;
    c.recording.keep_days = 90.0;
    c.recording.min_free = 2_000.0;
    c
}

/// The daemon's sections of `d` as commented TOML, each ending with a
/// blank line: the whole file (`anguilla config default`, with its header
/// and the other processes' sections) is the root package's
/// `anguilla::config::default_toml`.
pub fn sections_toml(d: &Config) -> String {
    let mut o = String::new();
    let mut w = |s: String| {
        let _ = writeln!(o, "{s}");
    };
    robot::write_default(&d.robot, &mut w);
    control::write_default(&d.control, &mut w);
    gait::write_default(&d.gait, &mut w);
    limits::write_default(&d.limits, &mut w);
    bus::write_default(&d.bus, &mut w);
    realtime::write_default(&d.realtime, &mut w);
    ipc::write_default(&d.ipc, &mut w);
    recording::write_default(&d.recording, &mut w);
    model::write_default(&d.model, &mut w);
    sensor::write_default(&d.sensor, &mut w);
    autopilot::write_default(&d.autopilot, &mut w);
    guidance::write_default(&d.guidance, &mut w);
    monitor::write_default(&d.monitor, &mut w);
    o
}
