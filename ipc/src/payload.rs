//! The `#[repr(C)]` payloads that cross shared memory: the state snapshot,
//! the command request and its reply.

use iceoryx2::prelude::*;

use crate::vocabulary::SwimParams;

/// Most joints a snapshot carries.
pub const MAX_JOINTS: usize = 32;
/// Version of the payload layouts; bumped on any change.
pub const LAYOUT_VERSION: u32 = 12;
/// Most sensors a snapshot carries.
pub const MAX_SENSORS: usize = 4;
/// Values a [`SensorEntry`] carries.
pub const SENSOR_VALUES: usize = 8;

/// One joint in a [`StateSnapshot`]: angles (rad), velocities (rad/s) and
/// torques (N·m) of its pitch and yaw axes.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::JointSnapshot")]
pub struct JointSnapshot {
    /// Commanded pitch angle (rad).
    pub commanded_pitch: f32,
    /// Commanded yaw angle (rad).
    pub commanded_yaw: f32,
    /// Measured pitch angle (rad).
    pub measured_pitch: f32,
    /// Measured yaw angle (rad).
    pub measured_yaw: f32,
    /// Commanded pitch velocity (rad/s).
    pub commanded_pitch_velocity: f32,
    /// Commanded yaw velocity (rad/s).
    pub commanded_yaw_velocity: f32,
    /// Measured pitch velocity (rad/s).
    pub measured_pitch_velocity: f32,
    /// Measured yaw velocity (rad/s).
    pub measured_yaw_velocity: f32,
    /// The model's predicted pitch torque, sent as feedforward (N·m).
    pub predicted_pitch_torque: f32,
    /// The model's predicted yaw torque, sent as feedforward (N·m).
    pub predicted_yaw_torque: f32,
    /// Measured pitch torque (N·m).
    pub measured_pitch_torque: f32,
    /// Measured yaw torque (N·m).
    pub measured_yaw_torque: f32,
    /// The node's state as it last reported it (protocol encoding: 0
    /// Boot, 1 Disabled, 2 Enabled, 3 Fault, 4 EStop), or
    /// [`JointSnapshot::NO_NODE_STATE`] if it has reported none yet.
    pub node_state: u8,
    /// 1 if the node's heartbeat is current, 0 if it is overdue.
    pub node_alive: u8,
    /// The torque-residual alarms (`[monitor]`, [`residual_bits`]): bit 0
    /// pitch, bit 1 yaw alarmed; bit 2 pitch, bit 3 yaw below the
    /// prediction (else above). 0: none.
    pub residual_alarm: u8,
    /// Padding, always 0.
    pub reserved: u8,
    /// The node's error bits as it last reported them (protocol encoding).
    pub node_errors: u32,
    /// The pitch axis's torque residual: measured less predicted torque,
    /// low-passed, over the prediction's low-passed magnitude plus a floor
    /// (`[monitor]`; 0 while not swimming, or without measured torque).
    pub pitch_torque_residual: f32,
    /// The yaw axis's torque residual, as the pitch's.
    pub yaw_torque_residual: f32,
}

/// [`JointSnapshot::residual_alarm`]'s bits.
pub mod residual_bits {
    /// The pitch axis is alarmed.
    pub const PITCH: u8 = 1;
    /// The yaw axis is alarmed.
    pub const YAW: u8 = 2;
    /// The pitch axis's residual is negative (needs less torque than
    /// predicted).
    pub const PITCH_BELOW: u8 = 4;
    /// The yaw axis's residual is negative.
    pub const YAW_BELOW: u8 = 8;
}

impl JointSnapshot {
    /// [`JointSnapshot::node_state`] of a node that has reported no state
    /// yet (no heartbeat, or a drive still being set up).
    pub const NO_NODE_STATE: u8 = 0xFF;
}

/// Gait parameters in a [`StateSnapshot`].
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::GaitSnapshot")]
pub struct GaitSnapshot {
    /// Amplitude, fraction of the configured maximum (0..=1).
    pub amplitude: f32,
    /// Frequency (Hz).
    pub frequency: f32,
    /// Yaw turn curvature K_c3 (1/m).
    pub turn: f32,
    /// Pitch curvature K_c2 (1/m).
    pub pitch: f32,
}

impl From<SwimParams> for GaitSnapshot {
    fn from(p: SwimParams) -> Self {
        Self {
            amplitude: p.amplitude as f32,
            frequency: p.frequency as f32,
            turn: p.turn as f32,
            pitch: p.pitch as f32,
        }
    }
}

/// Control-loop timing statistics over a sliding window (nanoseconds).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::LoopSnapshot")]
pub struct LoopSnapshot {
    /// The configured period.
    pub period_ns: u32,
    /// Wake-up lateness, median.
    pub jitter_p50_ns: u32,
    /// Wake-up lateness, 99th percentile.
    pub jitter_p99_ns: u32,
    /// Wake-up lateness, maximum.
    pub jitter_max_ns: u32,
    /// Compute time of one period, median.
    pub compute_p50_ns: u32,
    /// Compute time of one period, 99th percentile.
    pub compute_p99_ns: u32,
    /// Compute time of one period, maximum.
    pub compute_max_ns: u32,
    /// Padding, always 0.
    pub reserved: u32,
    /// Periods run since start.
    pub periods: u64,
    /// Periods that started late by more than a whole period (skipped, never caught up).
    pub overruns: u64,
}

/// Bus statistics since start.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::BusSnapshot")]
pub struct BusSnapshot {
    /// Frames sent.
    pub tx_frames: u64,
    /// Frames received.
    pub rx_frames: u64,
    /// Frames the driver could not send (queue full, bus-off).
    pub tx_dropped: u64,
    /// Frames received that did not decode (unknown id, bad length, bad value).
    pub malformed: u64,
    /// Bus error events reported by the driver.
    pub errors: u64,
    /// Frames lost on reception because a receive queue was full (the CAN
    /// controller's, or the kernel's socket buffer on SocketCAN).
    pub rx_overruns: u64,
    /// Times the bus went bus-off.
    pub bus_off_count: u32,
    /// 0 error-active, 1 error-passive, 2 bus-off, 3 adapter gone.
    pub state: u8,
    /// Padding, always 0.
    pub reserved: [u8; 3],
}

/// The daemon's limits, published so that tools need not read its
/// configuration file.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::LimitsSnapshot")]
pub struct LimitsSnapshot {
    /// Largest swim frequency accepted (Hz); the smallest is 0.
    pub max_frequency: f32,
    /// Largest |turn curvature| accepted (1/m).
    pub max_turn: f32,
    /// Largest |pitch curvature| accepted (1/m).
    pub max_pitch: f32,
    /// The holder's silence after which a swim stops smoothly (ms): a
    /// swimming tool resends within it.
    pub command_timeout_ms: u32,
    /// The holder's silence after which its control is released (ms).
    pub control_release_ms: u32,
    /// The daemon's process id.
    pub daemon_pid: u32,
}

/// The name of a [`BusSnapshot::state`] code, as operators see it.
pub fn bus_state_name(code: u8) -> &'static str {
    match code {
        0 => "error-active",
        1 => "error-passive",
        2 => "bus-off",
        3 => "adapter gone",
        _ => "unknown",
    }
}

/// The head sensor, the daemon's estimate of the head's attitude and depth,
/// and the autopilot (docs/autopilot.md). The estimate is 0
/// until the first sample (`samples` = 0), and moves on with the model's
/// prediction alone while no sample arrives; a target is 0 unless its
/// `hold` bit is set.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::NavSnapshot")]
pub struct NavSnapshot {
    /// The sensor's health (`SensorHealth`: 0 no sensor, 1 ok, 2 waiting,
    /// 3 silent, 4 stuck, 5 sensor error, 6 implausible).
    pub sensor: u8,
    /// What the autopilot holds now: bit 0 heading, bit 1 depth
    /// (`hold_bits`); 0 manual.
    pub hold: u8,
    /// Why the autopilot last let go of a hold (a `SensorHealth` code); 0
    /// if it never had to.
    pub hold_exit: u8,
    /// 1 while |roll| is beyond `[sensor] roll-alarm` (an alarm: the
    /// autopilot keeps steering, its commands turned by the roll).
    pub roll_alarm: u8,
    /// The body's heading (deg, 0 ..< 360, earth frame, counter-clockwise
    /// seen from above): the head's heading less the gait's swing of the
    /// head, which the model predicts.
    pub heading_deg: f32,
    /// The body's pitch (deg, positive nose up): its mean axis's, as the
    /// heading.
    pub pitch_deg: f32,
    /// The head's roll (deg, positive right side down).
    pub roll_deg: f32,
    /// The head's depth below the surface (m, positive down).
    pub depth_m: f32,
    /// The depth's rate of change (m/s, positive descending).
    pub depth_rate: f32,
    /// Water temperature (°C).
    pub temperature: f32,
    /// The heading held (deg).
    pub heading_target_deg: f32,
    /// The depth held (m).
    pub depth_target_m: f32,
    /// Model health: the gyro's body rates less the model's predicted head
    /// rates (rad/s, magnitude, low-passed over about a second).
    pub rate_innovation: f32,
    /// Model health: the measured depth less the predicted one (m), at the
    /// last sample.
    pub depth_innovation: f32,
    /// How the heading hold is doing (`HoldState`: 0 off, 1 waiting,
    /// 2 converging, 3 holding, 4 not converging, 5 cannot: surface,
    /// 6 cannot: limit, 7 cannot: authority).
    pub heading_hold: u8,
    /// How the depth hold is doing (`HoldState`, as `heading_hold`).
    pub depth_hold: u8,
    /// 1 while the depth estimate is at the surface (shallower than
    /// `SURFACE_DEPTH`, 0.05 m).
    pub surfaced: u8,
    /// Padding, always 0.
    pub reserved: u8,
    /// Head-sensor samples received since start.
    pub samples: u64,
    /// Samples the sample counter says were lost since start.
    pub lost_samples: u64,
    /// The nose's estimated position (m), in the estimate's local frame: x
    /// and y level, the origin where the estimate started. The model's
    /// predicted motion turned by the estimated attitude, corrected by
    /// position fixes (docs/autopilot.md, "Position").
    pub x_m: f32,
    /// y (m), as `x_m`.
    pub y_m: f32,
    /// The position's standard deviation (m, horizontal): 0 at the start,
    /// growing while dead-reckoned, shrinking with each fix.
    pub position_sigma_m: f32,
    /// Position fixes taken into the estimate since start.
    pub position_fixes: u32,
    /// The water's estimated velocity over ground (m/s), x, in the
    /// estimate's local frame: what moves the robot beside its own
    /// swimming, learnt from position fixes or a DVL's velocities (0
    /// without either).
    pub current_x: f32,
    /// The current's y (m/s), as `current_x`.
    pub current_y: f32,
    /// The current's standard deviation (m/s, per axis).
    pub current_sigma: f32,
    /// How long ago the last fix taken was measured (ms, saturating);
    /// `u32::MAX` before the first.
    pub fix_age_ms: u32,
    /// Whether fixes hold the position (`PositionHealth`: 0 dead
    /// reckoning, 1 waiting for a fix, 2 fixed, 3 fix stale, 4 fix lost).
    pub position_health: u8,
    /// Padding, always 0.
    pub reserved_position: [u8; 3],
    /// The factor by which the model's speed through the water is off,
    /// as the estimate learnt it from fixes and a DVL's velocities
    /// (`1 + k`, docs/autopilot.md, "Position"): 1.04 when the body swims
    /// 4 % faster than the model predicts; 1 until fixes or velocities
    /// tell, 0 without a head sensor.
    pub speed_scale: f32,
}

/// The path being followed (`Command::Follow`; docs/autopilot.md,
/// "Following a path"): where on it the robot is and what the guidance
/// asks. Positions in the estimate's local frame, as `NavSnapshot::x_m`.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct GuideSnapshot {
    /// How the path is doing (`GuideState`: 0 off, 1 following, 2 done,
    /// 3 ended by a command, 4 stopped: fix lost, 5 stopped: fence).
    pub state: u8,
    /// 1 when the path loops back to its first waypoint.
    pub looped: u8,
    /// The waypoint the current leg ends at (its index in the path).
    pub leg: u16,
    /// Waypoints in the path.
    pub waypoints: u16,
    /// Padding, always 0.
    pub reserved: u16,
    /// The body's centre's distance from the leg's line (m), positive
    /// left of its direction (the centre follows the path: half the
    /// body's length behind the nose, docs/autopilot.md).
    pub cross_track_m: f32,
    /// How far along the leg the body's centre is from its start (m).
    pub along_track_m: f32,
    /// The leg's length (m).
    pub leg_length_m: f32,
    /// The heading the guidance asks for (deg, as `heading_deg`).
    pub heading_deg: f32,
    /// The integral term's equivalent offset, `κ · y_int` (m): the
    /// sideways push of the current the guidance has learnt to lean
    /// against.
    pub integral_m: f32,
    /// The leg's start, x (m).
    pub from_x: f32,
    /// The leg's start, y (m).
    pub from_y: f32,
    /// The leg's end (the waypoint it heads for), x (m).
    pub to_x: f32,
    /// The leg's end, y (m).
    pub to_y: f32,
    /// The distance from the robot to the leg's end (m).
    pub to_go_m: f32,
}

impl GuideSnapshot {
    /// The path's state (`None`: an unknown code).
    pub fn guide_state(&self) -> Option<crate::GuideState> {
        crate::GuideState::from_code(self.state)
    }
}

/// A hold state code's name ("hold state N" for an unknown one).
fn hold_state_name(code: u8) -> std::borrow::Cow<'static, str> {
    crate::HoldState::from_code(code).map_or_else(
        || std::borrow::Cow::Owned(format!("hold state {code}")),
        |h| std::borrow::Cow::Borrowed(h.name()),
    )
}

impl NavSnapshot {
    /// The position's health (`None`: an unknown code).
    pub fn position_state(&self) -> Option<crate::PositionHealth> {
        crate::PositionHealth::from_code(self.position_health)
    }

    /// How long ago the last fix taken was measured (s); `None` before
    /// the first.
    pub fn fix_age_s(&self) -> Option<f64> {
        (self.position_fixes > 0 && self.fix_age_ms != u32::MAX)
            .then(|| f64::from(self.fix_age_ms) / 1e3)
    }

    /// The heading hold's state (`None`: an unknown code).
    pub fn heading_state(&self) -> Option<crate::HoldState> {
        crate::HoldState::from_code(self.heading_hold)
    }

    /// The depth hold's state (`None`: an unknown code).
    pub fn depth_state(&self) -> Option<crate::HoldState> {
        crate::HoldState::from_code(self.depth_hold)
    }

    /// The heading hold's state in words with its value and target, as
    /// the daemon judges it ("converging: heading 40.0 deg for 60.0 deg");
    /// `None` when the heading is not held.
    pub fn heading_words(&self) -> Option<String> {
        (self.heading_hold != 0).then(|| {
            format!(
                "{}: heading {:.1} deg for {:.1} deg",
                hold_state_name(self.heading_hold),
                self.heading_deg,
                self.heading_target_deg
            )
        })
    }

    /// The depth hold's state in words ("not converging: depth 2.50 m for
    /// 1.20 m"); `None` when the depth is not held.
    pub fn depth_words(&self) -> Option<String> {
        (self.depth_hold != 0).then(|| {
            format!(
                "{}: depth {:.2} m for {:.2} m",
                hold_state_name(self.depth_hold),
                self.depth_m,
                self.depth_target_m
            )
        })
    }

    /// Each held quantity's state in words with its value and target
    /// ([`NavSnapshot::heading_words`], [`NavSnapshot::depth_words`]);
    /// empty when nothing is held.
    pub fn hold_words(&self) -> Vec<String> {
        self.heading_words()
            .into_iter()
            .chain(self.depth_words())
            .collect()
    }

    /// Whether a held quantity is judged not to reach its target (not
    /// converging or cannot; an unknown code counts).
    pub fn hold_failed(&self) -> bool {
        [self.heading_hold, self.depth_hold]
            .into_iter()
            .any(|c| c != 0 && crate::HoldState::from_code(c).is_none_or(crate::HoldState::failed))
    }
}

/// One sensor in a [`StateSnapshot`]'s list: what it is, its bus id, its
/// health and its values, which [`SensorKind::values`](crate::SensorKind::values)
/// names. An entry of kind 0 is empty.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::SensorEntry")]
pub struct SensorEntry {
    /// `SensorKind` code (1 head-nav, 2 tail-imu); 0: no sensor here.
    pub kind: u8,
    /// Its node id on the bus.
    pub id: u8,
    /// Its health (`SensorHealth` code).
    pub health: u8,
    /// Padding, always 0.
    pub reserved: u8,
    /// Samples received since start.
    pub samples: u32,
    /// Its values, as its kind names them (0 before its first sample).
    pub values: [f32; SENSOR_VALUES],
}

impl SensorEntry {
    /// What sensor this is (`None`: an empty entry, or a kind this tool
    /// does not know).
    pub fn sensor_kind(&self) -> Option<crate::SensorKind> {
        crate::SensorKind::from_code(self.kind)
    }

    /// Its values with their names and units, as its kind names them
    /// (none for an empty or unknown entry).
    pub fn named_values(&self) -> impl Iterator<Item = (&'static str, &'static str, f32)> + '_ {
        self.sensor_kind()
            .map_or(&[][..], |k| k.values())
            .iter()
            .zip(self.values)
            .map(|(&(name, unit), v)| (name, unit, v))
    }
}

/// Everything an operator tool shows, published every control period.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::StateSnapshot")]
pub struct StateSnapshot {
    /// [`LAYOUT_VERSION`] of the publisher.
    pub layout_version: u32,
    /// Joints in use (the first `joint_count` entries of `joints`).
    pub joint_count: u32,
    /// Increments with every publication.
    pub sequence: u64,
    /// The loop's clock at publication (ns).
    pub time_ns: u64,
    /// Operating mode (see the supervisor's `Mode`: 0 idle, 1 enabling,
    /// 2 ready, 3 swimming, 4 stopping, 5 fault, 6 e-stop).
    pub mode: u8,
    /// Why the mode last changed (0 none, 1 command, 2 operator silent,
    /// 3 fault, 4 progress).
    pub cause: u8,
    /// 1 while the torque feedforward is dropped (model diverged).
    pub feedforward_dropped: u8,
    /// Padding, always 0.
    pub reserved: u8,
    /// Latched faults, one bit per kind (supervisor's `FaultKind`).
    pub fault_kinds: u32,
    /// Nodes involved in the faults (bit = node id).
    pub fault_nodes: u64,
    /// The client port holding control (its iceoryx2 `UniqueClientId`),
    /// low 64 bits; 0 and 0 if nobody holds it. A tool compares it with
    /// its own client port's id ([`crate::Client::id`]).
    pub holder_lo: u64,
    /// The holder's client port id, high 64 bits.
    pub holder_hi: u64,
    /// The model's predicted forward speed of the head (m/s).
    pub predicted_head_speed: f32,
    /// The model's predicted turn rate of the head (rad/s, positive left).
    pub predicted_turn_rate: f32,
    /// The gait the operator asked for.
    pub gait_target: GaitSnapshot,
    /// The gait being executed (the target, shaped by trapezoidal profiles).
    pub gait_actual: GaitSnapshot,
    /// Loop timing.
    pub loop_stats: LoopSnapshot,
    /// Bus statistics.
    pub bus: BusSnapshot,
    /// Setpoints clamped to joint limits since start.
    pub clamped_setpoints: u64,
    /// Commands refused since start.
    pub refused_commands: u64,
    /// Swims stopped because the holder went silent.
    pub operator_silent_stops: u64,
    /// E-stops taken out of band since start: datagrams on the reserved
    /// E-stop socket, and operator E-stops the command queue had no room for.
    pub socket_estops: u64,
    /// Recording records lost since start (the recorder fell behind, or
    /// failed: a full disk); 0 without a recording.
    pub records_lost: u64,
    /// The daemon's limits: what a command may ask for, and its timeouts.
    pub limits: LimitsSnapshot,
    /// The head sensor, the estimate and the autopilot.
    pub nav: NavSnapshot,
    /// The path being followed, or the last one (`GuideState`).
    pub guide: GuideSnapshot,
    /// Every configured sensor, the head sensor first (`kind` 0 past the
    /// last).
    pub sensors: [SensorEntry; MAX_SENSORS],
    /// Per joint, from the head (index 0) to the tail.
    pub joints: [JointSnapshot; MAX_JOINTS],
}

impl StateSnapshot {
    /// The torque-residual alarms: `(joint from 1, axis name, residual)`
    /// of every alarmed axis, head first.
    pub fn residual_alarms(&self) -> impl Iterator<Item = (usize, &'static str, f32)> + '_ {
        let n = (self.joint_count as usize).min(MAX_JOINTS);
        self.joints[..n].iter().enumerate().flat_map(|(j, js)| {
            [
                (residual_bits::PITCH, "pitch", js.pitch_torque_residual),
                (residual_bits::YAW, "yaw", js.yaw_torque_residual),
            ]
            .into_iter()
            .filter(move |(bit, _, _)| js.residual_alarm & bit != 0)
            .map(move |(_, axis, r)| (j + 1, axis, r))
        })
    }

    /// The client port holding control, if any.
    pub fn holder(&self) -> Option<u128> {
        let h = (self.holder_hi as u128) << 64 | self.holder_lo as u128;
        (h != 0).then_some(h)
    }

    /// Sets [`StateSnapshot::holder_lo`] and `holder_hi`.
    pub fn set_holder(&mut self, holder: Option<u128>) {
        let h = holder.unwrap_or(0);
        self.holder_lo = h as u64;
        self.holder_hi = (h >> 64) as u64;
    }
}

impl Default for StateSnapshot {
    fn default() -> Self {
        Self {
            layout_version: LAYOUT_VERSION,
            joint_count: 0,
            sequence: 0,
            time_ns: 0,
            mode: 0,
            cause: 0,
            feedforward_dropped: 0,
            reserved: 0,
            fault_kinds: 0,
            fault_nodes: 0,
            holder_lo: 0,
            holder_hi: 0,
            predicted_head_speed: 0.0,
            predicted_turn_rate: 0.0,
            gait_target: GaitSnapshot::default(),
            gait_actual: GaitSnapshot::default(),
            loop_stats: LoopSnapshot::default(),
            bus: BusSnapshot::default(),
            clamped_setpoints: 0,
            refused_commands: 0,
            operator_silent_stops: 0,
            socket_estops: 0,
            records_lost: 0,
            limits: LimitsSnapshot::default(),
            nav: NavSnapshot::default(),
            guide: GuideSnapshot::default(),
            sensors: [SensorEntry::default(); MAX_SENSORS],
            joints: [JointSnapshot::default(); MAX_JOINTS],
        }
    }
}

/// A payload as its raw bytes and back: the `#[repr(C)]` layout of
/// `docs/ipc.md` (native byte order: little-endian on every target the
/// daemon runs on). The recorder's `state.bin`, the session log's
/// commands and the remote link's messages use it.
///
/// Only for the payloads here, which are made of integers, floats and
/// arrays of them with no padding (the layout test checks that their
/// fields tile them), so every byte string of the right length is a value.
pub trait Raw: Copy + sealed::Sealed {
    /// The value's bytes.
    fn as_bytes(&self) -> &[u8] {
        // SAFETY: Self is #[repr(C)], Copy and has no padding (sealed to
        // the payloads the layout test covers).
        unsafe { core::slice::from_raw_parts(self as *const Self as *const u8, size_of::<Self>()) }
    }

    /// The value whose bytes are `bytes`; `None` unless `bytes` is exactly
    /// one value long.
    fn from_bytes(bytes: &[u8]) -> Option<Self> {
        if bytes.len() != size_of::<Self>() {
            return None;
        }
        let mut v = core::mem::MaybeUninit::<Self>::uninit();
        // SAFETY: same size, and every bit pattern is a valid value
        // (integers, floats and arrays of them only), so the copy
        // initializes it.
        unsafe {
            core::ptr::copy_nonoverlapping(bytes.as_ptr(), v.as_mut_ptr() as *mut u8, bytes.len());
            Some(v.assume_init())
        }
    }
}

pub(crate) mod sealed {
    pub trait Sealed {}
    impl Sealed for super::StateSnapshot {}
}

impl Raw for StateSnapshot {}
