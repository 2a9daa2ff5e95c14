//! DBC file generation from the message definitions.
//!
//! The DBC is written from [`crate::message::definitions`] and the signal
//! descriptors the codec uses, so it is the codec's layout by construction.
//! A DBC has no wildcard ids: it lists every message for nodes `1..=nodes`
//! (the committed files cover the default robot of 12 vertebrae; generate
//! another with `anguilla protocol dbc --nodes N`). The head sensor's
//! messages, and its Heartbeat, are listed once, for
//! [`DEFAULT_HEAD_SENSOR_ID`], sent by the DBC node `HeadSensor`.

use core::fmt::{self, Write};

use crate::message::{
    Addressing, DEFAULT_HEAD_SENSOR_ID, Direction, Function, GROUP_SLOTS, HEARTBEAT_PERIOD_MS,
    MessageDef, Variant, definitions,
};
use crate::signal::{Mux, Signal};

/// Node count of the committed DBC files (the default robot).
pub const DEFAULT_NODES: u8 = 12;

/// The DBC text for `variant` and nodes `1..=nodes` (clamped to 1..=63).
pub fn generate(variant: Variant, nodes: u8) -> String {
    let mut s = String::new();
    write_dbc(&mut s, variant, nodes).expect("writing to a String cannot fail");
    s
}

struct Instance {
    id: u16,
    suffix: Suffix,
    receivers: (u8, u8), // node range, inclusive; (0, 0) = Host
}

#[derive(Clone, Copy)]
enum Suffix {
    None,
    All,
    Node(u8),
    Group(u8),
}

impl fmt::Display for Suffix {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Suffix::None => Ok(()),
            Suffix::All => f.write_str("_All"),
            Suffix::Node(n) => write!(f, "_N{n:02}"),
            Suffix::Group(g) => write!(f, "_G{g}"),
        }
    }
}

fn instances(
    def: &MessageDef,
    nodes: u8,
    mut each: impl FnMut(Instance) -> fmt::Result,
) -> fmt::Result {
    let to_nodes = def.direction == Direction::HostToNode;
    let rx = |lo: u8, hi: u8| if to_nodes { (lo, hi) } else { (0, 0) };
    match def.addressing {
        Addressing::Broadcast => each(Instance {
            id: def.function.id(0),
            suffix: Suffix::None,
            receivers: rx(1, nodes),
        }),
        Addressing::AllOrNode => {
            each(Instance {
                id: def.function.id(0),
                suffix: Suffix::All,
                receivers: rx(1, nodes),
            })?;
            for n in 1..=nodes {
                each(Instance {
                    id: def.function.id(n),
                    suffix: Suffix::Node(n),
                    receivers: rx(n, n),
                })?;
            }
            Ok(())
        }
        Addressing::Node => {
            for n in 1..=nodes {
                each(Instance {
                    id: def.function.id(n),
                    suffix: Suffix::Node(n),
                    receivers: rx(n, n),
                })?;
            }
            // The head sensor sends the vertebrae's Heartbeat too.
            if def.function == Function::Heartbeat && DEFAULT_HEAD_SENSOR_ID > nodes {
                each(Instance {
                    id: def.function.id(DEFAULT_HEAD_SENSOR_ID),
                    suffix: Suffix::Node(DEFAULT_HEAD_SENSOR_ID),
                    receivers: (0, 0),
                })?;
            }
            Ok(())
        }
        Addressing::Sensor => each(Instance {
            id: def.function.id(DEFAULT_HEAD_SENSOR_ID),
            suffix: Suffix::Node(DEFAULT_HEAD_SENSOR_ID),
            receivers: (0, 0),
        }),
        Addressing::Group => {
            let groups = (nodes as usize).div_ceil(GROUP_SLOTS) as u8;
            for g in 0..groups {
                let lo = g * GROUP_SLOTS as u8 + 1;
                let hi = (lo + GROUP_SLOTS as u8 - 1).min(nodes);
                each(Instance {
                    id: def.function.id(g),
                    suffix: Suffix::Group(g),
                    receivers: rx(lo, hi),
                })?;
            }
            Ok(())
        }
    }
}

fn write_receivers(out: &mut impl Write, (lo, hi): (u8, u8)) -> fmt::Result {
    if lo == 0 {
        return out.write_str("Host");
    }
    for n in lo..=hi {
        if n > lo {
            out.write_char(',')?;
        }
        write!(out, "Node{n:02}")?;
    }
    Ok(())
}

fn write_signal(out: &mut impl Write, s: &Signal, receivers: (u8, u8)) -> fmt::Result {
    let mux = match s.mux {
        Mux::None => String::new(),
        Mux::Switch => " M".to_string(),
        Mux::When(v) => format!(" m{v}"),
    };
    write!(
        out,
        " SG_ {}{mux} : {}|{}@1{} ({},{}) [{}|{}] \"{}\" ",
        s.dbc_name(),
        s.start,
        s.len,
        if s.signed { '-' } else { '+' },
        s.factor,
        s.offset,
        s.min,
        s.max,
        s.unit
    )?;
    write_receivers(out, receivers)?;
    out.write_char('\n')
}

/// Value tables: (message function name, signal name, [(value, label)]).
type ValueTable = (&'static str, &'static str, &'static [(u8, &'static str)]);

const VALUE_TABLES: &[ValueTable] = &[
    (
        "Command",
        "Command",
        &[(1, "Enable"), (2, "Disable"), (3, "ClearFaults")],
    ),
    (
        "Heartbeat",
        "State",
        &[
            (0, "Boot"),
            (1, "Disabled"),
            (2, "Enabled"),
            (3, "Fault"),
            (4, "EStop"),
        ],
    ),
    ("ConfigWrite", "Param", PARAMS),
    ("ConfigAck", "Param", PARAMS),
    ("ConfigWrite", "SafeAction", SAFE_ACTIONS),
    ("ConfigAck", "SafeAction", SAFE_ACTIONS),
    (
        "ConfigAck",
        "Result",
        &[(0, "Accepted"), (1, "OutOfRange"), (2, "NotDisabled")],
    ),
];
const PARAMS: &[(u8, &str)] = &[
    (0, "WatchdogTimeout"),
    (1, "SafeAction"),
    (2, "PositionLimits"),
    (3, "VelocityLimit"),
    (4, "TorqueLimit"),
];
const SAFE_ACTIONS: &[(u8, &str)] = &[(0, "Hold"), (1, "Limp"), (2, "Brake")];

/// Writes the DBC text for `variant` and nodes `1..=nodes`.
pub fn write_dbc(out: &mut impl Write, variant: Variant, nodes: u8) -> fmt::Result {
    let nodes = nodes.clamp(1, crate::message::MAX_NODE_ID);
    let fd = variant == Variant::Fd;
    writeln!(out, "VERSION \"anguilla {}\"", env!("CARGO_PKG_VERSION"))?;
    out.write_str(
        "\n\nNS_ :\n    CM_\n    BA_DEF_\n    BA_\n    VAL_\n    BA_DEF_DEF_\n\nBS_:\n\nBU_: Host",
    )?;
    for n in 1..=nodes {
        write!(out, " Node{n:02}")?;
    }
    out.write_str(" HeadSensor\n\n")?;
    let defs = definitions(variant);
    for def in defs {
        instances(def, nodes, |inst| {
            write!(
                out,
                "BO_ {} {}{}: {} ",
                inst.id, def.name, inst.suffix, def.len
            )?;
            match def.direction {
                Direction::HostToNode => out.write_str("Host\n")?,
                Direction::NodeToHost
                    if def.addressing == Addressing::Sensor
                        || inst.id == def.function.id(DEFAULT_HEAD_SENSOR_ID)
                            && nodes < DEFAULT_HEAD_SENSOR_ID =>
                {
                    out.write_str("HeadSensor\n")?
                }
                Direction::NodeToHost => match inst.suffix {
                    Suffix::Node(n) => writeln!(out, "Node{n:02}")?,
                    _ => out.write_str("Vector__XXX\n")?,
                },
            }
            for s in def.signals {
                write_signal(out, s, inst.receivers)?;
            }
            out.write_char('\n')
        })?;
    }
    // Comments.
    writeln!(
        out,
        "CM_ \"anguilla vertebra protocol, {variant}, nodes 1..{nodes}. Generated by `anguilla protocol dbc`; do not edit. See protocol/README.md.\";"
    )?;
    for def in defs {
        instances(def, nodes, |inst| {
            writeln!(
                out,
                "CM_ BO_ {} \"{} ({})\";",
                inst.id, def.comment, def.period
            )?;
            for s in def.signals {
                writeln!(
                    out,
                    "CM_ SG_ {} {} \"{}\";",
                    inst.id,
                    s.dbc_name(),
                    s.comment
                )?;
            }
            Ok(())
        })?;
    }
    // Attributes.
    out.write_str("BA_DEF_ \"BusType\" STRING ;\n")?;
    out.write_str("BA_DEF_ BO_ \"GenMsgCycleTime\" INT 0 65535;\n")?;
    if fd {
        out.write_str(
            "BA_DEF_ BO_ \"VFrameFormat\" ENUM \"StandardCAN\",\"ExtendedCAN\",\"reserved\",\"J1939PG\",\"reserved\",\"reserved\",\"reserved\",\"reserved\",\"reserved\",\"reserved\",\"reserved\",\"reserved\",\"reserved\",\"reserved\",\"StandardCAN_FD\",\"ExtendedCAN_FD\";\n",
        )?;
        out.write_str("BA_DEF_ BO_ \"CANFD_BRS\" ENUM \"0\",\"1\";\n")?;
    }
    out.write_str("BA_DEF_DEF_ \"BusType\" \"\";\n")?;
    out.write_str("BA_DEF_DEF_ \"GenMsgCycleTime\" 0;\n")?;
    if fd {
        out.write_str("BA_DEF_DEF_ \"VFrameFormat\" \"StandardCAN\";\n")?;
        out.write_str("BA_DEF_DEF_ \"CANFD_BRS\" \"1\";\n")?;
    }
    writeln!(
        out,
        "BA_ \"BusType\" \"{}\";",
        if fd { "CAN FD" } else { "CAN" }
    )?;
    for def in defs {
        instances(def, nodes, |inst| {
            if def.function == Function::Heartbeat {
                writeln!(
                    out,
                    "BA_ \"GenMsgCycleTime\" BO_ {} {};",
                    inst.id, HEARTBEAT_PERIOD_MS
                )?;
            }
            if fd {
                writeln!(out, "BA_ \"VFrameFormat\" BO_ {} 14;", inst.id)?;
                writeln!(out, "BA_ \"CANFD_BRS\" BO_ {} 1;", inst.id)?;
            }
            Ok(())
        })?;
    }
    // Value tables.
    for def in defs {
        instances(def, nodes, |inst| {
            for (msg, sig, values) in VALUE_TABLES {
                if *msg != def.name || !def.signals.iter().any(|s| s.name == *sig) {
                    continue;
                }
                write!(out, "VAL_ {} {}", inst.id, sig)?;
                for (v, label) in *values {
                    write!(out, " {v} \"{label}\"")?;
                }
                out.write_str(" ;\n")?;
            }
            Ok(())
        })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn committed_dbc_files_are_the_generated_ones() {
        let classic = include_str!("../anguilla.dbc");
        let fd = include_str!("../anguilla_fd.dbc");
        // If this fails after a protocol change, regenerate with
        // `cargo run -- protocol dbc --out protocol/anguilla.dbc` (and
        // `--fd --out protocol/anguilla_fd.dbc`) and review the diff.
        assert!(
            classic == generate(Variant::Classic, DEFAULT_NODES),
            "protocol/anguilla.dbc is stale"
        );
        assert!(
            fd == generate(Variant::Fd, DEFAULT_NODES),
            "protocol/anguilla_fd.dbc is stale"
        );
    }

    #[test]
    fn every_id_appears_once() {
        for v in [Variant::Classic, Variant::Fd] {
            let text = generate(v, 63);
            let mut seen = std::collections::HashSet::new();
            for line in text.lines().filter(|l| l.starts_with("BO_ ")) {
                let id: u16 = line.split_whitespace().nth(1).unwrap().parse().unwrap();
                assert!(id <= 0x7FF);
                assert!(seen.insert(id), "duplicate id {id}");
            }
        }
    }
}
