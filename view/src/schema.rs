//! The JSON Schemas (draft 2020-12) of the channels in [`crate::TOPICS`]:
//! what a viewer reads to list a message's fields, their units and their
//! codes. `docs/data.md`'s field tables are generated from them
//! ([`markdown`]); a test checks every message [`crate::Scene`] writes
//! against them ([`check`]), and CI checks a daemon's recording again with
//! Python's `jsonschema` (`scripts/check_mcap.py`).
//!
//! Every object the writer makes is closed: all its properties are
//! written every time (`required` lists them, in the writer's order) and
//! no other (`additionalProperties: false`). Enumerations come from the
//! code's own tables (`codes.rs`: [`anguilla_ipc::Mode::ALL`],
//! [`anguilla_ipc::Cause::ALL`], [`anguilla_ipc::SensorHealth::ALL`],
//! [`anguilla_ipc::bus_state_name`],
//! [`anguilla_protocol::behaviour::STATES`],
//! [`anguilla_ipc::FaultKind::ALL`]), so a new
//! mode or cause is in the schema the moment it exists.
//!
//! anguilla's own messages (`anguilla.State`, `anguilla.Joints`,
//! `anguilla.Sensors`, `anguilla.SimTruth`) are typed structs whose schema
//! is made from their definition ([`crate::view!`], `message.rs`); the
//! Foxglove messages (`foxglove.Log`, `foxglove.FrameTransforms`,
//! `foxglove.SceneUpdate`) follow Foxglove's published schemas, written
//! here. The builders ([`message`], [`object`], [`real`], …) are public for
//! the next channel: a schema is a list of described properties.
//!
//! ```
//! use anguilla_view::schema::{check, message, real};
//! use serde_json::json;
//!
//! let s = message(
//!     "example.Depth",
//!     "One depth reading",
//!     vec![("depth_m", real("Depth below the surface (m, positive down)"))],
//! );
//! assert!(check(&s, &json!({ "depth_m": 1.5 })).is_ok());
//! assert!(check(&s, &json!({ "depth_m": "deep" })).is_err());
//! assert!(check(&s, &json!({})).is_err()); // required
//! ```

use core::fmt::Write as _;

use serde_json::Value;

mod build;
mod check;
mod codes;
mod table;

pub use build::{
    DIALECT, Property, array, bits, boolean, codes, count, empty_array, message, names, number,
    object, real, string, typed_object,
};
pub use check::check;
pub use codes::{
    LOG_LEVELS, UNKNOWN, bus_state_codes, cause_names, fault_bits, guide_state_names, hold_codes,
    hold_state_names, mode_names, node_state_codes, position_health_names, sensor_names,
};
pub use table::table;

use crate::foxglove::{FrameTransforms, Log, SceneUpdate};
use crate::message::{Joints, Sensors, State};

/// The schemas of [`crate::TOPICS`], in order: (name, schema).
pub fn all() -> [(&'static str, Value); 6] {
    [
        ("anguilla.State", State::schema()),
        ("anguilla.Joints", Joints::schema()),
        ("foxglove.Log", Log::schema()),
        ("foxglove.FrameTransforms", FrameTransforms::schema()),
        ("foxglove.SceneUpdate", SceneUpdate::schema()),
        ("anguilla.Sensors", Sensors::schema()),
    ]
}

/// `docs/data.md`'s generated part: per channel, a table of its fields
/// (in the order written) with their types and descriptions; then the
/// codes.
pub fn markdown() -> String {
    let mut out = String::new();
    for (topic, (name, s)) in crate::TOPICS.iter().zip(all()) {
        let _ = writeln!(out, "### `{topic}` ({name})\n");
        out.push_str(&table(&s));
        out.push('\n');
    }
    let _ = writeln!(
        out,
        "### `{}` ({}, a simulated robot only)\n",
        crate::truth::TOPIC,
        crate::truth::SCHEMA_NAME
    );
    out.push_str(&table(&crate::truth::schema()));
    out.push('\n');
    let _ = writeln!(out, "### Codes\n");
    let _ = writeln!(
        out,
        "`fault_kinds` (`/anguilla/state`), one bit each; latched until reset:\n"
    );
    let _ = writeln!(out, "| bit | value | fault |");
    let _ = writeln!(out, "|---:|---:|---|");
    for (b, n) in fault_bits() {
        let _ = writeln!(out, "| {b} | {:#x} | {n} |", 1u32 << b);
    }
    for (what, list) in [
        ("`bus.state` (`/anguilla/state`)", bus_state_codes()),
        ("`nav.hold` (`/anguilla/state`)", hold_codes()),
        ("`node_state[]` (`/anguilla/joints`)", node_state_codes()),
    ] {
        let _ = writeln!(out, "\n{what}:\n");
        let _ = writeln!(out, "| code | meaning |");
        let _ = writeln!(out, "|---:|---|");
        for (c, n) in list {
            let _ = writeln!(out, "| {c} | {n} |");
        }
    }
    let _ = writeln!(out, "\n`level` (`/log`, `foxglove.LogLevel`):\n");
    let _ = writeln!(out, "| code | name | used for |");
    let _ = writeln!(out, "|---:|---|---|");
    for (c, n, what) in LOG_LEVELS {
        let _ = writeln!(out, "| {c} | {n} | {what} |");
    }
    out
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use super::*;
    use crate::{Scene, TOPICS};
    use anguilla_ipc::MAX_JOINTS;
    use serde_json::json;

    /// The default robot's joints.
    const JOINTS: usize = 12;
    use anguilla_ipc::{
        Cause, FaultKind, GuideState, HoldState, Mode, SensorHealth, SensorKind, StateSnapshot,
    };

    /// Snapshots that take every mode, cause, sensor health, bus state,
    /// hold and node state (255 included), codes this anguilla does not
    /// know, changing faults and refusals (log lines), and floats that are
    /// not finite.
    fn snapshots(joints: usize) -> Vec<StateSnapshot> {
        let nodes = node_state_codes();
        (0..96u64)
            .map(|i| {
                let mut s = StateSnapshot {
                    joint_count: joints as u32,
                    sequence: i * 10,
                    time_ns: i * 20_000_000,
                    // One past the table: a code this anguilla does not know.
                    mode: (i % (Mode::ALL.len() as u64 + 1)) as u8,
                    cause: (i % (Cause::ALL.len() as u64 + 1)) as u8,
                    feedforward_dropped: (i % 2) as u8,
                    fault_kinds: if i % 3 == 0 {
                        0
                    } else {
                        FaultKind::ALL[i as usize % FaultKind::ALL.len()] as u32
                    },
                    fault_nodes: 1 << (i % 64),
                    predicted_head_speed: 0.3,
                    predicted_turn_rate: -0.2,
                    refused_commands: i / 4,
                    ..StateSnapshot::default()
                };
                let states = bus_state_codes();
                s.bus.state = states[i as usize % states.len()].0 as u8;
                s.bus.tx_frames = i * 1000;
                s.loop_stats.period_ns = 2_000_000;
                s.loop_stats.periods = i * 10;
                let n = &mut s.nav;
                n.sensor = (i % (SensorHealth::ALL.len() as u64 + 1)) as u8;
                n.hold = (i % 4) as u8;
                n.hold_exit = (i / 5 % 7) as u8;
                n.heading_hold = (i % (HoldState::ALL.len() as u64 + 1)) as u8;
                n.depth_hold = (i / 3 % (HoldState::ALL.len() as u64 + 1)) as u8;
                n.surfaced = (i % 2) as u8;
                n.samples = i / 2;
                n.heading_deg = (i * 7 % 360) as f32;
                n.pitch_deg = -10.0;
                n.roll_deg = 3.0;
                n.depth_m = 0.5;
                // 0..=4 sensors of every kind, an unknown kind (from a newer
                // daemon) and every health, NaN among the values.
                for (k, e) in s.sensors.iter_mut().enumerate().take(i as usize % 5) {
                    e.kind = ((i as usize + k) % (SensorKind::ALL.len() + 2)) as u8;
                    e.id = 20 + k as u8;
                    e.health = ((i as usize + k) % (SensorHealth::ALL.len() + 1)) as u8;
                    e.samples = i as u32;
                    e.values = [1.5, -2.0, f32::NAN, 0.0, 3.0, 4.0, 5.0, 6.0];
                }
                for (j, js) in s.joints.iter_mut().enumerate().take(joints) {
                    js.node_state = nodes[(i as usize + j) % nodes.len()].0 as u8;
                    js.node_alive = ((i as usize + j) % 2) as u8;
                    js.measured_pitch = 0.1 * j as f32;
                    js.measured_yaw = -0.2;
                    js.predicted_yaw_torque = 0.05;
                }
                // Every path state (and one unknown), legs coming and
                // going, an estimate with its σ or none.
                let g = &mut s.guide;
                g.state = (i / 2 % (GuideState::ALL.len() as u64 + 1)) as u8;
                g.leg = (i / 7) as u16;
                let x = (i / 7) as f32;
                [g.from_x, g.from_y, g.to_x, g.to_y] = [x, 0.0, x + 1.0, x * 0.5];
                g.cross_track_m = 0.25;
                s.nav.samples = i % 3;
                s.nav.x_m = x + 0.5;
                s.nav.position_sigma_m = 0.1 * (i % 4) as f32;
                s.nav.position_health = (i % 6) as u8;
                if i % 5 == 0 {
                    s.guide.to_x = f32::NAN;
                    s.nav.position_sigma_m = f32::INFINITY;
                    s.nav.x_m = f32::NAN;
                    s.predicted_head_speed = f32::NAN;
                    s.predicted_turn_rate = f32::INFINITY;
                    s.gait_actual.turn = f32::NAN;
                    s.nav.heading_deg = f32::NAN;
                    s.nav.depth_m = f32::NEG_INFINITY;
                    s.joints[0].measured_pitch = f32::NAN;
                    s.joints[1].predicted_pitch_torque = f32::INFINITY;
                }
                s
            })
            .collect()
    }

    #[test]
    fn every_message_conforms_to_its_channels_schema() {
        let mut scene = Scene::new(JOINTS);
        let schemas = all();
        let mut per_channel = [0usize; 6];
        let mut seen: [BTreeSet<String>; 3] = Default::default();
        let (mut guides, mut truths) = (0, 0);
        for s in snapshots(JOINTS) {
            if s.sequence % 30 == 0 {
                let t = crate::truth::GroundTruth {
                    position: [1.0, 2.0, -0.5],
                    orientation: [0.0, 0.0, 0.0, 1.0],
                    ..Default::default()
                };
                scene.truth(s.time_ns, &t);
            }
            for (ch, v) in scene.messages(&s) {
                guides += usize::from(v["entities"][1]["id"] == "guide");
                truths += usize::from(v["transforms"][2]["child_frame_id"] == "truth");
                if let Err(e) = check(&schemas[ch].1, &v) {
                    panic!("{} message {}: {e}\n{v}", TOPICS[ch], per_channel[ch]);
                }
                per_channel[ch] += 1;
                if ch == 0 {
                    for (k, x) in [&v["mode"], &v["cause"], &v["nav"]["sensor"]]
                        .into_iter()
                        .enumerate()
                    {
                        seen[k].insert(x.as_str().unwrap_or_default().to_string());
                    }
                }
            }
        }
        assert!(per_channel.iter().all(|&n| n > 0), "{per_channel:?}");
        assert!(
            guides > 30 && truths > 1,
            "{guides} guides, {truths} truths"
        );
        // The snapshots did take every value the enumerations allow.
        for (k, names) in [
            mode_names().collect::<BTreeSet<_>>(),
            cause_names().collect(),
            sensor_names().collect(),
        ]
        .into_iter()
        .enumerate()
        {
            let names: BTreeSet<String> = names.into_iter().map(String::from).collect();
            assert_eq!(seen[k], names);
        }
    }

    /// Every object is closed and lists all its properties as required,
    /// every property is described, and every message names its dialect.
    #[test]
    fn every_schema_is_closed_and_described() {
        fn walk(path: &str, s: &Value) {
            if s.get("description")
                .and_then(Value::as_str)
                .is_none_or(str::is_empty)
            {
                panic!("{path}: no description");
            }
            if s["type"] == "object" {
                let props: BTreeSet<&str> = s["properties"]
                    .as_object()
                    .map(|p| p.keys().map(String::as_str).collect())
                    .unwrap_or_default();
                let required: BTreeSet<&str> = s["required"]
                    .as_array()
                    .map(|r| r.iter().filter_map(Value::as_str).collect())
                    .unwrap_or_default();
                assert_eq!(props, required, "{path}: required");
                assert_eq!(s["additionalProperties"], false, "{path}: not closed");
                for (k, p) in s["properties"].as_object().into_iter().flatten() {
                    walk(&format!("{path}.{k}"), p);
                }
            }
            if let Some(items) = s.get("items") {
                walk(&format!("{path}[]"), items);
            }
        }
        for (name, s) in all() {
            assert_eq!(s["$schema"], DIALECT, "{name}");
            assert_eq!(s["title"], name);
            walk(name, &s);
        }
    }

    /// The check fails what does not conform: an unknown key, a missing
    /// one, a wrong type, a value outside an enumeration, too many items,
    /// a keyword it does not check.
    #[test]
    fn the_check_refuses_what_does_not_conform() {
        let mut scene = Scene::new(JOINTS);
        let mut s = StateSnapshot {
            joint_count: JOINTS as u32,
            ..StateSnapshot::default()
        };
        s.nav.samples = 1;
        let msgs = scene.messages(&s);
        let written = &msgs[0].1;
        let schema = State::schema();
        assert_eq!(check(&schema, written), Ok(()));
        let bad = |f: &dyn Fn(&mut Value)| {
            let mut v = written.clone();
            f(&mut v);
            check(&schema, &v).unwrap_err()
        };
        let e = bad(&|v| v["nav"]["extra"] = json!(1));
        assert_eq!(e, "nav.extra: not a property of the schema");
        let e = bad(&|v| {
            v["bus"].as_object_mut().unwrap().remove("state");
        });
        assert_eq!(e, "bus: required property state is missing");
        let e = bad(&|v| v["sequence"] = json!(1.5));
        assert!(e.starts_with("sequence: 1.5 is not of type"), "{e}");
        let e = bad(&|v| v["mode"] = json!("sleeping"));
        assert!(e.starts_with("mode: \"sleeping\" is not one of"), "{e}");
        let e = bad(&|v| v["bus"]["state"] = json!(4));
        assert!(e.starts_with("bus.state: 4 is not one of"), "{e}");
        let joints = &msgs[1].1;
        let mut long = joints.clone();
        long["node_state"] = json!(vec![1; MAX_JOINTS + 1]);
        let e = check(&Joints::schema(), &long).unwrap_err();
        assert_eq!(
            e,
            format!("node_state: {} items, at most {MAX_JOINTS}", MAX_JOINTS + 1)
        );
        let e = check(&json!({"pattern": "x"}), &json!("x")).unwrap_err();
        assert_eq!(e, "(message): schema keyword pattern is not checked here");
    }

    /// `docs/data.md` between `<!-- fields:begin -->` and `<!-- fields:end
    /// -->` is [`markdown`] (rewritten with ANGUILLA_BLESS=1).
    #[test]
    fn docs_data_md_has_the_generated_tables() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/data.md");
        anguilla_testkit::generated_block(std::path::Path::new(path), "fields", &markdown());
    }
}
