//! Arbitrary bytes as a message a Foxglove client publishes on
//! `/anguilla/command` (`anguilla foxglove` with `[foxglove] commands`):
//! parsing must not panic; a command comes only from a JSON object whose
//! "command" is its name, its numbers are finite and a held heading is in
//! 0 ..< 360; written back as JSON it parses to itself.
#![no_main]

use anguilla_ipc::Command;
use anguilla_teleop::json::command_from_json;
use libfuzzer_sys::fuzz_target;
use serde_json::{Value, json};

/// The command as a client would write it (scripts/foxglove_commands.py):
/// its gait and its hold, if it has them, and a path's fields.
fn to_json(cmd: Command) -> Value {
    let mut v = json!({ "command": cmd.name() });
    let (swim, hold) = cmd.swim_and_hold();
    if let Some(p) = swim {
        v["amplitude"] = json!(p.amplitude);
        v["frequency"] = json!(p.frequency);
        v["turn"] = json!(p.turn);
        v["pitch"] = json!(p.pitch);
    }
    if let Some(h) = hold {
        v["heading"] = json!(h.heading);
        v["depth"] = json!(h.depth);
    }
    match cmd {
        Command::Waypoint(w) => {
            v["index"] = json!(w.index);
            v["x"] = json!(w.x);
            v["y"] = json!(w.y);
            v["depth"] = json!(w.depth);
        }
        Command::Follow(f) => {
            v["count"] = json!(f.count);
            v["loop"] = json!(f.looped);
            v["from_here"] = json!(f.from_here);
            v["resume"] = json!(f.resume);
        }
        _ => {}
    }
    v
}

fuzz_target!(|input: &[u8]| {
    let cmd = match command_from_json(input) {
        Ok(cmd) => cmd,
        Err(why) => {
            assert!(!why.is_empty());
            return;
        }
    };
    let v: Value = serde_json::from_slice(input).expect("a command is JSON");
    assert_eq!(v["command"].as_str(), Some(cmd.name()));
    let (swim, hold) = cmd.swim_and_hold();
    if let Some(p) = swim {
        for x in [p.amplitude, p.frequency, p.turn, p.pitch] {
            assert!(x.is_finite(), "{x}");
        }
    }
    if let Some(h) = hold {
        if let Some(d) = h.heading {
            assert!((0.0..360.0).contains(&d), "heading {d}");
        }
        if let Some(d) = h.depth {
            assert!(d.is_finite(), "depth {d}");
        }
    }
    let text = to_json(cmd).to_string();
    assert_eq!(command_from_json(text.as_bytes()), Ok(cmd), "{text}");
});
