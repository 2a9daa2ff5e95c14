//! Bus spec strings: which bus to open, chosen at run time.

use std::time::Duration;

use crate::error::SpecError;
use crate::{Bus, Result};

/// A parsed bus spec.
///
/// | form | bus |
/// |---|---|
/// | `socketcan:can0`, `socketcan:vcan0?fd=1` | [`crate::socketcan::SocketCanBus`] |
/// | `slcan:/dev/ttyACM0@1000000?baud=115200&timestamps=1` | [`crate::slcan::SlcanBus`]; `@` gives the CAN bit rate (one of 10k, 20k, 50k, 100k, 125k, 250k, 500k, 800k, 1M) |
/// | `mem:NAME?bitrate=1000000&echo=1&capacity=1024` | [`crate::mem::MemBus`] participant |
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BusSpec {
    /// Linux SocketCAN.
    SocketCan(crate::socketcan::SocketCanConfig),
    /// An SLCAN serial adapter.
    Slcan(crate::slcan::SlcanConfig),
    /// The in-process bus.
    Mem(crate::mem::MemConfig),
}

fn err(spec: &str, reason: impl Into<String>) -> SpecError {
    SpecError {
        // shown as `\u{1b}`, never sent raw to the operator's terminal
        spec: spec
            .chars()
            .flat_map(|c| {
                let e: Vec<char> = if junk(c) {
                    c.escape_unicode().collect()
                } else {
                    vec![c]
                };
                e
            })
            .collect(),
        reason: reason.into(),
    }
}

/// A character no device path or interface name has: a control character
/// (C0, DEL, C1: a newline, an escape sequence, a NUL) or an invisible
/// format character (bidirectional overrides, zero-width ones, a BOM) that
/// makes a name read as another.
fn junk(c: char) -> bool {
    c.is_control()
        || matches!(c, '\u{200B}'..='\u{200F}' | '\u{202A}'..='\u{202E}' | '\u{2060}'..='\u{206F}' | '\u{FEFF}')
}

/// Refuses `name` (the `what` of `spec`) with a junk character
/// ([`junk`]) or a space at either end, naming the character's code and
/// byte position in `name`.
fn printable(spec: &str, what: &str, name: &str) -> Result<(), SpecError> {
    if let Some((i, c)) = name.char_indices().find(|&(_, c)| junk(c)) {
        return Err(err(
            spec,
            format!(
                "{what} has {} U+{:04X} at byte {i} (expected printable characters only)",
                if c.is_control() {
                    "the control character"
                } else {
                    "the invisible character"
                },
                c as u32
            ),
        ));
    }
    if name.starts_with(char::is_whitespace) || name.ends_with(char::is_whitespace) {
        return Err(err(
            spec,
            format!("{what} '{name}' starts or ends with a space (expected none)"),
        ));
    }
    Ok(())
}

fn parse_bool(spec: &str, key: &str, v: &str) -> Result<bool, SpecError> {
    match v {
        "1" | "true" | "yes" | "on" => Ok(true),
        "0" | "false" | "no" | "off" => Ok(false),
        _ => Err(err(spec, format!("option {key}={v}: expected 0 or 1"))),
    }
}

fn parse_u32(spec: &str, key: &str, v: &str, range: (u32, u32)) -> Result<u32, SpecError> {
    match v.parse::<u32>() {
        Ok(n) if n >= range.0 && n <= range.1 => Ok(n),
        _ => Err(err(
            spec,
            format!(
                "option {key}={v}: expected an integer in {}..={}",
                range.0, range.1
            ),
        )),
    }
}

/// `KEY=VALUE` options of a spec.
type Options<'a> = Vec<(&'a str, &'a str)>;

/// Splits `body?k=v&k=v` into the body and its options.
fn split_options<'a>(spec: &str, body: &'a str) -> Result<(&'a str, Options<'a>), SpecError> {
    let Some((head, query)) = body.split_once('?') else {
        return Ok((body, Vec::new()));
    };
    let mut opts = Vec::new();
    for kv in query.split('&').filter(|s| !s.is_empty()) {
        let (k, v) = kv
            .split_once('=')
            .ok_or_else(|| err(spec, format!("option '{kv}' is not KEY=VALUE")))?;
        opts.push((k, v));
    }
    Ok((head, opts))
}

fn unknown(spec: &str, key: &str, known: &str) -> SpecError {
    err(spec, format!("unknown option '{key}' (known: {known})"))
}

impl BusSpec {
    /// Parses a spec; the error names the spec and lists the accepted forms.
    pub fn parse(spec: &str) -> Result<Self, SpecError> {
        let (scheme, body) = spec
            .split_once(':')
            .ok_or_else(|| err(spec, "missing 'KIND:' prefix"))?;
        match scheme {
            "socketcan" | "can" => {
                let (iface, opts) = split_options(spec, body)?;
                printable(spec, "interface name", iface)?;
                if iface.is_empty() || iface.len() > 15 || iface.contains('/') {
                    return Err(err(
                        spec,
                        "interface name must be 1 to 15 characters, without '/'",
                    ));
                }
                let mut c = crate::socketcan::SocketCanConfig::new(iface);
                c.spec = spec.to_owned();
                for (k, v) in opts {
                    match k {
                        "fd" => c.fd = parse_bool(spec, k, v)?,
                        "timestamps" => c.timestamps = parse_bool(spec, k, v)?,
                        _ => return Err(unknown(spec, k, "fd, timestamps")),
                    }
                }
                Ok(BusSpec::SocketCan(c))
            }
            "slcan" => {
                let (body, opts) = split_options(spec, body)?;
                let (path, rate) = body
                    .rsplit_once('@')
                    .ok_or_else(|| err(spec, "missing '@BITRATE' after the device path"))?;
                if path.is_empty() {
                    return Err(err(spec, "empty device path"));
                }
                printable(spec, "device path", path)?;
                let bitrate = rate
                    .parse::<u32>()
                    .ok()
                    .and_then(crate::slcan::codec::Bitrate::from_bps)
                    .ok_or_else(|| {
                        err(
                            spec,
                            format!(
                                "CAN bit rate '{rate}' is not one SLCAN can set (expected one of {})",
                                crate::slcan::codec::Bitrate::ACCEPTED
                            ),
                        )
                    })?;
                let mut c = crate::slcan::SlcanConfig::new(path, bitrate);
                c.spec = spec.to_owned();
                for (k, v) in opts {
                    match k {
                        "baud" => c.baud = parse_u32(spec, k, v, (300, 12_000_000))?,
                        "timestamps" => c.timestamps = parse_bool(spec, k, v)?,
                        "listen" => c.listen_only = parse_bool(spec, k, v)?,
                        "recover" => c.auto_recover = parse_bool(spec, k, v)?,
                        "fd" => c.fd = parse_bool(spec, k, v)?,
                        "status_ms" => {
                            let ms = parse_u32(spec, k, v, (0, 60_000))?;
                            c.status_interval =
                                (ms > 0).then(|| Duration::from_millis(u64::from(ms)));
                        }
                        _ => {
                            return Err(unknown(
                                spec,
                                k,
                                "baud, timestamps, listen, fd, recover, status_ms",
                            ));
                        }
                    }
                }
                Ok(BusSpec::Slcan(c))
            }
            "mem" => {
                let (name, opts) = split_options(spec, body)?;
                if name.is_empty() {
                    return Err(err(spec, "empty bus name"));
                }
                let mut c = crate::mem::MemConfig::new(name);
                for (k, v) in opts {
                    match k {
                        "bitrate" => c.bitrate = Some(parse_u32(spec, k, v, (1_000, 8_000_000))?),
                        "echo" => c.echo = parse_bool(spec, k, v)?,
                        "capacity" => c.capacity = parse_u32(spec, k, v, (1, 1 << 20))? as usize,
                        _ => return Err(unknown(spec, k, "bitrate, echo, capacity")),
                    }
                }
                Ok(BusSpec::Mem(c))
            }
            other => Err(err(spec, format!("unknown bus kind '{other}'"))),
        }
    }

    /// Opens the bus.
    pub fn open(&self) -> crate::OpenResult<Box<dyn Bus>> {
        Ok(match self {
            BusSpec::SocketCan(c) => Box::new(crate::socketcan::SocketCanBus::open(c)?),
            BusSpec::Slcan(c) => Box::new(crate::slcan::SlcanBus::open(c)?),
            BusSpec::Mem(c) => Box::new(crate::mem::MemBus::open_or_create(c).participant()),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slcan::codec::Bitrate;

    #[test]
    fn parses_each_form() {
        let BusSpec::SocketCan(c) = BusSpec::parse("socketcan:vcan0?fd=1").unwrap() else {
            panic!()
        };
        assert_eq!(c.interface, "vcan0");
        assert!(c.fd);
        let BusSpec::Slcan(c) =
            BusSpec::parse("slcan:/dev/ttyACM0@500000?baud=115200&timestamps=1").unwrap()
        else {
            panic!()
        };
        assert_eq!(c.path, "/dev/ttyACM0");
        assert_eq!(c.bitrate, Bitrate::B500k);
        assert_eq!(c.baud, 115_200);
        assert!(c.timestamps);
        let BusSpec::Mem(c) = BusSpec::parse("mem:robot?bitrate=1000000&echo=1").unwrap() else {
            panic!()
        };
        assert_eq!(c.name, "robot");
        assert_eq!(c.bitrate, Some(1_000_000));
        assert!(c.echo);
    }

    #[test]
    fn errors_name_the_spec_and_the_accepted_forms() {
        for (spec, needle) in [
            ("pcan:usb0", "unknown bus kind 'pcan'"),
            ("vcan0", "missing 'KIND:'"),
            ("slcan:/dev/ttyACM0", "missing '@BITRATE'"),
            ("slcan:/dev/ttyACM0@123", "bit rate '123'"),
            ("mem:", "empty bus name"),
            ("mem:x?speed=3", "unknown option 'speed'"),
            ("socketcan:vcan0?fd=maybe", "fd=maybe"),
            ("socketcan:", "interface name"),
            (
                "slcan:/dev/tty\nACM0@1000000",
                "device path has the control character U+000A at byte 8",
            ),
            (
                "slcan:/dev/ttyACM0\u{1b}[2J@1000000",
                "device path has the control character U+001B at byte 12",
            ),
            (
                "slcan:/dev/tty\u{0}@1000000",
                "device path has the control character U+0000 at byte 8",
            ),
            (
                "slcan:/dev/tty\u{7f}@1000000",
                "device path has the control character U+007F at byte 8",
            ),
            (
                "slcan:/dev/ttyUSB\u{202e}0@1000000",
                "device path has the invisible character U+202E at byte 11",
            ),
            (
                "slcan: /dev/ttyACM0@1000000",
                "device path ' /dev/ttyACM0' starts or ends with a space",
            ),
            (
                "socketcan:can\t0",
                "interface name has the control character U+0009 at byte 3",
            ),
        ] {
            let e = BusSpec::parse(spec).unwrap_err().to_string();
            // the spec shown, its junk escaped: nothing raw reaches a terminal
            let shown: String = spec
                .chars()
                .map(|c| {
                    if junk(c) {
                        c.escape_unicode().to_string()
                    } else {
                        c.to_string()
                    }
                })
                .collect();
            assert!(e.contains(&shown), "{e}");
            assert!(!e.chars().any(junk), "{e:?}");
            assert!(e.contains(needle), "{e}");
            assert!(e.contains("slcan:PATH@BITRATE"), "{e}");
        }
    }
}
