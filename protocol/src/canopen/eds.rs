//! Electronic data sheets (CiA 306 EDS files): what a CANopen device says
//! it has, read far enough to check it offers what anguilla's CiA 402
//! master needs ([`check_cia402`]).
//!
//! An EDS is an INI file: a section per object (`[6040]`) or sub-object
//! (`[1600sub1]`) with `ParameterName`, `ObjectType`, `DataType`,
//! `AccessType`, `DefaultValue` and `PDOMapping` keys, and `[DeviceInfo]`
//! with the supported bit rates (`BaudRate_1000=1`). Section and key names
//! are case-insensitive; `;` starts a comment line. Reading never panics:
//! a malformed line is an error naming its number.

use std::collections::BTreeMap;

/// One object or sub-object of an EDS.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Entry {
    /// `ParameterName`.
    pub name: String,
    /// `AccessType` (lower case: `ro`, `rw`, `wo`, `const`, `rww`, `rwr`).
    pub access: String,
    /// `PDOMapping=1`.
    pub mappable: bool,
    /// `DefaultValue`, as written.
    pub default: String,
}

/// The parts of an EDS anguilla reads.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Eds {
    /// Entries by (index, sub); a plain object (`[6040]`) is sub 0.
    pub entries: BTreeMap<(u16, u8), Entry>,
    /// Bit rates the device supports, kbit/s (`BaudRate_N=1`).
    pub bitrates_kbit: Vec<u32>,
}

/// What was wrong with an EDS.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EdsError {
    /// A line is neither a section, a `key=value`, a comment nor blank.
    #[error("line {line}: {text:?} is not a [section], a key=value line or a ; comment")]
    Syntax {
        /// 1-based line number.
        line: usize,
        /// The line (cut to 80 characters).
        text: String,
    },
    /// The device lacks what the master needs.
    #[error("{0}")]
    Missing(String),
}

fn section_key(name: &str) -> Option<(u16, u8)> {
    let lower = name.to_ascii_lowercase();
    let (index, sub) = match lower.split_once("sub") {
        Some((i, s)) => (i, u8::from_str_radix(s, 16).ok()?),
        None => (lower.as_str(), 0),
    };
    if index.len() != 4 {
        return None;
    }
    Some((u16::from_str_radix(index, 16).ok()?, sub))
}

impl Eds {
    /// Reads EDS text.
    pub fn parse(text: &str) -> Result<Eds, EdsError> {
        let mut eds = Eds::default();
        let mut current: Option<(u16, u8)> = None;
        let mut device_info = false;
        for (n, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if line.is_empty() || line.starts_with(';') {
                continue;
            }
            if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
                device_info = name.eq_ignore_ascii_case("DeviceInfo");
                current = section_key(name);
                if let Some(k) = current {
                    eds.entries.entry(k).or_default();
                }
                continue;
            }
            let Some((key, value)) = line.split_once('=') else {
                return Err(EdsError::Syntax {
                    line: n + 1,
                    text: line.chars().take(80).collect(),
                });
            };
            let (key, value) = (key.trim().to_ascii_lowercase(), value.trim());
            if device_info {
                if let Some(rate) = key.strip_prefix("baudrate_")
                    && value == "1"
                    && let Ok(r) = rate.parse()
                {
                    eds.bitrates_kbit.push(r);
                }
                continue;
            }
            let Some(k) = current else { continue };
            let e = eds.entries.entry(k).or_default();
            match key.as_str() {
                "parametername" => e.name = value.to_string(),
                "accesstype" => e.access = value.to_ascii_lowercase(),
                "pdomapping" => e.mappable = value == "1",
                "defaultvalue" => e.default = value.to_string(),
                _ => {}
            }
        }
        Ok(eds)
    }

    /// The entry `index:sub`, if the device has it.
    pub fn get(&self, index: u16, sub: u8) -> Option<&Entry> {
        self.entries.get(&(index, sub))
    }
}

/// What anguilla's CiA 402 master needs of a drive (`docs/drives.md`):
/// each entry, whether it must be mappable into an RPDO or a TPDO.
pub const CIA402_NEEDS: [(u16, u8, &str, Mapping); 17] = [
    (0x1000, 0, "device type", Mapping::No),
    (0x1006, 0, "communication cycle period", Mapping::No),
    (0x1016, 1, "consumer heartbeat time", Mapping::No),
    (0x1017, 0, "producer heartbeat time", Mapping::No),
    (0x1400, 1, "RPDO1 COB-ID", Mapping::No),
    (0x1600, 1, "RPDO1 mapping", Mapping::No),
    (0x1800, 1, "TPDO1 COB-ID", Mapping::No),
    (0x1A00, 1, "TPDO1 mapping", Mapping::No),
    (0x6040, 0, "controlword", Mapping::Rpdo),
    (0x6041, 0, "statusword", Mapping::Tpdo),
    (0x6060, 0, "modes of operation", Mapping::No),
    (0x6061, 0, "modes of operation display", Mapping::No),
    (0x6064, 0, "position actual value", Mapping::Tpdo),
    (0x6077, 0, "torque actual value", Mapping::Tpdo),
    (0x607A, 0, "target position", Mapping::Rpdo),
    (0x60B2, 0, "torque offset", Mapping::Rpdo),
    (0x60C2, 1, "interpolation time period value", Mapping::No),
];

/// Whether an entry must be mappable, and where.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mapping {
    /// Not mapped.
    No,
    /// Into an RPDO (written by the master).
    Rpdo,
    /// Into a TPDO (read by the master).
    Tpdo,
}

/// Checks that the device of `eds` offers every entry anguilla's CiA 402
/// master uses (mappable where it maps them) and the bus's bit rate; the
/// error lists everything missing.
pub fn check_cia402(eds: &Eds, bitrate: u32) -> Result<(), EdsError> {
    let mut missing = Vec::new();
    for (index, sub, name, mapping) in CIA402_NEEDS {
        match eds.get(index, sub) {
            None => missing.push(format!("0x{index:04X}:{sub:02X} {name} (absent)")),
            Some(e) if mapping != Mapping::No && !e.mappable => missing.push(format!(
                "0x{index:04X}:{sub:02X} {name} (not PDO-mappable; anguilla maps it into {})",
                if mapping == Mapping::Rpdo {
                    "RPDO1"
                } else {
                    "TPDO1"
                }
            )),
            Some(_) => {}
        }
    }
    if eds.get(0x6076, 0).is_none() {
        missing.push(
            "0x6076:00 motor rated torque (absent: set [robot.axis] rated-torque instead)".into(),
        );
    }
    let kbit = bitrate / 1000;
    if !eds.bitrates_kbit.is_empty() && !eds.bitrates_kbit.contains(&kbit) {
        missing.push(format!(
            "bit rate {kbit} kbit/s (the device lists {:?} kbit/s)",
            eds.bitrates_kbit
        ));
    }
    if missing.is_empty() {
        Ok(())
    } else {
        Err(EdsError::Missing(format!(
            "the device lacks what anguilla's CiA 402 master needs: {}",
            missing.join("; ")
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "\
[DeviceInfo]
BaudRate_500=1
BaudRate_1000=1
; a comment
[1000]
ParameterName=Device type
DefaultValue=0x00020192
";

    fn full() -> String {
        let mut s = GOOD.to_string();
        for (index, sub, name, mapping) in CIA402_NEEDS {
            let section = if sub == 0 {
                format!("{index:04X}")
            } else {
                format!("{index:04X}sub{sub:X}")
            };
            s += &format!(
                "\n[{section}]\nParameterName={name}\nAccessType=RW\nPDOMapping={}\n",
                (mapping != Mapping::No) as u8
            );
        }
        s + "\n[6076]\nParameterName=Motor rated torque\n"
    }

    #[test]
    fn a_complete_device_passes_and_sections_are_case_insensitive() {
        let eds = Eds::parse(&full().to_lowercase().replace("rw", "RW")).unwrap();
        assert_eq!(eds.get(0x1600, 1).unwrap().name, "rpdo1 mapping");
        assert_eq!(eds.bitrates_kbit, vec![500, 1000]);
        check_cia402(&eds, 1_000_000).unwrap();
    }

    #[test]
    fn every_gap_is_named() {
        let text = full()
            .replace(
                "[60B2]\nParameterName=torque offset\nAccessType=RW\nPDOMapping=1",
                "[60B2]\nParameterName=torque offset\nAccessType=RW\nPDOMapping=0",
            )
            .replace("[6061]", "[2061]");
        let e = check_cia402(&Eds::parse(&text).unwrap(), 250_000)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("0x60B2:00 torque offset (not PDO-mappable; anguilla maps it into RPDO1)"),
            "{e}"
        );
        assert!(
            e.contains("0x6061:00 modes of operation display (absent)"),
            "{e}"
        );
        assert!(
            e.contains("bit rate 250 kbit/s (the device lists [500, 1000] kbit/s)"),
            "{e}"
        );
    }

    #[test]
    fn garbage_is_an_error_naming_the_line() {
        let e = Eds::parse("[1000]\nParameterName=x\nthis is not ini\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "line 3: \"this is not ini\" is not a [section], a key=value line or a ; comment"
        );
        // Binary junk never panics.
        let junk: String = (0..2000u32)
            .map(|i| char::from_u32(i * 7919 % 0x2FF).unwrap_or('?'))
            .collect();
        let _ = Eds::parse(&junk);
    }
}
