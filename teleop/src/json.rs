//! `anguilla monitor --json`: a state snapshot as one JSON object.

use anguilla_ipc::FaultSet;
use anguilla_ipc::StateSnapshot;
use serde_json::{Value, json};

use crate::view::{cause_name, mode_name};

/// The snapshot's fields as JSON, with the mode, cause and faults also
/// spelled out (`mode_name`, `cause_name`, `faults`) and only the joints in use.
pub fn snapshot_json(s: &StateSnapshot) -> Value {
    let n = (s.joint_count as usize).min(s.joints.len());
    let gait = |g: &anguilla_ipc::GaitSnapshot| json!({"amplitude": g.amplitude, "frequency": g.frequency, "turn": g.turn, "pitch": g.pitch});
    let l = &s.loop_stats;
    let b = &s.bus;
    let faults = FaultSet {
        kinds: s.fault_kinds,
        nodes: s.fault_nodes,
    };
    json!({
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
        "gait_target": gait(&s.gait_target),
        "gait_actual": gait(&s.gait_actual),
        "loop_stats": {
            "period_ns": l.period_ns, "jitter_p50_ns": l.jitter_p50_ns,
            "jitter_p99_ns": l.jitter_p99_ns, "jitter_max_ns": l.jitter_max_ns,
            "compute_p50_ns": l.compute_p50_ns, "compute_p99_ns": l.compute_p99_ns,
            "compute_max_ns": l.compute_max_ns, "periods": l.periods, "overruns": l.overruns,
        },
        "bus": {
            "tx_frames": b.tx_frames, "rx_frames": b.rx_frames, "tx_dropped": b.tx_dropped,
            "malformed": b.malformed, "errors": b.errors, "rx_overruns": b.rx_overruns,
            "bus_off_count": b.bus_off_count,
            "state": b.state,
        },
        "clamped_setpoints": s.clamped_setpoints,
        "refused_commands": s.refused_commands,
        "socket_estops": s.socket_estops,
        "records_lost": s.records_lost,
        "operator_silent_stops": s.operator_silent_stops,
        "joint_count": s.joint_count,
        "joints": s.joints[..n].iter().map(|j| json!({
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
            "node_state": j.node_state, "node_alive": j.node_alive != 0,
            "node_errors": j.node_errors,
        })).collect::<Vec<_>>(),
    })
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
    }
}
