//! `anguilla monitor --json`: a state snapshot as one JSON object.

use anguilla_ipc::FaultSet;
use anguilla_ipc::StateSnapshot;
use anguilla_view::{Bus, Gait, Guide, Loop};
use serde_json::{Value, json};

use crate::hold::{has_estimate, held};
use crate::view::{autopilot_name, cause_name, mode_name, sensor_name};

/// A hold state's name (`null` when not held).
fn hold_state_name(code: u8) -> Option<&'static str> {
    match anguilla_ipc::HoldState::from_code(code) {
        Some(anguilla_ipc::HoldState::Off) => None,
        Some(h) => Some(h.name()),
        None => Some("unknown"),
    }
}

/// The snapshot's fields as JSON, with the mode, cause and faults also
/// spelled out (`mode_name`, `cause_name`, `faults`) and only the joints in use.
///
/// The head sensor and the autopilot (`nav`) come twice: spelled out at the
/// top level (`sensor` and `hold_exit` by name, `autopilot` the hold's name,
/// `heading_hold` and `depth_hold` the daemon's hold states by name, `null`
/// when not held, `hold_words` them with their values, `surfaced`;
/// the estimate `null` without a sensor or before its first sample; a
/// target `null` unless held) and raw in `nav`. The path (`guide`) is
/// the recording's `guide`, its state by name.
pub fn snapshot_json(s: &StateSnapshot) -> Value {
    let n = (s.joint_count as usize).min(s.joints.len());
    let faults = FaultSet {
        kinds: s.fault_kinds,
        nodes: s.fault_nodes,
    };
    let lm = &s.limits;
    let limits = json!({
        "max_frequency": lm.max_frequency, "max_turn": lm.max_turn,
        "max_pitch": lm.max_pitch, "command_timeout_ms": lm.command_timeout_ms,
        "control_release_ms": lm.control_release_ms, "daemon_pid": lm.daemon_pid,
    });
    let nav = &s.nav;
    let estimate = |v: f32| has_estimate(nav).then_some(v);
    let hold = held(nav);
    let mut v = json!({
        "layout_version": s.layout_version,
        "sequence": s.sequence,
        "time_ns": s.time_ns,
        "mode": s.mode,
        "mode_name": mode_name(s.mode),
        "cause": s.cause,
        "cause_name": cause_name(s.cause),
        "feedforward_dropped": s.feedforward_dropped != 0,
        "fault_kinds": s.fault_kinds,
        "fault_nodes": s.fault_nodes,
        "faults": faults.to_string(),
        "holder": s.holder().map(|h| format!("{h:032x}")),
        "predicted_head_speed": s.predicted_head_speed,
        "predicted_turn_rate": s.predicted_turn_rate,
        // The recording's definitions (anguilla_view): the same keys.
        "gait_target": Gait::from(&s.gait_target),
        "gait_actual": Gait::from(&s.gait_actual),
        "loop_stats": Loop::from(&s.loop_stats),
        "bus": Bus::from(&s.bus),
        "guide": Guide::from(&s.guide),
        "clamped_setpoints": s.clamped_setpoints,
        "refused_commands": s.refused_commands,
        "socket_estops": s.socket_estops,
        "records_lost": s.records_lost,
        "operator_silent_stops": s.operator_silent_stops,
        "joint_count": s.joint_count,
        "joints": s.joints[..n].iter().map(joint_json).collect::<Vec<_>>(),
    });
    let extra = json!({
        "limits": limits,
        "sensor": sensor_name(nav.sensor),
        "autopilot": autopilot_name(nav),
        "hold_exit": (nav.hold_exit != 0).then(|| sensor_name(nav.hold_exit)),
        "heading_hold": hold_state_name(nav.heading_hold),
        "depth_hold": hold_state_name(nav.depth_hold),
        "hold_failed": nav.hold_failed(),
        "hold_words": nav.hold_words(),
        "surfaced": nav.surfaced != 0,
        "roll_alarm": nav.roll_alarm != 0,
        "heading_deg": estimate(nav.heading_deg),
        "pitch_deg": estimate(nav.pitch_deg),
        "roll_deg": estimate(nav.roll_deg),
        "depth_m": estimate(nav.depth_m),
        "depth_rate": estimate(nav.depth_rate),
        "x_m": estimate(nav.x_m),
        "y_m": estimate(nav.y_m),
        "position_sigma_m": estimate(nav.position_sigma_m),
        "position": nav.position_state().map_or("unknown", anguilla_ipc::PositionHealth::name),
        "fix_age_s": nav.fix_age_s(),
        "current_x": estimate(nav.current_x),
        "current_y": estimate(nav.current_y),
        "current_sigma": estimate(nav.current_sigma),
        "speed_scale": estimate(nav.speed_scale),
        "heading_target_deg": hold.heading.map(|_| nav.heading_target_deg),
        "depth_target_m": hold.depth.map(|_| nav.depth_target_m),
        "torque_residual_alarms": s.residual_alarms().map(|(joint, axis, r)| json!({
            "joint": joint, "axis": axis, "residual": r,
        })).collect::<Vec<Value>>(),
        "sensors": s.sensors.iter().filter(|e| e.kind != 0).map(|e| json!({
            "kind": e.sensor_kind().map_or("unknown", |k| k.name()),
            "id": e.id,
            "health": sensor_name(e.health),
            "samples": e.samples,
            "values": e.named_values().map(|(name, _, v)| (name.to_string(), json!(v)))
                .collect::<serde_json::Map<String, Value>>(),
        })).collect::<Vec<Value>>(),
        "nav": {
            "sensor": nav.sensor, "hold": nav.hold, "hold_exit": nav.hold_exit,
            "roll_alarm": nav.roll_alarm, "heading_deg": nav.heading_deg,
            "pitch_deg": nav.pitch_deg, "roll_deg": nav.roll_deg, "depth_m": nav.depth_m,
            "depth_rate": nav.depth_rate, "temperature": nav.temperature,
            "heading_target_deg": nav.heading_target_deg,
            "depth_target_m": nav.depth_target_m,
            "rate_innovation": nav.rate_innovation,
            "depth_innovation": nav.depth_innovation,
            "heading_hold": nav.heading_hold, "depth_hold": nav.depth_hold,
            "surfaced": nav.surfaced,
            "samples": nav.samples, "lost_samples": nav.lost_samples,
            "x_m": nav.x_m, "y_m": nav.y_m, "position_sigma_m": nav.position_sigma_m,
            "position_fixes": nav.position_fixes,
            "current_x": nav.current_x, "current_y": nav.current_y,
            "current_sigma": nav.current_sigma, "fix_age_ms": nav.fix_age_ms,
            "position_health": nav.position_health, "speed_scale": nav.speed_scale,
        },
    });
    if let (Value::Object(all), Value::Object(more)) = (&mut v, extra) {
        all.extend(more);
    }
    v
}

/// One joint's fields (a function of its own: one `json!` of them all
/// goes past the macro's recursion limit).
fn joint_json(j: &anguilla_ipc::JointSnapshot) -> Value {
    let mut v = json!({
        "commanded_pitch": j.commanded_pitch, "commanded_yaw": j.commanded_yaw,
        "measured_pitch": j.measured_pitch, "measured_yaw": j.measured_yaw,
        "commanded_pitch_velocity": j.commanded_pitch_velocity,
        "commanded_yaw_velocity": j.commanded_yaw_velocity,
        "measured_pitch_velocity": j.measured_pitch_velocity,
        "measured_yaw_velocity": j.measured_yaw_velocity,
        "predicted_pitch_torque": j.predicted_pitch_torque,
        "predicted_yaw_torque": j.predicted_yaw_torque,
        "measured_pitch_torque": j.measured_pitch_torque,
        "measured_yaw_torque": j.measured_yaw_torque,
    });
    let more = json!({
        "node_state": j.node_state, "node_alive": j.node_alive != 0,
        "node_errors": j.node_errors,
        "residual_alarm": j.residual_alarm,
        "pitch_torque_residual": j.pitch_torque_residual,
        "yaw_torque_residual": j.yaw_torque_residual,
    });
    if let (Value::Object(all), Value::Object(more)) = (&mut v, more) {
        all.extend(more);
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_line_with_the_fields_and_names() {
        let mut s = StateSnapshot {
            joint_count: 2,
            mode: 6,
            cause: 1,
            fault_kinds: 1 << 5,
            holder_lo: 42,
            holder_hi: 1,
            ..Default::default()
        };
        s.joints[1].measured_yaw = 0.5;
        let v = snapshot_json(&s);
        let line = v.to_string();
        assert!(!line.contains('\n'));
        let back: Value = serde_json::from_str(&line).unwrap();
        assert_eq!(back["mode_name"], "e-stop");
        assert_eq!(back["cause_name"], "command");
        assert_eq!(back["faults"], "operator e-stop");
        assert_eq!(back["holder"], "0000000000000001000000000000002a");
        assert_eq!(back["joints"].as_array().unwrap().len(), 2);
        assert_eq!(back["joints"][1]["measured_yaw"], 0.5);
        assert_eq!(back["loop_stats"]["overruns"], 0);
        // No head sensor: names, no numbers.
        assert_eq!(back["sensor"], "no sensor");
        assert_eq!(back["autopilot"], "manual");
        assert_eq!(back["hold_exit"], Value::Null);
        assert_eq!(back["roll_alarm"], false);
        for k in [
            "heading_deg",
            "pitch_deg",
            "roll_deg",
            "depth_m",
            "depth_rate",
        ] {
            assert_eq!(back[k], Value::Null, "{k}");
        }
        assert_eq!(back["heading_target_deg"], Value::Null);
        assert_eq!(back["nav"]["samples"], 0);
    }

    /// Every field of the state's layout (anguilla_ipc::layout_table, the
    /// same table that generates docs/ipc.md) is in the JSON, nested types
    /// as objects under their field's name (arrays: each element), except
    /// the reserved bytes and the holder's two halves, spelled out as one
    /// `holder`. A field added to the layout and not here fails this (layout
    /// 8's torque residuals, residual alarms and limits were missing).
    #[test]
    fn every_field_of_the_layout_is_in_the_json() {
        use anguilla_ipc::layout::{LayoutRow, layout_table};
        let table = layout_table();
        fn check(table: &[LayoutRow], ty: &str, v: &Value, path: &str, missing: &mut Vec<String>) {
            for r in table.iter().filter(|r| r.ty == ty) {
                if r.field.starts_with("reserved") {
                    continue;
                }
                let key = match r.field {
                    "holder_lo" | "holder_hi" => "holder",
                    f => f,
                };
                let Some(x) = v.get(key) else {
                    missing.push(format!("{path}{}", r.field));
                    continue;
                };
                // A nested payload type: its fields too.
                let inner = r.c_type.split('[').next().unwrap_or(r.c_type);
                if table.iter().any(|t| t.ty == inner) {
                    let items: Vec<&Value> = match x {
                        Value::Array(a) => a.iter().collect(),
                        other => vec![other],
                    };
                    assert!(!items.is_empty(), "{path}{key}: nothing to check");
                    for it in items {
                        check(table, inner, it, &format!("{path}{key}."), missing);
                    }
                }
            }
        }
        let mut s = StateSnapshot {
            joint_count: 2,
            ..Default::default()
        };
        s.sensors[0].kind = 1;
        let v = snapshot_json(&s);
        let mut missing = Vec::new();
        check(&table, "StateSnapshot", &v, "", &mut missing);
        missing.dedup();
        assert!(missing.is_empty(), "monitor --json lacks {missing:?}");
    }

    #[test]
    fn the_head_sensor_and_the_autopilot_are_spelled_out() {
        use anguilla_ipc::{NavSnapshot, SensorHealth, hold_bits};
        // Values exact in f32, so the JSON numbers compare exactly.
        let mut s = StateSnapshot {
            nav: NavSnapshot {
                sensor: SensorHealth::Ok as u8,
                hold: hold_bits::HEADING,
                hold_exit: SensorHealth::Stuck as u8,
                roll_alarm: 1,
                heading_deg: 87.5,
                pitch_deg: -2.25,
                roll_deg: 61.5,
                depth_m: 1.25,
                depth_rate: -0.125,
                heading_target_deg: 90.0,
                depth_target_m: 3.0,
                samples: 7,
                ..Default::default()
            },
            ..Default::default()
        };
        let v = snapshot_json(&s);
        assert_eq!(v["sensor"], "ok");
        assert_eq!(v["autopilot"], "heading");
        assert_eq!(v["hold_exit"], "stuck");
        assert_eq!(v["roll_alarm"], true);
        assert_eq!(v["heading_deg"], 87.5);
        assert_eq!(v["pitch_deg"], -2.25);
        assert_eq!(v["roll_deg"], 61.5);
        assert_eq!(v["depth_m"], 1.25);
        assert_eq!(v["depth_rate"], -0.125);
        assert_eq!(v["heading_target_deg"], 90.0);
        assert_eq!(v["depth_target_m"], Value::Null, "depth not held");
        assert_eq!(v["nav"]["depth_target_m"], 3.0, "raw");
        assert_eq!(v["nav"]["hold"], 1);
        // The existing fields are still there, unchanged.
        assert_eq!(v["mode_name"], "idle");
        s.nav.hold = hold_bits::HEADING | hold_bits::DEPTH;
        s.nav.sensor = SensorHealth::Implausible as u8;
        let v = snapshot_json(&s);
        assert_eq!(v["autopilot"], "heading+depth");
        assert_eq!(v["depth_target_m"], 3.0);
        assert_eq!(v["sensor"], "implausible");
        // The daemon's hold states (issue 46): by name, null when off.
        assert_eq!(v["heading_hold"], Value::Null);
        assert_eq!(v["hold_failed"], false);
        s.nav.heading_hold = anguilla_ipc::HoldState::Holding as u8;
        s.nav.depth_hold = anguilla_ipc::HoldState::NotConverging as u8;
        s.nav.surfaced = 1;
        let v = snapshot_json(&s);
        assert_eq!(v["heading_hold"], "holding");
        assert_eq!(v["depth_hold"], "not converging");
        assert_eq!(v["hold_failed"], true);
        assert_eq!(v["surfaced"], true);
        assert_eq!(v["nav"]["depth_hold"], 4, "raw");
        assert_eq!(
            v["hold_words"][1],
            "not converging: depth 1.25 m for 3.00 m"
        );
    }
}

/// An operator command from one JSON object (the Foxglove command channel,
/// `/anguilla/command`): `{"command": NAME, ...}` with NAME one of
/// [`anguilla_ipc::Command::name`]'s (`take-control`, `enable`, `swim`,
/// `stop`, `e-stop`, ...). `swim` takes `amplitude` and `frequency` (and
/// optionally `turn`, `pitch`); `hold` takes `heading` (degrees) and/or
/// `depth` (m); `waypoint` takes `index`, `x`, `y` (m) and optionally
/// `depth`; `follow` takes `amplitude`, `frequency`, `count` and
/// optionally `loop` and `from_here` (booleans). The daemon checks the
/// ranges; this checks the shape, and
/// each error names the field and what was expected.
pub fn command_from_json(bytes: &[u8]) -> Result<anguilla_ipc::Command, String> {
    use anguilla_ipc::{Command, CommandKind};
    let v: Value = serde_json::from_slice(bytes)
        .map_err(|e| format!("not JSON ({e}); expected {{\"command\": NAME, ...}}"))?;
    let name = v
        .get("command")
        .and_then(Value::as_str)
        .ok_or("expected a string field \"command\" (take-control, enable, swim, stop, ...)")?;
    let Some(kind) = CommandKind::from_name(name) else {
        let names: Vec<_> = CommandKind::ALL.iter().map(|k| k.name()).collect();
        return Err(format!(
            "unknown command \"{name}\" (expected one of {})",
            names.join(", ")
        ));
    };
    // Each command's module reads its own fields.
    Command::from_fields(kind, &JsonFields { v: &v, name })
}

/// A command's fields as a JSON object.
struct JsonFields<'a> {
    v: &'a Value,
    name: &'a str,
}

impl anguilla_ipc::Fields for JsonFields<'_> {
    fn command(&self) -> &str {
        self.name
    }

    fn number(&self, key: &str) -> Result<Option<f64>, String> {
        match self.v.get(key) {
            None | Some(Value::Null) => Ok(None),
            Some(x) => x
                .as_f64()
                .map(Some)
                .ok_or_else(|| format!("\"{key}\" of {} must be a number, not {x}", self.name)),
        }
    }

    /// A required number given as null says so, as any other non-number.
    fn required(&self, key: &str) -> Result<f64, String> {
        match self.v.get(key) {
            Some(Value::Null) => Err(format!(
                "\"{key}\" of {} must be a number, not null",
                self.name
            )),
            _ => self
                .number(key)?
                .ok_or_else(|| format!("{} needs a number \"{key}\"", self.name)),
        }
    }

    fn boolean(&self, key: &str) -> Result<Option<bool>, String> {
        match self.v.get(key) {
            None | Some(Value::Null) => Ok(None),
            Some(x) => x.as_bool().map(Some).ok_or_else(|| {
                format!("\"{key}\" of {} must be true or false, not {x}", self.name)
            }),
        }
    }
}

#[cfg(test)]
mod command_tests {
    use super::command_from_json;
    use anguilla_ipc::{Command, SwimParams};

    #[test]
    fn a_path_is_sent_as_json_waypoints_and_a_follow() {
        use anguilla_ipc::{Follow, Waypoint};
        assert_eq!(
            command_from_json(br#"{"command":"waypoint","index":2,"x":1.5,"y":-2,"depth":0.5}"#),
            Ok(Command::Waypoint(Waypoint {
                index: 2,
                x: 1.5,
                y: -2.0,
                depth: Some(0.5)
            }))
        );
        assert_eq!(
            command_from_json(
                br#"{"command":"follow","amplitude":1,"frequency":1,"count":3,"loop":true}"#
            ),
            Ok(Command::Follow(Follow {
                swim: SwimParams {
                    amplitude: 1.0,
                    frequency: 1.0,
                    turn: 0.0,
                    pitch: 0.0
                },
                count: 3,
                looped: true,
                from_here: false,
                resume: false
            }))
        );
    }

    #[test]
    fn commands_parse_and_bad_ones_say_what_was_expected() {
        assert_eq!(
            command_from_json(br#"{"command":"take-control"}"#),
            Ok(Command::TakeControl)
        );
        assert_eq!(
            command_from_json(br#"{"command":"swim","amplitude":0.5,"frequency":1}"#),
            Ok(Command::Swim(SwimParams {
                amplitude: 0.5,
                frequency: 1.0,
                turn: 0.0,
                pitch: 0.0
            }))
        );
        for (bad, says) in [
            (&b"{"[..], "not JSON"),
            (br#"{"cmd":"stop"}"#, "\"command\""),
            (br#"{"command":"fly"}"#, "unknown command \"fly\""),
            (
                br#"{"command":"swim","amplitude":0.5}"#,
                "needs a number \"frequency\"",
            ),
            (
                br#"{"command":"swim","amplitude":"big","frequency":1}"#,
                "\"amplitude\" of swim must be a number",
            ),
            (
                br#"{"command":"swim","amplitude":null,"frequency":1}"#,
                "\"amplitude\" of swim must be a number, not null",
            ),
            (
                br#"{"command":"waypoint","index":1.5,"x":0,"y":0}"#,
                "\"index\" of waypoint must be a whole number",
            ),
            (
                br#"{"command":"follow","amplitude":1,"frequency":1,"count":2,"loop":"yes"}"#,
                "\"loop\" of follow must be true or false",
            ),
        ] {
            let e = command_from_json(bad).unwrap_err();
            assert!(e.contains(says), "{e}");
        }
    }
    #[test]
    fn numbers_are_read_as_the_nearest_double() {
        // Found by the fuzz target foxglove_command: serde_json's default
        // parser read 5.55555555e+36 one unit in the last place low (the
        // power of ten is inexact), so a command written back as JSON
        // read as another command. std's parse is correctly rounded.
        for number in [
            "5.55555555e+36",
            "5555555550000000000000055555555555511",
            "0.1",
            "1e-7",
        ] {
            let text = format!(r#"{{"command":"swim","amplitude":0.5,"frequency":{number}}}"#);
            let Ok(Command::Swim(p)) = command_from_json(text.as_bytes()) else {
                panic!("{text} is a swim command");
            };
            assert_eq!(p.frequency, number.parse::<f64>().unwrap(), "{text}");
        }
    }
}
