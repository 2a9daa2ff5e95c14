//! The JSON messages of `/anguilla/state`, `/anguilla/joints` and
//! `/anguilla/sensors`, one of each per snapshot.

use anguilla_ipc::{Cause, HoldState, Mode, SensorHealth, StateSnapshot};
use serde_json::{Value, json};

use super::schema;

pub(super) fn stamp(ns: u64) -> Value {
    json!({ "sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000 })
}

/// `v`, or 0 if it is not finite.
pub(super) fn finite(v: f32) -> f64 {
    if v.is_finite() { v as f64 } else { 0.0 }
}

/// `/anguilla/state`'s message; its schema is [`schema::state`].
pub(super) fn state_json(s: &StateSnapshot) -> Value {
    let gait = |g: &anguilla_ipc::GaitSnapshot| json!({ "amplitude": g.amplitude, "frequency": g.frequency, "turn": g.turn, "pitch": g.pitch });
    let n = &s.nav;
    json!({
        "time_ns": s.time_ns,
        "sequence": s.sequence,
        "mode": Mode::from_code(s.mode).map_or(schema::UNKNOWN, Mode::name),
        "cause": Cause::from_code(s.cause).map_or(schema::UNKNOWN, Cause::name),
        "fault_kinds": s.fault_kinds,
        "fault_nodes": s.fault_nodes,
        "feedforward_dropped": s.feedforward_dropped != 0,
        "predicted_head_speed": s.predicted_head_speed,
        "predicted_turn_rate": s.predicted_turn_rate,
        "gait_target": gait(&s.gait_target),
        "gait_actual": gait(&s.gait_actual),
        "bus": { "tx_frames": s.bus.tx_frames, "rx_frames": s.bus.rx_frames,
                 "tx_dropped": s.bus.tx_dropped, "malformed": s.bus.malformed,
                 "errors": s.bus.errors, "rx_overruns": s.bus.rx_overruns,
                 "bus_off_count": s.bus.bus_off_count, "state": s.bus.state },
        "loop": { "period_ns": s.loop_stats.period_ns, "jitter_p99_ns": s.loop_stats.jitter_p99_ns,
                  "jitter_max_ns": s.loop_stats.jitter_max_ns,
                  "compute_p99_ns": s.loop_stats.compute_p99_ns,
                  "periods": s.loop_stats.periods, "overruns": s.loop_stats.overruns },
        "clamped_setpoints": s.clamped_setpoints,
        "refused_commands": s.refused_commands,
        "records_lost": s.records_lost,
        "nav": { "sensor": SensorHealth::from_code(n.sensor).map_or(schema::UNKNOWN, SensorHealth::name),
                 "hold": n.hold,
                 "heading_hold": HoldState::from_code(n.heading_hold).map_or(schema::UNKNOWN, HoldState::name),
                 "depth_hold": HoldState::from_code(n.depth_hold).map_or(schema::UNKNOWN, HoldState::name),
                 "surfaced": n.surfaced != 0,
                 "heading_deg": n.heading_deg, "pitch_deg": n.pitch_deg,
                 "roll_deg": n.roll_deg, "depth_m": n.depth_m, "depth_rate": n.depth_rate,
                 "heading_target_deg": n.heading_target_deg, "depth_target_m": n.depth_target_m,
                 "rate_innovation": n.rate_innovation, "depth_innovation": n.depth_innovation,
                 "samples": n.samples, "lost_samples": n.lost_samples,
                 "x_m": n.x_m, "y_m": n.y_m, "position_sigma_m": n.position_sigma_m,
                 "position_fixes": n.position_fixes },
    })
}

/// `/anguilla/sensors`'s message: every sensor of the snapshot's list, its
/// values named by its kind; its schema is [`schema::sensors`].
pub(super) fn sensors_json(s: &StateSnapshot) -> Value {
    let list: Vec<Value> = s
        .sensors
        .iter()
        .filter(|e| e.kind != 0)
        .map(|e| {
            let values: Vec<Value> = e
                .named_values()
                .map(|(name, unit, v)| json!({ "name": name, "unit": unit, "value": finite(v) }))
                .collect();
            json!({
                "kind": e.sensor_kind().map_or(schema::UNKNOWN, anguilla_ipc::SensorKind::name),
                "id": e.id,
                "health": SensorHealth::from_code(e.health).map_or(schema::UNKNOWN, SensorHealth::name),
                "samples": e.samples,
                "values": values,
            })
        })
        .collect();
    json!({ "time_ns": s.time_ns, "sensors": list })
}

/// `/anguilla/joints`'s message; its schema is [`schema::joints`].
pub(super) fn joints_json(s: &StateSnapshot) -> Value {
    let n = (s.joint_count as usize).min(s.joints.len());
    let js = &s.joints[..n];
    let col = |f: &dyn Fn(&anguilla_ipc::JointSnapshot) -> f32| -> Vec<f32> {
        js.iter().map(f).collect()
    };
    json!({
        "commanded_pitch": col(&|j| j.commanded_pitch),
        "commanded_yaw": col(&|j| j.commanded_yaw),
        "measured_pitch": col(&|j| j.measured_pitch),
        "measured_yaw": col(&|j| j.measured_yaw),
        "commanded_pitch_velocity": col(&|j| j.commanded_pitch_velocity),
        "commanded_yaw_velocity": col(&|j| j.commanded_yaw_velocity),
        "measured_pitch_velocity": col(&|j| j.measured_pitch_velocity),
        "measured_yaw_velocity": col(&|j| j.measured_yaw_velocity),
        "feedforward_pitch_torque": col(&|j| j.predicted_pitch_torque),
        "feedforward_yaw_torque": col(&|j| j.predicted_yaw_torque),
        "measured_pitch_torque": col(&|j| j.measured_pitch_torque),
        "measured_yaw_torque": col(&|j| j.measured_yaw_torque),
        "pitch_torque_residual": col(&|j| j.pitch_torque_residual),
        "yaw_torque_residual": col(&|j| j.yaw_torque_residual),
        "residual_alarm": js.iter().map(|j| j.residual_alarm).collect::<Vec<_>>(),
        "node_state": js.iter().map(|j| j.node_state).collect::<Vec<_>>(),
        "node_alive": js.iter().map(|j| j.node_alive).collect::<Vec<_>>(),
    })
}
