//! The daemon's configuration: TOML, kebab-case keys, every key optional.
//!
//! A missing key takes the paper robot's default; an unknown key, a value of
//! the wrong type or one out of range is an error that names the key and the
//! accepted range. [`default_toml`] prints the whole default file with a
//! comment on every key (`anguilla config default`); a test checks that it
//! parses back to [`Config::default`], so the printed file cannot drift from
//! the defaults in the code.

use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

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

/// What to do with an actuator fault or a lost heartbeat.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FaultPolicyConfig {
    /// Stop swimming and keep the healthy actuators holding straight.
    Hold,
    /// Disable every actuator at once.
    Disable,
}

/// `[robot] drive` as text: a [`Family`](anguilla_protocol::Family)'s name.
mod family_name {
    use anguilla_protocol::Family;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(f: &Family, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(f.name())
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Family, D::Error> {
        let name = String::deserialize(d)?;
        name.parse().map_err(serde::de::Error::custom)
    }
}

/// `[robot.axis]`: what every axis of a bought drive family has unless
/// its entry in `robot.axes` says otherwise.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct AxisDefaults {
    /// +1, or −1 when the motor turns the other way from the joint.
    pub direction: i8,
    /// The joint angle at motor position zero (rad).
    pub offset: f64,
    /// Motor turns per joint turn.
    pub gear: f64,
    /// CiA 402: position increments per motor turn.
    pub counts_per_turn: u32,
    /// CiA 402: the motor's rated torque (N·m), the unit of the torque
    /// objects; 0 reads it from the drive (0x6076).
    pub rated_torque: f64,
}

impl Default for AxisDefaults {
    fn default() -> Self {
        Self {
            direction: 1,
            offset: 0.0,
            gear: 1.0,
            counts_per_turn: 65536,
            rated_torque: 0.0,
        }
    }
}

/// One entry of `robot.axes`: one drive (bought families). Keys left out
/// take `[robot.axis]`'s value.
#[derive(Debug, Clone, PartialEq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct AxisConfig {
    /// The drive's node id (CiA 402: 1..=127, ODrive: 0..=63); default
    /// pitch 2j + 1, yaw 2j + 2 for joint j (0 = head end).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub node: Option<u8>,
    /// +1 or −1.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub direction: Option<i8>,
    /// Joint angle at motor zero (rad).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub offset: Option<f64>,
    /// Motor turns per joint turn.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gear: Option<f64>,
    /// CiA 402: increments per motor turn.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub counts_per_turn: Option<u32>,
    /// CiA 402: rated torque (N·m), 0 = read from the drive.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rated_torque: Option<f64>,
}

/// `[robot]`: the body's actuators.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct RobotConfig {
    /// Number of actuated joints (each a pitch and a yaw axis).
    pub joints: usize,
    /// The drives' protocol: `"anguilla"`, `"cia402"` or `"odrive"`.
    #[serde(with = "family_name")]
    pub drive: anguilla_protocol::Family,
    /// anguilla: node id of each joint from head to tail; empty means
    /// 1..=joints.
    pub node_ids: Vec<u8>,
    /// CiA 402: the master's own node id (its heartbeat is 0x700 + id).
    pub master_node_id: u8,
    /// CiA 402: the drives' EDS file, checked at start-up for every object
    /// the master uses (mappable where it maps them) and the bus's bit
    /// rate; empty: CiA 402's standard objects are taken as given.
    pub eds: String,
    /// Bought families: the axes, pitch then yaw for each joint from head
    /// to tail (2 × joints entries), or empty for every axis at its
    /// default id with `[robot.axis]`.
    pub axes: Vec<AxisConfig>,
    /// Bought families: every axis's defaults.
    pub axis: AxisDefaults,
}

impl Default for RobotConfig {
    fn default() -> Self {
        Self {
            joints: 12,
            drive: anguilla_protocol::Family::Anguilla,
            node_ids: Vec::new(),
            master_node_id: 127,
            eds: String::new(),
            axes: Vec::new(),
            axis: AxisDefaults::default(),
        }
    }
}

/// One axis of a bought drive, resolved ([`Config::axes`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisMap {
    /// Node id.
    pub node: u8,
    /// +1.0 or −1.0.
    pub direction: f64,
    /// Joint angle at motor zero (rad).
    pub offset: f64,
    /// Motor turns per joint turn.
    pub gear: f64,
    /// CiA 402 increments per motor turn.
    pub counts_per_turn: u32,
    /// CiA 402 rated torque (N·m); 0: read from the drive.
    pub rated_torque: f64,
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
/// (s; [`Config::relax_for_builtin`]).
pub const BUILTIN_TIMEOUT: f64 = 2.0;

/// `[gait]`: the parametric gait and how fast its parameters may change.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct GaitConfig {
    /// Wavelength λ of the body wave (m).
    pub wavelength: f64,
    /// Amplitude polynomial f_a(X) = a0 + a1·X + a2·X² at full amplitude (1/m).
    #[serde(deserialize_with = "three_numbers")]
    pub amplitude_polynomial: [f64; 3],
    /// Largest frequency an operator may ask for (Hz).
    pub max_frequency: f64,
    /// Largest |turn curvature| an operator may ask for (1/m).
    pub max_turn: f64,
    /// Largest |pitch curvature| an operator may ask for (1/m).
    pub max_pitch: f64,
    /// Fastest change of the amplitude fraction (1/s).
    pub amplitude_rate: f64,
    /// Largest acceleration of the amplitude fraction (1/s²).
    pub amplitude_accel: f64,
    /// Fastest change of the frequency (Hz/s).
    pub frequency_rate: f64,
    /// Largest acceleration of the frequency (Hz/s²).
    pub frequency_accel: f64,
    /// Fastest change of the turn and pitch curvatures (1/m/s).
    pub curvature_rate: f64,
    /// Largest acceleration of the turn and pitch curvatures (1/m/s²).
    pub curvature_accel: f64,
}

impl Default for GaitConfig {
    fn default() -> Self {
        // The paper's F1 gait (Table 1) at full amplitude.
        Self {
            wavelength: 1.0,
            amplitude_polynomial: [1.0, 0.5, 2.0],
            max_frequency: 2.0,
            max_turn: 2.0,
            max_pitch: 1.0,
            amplitude_rate: 0.5,
            amplitude_accel: 1.0,
            frequency_rate: 0.5,
            frequency_accel: 1.0,
            curvature_rate: 1.0,
            curvature_accel: 2.0,
        }
    }
}

/// `[limits]`: per-axis joint limits, applied to every setpoint.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct LimitsConfig {
    /// Largest |joint angle| (rad).
    pub angle: f64,
    /// Largest |joint velocity| (rad/s).
    pub velocity: f64,
    /// Largest |feedforward torque| (N·m).
    pub torque: f64,
}

impl Default for LimitsConfig {
    fn default() -> Self {
        Self {
            angle: 1.0,
            velocity: 8.0,
            torque: 4.0,
        }
    }
}

/// `[bus]`: which bus, and its physical layer.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct BusConfig {
    /// Bus spec (`socketcan:can0`, `slcan:/dev/ttyACM0@1000000`, `mem:NAME`);
    /// empty runs the built-in simulated robot on an in-process bus.
    pub spec: String,
    /// Use CAN FD frames.
    pub fd: bool,
    /// Nominal (arbitration) bit rate (bit/s).
    pub bitrate: u32,
    /// CAN FD data-phase bit rate (bit/s).
    pub data_bitrate: u32,
    /// Highest bus load the control rate may cause (fraction).
    pub max_load: f64,
}

impl BusConfig {
    /// The protocol variant the bus carries: CAN FD with `fd = true`.
    pub fn variant(&self) -> anguilla_protocol::Variant {
        if self.fd {
            anguilla_protocol::Variant::Fd
        } else {
            anguilla_protocol::Variant::Classic
        }
    }
}

impl Default for BusConfig {
    fn default() -> Self {
        Self {
            spec: String::new(),
            fd: false,
            bitrate: 1_000_000,
            data_bitrate: 5_000_000,
            max_load: 0.6,
        }
    }
}

/// `[realtime]`: what the loop thread asks of the OS.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct RealtimeConfig {
    /// SCHED_FIFO priority (1..=99); 0 keeps the normal scheduler.
    pub fifo_priority: u8,
    /// CPU to pin the loop thread to; -1 for none.
    pub cpu: i32,
    /// Lock the process's memory (mlockall).
    pub lock_memory: bool,
}

impl Default for RealtimeConfig {
    fn default() -> Self {
        Self {
            fifo_priority: 0,
            cpu: -1,
            lock_memory: false,
        }
    }
}

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

/// `[recording]`: what is written to disk.
#[derive(Debug, Clone, PartialEq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct RecordingConfig {
    /// Directory for the session recording; empty records nothing.
    pub dir: String,
}

/// `[model]`: the feedforward model's discretization.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct ModelConfig {
    /// Space nodes along the body.
    pub nodes: usize,
    /// How far below each section's axis the body's centre of mass lies
    /// (m): its ballast, which rights it in roll and pitch. 0: the paper's
    /// body, which rolls freely under a pitch curvature.
    pub ballast: f64,
}

impl Default for ModelConfig {
    fn default() -> Self {
        Self {
            nodes: 25,
            ballast: anguilla_model::TYPICAL_BALLAST,
        }
    }
}

/// `[sensor]`: the head sensor (IMU and pressure; protocol/README.md
/// "The head sensor") and how its samples become an estimate.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct SensorConfig {
    /// The sensor's node id, 1..=63 and none of the joints'; 0: no sensor.
    pub node: u8,
    /// Its sample rate (Hz), for the bus budget: 100..=200.
    pub rate_hz: u16,
    /// A sensor silent this long is lost (s).
    pub timeout: f64,
    /// Water density (kg/m³): depth = (pressure − surface-pressure) / (ρ g).
    pub water_density: f64,
    /// Atmospheric pressure at the surface (Pa).
    pub surface_pressure: f64,
    /// |body rate − the model's predicted rate|, low-passed, beyond which
    /// the estimate is implausible (rad/s).
    pub max_rate_innovation: f64,
    /// |roll| beyond which the robot is alarmed as rolled over (deg).
    pub roll_alarm: f64,
}

impl Default for SensorConfig {
    fn default() -> Self {
        Self {
            node: 0,
            rate_hz: 100,
            timeout: 0.1,
            water_density: 1000.0,
            surface_pressure: 101_325.0,
            max_rate_innovation: 1.0,
            roll_alarm: 60.0,
        }
    }
}

/// `[autopilot]`: heading and depth hold (docs/autopilot.md).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct AutopilotConfig {
    /// Heading error to turn-rate gain (1/s).
    pub heading_gain: f64,
    /// Heading integral gain (1/s²).
    pub heading_integral: f64,
    /// Largest turn rate the autopilot asks for (deg/s).
    pub max_turn_rate: f64,
    /// Depth error to dive-rate gain (1/s).
    pub depth_gain: f64,
    /// Depth integral gain (1/s²).
    pub depth_integral: f64,
    /// Steepest dive or climb the autopilot asks for (deg of pitch).
    pub max_dive_angle: f64,
    /// The pitch error's weight beside the model's curvature for the
    /// wanted pitch (a ballasted body, `model.ballast` > 0; dimensionless),
    /// or its gain to a pitch rate (an unballasted one; 1/s).
    pub pitch_gain: f64,
    /// Deepest depth a hold accepts (m).
    pub max_depth: f64,
}

impl Default for AutopilotConfig {
    fn default() -> Self {
        Self {
            heading_gain: 0.8,
            heading_integral: 0.05,
            max_turn_rate: 30.0,
            depth_gain: 0.4,
            depth_integral: 0.05,
            max_dive_angle: 30.0,
            pitch_gain: 0.3,
            max_depth: 10.0,
        }
    }
}

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
}

impl Default for FoxgloveConfig {
    fn default() -> Self {
        Self {
            commands: false,
            insecure_commands: false,
            max_clients: 16,
            subscribe_timeout: 30.0,
        }
    }
}

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

/// The whole configuration.
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
    /// `[foxglove]`.
    pub foxglove: FoxgloveConfig,
    /// `[link]`.
    pub link: LinkConfig,
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
        Err(ConfigError::Range {
            key,
            value: fmt_number(value),
            expected,
        })
    }
}

/// Exactly three numbers (serde truncates a longer array into `[f64; 3]`
/// without a word, extra elements of any type included).
fn three_numbers<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
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
            && self.sensor.node != 0
        {
            *sensor = Some(self.sensor.rate_hz);
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

    /// Parses and validates TOML text; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let cfg: Config = toml::from_str(text).map_err(|e| ConfigError::Parse {
            origin: origin.to_string(),
            message: e.to_string(),
        })?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// The configuration as TOML (every key written; used by recordings).
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    /// Reads, parses and validates a file.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// Each joint's two axes (bought families), pitch then yaw, with
    /// `[robot.axis]` filling what `robot.axes` leaves out.
    pub fn axes(&self) -> Vec<[AxisMap; 2]> {
        let d = &self.robot.axis;
        let family = self.robot.drive;
        (0..self.robot.joints)
            .map(|j| {
                let ids = family.default_ids(j);
                [0, 1].map(|a| {
                    let e = self.robot.axes.get(2 * j + a).cloned().unwrap_or_default();
                    AxisMap {
                        node: e.node.unwrap_or(ids[a]),
                        direction: e.direction.unwrap_or(d.direction) as f64,
                        offset: e.offset.unwrap_or(d.offset),
                        gear: e.gear.unwrap_or(d.gear),
                        counts_per_turn: e.counts_per_turn.unwrap_or(d.counts_per_turn),
                        rated_torque: e.rated_torque.unwrap_or(d.rated_torque),
                    }
                })
            })
            .collect()
    }

    /// The bought drives' node ids, `[pitch, yaw]` per joint (empty for
    /// anguilla, whose node carries both axes).
    pub fn axis_ids(&self) -> Vec<[u8; 2]> {
        if !self.robot.drive.drive_per_axis() {
            return Vec::new();
        }
        self.axes().iter().map(|p| [p[0].node, p[1].node]).collect()
    }

    /// The node id of each joint, head to tail (anguilla); for the bought
    /// families, each joint's report id 1..=joints.
    pub fn node_ids(&self) -> Vec<u8> {
        if self.robot.drive.drive_per_axis() {
            return (1..=self.robot.joints as u8).collect();
        }
        if self.robot.node_ids.is_empty() {
            (1..=self.robot.joints as u8).collect()
        } else {
            self.robot.node_ids.clone()
        }
    }

    /// The head sensor of the built-in simulated robot: with `[sensor]
    /// node = 0` (the default) and anguilla drives, the sensor goes on the
    /// first id no joint uses (13 with the default 12 joints), so heading
    /// and depth hold work out of the box. A real bus keeps "no sensor"
    /// unless the key is set. Returns the id chosen, or `None` (a sensor
    /// already configured, a bought family, no free id, or a configuration
    /// that the sensor's traffic would not fit: then it is left as it was).
    pub fn fit_builtin_sensor(&mut self) -> Option<u8> {
        if self.sensor.node != 0 || self.robot.drive != anguilla_protocol::Family::Anguilla {
            return None;
        }
        let joints = self.node_ids();
        let id = (1..=63u8).find(|id| !joints.contains(id))?;
        self.sensor.node = id;
        if self.validate().is_err() {
            self.sensor.node = 0;
            return None;
        }
        Some(id)
    }

    /// The timeouts of the built-in simulated robot. It shares the CPU
    /// with the daemon and the operator's tools: on a busy machine all of
    /// them stall together, and a 0.35 s heartbeat or 0.5 s command
    /// timeout then faults or stops a robot that did nothing wrong. Keys
    /// still at their defaults become [`BUILTIN_TIMEOUT`] (the node
    /// watchdog: 1 s, its maximum); keys set in the file are kept. A real
    /// bus keeps the strict defaults. Returns the keys changed, as
    /// `key = value` (for the log).
    pub fn relax_for_builtin(&mut self) -> Vec<String> {
        let d = ControlConfig::default();
        let c = &mut self.control;
        let mut changed = Vec::new();
        let secs = BUILTIN_TIMEOUT;
        if c.command_timeout == d.command_timeout {
            c.command_timeout = secs;
            changed.push(format!("control.command-timeout = {secs}"));
        }
        if c.heartbeat_timeout == d.heartbeat_timeout {
            c.heartbeat_timeout = secs;
            changed.push(format!("control.heartbeat-timeout = {secs}"));
        }
        if c.node_watchdog == d.node_watchdog {
            c.node_watchdog = 1.0;
            changed.push("control.node-watchdog = 1".to_string());
        }
        if c.feedback_timeout == d.feedback_timeout
            && let Ok(rate) = self.control_rate()
        {
            let periods = (secs * rate).ceil().min(10_000.0) as u32;
            self.control.feedback_timeout = periods;
            changed.push(format!("control.feedback-timeout = {periods}"));
        }
        changed
    }

    /// Checks every range; the error names the first key out of range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let r = &self.robot;
        range("robot.joints", r.joints as f64, 1.0, 32.0, "1 ..= 32")?;
        if !r.node_ids.is_empty() {
            if r.node_ids.len() != r.joints {
                return Err(ConfigError::Range {
                    key: "robot.node-ids",
                    value: format!("{} ids", r.node_ids.len()),
                    expected: "one id per joint (robot.joints of them), or none for 1..=joints",
                });
            }
            let mut seen = [false; 256];
            for &id in &r.node_ids {
                if !(1..=63).contains(&id) || seen[id as usize] {
                    return Err(ConfigError::Range {
                        key: "robot.node-ids",
                        value: format!("{:?}", r.node_ids),
                        expected: "distinct ids in 1 ..= 63",
                    });
                }
                seen[id as usize] = true;
            }
        }
        self.validate_axes()?;
        self.validate_nav()?;
        let c = &self.control;
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
        let g = &self.gait;
        range("gait.wavelength", g.wavelength, 0.1, 10.0, "0.1 ..= 10 m")?;
        for (i, a) in g.amplitude_polynomial.iter().enumerate() {
            let key = [
                "gait.amplitude-polynomial[0]",
                "gait.amplitude-polynomial[1]",
                "gait.amplitude-polynomial[2]",
            ][i];
            range(key, *a, -20.0, 20.0, "-20 ..= 20 1/m")?;
        }
        range(
            "gait.max-frequency",
            g.max_frequency,
            0.05,
            10.0,
            "0.05 ..= 10 Hz",
        )?;
        range("gait.max-turn", g.max_turn, 0.0, 10.0, "0 ..= 10 1/m")?;
        range("gait.max-pitch", g.max_pitch, 0.0, 10.0, "0 ..= 10 1/m")?;
        for (key, v) in [
            ("gait.amplitude-rate", g.amplitude_rate),
            ("gait.amplitude-accel", g.amplitude_accel),
            ("gait.frequency-rate", g.frequency_rate),
            ("gait.frequency-accel", g.frequency_accel),
            ("gait.curvature-rate", g.curvature_rate),
            ("gait.curvature-accel", g.curvature_accel),
        ] {
            range(key, v, 1e-3, 1e3, "0.001 ..= 1000")?;
        }
        let l = &self.limits;
        range("limits.angle", l.angle, 0.01, 1.5, "0.01 ..= 1.5 rad")?;
        // The protocol carries at most ±10 rad/s and ±5 N·m.
        range(
            "limits.velocity",
            l.velocity,
            0.01,
            10.0,
            "0.01 ..= 10 rad/s",
        )?;
        range("limits.torque", l.torque, 0.0, 5.0, "0 ..= 5 N·m")?;
        let b = &self.bus;
        range(
            "bus.bitrate",
            b.bitrate as f64,
            10_000.0,
            1_000_000.0,
            "10000 ..= 1000000 bit/s",
        )?;
        range(
            "bus.data-bitrate",
            b.data_bitrate as f64,
            b.bitrate as f64,
            12_000_000.0,
            "bus.bitrate ..= 12000000 bit/s",
        )?;
        range("bus.max-load", b.max_load, 0.05, 0.95, "0.05 ..= 0.95")?;
        let rt = &self.realtime;
        range(
            "realtime.fifo-priority",
            rt.fifo_priority as f64,
            0.0,
            99.0,
            "0 ..= 99",
        )?;
        range(
            "realtime.cpu",
            rt.cpu as f64,
            -1.0,
            1023.0,
            "-1 (none) ..= 1023",
        )?;
        let p = &self.ipc.prefix;
        // The services' names and the E-stop socket's path come from it.
        if anguilla_ipc::estop::socket_path(p).is_err() {
            return Err(ConfigError::Range {
                key: "ipc.prefix",
                value: format!("{p:?}"),
                expected: "names of letters, digits, '-' and '_' joined by '/', \
                           at most 80 characters",
            });
        }
        range(
            "model.nodes",
            self.model.nodes as f64,
            5.0,
            2000.0,
            "5 ..= 2000",
        )?;
        range(
            "model.ballast",
            self.model.ballast,
            0.0,
            0.05,
            "0 ..= 0.05 m",
        )?;
        // What the keys ask for together: a rate the bus and the model can
        // run (the same check `anguilla run` depends on).
        self.control_rate()?;
        Ok(())
    }
}

impl Config {
    fn validate_nav(&self) -> Result<(), ConfigError> {
        let s = &self.sensor;
        if s.node != 0 {
            range(
                "sensor.node",
                s.node as f64,
                1.0,
                63.0,
                "0 (none) or 1 ..= 63",
            )?;
            if self.robot.drive != anguilla_protocol::Family::Anguilla {
                return Err(ConfigError::Derived(format!(
                    "sensor.node = {} needs robot.drive = \"anguilla\": the head sensor's \
                     frames (0x240 + id ..) share identifiers with {} drives' traffic; \
                     set sensor.node = 0",
                    s.node, self.robot.drive
                )));
            }
            if self.node_ids().contains(&s.node) {
                return Err(ConfigError::Derived(format!(
                    "sensor.node = {} is also a joint's node id (robot.node-ids {:?}); \
                     the sensor needs an id of its own",
                    s.node,
                    self.node_ids()
                )));
            }
        }
        let (lo, hi) = anguilla_protocol::message::HEAD_SENSOR_RATE_HZ;
        range(
            "sensor.rate-hz",
            s.rate_hz as f64,
            lo as f64,
            hi as f64,
            "100 ..= 200 Hz",
        )?;
        range("sensor.timeout", s.timeout, 0.02, 5.0, "0.02 ..= 5 s")?;
        range(
            "sensor.water-density",
            s.water_density,
            900.0,
            1100.0,
            "900 ..= 1100 kg/m³",
        )?;
        range(
            "sensor.surface-pressure",
            s.surface_pressure,
            50_000.0,
            120_000.0,
            "50000 ..= 120000 Pa",
        )?;
        range(
            "sensor.max-rate-innovation",
            s.max_rate_innovation,
            0.05,
            10.0,
            "0.05 ..= 10 rad/s",
        )?;
        range(
            "sensor.roll-alarm",
            s.roll_alarm,
            5.0,
            180.0,
            "5 ..= 180 deg",
        )?;
        let a = &self.autopilot;
        for (key, v, lo, hi, expected) in [
            (
                "autopilot.heading-gain",
                a.heading_gain,
                0.01,
                10.0,
                "0.01 ..= 10 1/s",
            ),
            (
                "autopilot.heading-integral",
                a.heading_integral,
                0.0,
                10.0,
                "0 ..= 10 1/s²",
            ),
            (
                "autopilot.max-turn-rate",
                a.max_turn_rate,
                1.0,
                180.0,
                "1 ..= 180 deg/s",
            ),
            (
                "autopilot.depth-gain",
                a.depth_gain,
                0.01,
                10.0,
                "0.01 ..= 10 1/s",
            ),
            (
                "autopilot.depth-integral",
                a.depth_integral,
                0.0,
                10.0,
                "0 ..= 10 1/s²",
            ),
            (
                "autopilot.max-dive-angle",
                a.max_dive_angle,
                1.0,
                80.0,
                "1 ..= 80 deg",
            ),
            (
                "autopilot.pitch-gain",
                a.pitch_gain,
                0.01,
                20.0,
                "0.01 ..= 20 1/s",
            ),
            (
                "autopilot.max-depth",
                a.max_depth,
                0.1,
                1000.0,
                "0.1 ..= 1000 m",
            ),
        ] {
            range(key, v, lo, hi, expected)?;
        }
        range(
            "foxglove.max-clients",
            f64::from(self.foxglove.max_clients),
            1.0,
            1024.0,
            "1 ..= 1024 viewers",
        )?;
        if self.foxglove.subscribe_timeout != 0.0 {
            range(
                "foxglove.subscribe-timeout",
                self.foxglove.subscribe_timeout,
                1.0,
                3600.0,
                "0 (never) or 1 ..= 3600 s",
            )?;
        }
        self.validate_link()
    }

    fn validate_link(&self) -> Result<(), ConfigError> {
        let l = &self.link;
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

    fn validate_axes(&self) -> Result<(), ConfigError> {
        let r = &self.robot;
        let family = r.drive;
        if !family.drive_per_axis() {
            if !r.axes.is_empty() {
                return Err(ConfigError::Range {
                    key: "robot.axes",
                    value: format!("{} entries", r.axes.len()),
                    expected: "none with drive = \"anguilla\" (a node carries both axes; \
                               use robot.node-ids)",
                });
            }
            return Ok(());
        }
        if !r.node_ids.is_empty() {
            return Err(ConfigError::Range {
                key: "robot.node-ids",
                value: format!("{:?}", r.node_ids),
                expected: "[] with a bought drive family (give the drives' ids in robot.axes)",
            });
        }
        if !r.axes.is_empty() && r.axes.len() != 2 * r.joints {
            return Err(ConfigError::Range {
                key: "robot.axes",
                value: format!("{} entries", r.axes.len()),
                expected: "2 × robot.joints entries (pitch then yaw of each joint, head \
                           first), or none for the default ids",
            });
        }
        if !r.eds.is_empty() {
            if family != anguilla_protocol::Family::Cia402 {
                return Err(ConfigError::Range {
                    key: "robot.eds",
                    value: format!("{:?}", r.eds),
                    expected: "\"\" unless drive = \"cia402\" (an EDS describes a CANopen device)",
                });
            }
            use anguilla_protocol::canopen::eds;
            let text = std::fs::read_to_string(&r.eds).map_err(|source| ConfigError::Read {
                path: r.eds.clone(),
                source,
            })?;
            eds::Eds::parse(&text)
                .and_then(|e| eds::check_cia402(&e, self.bus.bitrate))
                .map_err(|e| ConfigError::Derived(format!("robot.eds = {:?}: {e}", r.eds)))?;
        }
        let (lo, hi) = family.id_range();
        let mut seen = [false; 256];
        if family == anguilla_protocol::Family::Cia402 {
            if !(1..=127).contains(&r.master_node_id) {
                return Err(ConfigError::Range {
                    key: "robot.master-node-id",
                    value: r.master_node_id.to_string(),
                    expected: "1 ..= 127",
                });
            }
            seen[r.master_node_id as usize] = true;
        }
        for (j, axes) in self.axes().iter().enumerate() {
            for a in axes {
                if a.node < lo || a.node > hi || seen[a.node as usize] {
                    return Err(ConfigError::Derived(format!(
                        "robot.axes: joint {} has drive id {}; {} drives take distinct ids in \
                         {lo}..={hi}{} (by default pitch 2j+1, yaw 2j+2 for joint j from 0: \
                         at most {} joints)",
                        j + 1,
                        a.node,
                        family,
                        if family == anguilla_protocol::Family::Cia402 {
                            ", other than robot.master-node-id"
                        } else {
                            ""
                        },
                        (hi as usize) / 2
                    )));
                }
                seen[a.node as usize] = true;
                if a.direction != 1.0 && a.direction != -1.0 {
                    return Err(ConfigError::Range {
                        key: "robot.axis.direction",
                        value: fmt_number(a.direction),
                        expected: "1 or -1",
                    });
                }
                range("robot.axis.offset", a.offset, -3.2, 3.2, "-3.2 ..= 3.2 rad")?;
                range("robot.axis.gear", a.gear, 1e-3, 1e4, "0.001 ..= 10000")?;
                range(
                    "robot.axis.counts-per-turn",
                    a.counts_per_turn as f64,
                    4.0,
                    (1u64 << 24) as f64,
                    "4 ..= 16777216",
                )?;
                if a.rated_torque != 0.0 {
                    range(
                        "robot.axis.rated-torque",
                        a.rated_torque,
                        1e-3,
                        1e4,
                        "0 (read from the drive) or 0.001 ..= 10000 N·m",
                    )?;
                }
            }
        }
        Ok(())
    }
}

fn fmt_f(v: f64) -> String {
    // TOML floats need a decimal point or exponent.
    let s = format!("{v}");
    if s.contains(['.', 'e', 'E']) || s.contains("inf") || s.contains("nan") {
        s
    } else {
        format!("{s}.0")
    }
}

/// The whole default configuration as a commented TOML file.
pub fn default_toml() -> String {
    let d = Config::default();
    let mut o = String::new();
    let mut w = |s: String| {
        let _ = writeln!(o, "{s}");
    };
    w("# anguilla daemon configuration. Every key is optional; these are the defaults.".into());
    w("# Keys are kebab-case; an unknown key or an out-of-range value is an error.".into());
    w(String::new());
    w("[robot]".into());
    w("# Actuated joints, head to tail (each: a pitch and a yaw axis on one node). 1..=32".into());
    w(format!("joints = {}", d.robot.joints));
    w("# The drives' protocol: \"anguilla\" (vertebra nodes, one per joint), \"cia402\"".into());
    w("# (CANopen CiA 402 drives) or \"odrive\" (ODrive CANSimple), one drive per axis.".into());
    w("drive = \"anguilla\"".into());
    w(
        "# anguilla: node id of each joint, head to tail; [] means 1..=joints. Distinct, 1..=63"
            .into(),
    );
    w("node-ids = []".into());
    w("# cia402: the master's node id (its heartbeat is 0x700 + id). 1..=127".into());
    w(format!("master-node-id = {}", d.robot.master_node_id));
    w("# cia402: the drives' EDS file, checked at start-up for every object the master".into());
    w("# uses and the bit rate; \"\": CiA 402's standard objects are taken as given.".into());
    w("eds = \"\"".into());
    w("# cia402/odrive: the drives, pitch then yaw of each joint from the head, e.g.".into());
    w("# [{ node = 1, direction = -1, gear = 50.0 }, { node = 2 }, ...] (2 × joints),".into());
    w("# keys left out from [robot.axis]; [] puts pitch on 2j+1, yaw on 2j+2 (j from 0).".into());
    w("axes = []".into());
    w(String::new());
    w("[robot.axis]".into());
    w("# Every bought drive's defaults: direction (1 or -1), offset (rad: joint angle at".into());
    w("# motor zero), gear (motor turns per joint turn); cia402: increments per motor".into());
    w("# turn and rated torque (N·m; 0 reads 0x6076 from the drive).".into());
    w(format!("direction = {}", d.robot.axis.direction));
    w(format!("offset = {}", fmt_f(d.robot.axis.offset)));
    w(format!("gear = {}", fmt_f(d.robot.axis.gear)));
    w(format!(
        "counts-per-turn = {}",
        d.robot.axis.counts_per_turn
    ));
    w(format!(
        "rated-torque = {}",
        fmt_f(d.robot.axis.rated_torque)
    ));
    w(String::new());
    w("[control]".into());
    w("# Control rate (Hz). 0: the highest rate the bus carries within bus.max-load.".into());
    w("# Else 20..=5000, and its bus load at most bus.max-load (checked).".into());
    w(format!("rate-hz = {}", fmt_f(d.control.rate_hz)));
    w("# The controlling operator must send a command at least this often (s),".into());
    w("# or the swim stops smoothly. 0.02..=10".into());
    w(format!(
        "command-timeout = {}",
        fmt_f(d.control.command_timeout)
    ));
    w("# Silence after which the operator's control is released (s).".into());
    w(format!(
        "control-release-timeout = {}",
        fmt_f(d.control.control_release_timeout)
    ));
    w("# Time allowed for every node to report enabled (s).".into());
    w(format!(
        "enable-timeout = {}",
        fmt_f(d.control.enable_timeout)
    ));
    w("# A node whose heartbeat is older than this is lost (s).".into());
    w(format!(
        "heartbeat-timeout = {}",
        fmt_f(d.control.heartbeat_timeout)
    ));
    w("# A node that answers none of this many SYNCs (control periods) is faulted,".into());
    w("# \"no feedback\", whatever its heartbeats say. ODrive axes answer every".into());
    w("# encoder_msg_rate_ms (10 ms by default): keep this above that in periods.".into());
    w(format!("feedback-timeout = {}", d.control.feedback_timeout));
    w("# The nodes' watchdog, written to them before every enable (s): a node that".into());
    w("# applies no setpoint for this long takes its safe action. 0: five periods,".into());
    w("# at least 100 ms.".into());
    w(format!(
        "node-watchdog = {}",
        fmt_f(d.control.node_watchdog)
    ));
    w("# On an actuator fault or a lost node: \"hold\" (stop swimming, healthy joints".into());
    w("# hold straight) or \"disable\" (every actuator off at once).".into());
    w("fault-policy = \"hold\"".into());
    w(String::new());
    w("[gait]".into());
    w("# Body wave length (m); amplitude polynomial a0 + a1·X + a2·X² (1/m) at full".into());
    w("# amplitude: the paper's F1 gait.".into());
    w(format!("wavelength = {}", fmt_f(d.gait.wavelength)));
    let [a0, a1, a2] = d.gait.amplitude_polynomial;
    w(format!(
        "amplitude-polynomial = [{}, {}, {}]",
        fmt_f(a0),
        fmt_f(a1),
        fmt_f(a2)
    ));
    w("# Largest frequency (Hz), turn and pitch curvatures (1/m) an operator may ask for.".into());
    w(format!("max-frequency = {}", fmt_f(d.gait.max_frequency)));
    w(format!("max-turn = {}", fmt_f(d.gait.max_turn)));
    w(format!("max-pitch = {}", fmt_f(d.gait.max_pitch)));
    w(
        "# Trapezoidal shaping of parameter changes: rate (per s) and acceleration (per s²)."
            .into(),
    );
    w(format!("amplitude-rate = {}", fmt_f(d.gait.amplitude_rate)));
    w(format!(
        "amplitude-accel = {}",
        fmt_f(d.gait.amplitude_accel)
    ));
    w(format!("frequency-rate = {}", fmt_f(d.gait.frequency_rate)));
    w(format!(
        "frequency-accel = {}",
        fmt_f(d.gait.frequency_accel)
    ));
    w(format!("curvature-rate = {}", fmt_f(d.gait.curvature_rate)));
    w(format!(
        "curvature-accel = {}",
        fmt_f(d.gait.curvature_accel)
    ));
    w(String::new());
    w("[limits]".into());
    w("# Per-axis limits applied to every setpoint (clamped and counted).".into());
    w("# Angle (rad) 0.01..=1.5, velocity (rad/s) 0.01..=10, torque (N·m) 0..=5.".into());
    w(format!("angle = {}", fmt_f(d.limits.angle)));
    w(format!("velocity = {}", fmt_f(d.limits.velocity)));
    w(format!("torque = {}", fmt_f(d.limits.torque)));
    w(String::new());
    w("[bus]".into());
    w("# \"socketcan:can0\", \"slcan:/dev/ttyACM0@1000000\", \"mem:NAME\"; empty runs the".into());
    w("# built-in simulated robot. Real hardware is driven only when this is set.".into());
    w("spec = \"\"".into());
    w("# CAN FD frames; nominal and data-phase bit rates (bit/s).".into());
    w(format!("fd = {}", d.bus.fd));
    w(format!("bitrate = {}", d.bus.bitrate));
    w(format!("data-bitrate = {}", d.bus.data_bitrate));
    w("# Highest bus load the automatic control rate may cause. 0.05..=0.95".into());
    w(format!("max-load = {}", fmt_f(d.bus.max_load)));
    w(String::new());
    w("[realtime]".into());
    w("# SCHED_FIFO priority of the loop thread (0: normal scheduler), its CPU (-1: any),".into());
    w("# and mlockall. When the system refuses, the daemon warns and runs anyway.".into());
    w("# Above 1, the iceoryx2 threads and the built-in simulated robot run one lower.".into());
    w(format!("fifo-priority = {}", d.realtime.fifo_priority));
    w(format!("cpu = {}", d.realtime.cpu));
    w(format!("lock-memory = {}", d.realtime.lock_memory));
    w(String::new());
    w("[ipc]".into());
    w("# Prefix of the iceoryx2 services (<prefix>/state, /state-ready, /command,".into());
    w("# /command-ready).".into());
    w(format!("prefix = {:?}", d.ipc.prefix));
    w(String::new());
    w("[recording]".into());
    w("# Directory for the session recording (candump log + state records); empty: none.".into());
    w(format!("dir = {:?}", d.recording.dir));
    w(String::new());
    w("[model]".into());
    w("# Space nodes of the feedforward model along the body. 5..=2000".into());
    w(format!("nodes = {}", d.model.nodes));
    w("# The body's ballast: its centre of mass this far below each section's axis (m),".into());
    w("# which rights it in roll and pitch (the built-in simulated robot is built the".into());
    w("# same). 0: the paper's body, which rolls freely under pitch curvature. 0..=0.05".into());
    w(format!("ballast = {}", fmt_f(d.model.ballast)));
    w(String::new());
    w("[sensor]".into());
    w("# The head sensor's node id (IMU + pressure, protocol/README.md): 1..=63, none of".into());
    w("# the joints'; anguilla drives only. 0: no sensor (heading/depth hold refused).".into());
    w(format!("node = {}", d.sensor.node));
    w("# Its sample rate (Hz, 100..=200, for the bus budget); silent this long, it is".into());
    w("# lost (s).".into());
    w(format!("rate-hz = {}", d.sensor.rate_hz));
    w(format!("timeout = {}", fmt_f(d.sensor.timeout)));
    w("# Depth = (pressure - surface-pressure) / (water-density · 9.81): kg/m³, Pa.".into());
    w(format!("water-density = {}", fmt_f(d.sensor.water_density)));
    w(format!(
        "surface-pressure = {}",
        fmt_f(d.sensor.surface_pressure)
    ));
    w("# The gyro's rates may differ from the model's prediction by this much".into());
    w("# (rad/s, low-passed) before the estimate is implausible and a hold lets go.".into());
    w(format!(
        "max-rate-innovation = {}",
        fmt_f(d.sensor.max_rate_innovation)
    ));
    w("# |roll| beyond which the operator is alarmed (deg).".into());
    w(format!("roll-alarm = {}", fmt_f(d.sensor.roll_alarm)));
    w(String::new());
    w("[autopilot]".into());
    w("# Heading hold: turn rate = heading-gain · error (+ integral), at most".into());
    w("# max-turn-rate; the model turns it into a turn curvature (docs/autopilot.md).".into());
    w(format!(
        "heading-gain = {}",
        fmt_f(d.autopilot.heading_gain)
    ));
    w(format!(
        "heading-integral = {}",
        fmt_f(d.autopilot.heading_integral)
    ));
    w(format!(
        "max-turn-rate = {}",
        fmt_f(d.autopilot.max_turn_rate)
    ));
    w("# Depth hold: dive rate = depth-gain · error (+ integral), flown at a pitch of at".into());
    w("# most max-dive-angle (deg); the model's curvature for that pitch, plus pitch-gain".into());
    w("# times the pitch error (ballasted body; unballasted: pitch rate per error, 1/s);".into());
    w("# holds to max-depth (m).".into());
    w(format!("depth-gain = {}", fmt_f(d.autopilot.depth_gain)));
    w(format!(
        "depth-integral = {}",
        fmt_f(d.autopilot.depth_integral)
    ));
    w(format!(
        "max-dive-angle = {}",
        fmt_f(d.autopilot.max_dive_angle)
    ));
    w(format!("pitch-gain = {}", fmt_f(d.autopilot.pitch_gain)));
    w(format!("max-depth = {}", fmt_f(d.autopilot.max_depth)));
    w(String::new());
    w("[foxglove]".into());
    w("# `anguilla foxglove` (its own process; the daemon ignores this section): accept".into());
    w("# operator commands Foxglove clients publish on /anguilla/command, each client".into());
    w("# its own operator under the daemon's authority and deadman rules. The".into());
    w("# WebSocket has no authentication: whoever reaches the port may then drive (any".into());
    w("# local user, on loopback), so commands also need insecure-commands = true.".into());
    w(format!("commands = {}", d.foxglove.commands));
    w(format!(
        "insecure-commands = {}",
        d.foxglove.insecure_commands
    ));
    w("# Most viewers connected at once; one more is refused (HTTP 503) and logged.".into());
    w(format!("max-clients = {}", d.foxglove.max_clients));
    w("# A viewer that subscribes to no channel this long after connecting is closed".into());
    w("# (s); 0: never.".into());
    w(format!(
        "subscribe-timeout = {}",
        fmt_f(d.foxglove.subscribe_timeout)
    ));
    w(String::new());
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
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_builtin_robot_gets_a_sensor_on_the_first_free_id() {
        let mut c = Config::default();
        assert_eq!(c.fit_builtin_sensor(), Some(13));
        assert_eq!(c.sensor.node, 13);
        c.validate().unwrap();
        // Set: kept. Joints on 1..=12 but not 3: the sensor takes 3.
        assert_eq!(c.fit_builtin_sensor(), None);
        let mut c = Config::default();
        c.robot.node_ids = vec![1, 2, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13];
        assert_eq!(c.fit_builtin_sensor(), Some(3));
        // A bought family: no anguilla head sensor.
        let mut c = Config::default();
        c.robot.drive = anguilla_protocol::Family::Cia402;
        assert_eq!(c.fit_builtin_sensor(), None);
        assert_eq!(c.sensor.node, 0);
    }

    #[test]
    fn the_builtin_robot_relaxes_only_default_timeouts() {
        let mut c = Config::default();
        c.control.command_timeout = 0.4;
        let changed = c.relax_for_builtin();
        assert_eq!(c.control.command_timeout, 0.4, "set in the file: kept");
        assert_eq!(c.control.heartbeat_timeout, BUILTIN_TIMEOUT);
        assert_eq!(c.control.node_watchdog, 1.0);
        let rate = c.control_rate().unwrap();
        assert_eq!(
            c.control.feedback_timeout,
            (BUILTIN_TIMEOUT * rate).ceil() as u32
        );
        assert_eq!(changed.len(), 3, "{changed:?}");
        assert!(!changed.iter().any(|k| k.contains("command-timeout")));
        c.validate().unwrap();
    }

    #[test]
    fn the_printed_default_parses_back_to_the_default() {
        let parsed = Config::from_toml(&default_toml(), "default").unwrap();
        assert_eq!(parsed, Config::default());
        Config::default().validate().unwrap();
    }

    #[test]
    fn docs_configuration_shows_the_default() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/configuration.md");
        let block = format!("```toml\n{}```\n", default_toml());
        anguilla_testkit::generated_block(std::path::Path::new(path), "config", &block);
    }

    #[test]
    fn a_written_configuration_reads_back() {
        let mut c = Config::default();
        c.robot.joints = 3;
        c.robot.node_ids = vec![4, 5, 6];
        c.bus.fd = true;
        c.control.rate_hz = 250.0;
        let back = Config::from_toml(&c.to_toml(), "written").unwrap();
        assert_eq!(back, c);
    }

    #[test]
    fn empty_file_is_the_default() {
        assert_eq!(Config::from_toml("", "t").unwrap(), Config::default());
    }

    #[test]
    fn unknown_keys_and_wrong_types_name_the_key() {
        let e = Config::from_toml("[control]\nrate = 100\n", "t").unwrap_err();
        assert!(e.to_string().contains("unknown field `rate`"), "{e}");
        let e = Config::from_toml("[robot]\njoints = \"twelve\"\n", "t").unwrap_err();
        assert!(e.to_string().contains("joints"), "{e}");
        let e = Config::from_toml("[nonsense]\n", "t").unwrap_err();
        assert!(e.to_string().contains("nonsense"), "{e}");
    }

    #[test]
    fn out_of_range_values_name_the_key_and_the_range() {
        let e = Config::from_toml("[control]\ncommand-timeout = -1.0\n", "t").unwrap_err();
        assert_eq!(
            e.to_string(),
            "configuration key 'control.command-timeout' = -1 is out of range (expected 0.02 ..= 10 s)"
        );
        let e = Config::from_toml("[robot]\njoints = 3\nnode-ids = [1, 2, 2]\n", "t").unwrap_err();
        assert!(e.to_string().contains("distinct ids"), "{e}");
        let e = Config::from_toml("[robot]\njoints = 3\nnode-ids = [1, 2]\n", "t").unwrap_err();
        assert!(e.to_string().contains("one id per joint"), "{e}");
        let e = Config::from_toml("[bus]\nmax-load = 1.5\n", "t").unwrap_err();
        assert!(e.to_string().contains("bus.max-load"), "{e}");
        let e = Config::from_toml("[ipc]\nprefix = \"a b\"\n", "t").unwrap_err();
        assert!(e.to_string().contains("ipc.prefix"), "{e}");
        for (toml, key) in [
            ("max-clients = 0", "'foxglove.max-clients' = 0"),
            (
                "subscribe-timeout = 0.5",
                "'foxglove.subscribe-timeout' = 0.5",
            ),
            (
                "subscribe-timeout = -1",
                "'foxglove.subscribe-timeout' = -1",
            ),
        ] {
            let e = Config::from_toml(&format!("[foxglove]\n{toml}\n"), "t").unwrap_err();
            assert!(e.to_string().contains(key), "{e}");
        }
        let never = Config::from_toml("[foxglove]\nsubscribe-timeout = 0\n", "t").unwrap();
        assert_eq!(never.foxglove.subscribe_timeout, 0.0);
    }

    #[test]
    fn check_and_run_agree_on_the_derived_rate_and_load() {
        // Each was accepted by `config check`, then refused by `run`, or
        // ran a bus past saturation.
        let err = |t: &str| Config::from_toml(t, "t").unwrap_err().to_string();
        let e = err("[control]\nrate-hz = 15\n");
        assert!(
            e.contains("'control.rate-hz' = 15") && e.contains("20 ..= 5000"),
            "{e}"
        );
        let e = err("[robot]\njoints = 32\n[control]\nrate-hz = 1000\n");
        assert!(
            e.contains("control.rate-hz = 1000 puts 875 % load on the bus")
                && e.contains("bus.max-load = 0.6")
                && e.contains("at most 64.6 Hz"),
            "{e}"
        );
        let e = err("[robot]\njoints = 32\n[bus]\nmax-load = 0.05\n");
        assert!(
            e.contains("finds no rate") && e.contains("at least 20 Hz"),
            "{e}"
        );
        // Every accepted configuration has a rate the model takes.
        for t in [
            "",
            "[robot]\njoints = 32\n",
            "[bus]\nfd = true\n",
            "[control]\nrate-hz = 20\n",
        ] {
            let c = Config::from_toml(t, "t").unwrap();
            let rate = c.control_rate().unwrap();
            assert!(1.0 / rate <= anguilla_model::MAX_DT, "{t}: {rate} Hz");
        }
    }

    #[test]
    fn the_amplitude_polynomial_takes_exactly_three_numbers() {
        for (t, want) in [
            (
                "[1, 2, 3, 4]",
                "expected exactly three numbers [a0, a1, a2], got 4",
            ),
            (
                "[1, 2]",
                "expected exactly three numbers [a0, a1, a2], got 2",
            ),
            ("[1, 2, 3, \"junk\"]", "invalid type: string \"junk\""),
        ] {
            let e = Config::from_toml(&format!("[gait]\namplitude-polynomial = {t}\n"), "t")
                .unwrap_err()
                .to_string();
            assert!(e.contains(want), "{t}: {e}");
        }
        let c = Config::from_toml("[gait]\namplitude-polynomial = [1, 0, 2]\n", "t").unwrap();
        assert_eq!(c.gait.amplitude_polynomial, [1.0, 0.0, 2.0]);
    }

    #[test]
    fn huge_numbers_print_short() {
        assert_eq!(fmt_number(1e300), "1e300");
        assert_eq!(fmt_number(1e-300), "1e-300");
        assert_eq!(fmt_number(176.8), "176.8");
        let e = Config::from_toml("[gait]\nwavelength = 1e300\n", "t").unwrap_err();
        assert!(e.to_string().contains("= 1e300 is out of range"), "{e}");
    }

    #[test]
    fn an_unknown_drive_family_is_named_with_the_accepted_ones() {
        let e = Config::from_toml("[robot]\ndrive = \"canopen\"\n", "test")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(
                "unknown drive family \"canopen\" (expected \"anguilla\", \"cia402\" or \"odrive\")"
            ) && e.contains("drive"),
            "{e}"
        );
        let c = Config::from_toml("[robot]\ndrive = \"odrive\"\njoints = 4\n", "test").unwrap();
        assert_eq!(c.robot.drive, anguilla_protocol::Family::Odrive);
        assert!(c.to_toml().contains("drive = \"odrive\""));
    }

    #[test]
    fn a_cia402_eds_is_checked_for_what_the_master_needs() {
        let sim = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../sim-backend/eds/anguilla-sim-cia402.eds"
        );
        let text = |eds: &str, drive: &str| {
            format!("[robot]\njoints = 2\ndrive = \"{drive}\"\neds = {eds:?}\n")
        };
        Config::from_toml(&text(sim, "cia402"), "test").unwrap();
        // The simulated drive lists 125..=1000 kbit/s, not 100.
        let e = Config::from_toml(
            &(text(sim, "cia402")
                + "[bus]\nbitrate = 100000\nmax-load = 0.95\n[control]\nrate-hz = 20.0\n"),
            "test",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("bit rate 100 kbit/s"), "{e}");
        // A drive without a mappable torque offset.
        let path = std::env::temp_dir().join(format!("anguilla-eds-{}.eds", std::process::id()));
        let bad = std::fs::read_to_string(sim).unwrap().replace(
            "[60B2]\nParameterName=Torque offset\nObjectType=0x7\nDataType=0x0003\nAccessType=rw\nDefaultValue=0\nPDOMapping=1",
            "[60B2]\nParameterName=Torque offset\nObjectType=0x7\nDataType=0x0003\nAccessType=rw\nDefaultValue=0\nPDOMapping=0",
        );
        std::fs::write(&path, bad).unwrap();
        let e = Config::from_toml(&text(path.to_str().unwrap(), "cia402"), "test")
            .unwrap_err()
            .to_string();
        let _ = std::fs::remove_file(&path);
        assert!(
            e.contains("0x60B2:00 torque offset (not PDO-mappable"),
            "{e}"
        );
        let e = Config::from_toml(&text("/nonexistent.eds", "cia402"), "test")
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent.eds"), "{e}");
        let e = Config::from_toml(&text(sim, "odrive"), "test")
            .unwrap_err()
            .to_string();
        assert!(e.contains("robot.eds"), "{e}");
    }

    #[test]
    fn node_ids_default_to_one_through_joints() {
        let c = Config::from_toml("[robot]\njoints = 4\n", "t").unwrap();
        assert_eq!(c.node_ids(), vec![1, 2, 3, 4]);
        let c = Config::from_toml("[robot]\njoints = 2\nnode-ids = [9, 4]\n", "t").unwrap();
        assert_eq!(c.node_ids(), vec![9, 4]);
    }

    #[test]
    fn a_missing_file_names_the_path() {
        let e = Config::load(Path::new("/nonexistent/anguilla.toml")).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/anguilla.toml"), "{e}");
    }
}
