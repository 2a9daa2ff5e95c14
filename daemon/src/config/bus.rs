//! `[bus]`: which bus, and its physical layer.

use serde::{Deserialize, Serialize};

use super::error::{ConfigError, fmt_f, range};

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

/// `[bus] spec` for the built-in simulated robot, said outright (`--bus
/// builtin`); the same as an empty spec.
pub const BUS_BUILTIN: &str = "builtin";

/// `[bus] spec` of a file whose bus the operator has not named yet (the
/// Debian package's `/etc/anguilla/anguilla.toml`): the daemon refuses to
/// start on it, saying how to set it; the tools read the file as usual.
pub const BUS_UNSET: &str = "unset";

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

impl BusConfig {
    /// Checks `[bus]` (its load: [`Config::control_rate`](super::Config::control_rate)).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let b = self;
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
        Ok(())
    }
}

/// `[bus]` in the commented default file ([`super::sections_toml`]).
pub(super) fn write_default(d: &BusConfig, w: &mut dyn FnMut(String)) {
    w("[bus]".into());
    if d.spec == BUS_UNSET {
        w("# The robot's bus: SET IT. The daemon refuses to start while it is \"unset\".".into());
        w("# \"socketcan:can0\" (a CAN card or a USB adapter with a kernel driver), or".into());
        w(
            "# \"slcan:/dev/serial/by-id/<adapter>@1000000\" (an SLCAN adapter); every form in"
                .into(),
        );
        w("# /usr/share/doc/anguilla/drivers-README.md. \"builtin\": the built-in simulated robot.".into());
        w("# `sudo anguilla config set-bus SPEC` writes it here.".into());
    } else {
        w("# \"socketcan:can0\", \"slcan:/dev/ttyACM0@1000000\", \"mem:NAME\"; empty (or".into());
        w("# \"builtin\") runs the built-in simulated robot. Real hardware is driven only".into());
        w("# when this names a bus.".into());
    }
    w(format!("spec = {:?}", d.spec));
    w("# CAN FD frames; nominal and data-phase bit rates (bit/s).".into());
    w(format!("fd = {}", d.fd));
    w(format!("bitrate = {}", d.bitrate));
    w(format!("data-bitrate = {}", d.data_bitrate));
    w("# Highest bus load the automatic control rate may cause. 0.05..=0.95".into());
    w(format!("max-load = {}", fmt_f(d.max_load)));
    w(String::new());
}
