//! Markdown tables of the message layouts and of the node's transitions,
//! for `protocol/README.md`.
//!
//! The README's layout tables and its transition table are these functions'
//! output (a test checks it), so the document a firmware engineer implements
//! from is the codec's layout and the rule table the conformance suite
//! checks ([`crate::behaviour::TRANSITIONS`]).

use core::fmt::Write;

use crate::behaviour::{Input, STATES, describe, expected, state_name};
use crate::message::{Addressing, Direction, Variant, definitions};
use crate::signal::{Mux, Signal};

fn range(s: &Signal) -> String {
    if s.factor == 1.0 && s.offset == 0.0 && s.unit.is_empty() {
        format!("{}..={}", s.min, s.max)
    } else {
        format!("{} ..= {} {}", s.min, s.max, s.unit)
    }
}

/// The layout tables of every message of `variant`, as Markdown.
pub fn layout_markdown(variant: Variant) -> String {
    let mut out = String::new();
    let w = &mut out;
    for def in definitions(variant) {
        let base = def.function.id(0);
        let ids = match def.addressing {
            Addressing::Broadcast => format!("0x{base:03X}"),
            Addressing::AllOrNode => format!("0x{base:03X} (all), 0x{base:03X}+node"),
            Addressing::Node => format!("0x{base:03X}+node"),
            Addressing::Group => format!("0x{base:03X}+group"),
            Addressing::Sensor => format!("0x{base:03X}+sensor"),
        };
        let dir = match def.direction {
            Direction::HostToNode => "host → node",
            Direction::NodeToHost => "node → host",
        };
        let _ = writeln!(
            w,
            "#### {} — id {ids}, {dir}, {} bytes{}\n\n{}; {}.\n",
            def.name,
            def.len,
            if def.addressing == Addressing::Group {
                " (shorter when fewer slots: 12/24/32/48/64)"
            } else {
                ""
            },
            def.comment,
            def.period
        );
        if def.signals.is_empty() {
            let _ = writeln!(w, "No data bytes.\n");
            continue;
        }
        let _ = writeln!(w, "| field | bits | type | scale | range | meaning |");
        let _ = writeln!(w, "|---|---|---|---|---|---|");
        // Slots of a group: list slot 0 and say the rest repeat.
        for s in def.signals.iter().filter(|s| s.slot.is_none_or(|k| k == 0)) {
            let name = match (s.slot, s.mux) {
                (Some(_), _) => format!("slot s: {}", s.name),
                (None, Mux::When(v)) => format!("{} (Param = {v})", s.name),
                (None, _) => s.name.to_string(),
            };
            let bits = match s.slot {
                Some(_) => format!("{}+80s..={}+80s", s.start, s.end()),
                None => format!("{}..={}", s.start, s.end()),
            };
            let ty = format!("{}{}", if s.signed { "i" } else { "u" }, s.len);
            let scale = if s.factor == 1.0 {
                "1".to_string()
            } else {
                format!("{} {}", s.factor, s.unit)
            };
            let _ = writeln!(
                w,
                "| {name} | {bits} | {ty} | {scale} | {} | {} |",
                range(s),
                s.comment
            );
        }
        let _ = writeln!(w);
    }
    out
}

/// The transition table of the node's state machine (state × input), as
/// Markdown: one row per state, one column per [`Input`].
pub fn transitions_markdown() -> String {
    let mut out = String::new();
    let w = &mut out;
    let _ = write!(w, "| state |");
    for i in Input::ALL {
        let _ = write!(w, " {} |", i.name());
    }
    let _ = write!(w, "\n|---|");
    for _ in Input::ALL {
        let _ = write!(w, "---|");
    }
    let _ = writeln!(w);
    for s in STATES {
        let _ = write!(w, "| {} ({}) |", state_name(s), s as u8);
        for i in Input::ALL {
            let _ = write!(w, " {} |", describe(s, &expected(s, i)));
        }
        let _ = writeln!(w);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn readme_tables_are_the_generated_ones() {
        let readme = include_str!("../README.md");
        for (variant, flag) in [(Variant::Classic, ""), (Variant::Fd, " --fd")] {
            let table = layout_markdown(variant);
            assert!(
                readme.contains(&table),
                "protocol/README.md layout tables are stale: paste the output of \
                 `cargo run -- protocol layout{flag}` between the markers"
            );
        }
        assert!(
            readme.contains(&transitions_markdown()),
            "protocol/README.md transition table is stale: paste the output of \
             `cargo run -- protocol transitions` in its place"
        );
    }
}
