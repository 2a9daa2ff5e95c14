//! One control period, from bus to bus.
//!
//! [`Controller::run_period`] is everything the loop thread does in a period, in
//! this order (`docs/architecture.md`, "The control loop and its
//! threads"):
//!
//! 1. drain the bus into the joints' [`Drives`] (the family's master);
//! 2. the head sensor's `Nav` estimate moves on with the model's
//!    prediction and the newest sample; the `Supervisor` turns
//!    observations and timeouts into directives (operator commands arrive
//!    before, through [`Controller::command`]); a hold whose sensor failed
//!    ends, and the swim stops smoothly;
//! 3. a path followed sets the heading (and depth) held, from the
//!    estimate's position ([`Guidance`]; a path done, the fix lost or the
//!    geofence crossed stops the swim); the [`Autopilot`] replaces the
//!    turn and pitch of what it holds; the
//!    gait parameters follow the operator's targets along our own
//!    trapezoidal [`profile`](crate::profile)s (and the model's parametric
//!    gait smooths them once more, to C² in time);
//! 4. the model's forward + inverse dynamics step gives every joint an
//!    angle, a rate and a torque feedforward, plus the predicted head speed
//!    and turn rate; a posture offset (also trapezoidal) straightens the
//!    body from wherever it was when the actuators were enabled;
//! 5. joint limits clamp (and count) the setpoints;
//! 6. the drives turn the supervisor's decision and the setpoints into
//!    their family's frames (and SYNC where the family has one);
//! 7. the [`StateSnapshot`] is filled for publication.
//!
//! Steps 1 to 5 are in `control/steps.rs`, step 7 in `control/snapshot.rs`.
//!
//! Time is a parameter (`now`, ns): the loop passes its clock, tests pass a
//! simulated one. After construction nothing here allocates (a
//! counting-allocator test runs whole periods).

use anguilla_drivers::{Bus, BusState};
use anguilla_model::{
    GaitParams, HeadState, Integrator, Model, ModelConfig, ModelError, ParametricGait, StepReport,
    Workspace,
};
use anguilla_protocol::message::{AxisSetpoint, NodeSet};

use crate::autopilot::{self, Autopilot};
use crate::config::{Config, FaultPolicyConfig};
use crate::drive::Liveness;
use crate::drive::{self, DriveError, Drives, Out, Period};
use crate::guidance::Guidance;
use crate::nav::Nav;
use crate::profile::{Follower, Limits};
use crate::residual::ResidualMonitor;
use crate::sensors::Sensors;
use crate::session::Record;
use crate::supervisor::{FaultPolicy, Supervisor, SupervisorConfig};
use crate::tracking::Tracking;
use anguilla_ipc::vocabulary::{ClientId, Command, Mode, Nanos};
use anguilla_ipc::{
    CommandReply, CommandRequest, Envelope, Hold, LimitsSnapshot, MAX_JOINTS, SensorHealth,
    StateSnapshot,
};

/// The drives' way to `bus` for the controller `ctl` this period: every
/// frame recorded, every refusal counted (split borrows of its fields, so
/// the drives can be borrowed beside it).
macro_rules! out {
    ($ctl:ident, $bus:expr) => {
        Out {
            bus: $bus,
            tap: &$ctl.tap,
            tap_dropped: &mut $ctl.tap_dropped,
            tx_errors: &mut $ctl.counters.tx_errors,
            now: $ctl.now,
        }
    };
}

// After `out!`, which `steps` uses.
mod snapshot;
mod steps;

const MS: Nanos = Nanos::from_millis(1);

/// The gait's period when the operator's frequency is 0: the wave stands
/// still (a period must be finite for the model).
const STILL_PERIOD: f64 = 1e6;

/// What went wrong building a controller from a configuration.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// The model refused the discretization or the body.
    #[error("model: {0}")]
    Model(#[from] ModelError),
    /// A drive's node id is not valid for its family.
    #[error(transparent)]
    Drive(#[from] DriveError),
    /// A gait limit is invalid.
    #[error("gait profile limits: {0}")]
    Profile(#[from] crate::profile::ProfileError),
    /// A sensor off the bus cannot open its source.
    #[error(transparent)]
    Sensor(#[from] crate::sensors::SensorError),
}

/// Counters of what the controller did to setpoints and frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ControlCounters {
    /// Setpoint values clamped to joint limits.
    pub clamped: u64,
    /// Commands refused.
    pub refused: u64,
    /// Frames the bus refused to send.
    pub tx_errors: u64,
    /// Periods whose model step failed.
    pub model_failures: u64,
}

/// The whole state the loop thread owns.
pub struct Controller {
    period_ns: Nanos,
    dt: f64,
    joints: usize,
    cfg: Config,
    sup: Supervisor,
    drives: Box<dyn Drives>,
    amplitude: Follower,
    frequency: Follower,
    turn: Follower,
    pitch: Follower,
    gait: ParametricGait,
    model: Model,
    ws: Workspace,
    head: HeadState,
    offsets: Vec<[Follower; 2]>,
    setpoints: Vec<[AxisSetpoint; 2]>,
    torque_ff: Vec<[f64; 2]>,
    /// Per joint, last period's model rates and torques `[pitch rate, yaw
    /// rate, pitch torque, yaw torque]` (the drives' terms of the
    /// feed-forward differentiate them), and whether they are set.
    ff_prev: Vec<[f64; 4]>,
    ff_primed: bool,
    counter: u16,
    mode_before: Mode,
    /// Joints that get no setpoint this period (lost or silent, in Fault).
    setpoint_skip: NodeSet,
    /// When a joint counts as lost or silent.
    liveness: Liveness,
    model_failed: bool,
    last_model_error: Option<ModelError>,
    report: StepReport,
    counters: ControlCounters,
    holder_node: Option<(ClientId, u128)>,
    new_holder_node: bool,
    snapshot: StateSnapshot,
    started: Nanos,
    tap: Option<crossbeam_channel::Sender<Record>>,
    tap_dropped: u64,
    now: Nanos,
    sensors: Sensors,
    residual: ResidualMonitor,
    autopilot: Option<Autopilot>,
    guidance: Guidance,
    hold: Hold,
    hold_exit: Option<SensorHealth>,
    /// How the heading and depth holds are doing, judged each period.
    hold_states: [anguilla_ipc::HoldState; 2],
    /// The second line ([`crate::tracking`]).
    tracking: Tracking,
    /// The setpoints of the last period were sent and followed (Ready,
    /// Swimming, Stopping): this period's feedback answers them.
    setpoints_followed: bool,
    /// The joints' report ids, in joint order.
    report_ids: Vec<anguilla_protocol::message::NodeId>,
}

/// The control period (ns) for `cfg`: 1 / [`Config::control_rate`] (a
/// validated configuration always has one, and [`crate::run::spawn`]
/// refuses one without; 100 Hz otherwise).
pub fn period_ns(cfg: &Config) -> Nanos {
    let rate = cfg.control_rate().unwrap_or(100.0);
    Nanos::from_nanos((1e9 / rate).ceil() as u64)
}

impl Controller {
    /// Builds the controller for `cfg` at time `now`. Allocates everything
    /// the periods will use.
    pub fn new(cfg: &Config, now: Nanos) -> Result<Self, SetupError> {
        let period_ns = period_ns(cfg);
        let dt = period_ns.as_nanos() as f64 * 1e-9;
        let drives = drive::build(cfg, now, period_ns)?;
        let joints = cfg.robot.joints;
        let model = Model::new(ModelConfig {
            body: cfg.model.body(),
            nodes: cfg.model.nodes,
            dt,
            joints,
            integrator: Integrator::Midpoint,
        })?;
        let ws = Workspace::new(&model);
        // The autopilot's feed-forward: how this body answers its
        // curvatures, from the model itself (only with a head sensor).
        let autopilot = match cfg.sensor.node {
            0 => None,
            _ => Some(Autopilot::new(cfg, autopilot::calibrate(cfg, &model)?)),
        };
        // After the calibration: the sensors' boot time counts from here.
        let sensors = Sensors::new(cfg, now)?;
        let g = &cfg.gait;
        let lim = |v, a| Limits::new(v, a);
        let amp_l = lim(g.amplitude_rate, g.amplitude_accel)?;
        let freq_l = lim(g.frequency_rate, g.frequency_accel)?;
        let curv_l = lim(g.curvature_rate, g.curvature_accel)?;
        let posture_l = lim(cfg.limits.velocity * 0.25, cfg.limits.velocity)?;
        let rest = GaitParams {
            wavelength: g.wavelength,
            period: STILL_PERIOD,
            amplitude: [0.0; 3],
            phase: 0.0,
            kc3: 0.0,
            kc2: 0.0,
        };
        let c = &cfg.control;
        let mut sup = Supervisor::new(SupervisorConfig {
            command_timeout: Nanos::from_secs_f64(c.command_timeout),
            control_release_timeout: Nanos::from_secs_f64(c.control_release_timeout),
            enable_timeout: Nanos::from_secs_f64(c.enable_timeout),
            max_frequency: g.max_frequency,
            max_turn: g.max_turn,
            max_pitch: g.max_pitch,
            fault_policy: match c.fault_policy {
                FaultPolicyConfig::Hold => FaultPolicy::Hold,
                FaultPolicyConfig::Disable => FaultPolicy::Disable,
            },
            max_depth: cfg.autopilot.max_depth,
            // A node owes a heartbeat within the heartbeat timeout: that
            // long after a reset, its report reflects the clear-faults (at
            // least 300 ms). The built-in robot's relaxed timeout (2 s)
            // covers its own starvation on a busy machine, which once
            // re-latched an E-stop after a reset in the VM's gamepad test.
            clear_settle_time: Nanos::from_secs_f64(c.heartbeat_timeout).max(300 * MS),
        });
        // The sensor as it is before the first period (waiting, or none):
        // the supervisor alone judges a Hold, on what it observed.
        sup.observe_sensor(now, sensors.head_health());
        let n = joints;
        let snapshot = StateSnapshot {
            joint_count: n.min(MAX_JOINTS) as u32,
            limits: LimitsSnapshot {
                max_frequency: g.max_frequency as f32,
                max_turn: g.max_turn as f32,
                max_pitch: g.max_pitch as f32,
                command_timeout_ms: (c.command_timeout * 1e3).round() as u32,
                control_release_ms: (c.control_release_timeout * 1e3).round() as u32,
                daemon_pid: std::process::id(),
            },
            ..Default::default()
        };
        Ok(Self {
            period_ns,
            dt,
            joints,
            drives,
            cfg: cfg.clone(),
            sup,
            amplitude: Follower::new(0.0, amp_l),
            frequency: Follower::new(0.0, freq_l),
            turn: Follower::new(0.0, curv_l),
            pitch: Follower::new(0.0, curv_l),
            // The daemon's trapezoids already bound rates and accelerations;
            // the gait's own filter (50 ms) only rounds their corners so the
            // curvature's second derivative stays continuous.
            gait: ParametricGait::new(rest, 0.05)?,
            ws,
            model,
            head: HeadState::launch(0.0),
            offsets: vec![[Follower::new(0.0, posture_l); 2]; n],
            setpoints: vec![[AxisSetpoint::default(); 2]; n],
            torque_ff: vec![[0.0; 2]; n],
            ff_prev: vec![[0.0; 4]; n],
            ff_primed: false,
            counter: 0,
            mode_before: Mode::Idle,
            setpoint_skip: NodeSet::empty(),
            liveness: Liveness {
                heartbeat_timeout: Nanos::from_secs_f64(cfg.control.heartbeat_timeout),
                feedback_periods: cfg.control.feedback_timeout,
            },
            model_failed: false,
            last_model_error: None,
            report: StepReport::default(),
            counters: ControlCounters::default(),
            holder_node: None,
            new_holder_node: false,
            snapshot,
            started: now,
            tap: None,
            tap_dropped: 0,
            now,
            sensors,
            residual: ResidualMonitor::new(&cfg.monitor, joints),
            autopilot,
            guidance: Guidance::new(cfg),
            hold: Hold::MANUAL,
            hold_exit: None,
            hold_states: [anguilla_ipc::HoldState::Off; 2],
            tracking: Tracking::new(joints),
            setpoints_followed: false,
            report_ids: if cfg.robot.drive.drive_per_axis() {
                (1..=joints)
                    .filter_map(|j| anguilla_protocol::message::NodeId::new(j as u8).ok())
                    .collect()
            } else {
                cfg.node_ids()
                    .into_iter()
                    .filter_map(|id| anguilla_protocol::message::NodeId::new(id).ok())
                    .collect()
            },
        })
    }

    /// Records every input and output from now on into `tap` (bounded,
    /// never blocking: a full channel drops the record and counts it).
    pub fn set_tap(&mut self, tap: crossbeam_channel::Sender<Record>) {
        let _ = tap.try_send(Record::Start(self.started));
        self.tap = Some(tap);
    }

    /// Records dropped because the recorder fell behind.
    pub fn tap_dropped(&self) -> u64 {
        self.tap_dropped
    }

    fn record(&mut self, r: Record) {
        if let Some(t) = &self.tap
            && t.try_send(r).is_err()
        {
            self.tap_dropped += 1;
        }
    }

    /// The control period (ns).
    pub fn period_ns(&self) -> Nanos {
        self.period_ns
    }

    /// The supervisor (mode, faults, holder).
    pub fn supervisor(&self) -> &Supervisor {
        &self.sup
    }

    /// The joints' drives.
    pub fn drives(&self) -> &dyn Drives {
        self.drives.as_ref()
    }

    /// The drives' next notice for the log (configuration done or failed).
    pub fn take_drive_notice(&mut self) -> Option<crate::drive::Notice> {
        self.drives.take_notice()
    }

    /// The largest tracking error (rad) seen on fresh feedback while the
    /// drives followed setpoints, since the start ([`crate::tracking`]).
    pub fn worst_tracking_error(&self) -> f64 {
        self.tracking.worst()
    }

    /// Counters.
    pub fn counters(&self) -> ControlCounters {
        self.counters
    }

    /// The setpoints sent in the last period, joint order.
    pub fn setpoints(&self) -> &[[AxisSetpoint; 2]] {
        &self.setpoints
    }

    /// The model's last report (predicted head speed, turn rate).
    pub fn report(&self) -> &StepReport {
        &self.report
    }

    /// The last model error, if a step failed.
    pub fn last_model_error(&self) -> Option<ModelError> {
        self.last_model_error
    }

    /// The snapshot filled by the last period.
    pub fn snapshot(&self) -> &StateSnapshot {
        &self.snapshot
    }

    /// Handles one operator request, from the client port the transport
    /// names in `env`, and says what to reply.
    pub fn command(&mut self, now: Nanos, env: &Envelope) -> CommandReply {
        self.record(Record::Command(now, *env));
        let req = &env.request;
        let reply = match req.command() {
            Err(e) => CommandReply::refused(req, self.sup.mode() as u8, &e),
            Ok(cmd) => match self.check_path(env.origin, &cmd) {
                Err(why) => CommandReply::refused(req, self.sup.mode() as u8, &why),
                Ok(()) => match self.sup.command(now, env.origin, req.sequence, cmd) {
                    Ok(()) => {
                        self.path_accepted(&cmd);
                        if self.sup.holder() == Some(env.origin)
                            && self.holder_node != Some((env.origin, env.node))
                        {
                            self.holder_node = Some((env.origin, env.node));
                            self.new_holder_node = true;
                        }
                        CommandReply::accepted(req, self.sup.mode() as u8)
                    }
                    Err(why) => CommandReply::refused(req, self.sup.mode() as u8, &why),
                },
            },
        };
        if reply.accepted == 0 {
            self.counters.refused += 1;
        }
        reply
    }

    /// A path command's own checks, for the holder (anyone else's is
    /// refused by the supervisor, for its authority).
    fn check_path(
        &self,
        origin: ClientId,
        cmd: &Command,
    ) -> Result<(), crate::guidance::PathRefusal> {
        if self.sup.holder() != Some(origin) {
            return Ok(());
        }
        match cmd {
            Command::Waypoint(w) => self.guidance.check_waypoint(w),
            Command::Follow(f) => {
                let nav = self.sensors.nav().filter(|n| n.has_estimate());
                let plane = nav.map(|n| n.plane());
                self.guidance.check_follow(
                    f,
                    plane.map(|p| p.position()),
                    plane.map_or(anguilla_ipc::PositionHealth::DeadReckoning, |p| p.health()),
                )
            }
            _ => Ok(()),
        }
    }

    /// What an accepted command does to the path: a waypoint is loaded, a
    /// follow starts it, and any other command that sets the swim or its
    /// hold, stops it or gives control up ends it.
    fn path_accepted(&mut self, cmd: &Command) {
        match cmd {
            Command::Waypoint(w) => self.guidance.load(w),
            Command::Follow(f) => {
                if let Some(nav) = self.sensors.nav() {
                    let plane = nav.plane();
                    if f.resume {
                        let speed = self.report.forward_speed * plane.speed_scale();
                        self.guidance.resume(plane.current(), speed);
                    } else {
                        self.guidance.start(f, plane.position());
                    }
                }
            }
            Command::Swim(_)
            | Command::Hold(_)
            | Command::SwimHold(..)
            | Command::Stop
            | Command::EStop
            | Command::ReleaseControl
            | Command::Disable
            | Command::Reset => self.guidance.end(anguilla_ipc::GuideState::Interrupted),
            Command::Enable | Command::TakeControl | Command::KeepAlive => {}
        }
    }

    /// Hands the estimate an observation the host read itself (after
    /// the period that covers its time); `false` if it was left out.
    pub fn observe(&mut self, obs: &crate::sensors::Observation) -> bool {
        self.sensors.observe(obs)
    }

    /// The path followed, if any.
    pub fn guidance(&self) -> &Guidance {
        &self.guidance
    }

    /// The head sensor's health ([`SensorHealth::None`] without one).
    pub fn sensor_health(&self) -> SensorHealth {
        self.sensors.head_health()
    }

    /// The head sensor's estimate, if a sensor is configured.
    pub fn nav(&self) -> Option<&Nav> {
        self.sensors.nav()
    }

    /// Every configured sensor.
    pub fn sensors(&self) -> &Sensors {
        &self.sensors
    }

    /// The autopilot, if a sensor is configured.
    pub fn autopilot(&self) -> Option<&Autopilot> {
        self.autopilot.as_ref()
    }

    /// E-stops that arrived out of band (the reserved E-stop socket, with
    /// no client port): recorded and handled like an operator's;
    /// `total` is how many arrived since start, shown in the snapshot.
    pub fn socket_estop(&mut self, now: Nanos, total: u64) {
        let env = Envelope {
            origin: 0,
            node: 0,
            request: CommandRequest::new(Command::EStop, 0),
        };
        self.snapshot.socket_estops = total;
        self.command(now, &env);
    }

    /// The iceoryx2 node of a client that just took control, once (the
    /// loop hands it to the reaper to watch).
    pub fn take_new_holder_node(&mut self) -> Option<u128> {
        if core::mem::take(&mut self.new_holder_node) {
            self.holder_node.map(|(_, n)| n)
        } else {
            None
        }
    }

    /// Tells the controller that an iceoryx2 node died; if it held control,
    /// control is released and a swim stops smoothly.
    pub fn node_died(&mut self, now: Nanos, node_id: u128) -> bool {
        self.record(Record::Dead(now, node_id));
        match self.holder_node {
            Some((client, node)) if node == node_id => {
                self.holder_node = None;
                self.sup.release_dead(now, client)
            }
            _ => false,
        }
    }

    /// Runs one period at time `now` against `bus`: the seven steps of the
    /// module's documentation, in order.
    pub fn run_period(&mut self, now: Nanos, bus: &mut dyn Bus) {
        self.now = now;
        // The state this period acts on throughout (a bus that goes off
        // meanwhile refuses the sends, recorded as such): a replay sees the
        // same period.
        let period_state = bus.state();
        self.record(Record::Period {
            now,
            bus: period_state,
        });
        self.ingest(now, bus); // 1
        let mut d = self.supervise(now, period_state, bus); // 2
        self.guide(now, &mut d);
        let mode = self.sup.mode();
        let (target, followed) = self.follow_targets(&d, mode); // 3
        self.step_model(); // 4
        self.straighten_on_ready(mode);
        self.limit_setpoints(d.drop_feedforward); // 5
        // 6. Frames: drive commands, setpoints, SYNC. Nothing is sent while
        // bus-off or while the adapter is gone.
        let bus_off = matches!(period_state, BusState::BusOff | BusState::Gone);
        let mut out = out!(self, &mut *bus);
        self.drives.period(
            &Period {
                now,
                drive: d.drive,
                mode,
                entering: mode != self.mode_before,
                bus_off,
                counter: self.counter,
                setpoints: &self.setpoints,
                skip: self.setpoint_skip,
            },
            &mut out,
        );
        self.counter = self.counter.wrapping_add(1);
        self.mode_before = mode;
        // 7. Snapshot.
        self.fill_snapshot(
            now,
            bus,
            period_state.code(),
            &target,
            followed,
            d.drop_feedforward,
        );
    }

    /// Shutdown, first half: stop a swim smoothly (idempotent).
    pub fn begin_shutdown(&mut self, now: Nanos) {
        self.record(Record::Shutdown(now));
        self.sup.stop_swimming(now);
    }

    /// Shutdown, second half: disable every actuator now.
    pub fn disable_all(&mut self, bus: &mut dyn Bus) {
        self.record(Record::End);
        let mut out = out!(self, bus);
        self.drives.disable_all(&mut out);
    }

    /// Sets the loop statistics shown in the snapshot.
    pub fn set_loop_stats(&mut self, stats: anguilla_ipc::LoopSnapshot) {
        self.snapshot.loop_stats = stats;
    }
}
