//! The messages of `/anguilla/state`, `/anguilla/joints` and
//! `/anguilla/sensors`, one of each per snapshot: typed, each field's
//! schema written beside it ([`crate::view!`]), so the writer and the
//! schema cannot disagree.

use anguilla_ipc::{
    BusSnapshot, Cause, GaitSnapshot, GuideSnapshot, GuideState, HoldState, JointSnapshot,
    LoopSnapshot, MAX_JOINTS, MAX_SENSORS, Mode, PositionHealth, SENSOR_VALUES, SensorHealth,
    SensorKind, StateSnapshot,
};
use serde_json::Value;

use crate::schema::{
    UNKNOWN, array, bits, boolean, bus_state_codes, cause_names, codes, count, fault_bits,
    guide_state_names, hold_codes, hold_state_names, message, mode_names, names, node_state_codes,
    position_health_names, real, sensor_names, string,
};

/// `v`, or 0 if it is not finite.
pub(crate) fn finite(v: f32) -> f64 {
    if v.is_finite() { v as f64 } else { 0.0 }
}

fn mode_schema(d: &str) -> Value {
    names(d, mode_names())
}

fn faults_schema(d: &str) -> Value {
    let faults: Vec<String> = fault_bits()
        .iter()
        .map(|(b, n)| format!("{b} {n}"))
        .collect();
    bits(
        &format!("{d}; bit {}", faults.join(", ")),
        u64::from(u32::MAX),
    )
}

crate::view! {
    /// A gait's parameters
    pub struct Gait {
        /// Undulation amplitude, a fraction of the configured maximum (0..=1)
        amplitude: f32 => real,
        /// Undulation frequency (Hz)
        frequency: f32 => real,
        /// Yaw turn curvature K_c3 (1/m, positive turns left)
        turn: f32 => real,
        /// Pitch curvature K_c2 (1/m, positive dives)
        pitch: f32 => real,
    }
}

impl From<&GaitSnapshot> for Gait {
    fn from(g: &GaitSnapshot) -> Self {
        Self {
            amplitude: g.amplitude,
            frequency: g.frequency,
            turn: g.turn,
            pitch: g.pitch,
        }
    }
}

crate::view! {
    /// Bus statistics since start
    pub struct Bus {
        /// Frames sent
        tx_frames: u64 => count,
        /// Frames received
        rx_frames: u64 => count,
        /// Frames the driver could not send (queue full, bus-off)
        tx_dropped: u64 => count,
        /// Frames received that did not decode (unknown id, bad length, bad value)
        malformed: u64 => count,
        /// Bus error events the driver reported
        errors: u64 => count,
        /// Frames lost on reception to a full receive queue
        rx_overruns: u64 => count,
        /// Times the bus went bus-off
        bus_off_count: u32 => count,
        /// The bus state the period acted on
        state: u8 => |d: &str| codes(d, &bus_state_codes()),
    }
}

crate::view! {
    /// Control-loop timing over a sliding window
    pub struct Loop {
        /// The configured control period (ns)
        period_ns: u32 => count,
        /// Wake-up lateness, median (ns)
        jitter_p50_ns: u32 => count,
        /// Wake-up lateness, 99th percentile (ns)
        jitter_p99_ns: u32 => count,
        /// Wake-up lateness, maximum (ns)
        jitter_max_ns: u32 => count,
        /// Compute time of one period, median (ns)
        compute_p50_ns: u32 => count,
        /// Compute time of one period, 99th percentile (ns)
        compute_p99_ns: u32 => count,
        /// Compute time of one period, maximum (ns)
        compute_max_ns: u32 => count,
        /// Periods run since start
        periods: u64 => count,
        /// Periods that started more than a whole period late (skipped, never caught up)
        overruns: u64 => count,
    }
}

impl From<&BusSnapshot> for Bus {
    fn from(b: &BusSnapshot) -> Self {
        Self {
            tx_frames: b.tx_frames,
            rx_frames: b.rx_frames,
            tx_dropped: b.tx_dropped,
            malformed: b.malformed,
            errors: b.errors,
            rx_overruns: b.rx_overruns,
            bus_off_count: b.bus_off_count,
            state: b.state,
        }
    }
}

impl From<&LoopSnapshot> for Loop {
    fn from(l: &LoopSnapshot) -> Self {
        Self {
            period_ns: l.period_ns,
            jitter_p50_ns: l.jitter_p50_ns,
            jitter_p99_ns: l.jitter_p99_ns,
            jitter_max_ns: l.jitter_max_ns,
            compute_p50_ns: l.compute_p50_ns,
            compute_p99_ns: l.compute_p99_ns,
            compute_max_ns: l.compute_max_ns,
            periods: l.periods,
            overruns: l.overruns,
        }
    }
}

crate::view! {
    /// The head sensor, the daemon's estimate of the head's attitude and depth
    /// (0 until the first sample), and the autopilot (docs/autopilot.md)
    pub struct Nav {
        /// The head sensor's health
        sensor: &'static str => |d: &str| names(d, sensor_names()),
        /// What the autopilot holds (bit 0 heading, bit 1 depth)
        hold: u8 => |d: &str| codes(d, &hold_codes()),
        /// How the heading hold is doing, as the daemon judges it (off: not
        /// held; not converging and cannot: the target is not reached)
        heading_hold: &'static str => |d: &str| names(d, hold_state_names()),
        /// How the depth hold is doing, as the daemon judges it
        depth_hold: &'static str => |d: &str| names(d, hold_state_names()),
        /// True while the depth estimate is at the surface (shallower than 0.05 m)
        surfaced: bool => boolean,
        /// The body's heading (deg, 0..<360, earth frame, counter-clockwise seen from above)
        heading_deg: f32 => real,
        /// The body's pitch (deg, positive nose up)
        pitch_deg: f32 => real,
        /// The head's roll (deg, positive right side down)
        roll_deg: f32 => real,
        /// The head's depth below the surface (m, positive down)
        depth_m: f32 => real,
        /// The depth's rate of change (m/s, positive descending)
        depth_rate: f32 => real,
        /// The heading held (deg); 0 unless hold has bit 0
        heading_target_deg: f32 => real,
        /// The depth held (m, positive down); 0 unless hold has bit 1
        depth_target_m: f32 => real,
        /// Model health: the gyro's body rates less the model's predicted head
        /// rates (rad/s, magnitude, low-passed over about 1 s)
        rate_innovation: f32 => real,
        /// Model health: the measured depth less the predicted one at the last sample (m)
        depth_innovation: f32 => real,
        /// Head-sensor samples received since start
        samples: u64 => count,
        /// Samples the sensor's counter says were lost since start
        lost_samples: u64 => count,
        /// The nose's estimated position (m), x, in the estimate's local frame
        /// (x, y level, the origin where the estimate started): the model's
        /// motion dead-reckoned with the estimated attitude, corrected by
        /// position fixes
        x_m: f32 => real,
        /// The nose's estimated position (m), y, as x_m
        y_m: f32 => real,
        /// The position's standard deviation (m, horizontal)
        position_sigma_m: f32 => real,
        /// Position fixes taken into the estimate since start
        position_fixes: u32 => count,
        /// Whether fixes hold the position: dead reckoning (no position
        /// sensor), waiting for a fix, fixed, fix stale (older than
        /// \[autopilot\] fix-stale), fix lost (older than fix-lost)
        position_health: &'static str => |d: &str| names(d, position_health_names()),
        /// How long ago the last fix taken was measured (s); null before the first
        fix_age_s: Option<f64> => real,
        /// The water's estimated velocity over ground (m/s), x, in the
        /// estimate's frame: what moves the robot beside its swimming,
        /// learnt from position fixes or a DVL's velocities (0 without either)
        current_x: f32 => real,
        /// The current's y (m/s), as current_x
        current_y: f32 => real,
        /// The current's standard deviation (m/s, per axis)
        current_sigma: f32 => real,
        /// The factor by which the model's speed through the water is off,
        /// as fixes and a DVL's velocities taught the estimate (1 until
        /// they tell; 0 without a head sensor)
        speed_scale: f32 => real,
    }
}

crate::view! {
    /// The path being followed, or the last one (docs/autopilot.md,
    /// "Following a path"); positions in the estimate's frame, as nav.x_m
    pub struct Guide {
        /// How the path is doing (off: no path since the start; stopped: it
        /// was not finished)
        state: &'static str => |d: &str| names(d, guide_state_names()),
        /// Waypoints in the path
        waypoints: u16 => count,
        /// The waypoint the current leg ends at (its index, from 0)
        leg: u16 => count,
        /// True when the path loops back to its first waypoint
        looped: bool => boolean,
        /// The body's centre's distance from the leg's line (m), positive
        /// left of its direction (the centre follows the path)
        cross_track_m: f32 => real,
        /// How far along the leg the body's centre is from its start (m)
        along_track_m: f32 => real,
        /// The leg's length (m)
        leg_length_m: f32 => real,
        /// The heading the guidance asks of the heading hold (deg)
        heading_deg: f32 => real,
        /// The integral term's offset (m): the current's sideways push the
        /// guidance has learnt to lean against
        integral_m: f32 => real,
        /// The leg's start, x (m)
        from_x: f32 => real,
        /// The leg's start, y (m)
        from_y: f32 => real,
        /// The leg's end (the waypoint it heads for), x (m)
        to_x: f32 => real,
        /// The leg's end, y (m)
        to_y: f32 => real,
        /// The distance from the robot to the leg's end (m)
        to_go_m: f32 => real,
    }
}

impl From<&GuideSnapshot> for Guide {
    fn from(g: &GuideSnapshot) -> Self {
        Self {
            state: GuideState::from_code(g.state).map_or(UNKNOWN, GuideState::name),
            waypoints: g.waypoints,
            leg: g.leg,
            looped: g.looped != 0,
            cross_track_m: g.cross_track_m,
            along_track_m: g.along_track_m,
            leg_length_m: g.leg_length_m,
            heading_deg: g.heading_deg,
            integral_m: g.integral_m,
            from_x: g.from_x,
            from_y: g.from_y,
            to_x: g.to_x,
            to_y: g.to_y,
            to_go_m: g.to_go_m,
        }
    }
}

fn hold_state(code: u8) -> &'static str {
    HoldState::from_code(code).map_or(UNKNOWN, HoldState::name)
}

crate::view! {
    /// The daemon's state: mode, faults, gait, the model's prediction, bus and
    /// loop statistics, the head sensor's estimate and the autopilot
    pub struct State {
        /// The daemon's clock when the snapshot was taken (ns since the
        /// controller started; the message's log time)
        time_ns: u64 => count,
        /// The snapshot's number: +1 every control period (a recording keeps
        /// every tenth, the live view at most --rate a second)
        sequence: u64 => count,
        /// Operating mode
        mode: &'static str => mode_schema,
        /// Why the mode last changed
        cause: &'static str => |d: &str| names(d, cause_names()),
        /// Latched faults, one bit each (0: none)
        fault_kinds: u32 => faults_schema,
        /// Nodes involved in the faults: bit i set for node id i (0..=63)
        fault_nodes: u64 => count,
        /// True while the torque feedforward is dropped (the model diverged)
        feedforward_dropped: bool => boolean,
        /// The model's predicted forward speed of the head (m/s)
        predicted_head_speed: f32 => real,
        /// The model's predicted turn rate of the head (rad/s, positive left)
        predicted_turn_rate: f32 => real,
        /// The gait the operator asked for
        gait_target: Gait => Gait::object,
        /// The gait being executed: the target shaped by trapezoidal profiles
        gait_actual: Gait => Gait::object,
        /// Bus statistics since start
        bus: Bus => Bus::object,
        /// Control-loop timing over a sliding window
        loop_stats as "loop": Loop => Loop::object,
        /// Setpoints clamped to the joint limits since start
        clamped_setpoints: u64 => count,
        /// Operator commands refused since start
        refused_commands: u64 => count,
        /// Recording records lost since start (the recorder fell behind or
        /// failed); 0 without a recording
        records_lost: u64 => count,
        /// The head sensor, the daemon's estimate of the head's attitude and
        /// depth (0 until the first sample), and the autopilot (docs/autopilot.md)
        nav: Nav => Nav::object,
        /// The path being followed, or the last one
        guide: Guide => Guide::object,
    }
}

impl State {
    /// The message's schema (`anguilla.State`).
    pub fn schema() -> Value {
        message("anguilla.State", &Self::description(), Self::properties())
    }
}

impl From<&StateSnapshot> for State {
    fn from(s: &StateSnapshot) -> Self {
        let n = &s.nav;
        Self {
            time_ns: s.time_ns,
            sequence: s.sequence,
            mode: Mode::from_code(s.mode).map_or(UNKNOWN, Mode::name),
            cause: Cause::from_code(s.cause).map_or(UNKNOWN, Cause::name),
            fault_kinds: s.fault_kinds,
            fault_nodes: s.fault_nodes,
            feedforward_dropped: s.feedforward_dropped != 0,
            predicted_head_speed: s.predicted_head_speed,
            predicted_turn_rate: s.predicted_turn_rate,
            gait_target: Gait::from(&s.gait_target),
            gait_actual: Gait::from(&s.gait_actual),
            bus: Bus::from(&s.bus),
            loop_stats: Loop::from(&s.loop_stats),
            clamped_setpoints: s.clamped_setpoints,
            refused_commands: s.refused_commands,
            records_lost: s.records_lost,
            nav: Nav {
                sensor: SensorHealth::from_code(n.sensor).map_or(UNKNOWN, SensorHealth::name),
                hold: n.hold,
                heading_hold: hold_state(n.heading_hold),
                depth_hold: hold_state(n.depth_hold),
                surfaced: n.surfaced != 0,
                heading_deg: n.heading_deg,
                pitch_deg: n.pitch_deg,
                roll_deg: n.roll_deg,
                depth_m: n.depth_m,
                depth_rate: n.depth_rate,
                heading_target_deg: n.heading_target_deg,
                depth_target_m: n.depth_target_m,
                rate_innovation: n.rate_innovation,
                depth_innovation: n.depth_innovation,
                samples: n.samples,
                lost_samples: n.lost_samples,
                x_m: n.x_m,
                y_m: n.y_m,
                position_sigma_m: n.position_sigma_m,
                position_fixes: n.position_fixes,
                position_health: n.position_state().map_or(UNKNOWN, PositionHealth::name),
                fix_age_s: n.fix_age_s(),
                current_x: n.current_x,
                current_y: n.current_y,
                current_sigma: n.current_sigma,
                speed_scale: n.speed_scale,
            },
            guide: Guide::from(&s.guide),
        }
    }
}

/// A float per joint, head first.
fn per_joint(d: &str) -> Value {
    array(&format!("{d}, per joint, head first"), real(d), MAX_JOINTS)
}

fn residual_alarms(d: &str) -> Value {
    let one = bits(
        "Bit 0 pitch, bit 1 yaw alarmed; bit 2 pitch, bit 3 yaw below the \
         prediction (else above); 0 none",
        15,
    );
    array(d, one, MAX_JOINTS)
}

fn node_states(d: &str) -> Value {
    let one = codes(
        "The node's state (for a bought drive family, the worse of the \
         joint's two drives; docs/ipc.md)",
        &node_state_codes(),
    );
    array(d, one, MAX_JOINTS)
}

fn node_alive(d: &str) -> Value {
    let one = codes(
        "The node's heartbeat",
        &[(0, "overdue".into()), (1, "current".into())],
    );
    array(d, one, MAX_JOINTS)
}

crate::view! {
    /// Per joint (head first; the configured joints): commanded and measured
    /// angles and rates, the model's feedforward torque, the measured torque,
    /// and the node's state
    pub struct Joints {
        /// Commanded pitch angle (rad)
        commanded_pitch: Vec<f32> => per_joint,
        /// Commanded yaw angle (rad)
        commanded_yaw: Vec<f32> => per_joint,
        /// Measured pitch angle (rad)
        measured_pitch: Vec<f32> => per_joint,
        /// Measured yaw angle (rad)
        measured_yaw: Vec<f32> => per_joint,
        /// Commanded pitch velocity (rad/s)
        commanded_pitch_velocity: Vec<f32> => per_joint,
        /// Commanded yaw velocity (rad/s)
        commanded_yaw_velocity: Vec<f32> => per_joint,
        /// Measured pitch velocity (rad/s)
        measured_pitch_velocity: Vec<f32> => per_joint,
        /// Measured yaw velocity (rad/s)
        measured_yaw_velocity: Vec<f32> => per_joint,
        /// The model's pitch torque, sent as feedforward (N·m)
        feedforward_pitch_torque: Vec<f32> => per_joint,
        /// The model's yaw torque, sent as feedforward (N·m)
        feedforward_yaw_torque: Vec<f32> => per_joint,
        /// Measured pitch torque (N·m)
        measured_pitch_torque: Vec<f32> => per_joint,
        /// Measured yaw torque (N·m)
        measured_yaw_torque: Vec<f32> => per_joint,
        /// Pitch torque residual: measured less predicted torque, low-passed,
        /// over the prediction's low-passed magnitude plus a floor (\[monitor\];
        /// 0 while not swimming or without measured torque)
        pitch_torque_residual: Vec<f32> => per_joint,
        /// Yaw torque residual, as the pitch's
        yaw_torque_residual: Vec<f32> => per_joint,
        /// The torque-residual alarms, per joint, head first
        residual_alarm: Vec<u8> => residual_alarms,
        /// The node's state as it last reported it, per joint, head first
        node_state: Vec<u8> => node_states,
        /// Whether the node's heartbeat is current, per joint, head first
        node_alive: Vec<u8> => node_alive,
    }
}

impl Joints {
    /// The message's schema (`anguilla.Joints`).
    pub fn schema() -> Value {
        message("anguilla.Joints", &Self::description(), Self::properties())
    }
}

impl From<&StateSnapshot> for Joints {
    fn from(s: &StateSnapshot) -> Self {
        let n = (s.joint_count as usize).min(s.joints.len());
        let js = &s.joints[..n];
        let col = |f: fn(&JointSnapshot) -> f32| js.iter().map(f).collect();
        let codes = |f: fn(&JointSnapshot) -> u8| js.iter().map(f).collect();
        Self {
            commanded_pitch: col(|j| j.commanded_pitch),
            commanded_yaw: col(|j| j.commanded_yaw),
            measured_pitch: col(|j| j.measured_pitch),
            measured_yaw: col(|j| j.measured_yaw),
            commanded_pitch_velocity: col(|j| j.commanded_pitch_velocity),
            commanded_yaw_velocity: col(|j| j.commanded_yaw_velocity),
            measured_pitch_velocity: col(|j| j.measured_pitch_velocity),
            measured_yaw_velocity: col(|j| j.measured_yaw_velocity),
            feedforward_pitch_torque: col(|j| j.predicted_pitch_torque),
            feedforward_yaw_torque: col(|j| j.predicted_yaw_torque),
            measured_pitch_torque: col(|j| j.measured_pitch_torque),
            measured_yaw_torque: col(|j| j.measured_yaw_torque),
            pitch_torque_residual: col(|j| j.pitch_torque_residual),
            yaw_torque_residual: col(|j| j.yaw_torque_residual),
            residual_alarm: codes(|j| j.residual_alarm),
            node_state: codes(|j| j.node_state),
            node_alive: codes(|j| j.node_alive),
        }
    }
}

crate::view! {
    /// One value
    pub struct SensorValue {
        /// The value's name
        name: &'static str => string,
        /// Its unit
        unit: &'static str => string,
        /// The value
        value: f64 => real,
    }
}

fn kinds(d: &str) -> Value {
    let kinds: Vec<String> = SensorKind::ALL
        .iter()
        .map(|k| {
            let v: Vec<&str> = k.values().iter().map(|(n, _)| *n).collect();
            format!("{} ({})", k.name(), v.join(", "))
        })
        .collect();
    names(
        &format!("{d}: {}", kinds.join("; ")),
        SensorKind::ALL.iter().map(|k| k.name()).chain([UNKNOWN]),
    )
}

fn values(d: &str) -> Value {
    array(d, SensorValue::object("One value"), SENSOR_VALUES)
}

crate::view! {
    /// One sensor
    pub struct Sensor {
        /// What it is
        kind: &'static str => kinds,
        /// Its node id on the bus
        id: u8 => count,
        /// Its health
        health: &'static str => |d: &str| names(d, sensor_names()),
        /// Samples received since start
        samples: u32 => count,
        /// Its values, in its kind's order (none before its first sample is
        /// counted, zeros until then)
        values: Vec<SensorValue> => values,
    }
}

fn sensor_list(d: &str) -> Value {
    array(d, Sensor::object("One sensor"), MAX_SENSORS)
}

crate::view! {
    /// Every configured sensor, the head sensor first: its kind, node id,
    /// health and values (each named, with its unit)
    pub struct Sensors {
        /// The daemon's clock when the snapshot was taken (ns)
        time_ns: u64 => count,
        /// The sensors
        sensors: Vec<Sensor> => sensor_list,
    }
}

impl Sensors {
    /// The message's schema (`anguilla.Sensors`).
    pub fn schema() -> Value {
        message("anguilla.Sensors", &Self::description(), Self::properties())
    }
}

impl From<&StateSnapshot> for Sensors {
    fn from(s: &StateSnapshot) -> Self {
        let sensors = s
            .sensors
            .iter()
            .filter(|e| e.kind != 0)
            .map(|e| Sensor {
                kind: e.sensor_kind().map_or(UNKNOWN, SensorKind::name),
                id: e.id,
                health: SensorHealth::from_code(e.health).map_or(UNKNOWN, SensorHealth::name),
                samples: e.samples,
                values: e
                    .named_values()
                    .map(|(name, unit, v)| SensorValue {
                        name,
                        unit,
                        value: finite(v),
                    })
                    .collect(),
            })
            .collect();
        Self {
            time_ns: s.time_ns,
            sensors,
        }
    }
}
