//! A vertebra actuator node, as its firmware would behave on the bus.
//!
//! It implements the node contract of `protocol/README.md` ("The node's
//! required behaviour") case by case: the Boot → Disabled → Enabled state
//! machine with Fault and a latched EStop, setpoints held pending until the
//! SYNC whose cycle tag they carry, feedback sampled at each SYNC, the
//! watchdog and its safe action, limits with clamping, heartbeats every
//! 100 ms and on every state change, and BAD_FRAME for frames addressed to
//! it that do not decode. Each node drives two [`Actuator`]s (pitch, yaw).
//!
//! Time comes from the caller (`now`, in nanoseconds), so a simulation is
//! deterministic and runs as fast as the host allows.

use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{
    self, AxisFeedback, AxisSetpoint, Command, ConfigParam, ConfigResult, ErrorBits, Feedback,
    Heartbeat, Message, NodeId, NodeSet, NodeState, SafeAction, Target, Variant,
};

use crate::actuator::{Actuator, ActuatorParams, AxisFaults, Drive, Load};
use crate::rng::Rng;

/// Nanoseconds of simulated time (the bus's one time type).
pub use anguilla_protocol::time::Nanos;

/// Servo integration step inside the node (s).
pub(crate) const SERVO_DT: f64 = 2.5e-4;
pub(crate) const SERVO_DT_NS: Nanos = Nanos::from_nanos(250_000);

/// Configuration of one simulated node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeConfig {
    /// The node's id on the bus.
    pub id: NodeId,
    /// Classic CAN or CAN FD.
    pub variant: Variant,
    /// Pitch (0) and yaw (1) actuators.
    pub axes: [ActuatorParams; 2],
    /// Time from power-on to Disabled (ns).
    pub boot_time: Nanos,
    /// Seed of the node's sensor noise.
    pub seed: u64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Limits {
    pos_min: f64,
    pos_max: f64,
    vel_max: f64,
    trq_max: f64,
}

const DEFAULT_LIMITS: Limits = Limits {
    pos_min: -message::POSITION_LIMIT,
    pos_max: message::POSITION_LIMIT,
    vel_max: message::VELOCITY_LIMIT,
    trq_max: message::TORQUE_LIMIT,
};

/// Counters a firmware would keep (and a test can read).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NodeCounters {
    /// Frames addressed to this node that did not decode.
    pub bad_frames: u64,
    /// Setpoints discarded for a wrong cycle tag.
    pub stale_setpoints: u64,
    /// Setpoints applied at a SYNC.
    pub applied: u64,
    /// Setpoints clamped to the configured limits.
    pub clamped: u64,
    /// Watchdog expiries.
    pub watchdog_expiries: u64,
}

/// One simulated vertebra node.
#[derive(Debug, Clone)]
pub struct VertebraNode {
    cfg: NodeConfig,
    state: NodeState,
    latched: u16,
    warnings: u16,
    hb_counter: u8,
    missed_syncs: u8,
    last_sync: Option<u16>,
    pending: Option<(u8, [AxisSetpoint; 2])>,
    active: [AxisSetpoint; 2],
    limited: [bool; 2],
    watchdog_ms: u16,
    safe_action: SafeAction,
    limits: [Limits; 2],
    last_applied: Nanos,
    next_heartbeat: Nanos,
    time: Nanos,
    boot_done: Nanos,
    axes: [Actuator; 2],
    rng: Rng,
    silent: bool,
    injected_fault: u16,
    counters: NodeCounters,
}

impl VertebraNode {
    /// A node powered on at time `now`.
    pub fn new(cfg: NodeConfig, now: Nanos) -> Self {
        Self {
            cfg,
            state: NodeState::Boot,
            latched: 0,
            warnings: 0,
            hb_counter: 0,
            missed_syncs: 0,
            last_sync: None,
            pending: None,
            active: [AxisSetpoint::default(); 2],
            limited: [false; 2],
            watchdog_ms: message::DEFAULT_WATCHDOG_MS,
            safe_action: message::DEFAULT_SAFE_ACTION,
            limits: [DEFAULT_LIMITS; 2],
            last_applied: now,
            next_heartbeat: now,
            time: now,
            boot_done: now + cfg.boot_time,
            axes: [Actuator::new(cfg.axes[0]), Actuator::new(cfg.axes[1])],
            rng: Rng::new(cfg.seed),
            silent: false,
            injected_fault: 0,
            counters: NodeCounters::default(),
        }
    }

    /// The node's id.
    pub fn id(&self) -> NodeId {
        self.cfg.id
    }

    /// Classic CAN or CAN FD.
    pub fn variant(&self) -> Variant {
        self.cfg.variant
    }

    /// The state machine state.
    pub fn state(&self) -> NodeState {
        self.state
    }

    /// Latched error bits and pending warnings.
    pub fn errors(&self) -> ErrorBits {
        ErrorBits(self.latched | self.warnings)
    }

    /// Counters.
    pub fn counters(&self) -> NodeCounters {
        self.counters
    }

    /// The active setpoint of both axes.
    pub fn active_setpoint(&self) -> [AxisSetpoint; 2] {
        self.active
    }

    /// True angle, velocity and acceleration of an axis (0 pitch, 1 yaw).
    pub fn kinematics(&self, axis: usize) -> (f64, f64, f64) {
        self.axes[axis].kinematics()
    }

    /// Motor torque of an axis (N·m).
    pub fn motor_torque(&self, axis: usize) -> f64 {
        self.axes[axis].torque()
    }

    /// Sets the body's load on each axis from now on
    /// ([`crate::actuator::Actuator::set_load`]).
    pub fn set_load(&mut self, load: [Load; 2]) {
        for (a, l) in self.axes.iter_mut().zip(load) {
            a.set_load(l);
        }
    }

    /// Places the joint at an angle (a simulation's initial pose).
    pub fn set_pose(&mut self, angles: [f64; 2]) {
        for (a, th) in self.axes.iter_mut().zip(angles) {
            a.set_state(th, 0.0);
        }
    }

    /// Fault injection: a silent node neither sends nor hears anything.
    pub fn set_silent(&mut self, silent: bool) {
        self.silent = silent;
    }

    /// Whether the node is silent.
    pub fn is_silent(&self) -> bool {
        self.silent
    }

    /// Fault injection: the node reboots (volatile configuration is lost).
    pub fn reboot(&mut self, now: Nanos) {
        let mut fresh = Self::new(self.cfg, now);
        fresh.axes = self.axes.clone();
        fresh.rng = self.rng.clone();
        *self = fresh;
    }

    /// Fault injection: a faults of an axis (stuck, torque cap, noise, spike).
    pub fn axis_faults_mut(&mut self, axis: usize) -> &mut AxisFaults {
        self.axes[axis].faults_mut()
    }

    /// Fault injection: a latched fault condition (e.g.
    /// [`ErrorBits::OVER_TEMPERATURE`]) that persists until cleared with
    /// [`VertebraNode::clear_injected_fault`].
    pub fn inject_fault(&mut self, bits: u16, now: Nanos, tx: &mut impl FnMut(Frame)) {
        self.injected_fault |= bits;
        self.latched |= bits;
        if matches!(self.state, NodeState::Enabled | NodeState::Disabled) {
            self.go(NodeState::Fault, now, tx);
        }
    }

    /// Removes an injected fault condition (ClearFaults can then succeed).
    pub fn clear_injected_fault(&mut self) {
        self.injected_fault = 0;
    }

    fn go(&mut self, state: NodeState, now: Nanos, tx: &mut impl FnMut(Frame)) {
        if self.state != state {
            self.state = state;
            if state == NodeState::Enabled {
                // Hold still where we are until the first applied setpoint.
                for (sp, a) in self.active.iter_mut().zip(&self.axes) {
                    *sp = AxisSetpoint {
                        position: a.kinematics().0 as f32,
                        velocity: 0.0,
                        torque: 0.0,
                    };
                }
                self.last_applied = now;
            }
            if state != NodeState::Enabled {
                self.pending = None;
            }
            self.heartbeat(now, tx);
        }
    }

    fn heartbeat(&mut self, now: Nanos, tx: &mut impl FnMut(Frame)) {
        let hb = Message::Heartbeat(Heartbeat {
            node: self.cfg.id,
            state: self.state,
            errors: ErrorBits((self.latched | self.warnings) & ErrorBits::ALL),
            counter: self.hb_counter,
            missed_syncs: self.missed_syncs,
            temperature: 35,
        });
        if let Ok(f) = hb.encode(self.cfg.variant) {
            tx(f);
        }
        self.hb_counter = self.hb_counter.wrapping_add(1);
        self.warnings = 0;
        self.next_heartbeat = now + Nanos::from_millis(message::HEARTBEAT_PERIOD_MS.into());
    }

    fn drive(&self, axis: usize) -> Drive {
        let hold = |sp: &AxisSetpoint| Drive::Servo {
            position: sp.position as f64,
            velocity: 0.0,
            torque: 0.0,
        };
        match self.state {
            NodeState::Enabled => {
                let sp = &self.active[axis];
                Drive::Servo {
                    position: sp.position as f64,
                    velocity: sp.velocity as f64,
                    torque: sp.torque as f64,
                }
            }
            NodeState::Fault => match self.safe_action {
                SafeAction::Hold => hold(&self.active[axis]),
                SafeAction::Limp => Drive::Limp,
                SafeAction::Brake => Drive::Brake,
            },
            NodeState::Disabled if self.safe_action == SafeAction::Brake => Drive::Brake,
            NodeState::EStop if self.safe_action == SafeAction::Brake => Drive::Brake,
            NodeState::Boot | NodeState::Disabled | NodeState::EStop => Drive::Limp,
        }
    }

    /// Runs the node's own loop (servo, watchdog, heartbeat) up to `now`.
    pub fn advance(&mut self, now: Nanos, tx: &mut impl FnMut(Frame)) {
        while self.time + SERVO_DT_NS <= now {
            self.time += SERVO_DT_NS;
            let t = self.time;
            let mut saturated = false;
            for axis in 0..2 {
                let drive = self.drive(axis);
                self.axes[axis].step(SERVO_DT, drive);
                saturated |= self.axes[axis].saturated();
            }
            if saturated {
                self.warnings |= ErrorBits::TORQUE_LIMIT;
            }
            if self.silent {
                continue;
            }
            if self.state == NodeState::Boot && t >= self.boot_done {
                self.go(NodeState::Disabled, t, tx);
            }
            if self.state == NodeState::Enabled
                && t.saturating_sub(self.last_applied) > Nanos::from_millis(self.watchdog_ms.into())
            {
                self.latched |= ErrorBits::WATCHDOG;
                self.counters.watchdog_expiries += 1;
                self.go(NodeState::Fault, t, tx);
            }
            if t >= self.next_heartbeat {
                self.heartbeat(t, tx);
            }
        }
    }

    /// Handles one frame seen on the bus at time `now`.
    pub fn receive(&mut self, now: Nanos, frame: &Frame, tx: &mut impl FnMut(Frame)) {
        self.advance(now, tx);
        if self.silent {
            return;
        }
        if frame.id().is_extended() {
            return;
        }
        // E-stop: any frame on 0x000 or 0x000 + own id, whatever its length
        // or kind (fail safe).
        if message::estop_target(frame.id()).is_some_and(|t| t.includes(self.cfg.id)) {
            self.latched |= ErrorBits::ESTOP_LATCHED;
            self.go(NodeState::EStop, now, tx);
            return;
        }
        // Remote frames are not part of the protocol: ignored silently.
        if frame.is_remote() {
            return;
        }
        let msg = match message::decode(frame, self.cfg.variant, NodeSet::all()) {
            Ok(m) => m,
            Err(_) => {
                // Addressed to this node (protocol's definitions table):
                // counted; for other nodes, node-to-host or unused: ignored.
                if message::addressed_to(self.cfg.variant, frame.id(), self.cfg.id) {
                    self.warnings |= ErrorBits::BAD_FRAME;
                    self.counters.bad_frames += 1;
                }
                return;
            }
        };
        let for_me = |t: Target| t.includes(self.cfg.id);
        match msg {
            Message::EStop(_) => {}
            Message::Sync { counter } => self.on_sync(now, counter, tx),
            Message::Command { target, command } if for_me(target) => {
                self.on_command(now, command, tx)
            }
            Message::Setpoint(sp) if sp.node == self.cfg.id && self.accepts_setpoints() => {
                self.pending = Some((sp.cycle, sp.axes));
            }
            Message::SetpointGroup(g) => {
                if let Some(axes) = g.for_node(self.cfg.id)
                    && self.accepts_setpoints()
                {
                    self.pending = Some((g.cycle, axes));
                }
            }
            Message::ConfigWrite { node, param } if node == self.cfg.id => {
                self.on_config(param, tx)
            }
            _ => {}
        }
    }

    fn accepts_setpoints(&self) -> bool {
        self.state == NodeState::Enabled
    }

    fn on_command(&mut self, now: Nanos, cmd: Command, tx: &mut impl FnMut(Frame)) {
        match (cmd, self.state) {
            (Command::Enable, NodeState::Disabled) => {
                self.pending = None;
                self.go(NodeState::Enabled, now, tx);
            }
            (Command::Disable, NodeState::Enabled) => self.go(NodeState::Disabled, now, tx),
            // Idempotent: the host repeats Disable to hold its nodes off, and
            // outside Enabled the motors are off already (protocol/README.md).
            (Command::Disable, _) => {}
            (Command::ClearFaults, NodeState::Fault | NodeState::EStop) => {
                if self.injected_fault != 0 {
                    // The cause persists: stay in Fault with the bit set.
                    self.latched = self.injected_fault;
                    self.state = NodeState::Fault;
                    self.heartbeat(now, tx);
                } else {
                    self.latched = 0;
                    self.missed_syncs = 0;
                    self.go(NodeState::Disabled, now, tx);
                }
            }
            // The host broadcasts ClearFaults on a reset, whatever state
            // each node is in: nothing to clear, nothing wrong (Boot included).
            (Command::ClearFaults, NodeState::Boot | NodeState::Disabled | NodeState::Enabled) => {}
            _ => {
                // Not valid in this state (e.g. Enable while in Fault).
                self.warnings |= ErrorBits::BAD_FRAME;
            }
        }
    }

    fn on_sync(&mut self, now: Nanos, counter: u16, tx: &mut impl FnMut(Frame)) {
        if self.state == NodeState::Boot {
            return;
        }
        // 1. Missed SYNCs.
        if let Some(prev) = self.last_sync {
            let gap = counter.wrapping_sub(prev).wrapping_sub(1);
            if gap != 0 {
                self.missed_syncs = self.missed_syncs.saturating_add(gap.min(255) as u8);
                self.warnings |= ErrorBits::SYNC_MISSED;
            }
        }
        self.last_sync = Some(counter);
        // 2. Apply.
        if let Some((tag, axes)) = self.pending.take()
            && self.state == NodeState::Enabled
        {
            if tag == self.cfg.variant.cycle_tag(counter) {
                for (i, sp) in axes.iter().enumerate() {
                    self.active[i] = self.clamp(i, *sp);
                }
                self.last_applied = now;
                self.counters.applied += 1;
            } else {
                self.warnings |= ErrorBits::STALE_SETPOINT;
                self.counters.stale_setpoints += 1;
            }
        }
        // 3. Sample and report.
        let mut axes = [AxisFeedback::default(); 2];
        for (i, fb) in axes.iter_mut().enumerate() {
            let pos = self.axes[i].measure(&mut self.rng);
            let (_, vel, _) = self.axes[i].kinematics();
            *fb = AxisFeedback {
                position: pos.clamp(-message::POSITION_LIMIT, message::POSITION_LIMIT) as f32,
                velocity: vel.clamp(-message::VELOCITY_LIMIT, message::VELOCITY_LIMIT) as f32,
                torque: self.axes[i]
                    .torque()
                    .clamp(-message::TORQUE_LIMIT, message::TORQUE_LIMIT)
                    as f32,
                limited: self.limited[i],
            };
        }
        let fb = Message::Feedback(Feedback {
            node: self.cfg.id,
            enabled: self.state == NodeState::Enabled,
            fault: matches!(self.state, NodeState::Fault | NodeState::EStop),
            axes,
        });
        if let Ok(f) = fb.encode(self.cfg.variant) {
            tx(f);
        }
    }

    fn clamp(&mut self, axis: usize, sp: AxisSetpoint) -> AxisSetpoint {
        let l = self.limits[axis];
        let p = (sp.position as f64).clamp(l.pos_min, l.pos_max);
        let v = (sp.velocity as f64).clamp(-l.vel_max, l.vel_max);
        let t = (sp.torque as f64).clamp(-l.trq_max, l.trq_max);
        let pos_clamped = p != sp.position as f64;
        let vel_clamped = v != sp.velocity as f64;
        if pos_clamped {
            self.warnings |= ErrorBits::POSITION_LIMIT;
        }
        if vel_clamped {
            self.warnings |= ErrorBits::VELOCITY_LIMIT;
        }
        self.limited[axis] = pos_clamped || vel_clamped;
        if pos_clamped || vel_clamped {
            self.counters.clamped += 1;
        }
        AxisSetpoint {
            position: p as f32,
            velocity: v as f32,
            torque: t as f32,
        }
    }

    fn on_config(&mut self, param: ConfigParam, tx: &mut impl FnMut(Frame)) {
        let result = if self.state != NodeState::Disabled {
            ConfigResult::NotDisabled
        } else {
            match param {
                ConfigParam::WatchdogTimeout { ms } => {
                    self.watchdog_ms = ms;
                    ConfigResult::Accepted
                }
                ConfigParam::SafeAction(a) => {
                    self.safe_action = a;
                    ConfigResult::Accepted
                }
                ConfigParam::PositionLimits { axis, min, max } => {
                    let l = &mut self.limits[axis as usize];
                    l.pos_min = min as f64;
                    l.pos_max = max as f64;
                    ConfigResult::Accepted
                }
                ConfigParam::VelocityLimit { axis, max } => {
                    self.limits[axis as usize].vel_max = max as f64;
                    ConfigResult::Accepted
                }
                ConfigParam::TorqueLimit { axis, max } => {
                    let a = axis as usize;
                    // The actuator cannot exceed its own saturation.
                    if max as f64 > self.axes[a].params().torque_limit {
                        ConfigResult::OutOfRange
                    } else {
                        self.limits[a].trq_max = max as f64;
                        ConfigResult::Accepted
                    }
                }
            }
        };
        let echo = match param {
            ConfigParam::WatchdogTimeout { .. } => ConfigParam::WatchdogTimeout {
                ms: self.watchdog_ms,
            },
            ConfigParam::SafeAction(_) => ConfigParam::SafeAction(self.safe_action),
            ConfigParam::PositionLimits { axis, .. } => ConfigParam::PositionLimits {
                axis,
                min: self.limits[axis as usize].pos_min as f32,
                max: self.limits[axis as usize].pos_max as f32,
            },
            ConfigParam::VelocityLimit { axis, .. } => ConfigParam::VelocityLimit {
                axis,
                max: self.limits[axis as usize].vel_max as f32,
            },
            ConfigParam::TorqueLimit { axis, .. } => ConfigParam::TorqueLimit {
                axis,
                max: self.limits[axis as usize].trq_max as f32,
            },
        };
        let ack = Message::ConfigAck {
            node: self.cfg.id,
            param: echo,
            result,
        };
        if let Ok(f) = ack.encode(self.cfg.variant) {
            tx(f);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_protocol::frame::Id;
    use anguilla_protocol::message::{Axis, FIRST_UNUSED_ID, Function, Setpoint};

    const MS: Nanos = Nanos::from_millis(1);

    const ID: u8 = 3;

    /// Node `ID`, default actuators, booting in 20 ms.
    fn test_config(variant: Variant) -> NodeConfig {
        NodeConfig {
            id: NodeId::new(ID).unwrap(),
            variant,
            axes: [ActuatorParams::default(); 2],
            boot_time: 20 * MS,
            seed: 1,
        }
    }

    struct Bench {
        node: VertebraNode,
        out: Vec<Frame>,
        now: Nanos,
        variant: Variant,
    }

    impl Bench {
        fn new(variant: Variant) -> Self {
            let cfg = test_config(variant);
            let mut b = Self {
                node: VertebraNode::new(cfg, Nanos::ZERO),
                out: Vec::new(),
                now: Nanos::ZERO,
                variant,
            };
            b.wait(30 * MS);
            assert_eq!(b.node.state(), NodeState::Disabled);
            b.out.clear();
            b
        }

        fn wait(&mut self, dt: Nanos) {
            self.now += dt;
            let out = &mut self.out;
            self.node.advance(self.now, &mut |f| out.push(f));
        }

        fn send(&mut self, m: Message) {
            let f = m.encode(self.variant).unwrap();
            self.send_frame(&f);
        }

        fn send_frame(&mut self, f: &Frame) {
            let out = &mut self.out;
            self.node.receive(self.now, f, &mut |fr| out.push(fr));
        }

        fn node_id(&self) -> NodeId {
            NodeId::new(ID).unwrap()
        }

        fn command(&mut self, command: Command) {
            self.send(Message::Command {
                target: Target::All,
                command,
            });
        }

        fn setpoint(&mut self, counter: u16, pitch: f32) {
            let axes = [
                AxisSetpoint {
                    position: pitch,
                    velocity: 0.0,
                    torque: 0.0,
                },
                AxisSetpoint::default(),
            ];
            let cycle = self.variant.cycle_tag(counter);
            match self.variant {
                Variant::Classic => self.send(Message::Setpoint(Setpoint {
                    node: self.node_id(),
                    cycle,
                    axes,
                })),
                Variant::Fd => {
                    let (group, slot) = message::SetpointGroup::locate(self.node_id());
                    let mut slots = [None; message::GROUP_SLOTS];
                    slots[slot] = Some(axes);
                    self.send(Message::SetpointGroup(message::SetpointGroup {
                        group,
                        cycle,
                        slots,
                    }));
                }
            }
        }

        fn sync(&mut self, counter: u16) {
            self.send(Message::Sync { counter });
        }

        fn decoded(&mut self) -> Vec<Message> {
            let variant = self.variant;
            self.out
                .drain(..)
                .map(|f| message::decode(&f, variant, NodeSet::all()).unwrap())
                .collect()
        }

        fn last_heartbeat(&mut self) -> Heartbeat {
            self.decoded()
                .into_iter()
                .rev()
                .find_map(|m| match m {
                    Message::Heartbeat(h) => Some(h),
                    _ => None,
                })
                .expect("a heartbeat")
        }

        /// Enable and run `n` periods of 10 ms with setpoints at `pitch`.
        fn enable_and_run(&mut self, n: u16, pitch: f32) {
            self.command(Command::Enable);
            assert_eq!(self.node.state(), NodeState::Enabled);
            for c in 1..=n {
                self.setpoint(c, pitch);
                self.sync(c);
                self.wait(10 * MS);
            }
        }
    }

    /// Puts a fresh node in `state` by the documented means (Boot: just
    /// powered on; Fault: the watchdog).
    fn bench_in(state: NodeState) -> Bench {
        let variant = Variant::Classic;
        if state == NodeState::Boot {
            return Bench {
                node: VertebraNode::new(test_config(variant), Nanos::ZERO),
                out: Vec::new(),
                now: Nanos::ZERO,
                variant,
            };
        }
        let mut b = Bench::new(variant);
        match state {
            NodeState::Enabled => b.command(Command::Enable),
            NodeState::Fault => {
                b.command(Command::Enable);
                b.wait(100 * MS);
            }
            NodeState::EStop => b.send(Message::EStop(Target::All)),
            _ => {}
        }
        b.out.clear();
        b
    }

    #[test]
    fn every_row_of_the_transition_table_boot_included() {
        // The wire suite (`anguilla conform`) cannot hold a node in Boot;
        // here the node is stepped by hand, so every row is checked.
        use anguilla_protocol::behaviour::{FeedbackFlags, Input, Outcome, TRANSITIONS, describe};
        let mut wrong = Vec::new();
        for t in TRANSITIONS {
            let mut b = bench_in(t.state);
            assert_eq!(b.node.state(), t.state, "reaching {:?}", t.state);
            let id = b.node_id();
            match t.input {
                Input::Enable => b.command(Command::Enable),
                Input::Disable => b.command(Command::Disable),
                Input::ClearFaults => b.command(Command::ClearFaults),
                Input::EStop => b.send(Message::EStop(Target::Node(id))),
                Input::ConfigWrite => b.send(Message::ConfigWrite {
                    node: id,
                    param: ConfigParam::SafeAction(SafeAction::Limp),
                }),
                Input::SetpointSync => {
                    b.setpoint(7, 0.0);
                    b.sync(7);
                }
                Input::BadFrame => {
                    b.send_frame(&Frame::new_standard(0x080 + ID as u16, &[0]).unwrap())
                }
            }
            let errors = b.node.errors();
            let msgs = b.decoded();
            let seen = Outcome {
                next: b.node.state(),
                bad_frame: errors.any(ErrorBits::BAD_FRAME)
                    || msgs.iter().any(|m| {
                        matches!(m, Message::Heartbeat(h) if h.errors.any(ErrorBits::BAD_FRAME))
                    }),
                ack: msgs.iter().find_map(|m| match m {
                    Message::ConfigAck { result, .. } => Some(*result),
                    _ => None,
                }),
                feedback: msgs.iter().find_map(|m| match m {
                    Message::Feedback(f) => Some(FeedbackFlags {
                        enabled: f.enabled,
                        fault: f.fault,
                    }),
                    _ => None,
                }),
            };
            if seen != t.outcome {
                wrong.push(format!(
                    "{:?} × {:?}: expected {}, saw {}",
                    t.state,
                    t.input,
                    describe(t.state, &t.outcome),
                    describe(t.state, &seen)
                ));
            }
        }
        assert!(wrong.is_empty(), "{wrong:#?}");
    }

    #[test]
    fn boots_into_disabled_with_heartbeats() {
        let cfg = test_config(Variant::Classic);
        let mut node = VertebraNode::new(cfg, Nanos::ZERO);
        let mut out = Vec::new();
        node.advance(250 * MS, &mut |f| out.push(f));
        let states: Vec<_> = out
            .iter()
            .filter_map(
                |f| match message::decode(f, Variant::Classic, NodeSet::all()) {
                    Ok(Message::Heartbeat(h)) => Some((h.state, h.counter)),
                    _ => None,
                },
            )
            .collect();
        // Boot at 0.25 ms, Disabled at once on the change at 20 ms, then
        // every 100 ms.
        assert_eq!(
            states,
            vec![
                (NodeState::Boot, 0),
                (NodeState::Disabled, 1),
                (NodeState::Disabled, 2),
                (NodeState::Disabled, 3)
            ]
        );
    }

    #[test]
    fn setpoints_apply_only_at_their_sync() {
        for variant in [Variant::Classic, Variant::Fd] {
            let mut b = Bench::new(variant);
            b.command(Command::Enable);
            b.setpoint(1, 0.4);
            b.wait(5 * MS);
            assert_eq!(b.node.active_setpoint()[0].position, 0.0, "pending only");
            b.sync(1);
            assert!((b.node.active_setpoint()[0].position - 0.4).abs() < 1e-3);
            // The joint moves towards it and feedback reports it.
            for c in 2..50 {
                b.setpoint(c, 0.4);
                b.sync(c);
                b.wait(10 * MS);
            }
            let fb = b
                .decoded()
                .into_iter()
                .rev()
                .find_map(|m| match m {
                    Message::Feedback(f) => Some(f),
                    _ => None,
                })
                .unwrap();
            assert!(fb.enabled && !fb.fault);
            assert!(
                (fb.axes[Axis::Pitch as usize].position - 0.4).abs() < 0.01,
                "{fb:?}"
            );
        }
    }

    #[test]
    fn a_setpoint_for_another_sync_is_stale() {
        let mut b = Bench::new(Variant::Classic);
        b.command(Command::Enable);
        b.setpoint(5, 0.4);
        b.sync(4);
        assert_eq!(b.node.active_setpoint()[0].position, 0.0);
        assert_eq!(b.node.counters().stale_setpoints, 1);
        assert!(b.node.errors().any(ErrorBits::STALE_SETPOINT));
        // Pending is empty after every SYNC: the next SYNC applies nothing.
        b.sync(5);
        assert_eq!(b.node.counters().applied, 0);
    }

    #[test]
    fn watchdog_expires_into_fault_with_the_safe_action() {
        let mut b = Bench::new(Variant::Classic);
        b.enable_and_run(10, 0.2);
        assert_eq!(b.node.state(), NodeState::Enabled);
        // SYNCs go on, setpoints stop: 50 ms later the watchdog fires.
        for c in 11..20 {
            b.sync(c);
            b.wait(10 * MS);
        }
        assert_eq!(b.node.state(), NodeState::Fault);
        assert!(b.node.errors().any(ErrorBits::WATCHDOG));
        assert_eq!(b.node.counters().watchdog_expiries, 1);
        // Default safe action: limp (zero torque).
        assert_eq!(b.node.motor_torque(0), 0.0);
        let hb = b.last_heartbeat();
        assert_eq!(hb.state, NodeState::Fault);
        // Setpoints are ignored in Fault; ClearFaults returns to Disabled.
        b.setpoint(20, 0.3);
        b.sync(20);
        assert_eq!(b.node.state(), NodeState::Fault);
        b.command(Command::ClearFaults);
        assert_eq!(b.node.state(), NodeState::Disabled);
        assert!(!b.node.errors().any(ErrorBits::WATCHDOG));
    }

    #[test]
    fn disable_is_accepted_in_every_state_without_a_bad_frame() {
        // The daemon broadcasts Disable every 100 ms while its nodes are off:
        // no state may take it for a bad frame.
        let mut b = Bench::new(Variant::Classic);
        b.wait(100 * MS);
        assert_eq!(b.node.state(), NodeState::Disabled);
        for _ in 0..10 {
            b.command(Command::Disable);
        }
        assert!(!b.node.errors().any(ErrorBits::BAD_FRAME), "in Disabled");
        b.enable_and_run(10, 0.2);
        for c in 11..20 {
            b.sync(c);
            b.wait(10 * MS);
        }
        assert_eq!(b.node.state(), NodeState::Fault);
        for _ in 0..10 {
            b.command(Command::Disable);
        }
        assert_eq!(b.node.state(), NodeState::Fault, "a fault stays latched");
        assert!(!b.node.errors().any(ErrorBits::BAD_FRAME), "in Fault");
        // Enable outside Disabled is still a bad frame.
        b.command(Command::Enable);
        assert!(b.node.errors().any(ErrorBits::BAD_FRAME));
    }

    #[test]
    fn hold_safe_action_keeps_the_last_position() {
        let mut b = Bench::new(Variant::Classic);
        b.send(Message::ConfigWrite {
            node: b.node_id(),
            param: ConfigParam::SafeAction(SafeAction::Hold),
        });
        b.enable_and_run(40, 0.3);
        b.wait(200 * MS); // no more SYNCs: the watchdog fires
        assert_eq!(b.node.state(), NodeState::Fault);
        b.wait(300 * MS);
        assert!((b.node.kinematics(0).0 - 0.3).abs() < 0.01);
    }

    #[test]
    fn estop_latches_from_any_frame_on_its_ids() {
        let mut b = Bench::new(Variant::Classic);
        b.enable_and_run(3, 0.1);
        // Junk payload on id 0x000: still an E-stop (fail safe).
        b.send_frame(&Frame::new_standard(0x000, &[1, 2, 3]).unwrap());
        assert_eq!(b.node.state(), NodeState::EStop);
        assert_eq!(b.last_heartbeat().state, NodeState::EStop, "sent at once");
        b.command(Command::Enable);
        b.setpoint(4, 0.5);
        b.sync(4);
        assert_eq!(b.node.state(), NodeState::EStop);
        // Power stage off within a servo step.
        b.wait(MS);
        assert_eq!(b.node.motor_torque(0), 0.0);
        b.command(Command::ClearFaults);
        assert_eq!(b.node.state(), NodeState::Disabled);
        // Its own id works too; another node's does not.
        b.send_frame(&Frame::new_standard(ID as u16 + 1, &[]).unwrap());
        assert_eq!(b.node.state(), NodeState::Disabled);
        b.send_frame(&Frame::new_standard(ID as u16, &[]).unwrap());
        assert_eq!(b.node.state(), NodeState::EStop);
    }

    #[test]
    fn clear_faults_fails_while_the_cause_persists() {
        let mut b = Bench::new(Variant::Classic);
        let out = &mut b.out;
        b.node
            .inject_fault(ErrorBits::OVER_TEMPERATURE, b.now, &mut |f| out.push(f));
        assert_eq!(b.node.state(), NodeState::Fault);
        b.command(Command::ClearFaults);
        assert_eq!(b.node.state(), NodeState::Fault);
        assert!(b.node.errors().any(ErrorBits::OVER_TEMPERATURE));
        b.node.clear_injected_fault();
        b.command(Command::ClearFaults);
        assert_eq!(b.node.state(), NodeState::Disabled);
    }

    #[test]
    fn undecodable_frames_for_me_are_bad_frames_others_are_ignored() {
        let mut b = Bench::new(Variant::Classic);
        b.command(Command::Enable);
        // A setpoint frame for this node with a wrong length.
        b.send_frame(&Frame::new_standard(Function::Setpoint.id(ID), &[0; 5]).unwrap());
        assert_eq!(b.node.counters().bad_frames, 1);
        assert!(b.node.errors().any(ErrorBits::BAD_FRAME));
        // Pitch position raw 8000 (bits 4..=17) is beyond the documented
        // ±7500 (±1.5 rad).
        let raw = 8000u32 << 4;
        let data = [
            raw as u8,
            (raw >> 8) as u8,
            (raw >> 16) as u8,
            0,
            0,
            0,
            0,
            0,
        ];
        b.send_frame(&Frame::new_standard(Function::Setpoint.id(ID), &data).unwrap());
        assert_eq!(b.node.counters().bad_frames, 2);
        b.sync(1);
        assert_eq!(
            b.node.counters().applied,
            0,
            "nothing pending from a bad frame"
        );
        // Unknown ids, extended ids, remote frames, other nodes: silent.
        b.send_frame(&Frame::new_standard(0x7FF, &[1]).unwrap());
        b.send_frame(&Frame::new_standard(0x041, &[1]).unwrap());
        b.send_frame(&Frame::new_standard(FIRST_UNUSED_ID + ID as u16, &[1]).unwrap());
        b.send_frame(&Frame::new_standard(0x3C0 + ID as u16, &[]).unwrap());
        // A head sensor's frames (node to host), even on this node's id
        // and whatever their length.
        b.send_frame(&Frame::new_standard(Function::HeadRates.id(ID), &[1]).unwrap());
        b.send_frame(&Frame::new_standard(Function::HeadDepth.id(ID), &[0; 8]).unwrap());
        b.send_frame(&Frame::new(Id::extended(0x1234).unwrap(), &[1]).unwrap());
        b.send_frame(&Frame::new_remote(Function::Setpoint.can_id(ID), 8).unwrap());
        b.send_frame(&Frame::new_standard(Function::Setpoint.id(ID + 1), &[0; 5]).unwrap());
        assert_eq!(b.node.counters().bad_frames, 2);
    }

    #[test]
    fn setpoints_beyond_configured_limits_are_clamped_and_reported() {
        let mut b = Bench::new(Variant::Classic);
        b.send(Message::ConfigWrite {
            node: b.node_id(),
            param: ConfigParam::PositionLimits {
                axis: Axis::Pitch,
                min: -0.2,
                max: 0.2,
            },
        });
        let ack = b.decoded();
        assert!(matches!(
            ack[0],
            Message::ConfigAck {
                result: ConfigResult::Accepted,
                ..
            }
        ));
        b.enable_and_run(2, 0.5);
        assert!((b.node.active_setpoint()[0].position - 0.2).abs() < 1e-6);
        assert!(b.node.errors().any(ErrorBits::POSITION_LIMIT));
        assert_eq!(b.node.counters().clamped, 2);
        let limited = b
            .decoded()
            .into_iter()
            .any(|m| matches!(m, Message::Feedback(f) if f.axes[0].limited && !f.axes[1].limited));
        assert!(limited);
    }

    #[test]
    fn configuration_only_while_disabled() {
        let mut b = Bench::new(Variant::Classic);
        b.command(Command::Enable);
        b.out.clear();
        b.send(Message::ConfigWrite {
            node: b.node_id(),
            param: ConfigParam::WatchdogTimeout { ms: 500 },
        });
        let ack = b.decoded();
        assert!(matches!(
            ack[0],
            Message::ConfigAck {
                result: ConfigResult::NotDisabled,
                param: ConfigParam::WatchdogTimeout { ms: 50 },
                ..
            }
        ));
        b.command(Command::Disable);
        b.out.clear();
        b.send(Message::ConfigWrite {
            node: b.node_id(),
            param: ConfigParam::TorqueLimit {
                axis: Axis::Yaw,
                max: 4.5,
            },
        });
        let ack = b.decoded();
        assert!(matches!(
            ack[0],
            Message::ConfigAck {
                result: ConfigResult::OutOfRange,
                ..
            }
        ));
    }

    #[test]
    fn sync_gaps_are_counted() {
        let mut b = Bench::new(Variant::Classic);
        b.sync(10);
        b.sync(11);
        b.sync(15);
        let hb = {
            b.wait(150 * MS);
            b.last_heartbeat()
        };
        assert_eq!(hb.missed_syncs, 3);
        assert!(hb.errors.any(ErrorBits::SYNC_MISSED));
        // Warnings clear after the heartbeat that reported them.
        b.wait(100 * MS);
        assert!(!b.last_heartbeat().errors.any(ErrorBits::SYNC_MISSED));
    }

    #[test]
    fn feedback_on_sync_except_while_booting() {
        let cfg = test_config(Variant::Classic);
        let mut node = VertebraNode::new(cfg, Nanos::ZERO);
        let mut out = Vec::new();
        let sync = Message::Sync { counter: 1 }
            .encode(Variant::Classic)
            .unwrap();
        node.receive(MS, &sync, &mut |f| out.push(f));
        let is_fb = |f: &Frame| f.id() == Function::Feedback.can_id(ID);
        assert!(!out.iter().any(is_fb));
        node.receive(30 * MS, &sync, &mut |f| out.push(f));
        assert!(out.iter().any(is_fb));
    }

    #[test]
    fn silent_and_rebooted_nodes() {
        let mut b = Bench::new(Variant::Classic);
        b.enable_and_run(3, 0.1);
        b.node.set_silent(true);
        b.out.clear();
        b.sync(4);
        b.wait(300 * MS);
        assert!(b.out.is_empty(), "a silent node sends nothing");
        assert_eq!(b.node.state(), NodeState::Enabled, "and hears nothing");
        b.node.set_silent(false);
        b.node.reboot(b.now);
        b.wait(MS);
        assert_eq!(b.last_heartbeat().state, NodeState::Boot);
        b.wait(30 * MS);
        assert_eq!(b.node.state(), NodeState::Disabled);
    }
}
