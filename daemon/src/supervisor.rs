//! The safety supervisor: operating modes, control authority, command
//! validation and the reactions of `docs/safety.md`'s table ("Safety
//! behaviour").
//!
//! It is pure logic: the control loop feeds it operator commands and, once a
//! period, what it observed of the robot ([`Observations`]); the supervisor
//! answers with what the loop must do ([`Directives`]). Nothing here
//! allocates or blocks; every refusal is a small `Copy` [`Refusal`] whose
//! `Display` names the reason, sent back to the client that asked.
//!
//! ```text
//!            enable             all nodes enabled
//!   Idle ───────────► Enabling ─────────────────► Ready ◄──────────┐
//!    ▲  ◄── disable ──────────────────────────────  │ swim          │ at rest
//!    │                                              ▼               │
//!    │ reset                                     Swimming ─stop──► Stopping
//!    │                                          (operator silent ──►)
//!  Fault ◄── heartbeat lost, no feedback, duplicate node id, node fault,
//!            bus-off, model diverged (any active mode); a node rebooted
//!            or disabled, a tracking error, frozen feedback (Ready,
//!            Swimming, Stopping: the nodes must be enabled and follow)
//!  EStop ◄── E-stop from any client or from the bus, or a foreign drive
//!            command on the bus (any mode); latched until reset
//! ```

use anguilla_protocol::NodeSet;

use anguilla_ipc::vocabulary::{
    Cause, ClientId, Command, FaultKind, FaultSet, Field, Hold, Mode, Nanos, Refusal, SensorHealth,
    SwimParams,
};

/// What the loop observed of the robot during one period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Observations {
    /// Every configured node reports it is enabled.
    pub all_enabled: bool,
    /// Nodes whose heartbeat is overdue.
    pub heartbeat_lost: NodeSet,
    /// Nodes that answered no SYNC for the feedback timeout, whatever
    /// their heartbeats say.
    pub feedback_lost: NodeSet,
    /// Nodes whose id two senders use (heartbeat counters interleave).
    pub duplicate_id: NodeSet,
    /// Every configured node's heartbeat is overdue: no actuator is left to
    /// hold, and setpoints would only load a bus that may be the cause.
    pub all_lost: bool,
    /// Nodes that report a fault.
    pub node_fault: NodeSet,
    /// Nodes that report Boot (they rebooted: their joints are limp).
    pub booting: NodeSet,
    /// Nodes that report Disabled (their joints are limp).
    pub disabled: NodeSet,
    /// Joints whose measured angle stayed beyond the tracking band
    /// ([`crate::tracking`]).
    pub tracking_error: NodeSet,
    /// Joints whose fresh feedback stayed the same while commanded to move
    /// ([`crate::tracking`]).
    pub feedback_frozen: NodeSet,
    /// Nodes that sent or report an E-stop (bit = node id); `bus_estop`
    /// covers E-stops whose sender is not a node.
    pub estop_nodes: NodeSet,
    /// An E-stop frame was seen on the bus.
    pub bus_estop: bool,
    /// Nodes that another sender on the bus told to change state (enable,
    /// disable, clear faults, re-zero, change mode): an E-stop from the
    /// bus, whatever the mode.
    pub foreign_command: NodeSet,
    /// The bus is bus-off.
    pub bus_off: bool,
    /// The bus adapter is gone (unplugged; the driver reconnects).
    pub bus_gone: bool,
    /// The model's step failed or produced a non-finite value.
    pub model_diverged: bool,
    /// The gait has ramped to zero amplitude and the body is straight.
    pub gait_at_rest: bool,
}

/// How the loop must drive the actuators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Drive {
    /// Send disable; send no setpoints.
    Disabled,
    /// Send enable, hold the current posture until the nodes are ready.
    Enable,
    /// Send setpoints from the gait generator (which may be ramping to rest).
    Setpoints,
}

/// What happens to the actuators on an actuator fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FaultPolicy {
    /// Ramp the gait down and keep the healthy actuators holding straight.
    Hold,
    /// Disable every actuator at once.
    Disable,
}

/// What the loop must do this period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Directives {
    /// How to drive the actuators.
    pub drive: Drive,
    /// The gait the generator must head for (REST while not swimming).
    pub gait_target: SwimParams,
    /// What the autopilot holds (manual while not swimming): its turn and
    /// pitch replace the gait target's where it holds.
    pub hold: Hold,
    /// Send an E-stop broadcast this period (once per E-stop event).
    pub send_estop: bool,
    /// Send a clear-faults broadcast this period (once, on reset).
    pub send_clear_faults: bool,
    /// Drop the torque feedforward (model diverged).
    pub drop_feedforward: bool,
}

/// Supervisor settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupervisorConfig {
    /// The holder's silence after which a swim stops smoothly (ns).
    pub command_timeout: Nanos,
    /// The holder's silence after which its control is released (ns).
    pub control_release_timeout: Nanos,
    /// Time allowed for every node to report enabled (ns).
    pub enable_timeout: Nanos,
    /// Largest frequency accepted (Hz); the smallest is 0.
    pub max_frequency: f64,
    /// Largest |turn curvature| accepted (1/m).
    pub max_turn: f64,
    /// Largest |pitch curvature| accepted (1/m).
    pub max_pitch: f64,
    /// Deepest depth a hold accepts (m).
    pub max_depth: f64,
    /// Reaction to an actuator fault or a lost heartbeat.
    pub fault_policy: FaultPolicy,
    /// After a reset, how long node faults and E-stops still reported are
    /// taken as stale (the nodes have not yet seen the clear-faults) (ns).
    pub clear_settle_time: Nanos,
}

impl Default for SupervisorConfig {
    fn default() -> Self {
        Self {
            command_timeout: Nanos::from_millis(500),
            control_release_timeout: Nanos::from_millis(3_000),
            enable_timeout: Nanos::from_millis(1_000),
            max_frequency: 3.0,
            max_turn: 4.0,
            max_pitch: 2.0,
            max_depth: 10.0,
            fault_policy: FaultPolicy::Hold,
            clear_settle_time: Nanos::from_millis(300),
        }
    }
}

const MAX_CLIENTS: usize = 16;

#[derive(Debug, Clone, Copy)]
struct Holder {
    client: ClientId,
    last_heard: Nanos,
}

/// The supervisor state machine.
#[derive(Debug, Clone)]
pub struct Supervisor {
    cfg: SupervisorConfig,
    mode: Mode,
    cause: Cause,
    holder: Option<Holder>,
    seqs: [(ClientId, u32); MAX_CLIENTS],
    seq_count: usize,
    faults: FaultSet,
    swim: SwimParams,
    hold: Hold,
    entered: Nanos,
    estop_pending: bool,
    clear_pending: bool,
    operator_silent_count: u64,
    disabled_in_fault: bool,
    last_obs: Observations,
    /// When the last reset was accepted: node faults and E-stops reported
    /// until the clear-faults broadcast has had time to act are not re-latched.
    reset_at: Option<Nanos>,
    /// The head sensor's health ([`Supervisor::observe_sensor`]).
    sensor: SensorHealth,
}

impl Supervisor {
    /// A supervisor in Idle with nobody in control.
    pub fn new(cfg: SupervisorConfig) -> Self {
        Self {
            cfg,
            mode: Mode::Idle,
            cause: Cause::None,
            holder: None,
            seqs: [(0, 0); MAX_CLIENTS],
            seq_count: 0,
            faults: FaultSet::default(),
            swim: SwimParams::REST,
            hold: Hold::MANUAL,
            entered: Nanos::ZERO,
            estop_pending: false,
            clear_pending: false,
            operator_silent_count: 0,
            disabled_in_fault: false,
            last_obs: Observations::default(),
            reset_at: None,
            sensor: SensorHealth::None,
        }
    }

    /// The current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Why the mode last changed.
    pub fn cause(&self) -> Cause {
        self.cause
    }

    /// The faults latched since the last reset.
    pub fn faults(&self) -> FaultSet {
        self.faults
    }

    /// The client holding control, if any.
    pub fn holder(&self) -> Option<ClientId> {
        self.holder.map(|h| h.client)
    }

    /// The last accepted swim parameters.
    pub fn swim_params(&self) -> SwimParams {
        self.swim
    }

    /// How many times a swim was stopped because the holder went silent.
    pub fn operator_silent_count(&self) -> u64 {
        self.operator_silent_count
    }

    /// What the autopilot is asked to hold (for this swim, or the next one
    /// when set while not swimming).
    pub fn hold(&self) -> Hold {
        self.hold
    }

    /// The head sensor's health, as the controller observes it every
    /// period (and once before the first): a Hold that holds something is
    /// accepted only while it is [`SensorHealth::Ok`], and one in force
    /// ends when it is not (the swim stops smoothly, with
    /// [`Cause::SensorLost`]). Returns whether a hold was in force and
    /// ended.
    pub fn observe_sensor(&mut self, now: Nanos, health: SensorHealth) -> bool {
        self.sensor = health;
        health != SensorHealth::Ok && self.sensor_lost(now)
    }

    /// The head sensor's health, as last observed.
    pub fn sensor(&self) -> SensorHealth {
        self.sensor
    }

    fn sensor_lost(&mut self, now: Nanos) -> bool {
        if !self.hold.is_active() {
            return false;
        }
        self.hold = Hold::MANUAL;
        self.stop_if_swimming(now, Cause::SensorLost);
        true
    }

    fn enter(&mut self, mode: Mode, now: Nanos, cause: Cause) {
        // A hold belongs to a swim (or the next one, set in Ready or
        // Stopping): it ends with the swim, and with any mode that is not
        // swimming's neighbour (idle, enabling, fault, e-stop).
        let leaves_swim = self.mode == Mode::Swimming && mode != Mode::Swimming;
        if leaves_swim || !matches!(mode, Mode::Ready | Mode::Swimming | Mode::Stopping) {
            self.hold = Hold::MANUAL;
        }
        self.mode = mode;
        self.entered = now;
        self.cause = cause;
    }

    fn check_seq(&mut self, client: ClientId, seq: u32) -> Result<(), Refusal> {
        if let Some(slot) = self.seqs[..self.seq_count]
            .iter_mut()
            .find(|(c, _)| *c == client)
        {
            if seq <= slot.1 {
                return Err(Refusal::StaleSequence {
                    got: seq,
                    last: slot.1,
                });
            }
            slot.1 = seq;
            return Ok(());
        }
        if self.seq_count == MAX_CLIENTS {
            // Forget the least recent entry that is not the holder.
            let holder = self.holder();
            if let Some(i) = (0..MAX_CLIENTS).find(|&i| Some(self.seqs[i].0) != holder) {
                self.seqs.copy_within(i + 1.., i);
                self.seq_count -= 1;
            } else {
                return Err(Refusal::TooManyClients);
            }
        }
        self.seqs[self.seq_count] = (client, seq);
        self.seq_count += 1;
        Ok(())
    }

    fn validate(&self, p: &SwimParams) -> Result<(), Refusal> {
        let checks = [
            (Field::Amplitude, p.amplitude, 0.0, 1.0),
            (Field::Frequency, p.frequency, 0.0, self.cfg.max_frequency),
            (Field::Turn, p.turn, -self.cfg.max_turn, self.cfg.max_turn),
            (
                Field::Pitch,
                p.pitch,
                -self.cfg.max_pitch,
                self.cfg.max_pitch,
            ),
        ];
        for (field, value, min, max) in checks {
            if !value.is_finite() {
                return Err(Refusal::NonFinite(field));
            }
            if value < min || value > max {
                return Err(Refusal::OutOfRange {
                    field,
                    value,
                    min,
                    max,
                });
            }
        }
        Ok(())
    }

    fn validate_hold(&self, h: &Hold) -> Result<Hold, Refusal> {
        let heading = match h.heading {
            Some(v) if !v.is_finite() => return Err(Refusal::NonFinite(Field::Heading)),
            Some(v) => Some(v.rem_euclid(360.0)),
            None => None,
        };
        if let Some(d) = h.depth {
            if !d.is_finite() {
                return Err(Refusal::NonFinite(Field::Depth));
            }
            if !(0.0..=self.cfg.max_depth).contains(&d) {
                return Err(Refusal::OutOfRange {
                    field: Field::Depth,
                    value: d,
                    min: 0.0,
                    max: self.cfg.max_depth,
                });
            }
        }
        Ok(Hold {
            heading,
            depth: h.depth,
        })
    }

    /// Handles one operator command at time `now` from `client` (the
    /// origin the transport vouches for); `Ok` means accepted.
    pub fn command(
        &mut self,
        now: Nanos,
        client: ClientId,
        seq: u32,
        cmd: Command,
    ) -> Result<(), Refusal> {
        // E-stop: from anyone, in any mode, never refused: before the
        // sequence check, so no duplicate, replayed or out-of-order number
        // stands in its way.
        if cmd == Command::EStop {
            self.estop(now, FaultKind::OperatorEStop, 0);
            return Ok(());
        }
        self.check_seq(client, seq)?;
        match self.holder {
            Some(h) if h.client == client => {
                self.holder = Some(Holder {
                    client,
                    last_heard: now,
                });
            }
            Some(h) => return Err(Refusal::ControlHeldBy(h.client)),
            None if cmd == Command::TakeControl => {
                self.holder = Some(Holder {
                    client,
                    last_heard: now,
                });
                return Ok(());
            }
            None => return Err(Refusal::NotInControl),
        }
        let mode = self.mode;
        let invalid = |hint| {
            Err(Refusal::InvalidInMode {
                command: cmd.kind(),
                mode,
                hint,
            })
        };
        match cmd {
            // A waypoint is the controller's to check and keep.
            Command::TakeControl | Command::KeepAlive | Command::EStop | Command::Waypoint(_) => {
                Ok(())
            }
            Command::ReleaseControl => {
                self.holder = None;
                self.hold = Hold::MANUAL;
                self.stop_if_swimming(now, Cause::Command);
                Ok(())
            }
            Command::Enable => match mode {
                Mode::Idle => {
                    self.enter(Mode::Enabling, now, Cause::Command);
                    Ok(())
                }
                Mode::Enabling | Mode::Ready | Mode::Swimming | Mode::Stopping => Ok(()),
                Mode::Fault | Mode::EStop => invalid("reset first"),
            },
            Command::Disable => match mode {
                Mode::Idle | Mode::Enabling | Mode::Ready => {
                    self.enter(Mode::Idle, now, Cause::Command);
                    Ok(())
                }
                Mode::Fault => {
                    // The fault stays latched; only the actuators go limp.
                    self.disabled_in_fault = true;
                    Ok(())
                }
                Mode::Swimming | Mode::Stopping => invalid("stop first, or e-stop"),
                Mode::EStop => Ok(()),
            },
            Command::Swim(_) | Command::Hold(_) | Command::SwimHold(..) | Command::Follow(_) => {
                // The gait and the hold are checked before either is taken:
                // a held swim takes both or neither. A hold needs a healthy
                // sensor (manual never does).
                let (swim, hold) = cmd.swim_and_hold();
                if let Some(p) = &swim {
                    self.validate(p)?;
                }
                let hold = match hold {
                    Some(h) => Some(self.validate_hold(&h)?),
                    None => None,
                };
                match mode {
                    Mode::Ready | Mode::Swimming | Mode::Stopping
                        if hold.is_some_and(|h| h.is_active())
                            && self.sensor != SensorHealth::Ok =>
                    {
                        Err(Refusal::Sensor(self.sensor))
                    }
                    Mode::Ready | Mode::Swimming | Mode::Stopping => {
                        if let Some(h) = hold {
                            self.hold = h;
                        }
                        if let Some(p) = swim {
                            self.swim = p;
                            if mode != Mode::Swimming {
                                self.enter(Mode::Swimming, now, Cause::Command);
                            }
                        }
                        Ok(())
                    }
                    Mode::Idle | Mode::Enabling => invalid("enable and wait for ready"),
                    Mode::Fault | Mode::EStop => invalid("reset first"),
                }
            }
            Command::Stop => match mode {
                Mode::Swimming => {
                    self.stop_if_swimming(now, Cause::Command);
                    Ok(())
                }
                Mode::Stopping | Mode::Ready | Mode::Idle | Mode::Enabling => Ok(()),
                Mode::Fault | Mode::EStop => Ok(()),
            },
            Command::Reset => match mode {
                Mode::Fault | Mode::EStop => {
                    // Node faults and E-stops are cleared by the clear-faults
                    // broadcast that follows; a silent node or a dead bus is
                    // not, so a reset waits for them to come back.
                    let o = &self.last_obs;
                    let mut persists = FaultSet::default();
                    if !o.heartbeat_lost.is_empty() {
                        persists.insert(FaultKind::HeartbeatLost, o.heartbeat_lost.bits());
                    }
                    if !o.feedback_lost.is_empty() {
                        persists.insert(FaultKind::FeedbackLost, o.feedback_lost.bits());
                    }
                    if !o.duplicate_id.is_empty() {
                        persists.insert(FaultKind::DuplicateNode, o.duplicate_id.bits());
                    }
                    if o.bus_off {
                        persists.insert(FaultKind::BusOff, 0);
                    }
                    if o.bus_gone {
                        persists.insert(FaultKind::AdapterGone, 0);
                    }
                    if !persists.is_empty() {
                        return Err(Refusal::FaultPersists(persists));
                    }
                    self.faults = FaultSet::default();
                    self.disabled_in_fault = false;
                    self.reset_at = Some(now);
                    self.clear_pending = true;
                    self.enter(Mode::Idle, now, Cause::Command);
                    Ok(())
                }
                _ => invalid("nothing to reset"),
            },
        }
    }

    /// The daemon stops a swim smoothly for `cause` (a path done, the
    /// geofence, the position fix lost), holding `hold` on the way down.
    pub fn stop_for(&mut self, now: Nanos, cause: Cause, hold: Hold) {
        if self.mode == Mode::Swimming {
            self.hold = hold;
            self.stop_if_swimming(now, cause);
        }
    }

    /// The daemon itself stops a swim smoothly (shutdown: a signal, not an
    /// operator's command).
    pub fn stop_swimming(&mut self, now: Nanos) {
        self.stop_if_swimming(now, Cause::Shutdown);
    }

    /// Releases `client`'s control if it holds it (its process died), and
    /// stops a swim smoothly as if it had gone silent. Returns whether it held it.
    pub fn release_dead(&mut self, now: Nanos, client: ClientId) -> bool {
        if self.holder() != Some(client) {
            return false;
        }
        self.holder = None;
        self.hold = Hold::MANUAL;
        if self.mode == Mode::Swimming {
            self.operator_silent_count += 1;
        }
        self.stop_if_swimming(now, Cause::OperatorSilent);
        true
    }

    fn stop_if_swimming(&mut self, now: Nanos, cause: Cause) {
        if self.mode == Mode::Swimming {
            self.swim = SwimParams::REST;
            self.enter(Mode::Stopping, now, cause);
        }
    }

    fn estop(&mut self, now: Nanos, kind: FaultKind, nodes: u64) {
        self.faults.insert(kind, nodes);
        self.swim = SwimParams::REST;
        if self.mode != Mode::EStop {
            self.estop_pending = true;
            // An operator's E-stop is a command, not a fault.
            self.enter(Mode::EStop, now, kind.cause());
        }
    }

    fn fault(&mut self, now: Nanos, kind: FaultKind, nodes: u64) {
        self.faults.insert(kind, nodes);
        match self.mode {
            Mode::EStop => {}
            Mode::Fault => {}
            Mode::Idle
                if !matches!(
                    kind,
                    FaultKind::BusOff | FaultKind::AdapterGone | FaultKind::ModelDiverged
                ) =>
            {
                // A node problem while limp is reported but changes nothing.
            }
            _ => {
                self.swim = SwimParams::REST;
                self.enter(Mode::Fault, now, Cause::Fault);
            }
        }
    }

    /// Once per period: applies timeouts and the robot's observed state, and
    /// says what the loop must do.
    pub fn tick(&mut self, now: Nanos, obs: &Observations) -> Directives {
        // Operator silence.
        if let Some(h) = self.holder {
            let silent = now.saturating_sub(h.last_heard);
            if silent >= self.cfg.control_release_timeout {
                self.holder = None;
                self.hold = Hold::MANUAL;
            }
            if silent >= self.cfg.command_timeout && self.mode == Mode::Swimming {
                self.operator_silent_count += 1;
                self.stop_if_swimming(now, Cause::OperatorSilent);
            }
        } else if self.mode == Mode::Swimming {
            self.operator_silent_count += 1;
            self.stop_if_swimming(now, Cause::OperatorSilent);
        }
        self.last_obs = *obs;
        // After a reset, nodes need a moment to act on the clear-faults
        // broadcast: their stale reports are not re-latched meanwhile.
        let settling = match self.reset_at {
            Some(t) if now.saturating_sub(t) < self.cfg.clear_settle_time => true,
            Some(_) => {
                self.reset_at = None;
                false
            }
            None => false,
        };
        // Where every node must be enabled: a node that reports anything
        // else here went limp behind the supervisor's back (a reboot, a
        // Disable from another sender, its own firmware). While enabling
        // the nodes are on their way; in Idle, Fault and E-stop they may be
        // anything. Judged on the mode the period starts in, so a fault
        // found in the same period does not hide it.
        let must_be_enabled = matches!(self.mode, Mode::Ready | Mode::Swimming | Mode::Stopping);
        // Safety reactions (docs/safety.md's table).
        // Nodes that report E-stop while the daemon is already E-stopped
        // obey it: a consequence, not another fault (an operator's E-stop
        // was listed as "e-stop on the bus" of every node). An E-stop frame
        // from someone else on the bus still latches.
        let obeying = self.mode == Mode::EStop && !obs.bus_estop;
        if !settling && !obeying && (obs.bus_estop || !obs.estop_nodes.is_empty()) {
            self.estop(now, FaultKind::BusEStop, obs.estop_nodes.bits());
        }
        // Another sender told our drives to change state: they obey it
        // behind the supervisor's back (limp, enabled, faults cleared, a
        // new zero), so the robot is no longer what it commands. The same
        // answer as to its E-stop frame.
        if !obs.foreign_command.is_empty() {
            self.estop(now, FaultKind::ForeignCommand, obs.foreign_command.bits());
        }
        if obs.bus_off {
            self.fault(now, FaultKind::BusOff, 0);
        }
        if obs.bus_gone {
            self.fault(now, FaultKind::AdapterGone, 0);
        }
        if !obs.heartbeat_lost.is_empty() {
            self.fault(now, FaultKind::HeartbeatLost, obs.heartbeat_lost.bits());
        }
        if !obs.feedback_lost.is_empty() {
            self.fault(now, FaultKind::FeedbackLost, obs.feedback_lost.bits());
        }
        if !obs.duplicate_id.is_empty() {
            self.fault(now, FaultKind::DuplicateNode, obs.duplicate_id.bits());
        }
        if !settling && !obs.node_fault.is_empty() {
            self.fault(now, FaultKind::NodeFault, obs.node_fault.bits());
        }
        if obs.model_diverged {
            self.fault(now, FaultKind::ModelDiverged, 0);
        }
        if must_be_enabled && !obs.booting.is_empty() {
            self.fault(now, FaultKind::NodeRebooted, obs.booting.bits());
        }
        if must_be_enabled && !obs.disabled.is_empty() {
            self.fault(now, FaultKind::NodeDisabled, obs.disabled.bits());
        }
        // The second line, which does not take the drives' word: the
        // joints do not do what they are told.
        if must_be_enabled && !obs.tracking_error.is_empty() {
            self.fault(now, FaultKind::TrackingError, obs.tracking_error.bits());
        }
        if must_be_enabled && !obs.feedback_frozen.is_empty() {
            self.fault(now, FaultKind::FeedbackFrozen, obs.feedback_frozen.bits());
        }
        // Progress.
        match self.mode {
            Mode::Enabling if obs.all_enabled => self.enter(Mode::Ready, now, Cause::Progress),
            Mode::Enabling if now.saturating_sub(self.entered) >= self.cfg.enable_timeout => {
                self.faults.insert(FaultKind::EnableTimeout, 0);
                self.enter(Mode::Fault, now, Cause::Fault);
            }
            Mode::Stopping if obs.gait_at_rest => self.enter(Mode::Ready, now, self.cause),
            _ => {}
        }
        let drive = match self.mode {
            Mode::Idle | Mode::EStop => Drive::Disabled,
            Mode::Enabling => Drive::Enable,
            Mode::Ready | Mode::Swimming | Mode::Stopping => Drive::Setpoints,
            Mode::Fault if self.disabled_in_fault => Drive::Disabled,
            Mode::Fault => match self.cfg.fault_policy {
                FaultPolicy::Disable => Drive::Disabled,
                // Without a bus, or with no node left answering, holding is
                // not possible: send nothing but Disable and SYNC.
                FaultPolicy::Hold if obs.bus_off || obs.bus_gone || obs.all_lost => Drive::Disabled,
                FaultPolicy::Hold => Drive::Setpoints,
            },
        };
        let d = Directives {
            drive,
            gait_target: if self.mode == Mode::Swimming {
                self.swim
            } else {
                SwimParams::REST
            },
            hold: if self.mode == Mode::Swimming {
                self.hold
            } else {
                Hold::MANUAL
            },
            send_estop: self.estop_pending,
            send_clear_faults: self.clear_pending,
            drop_feedforward: self.faults.contains(FaultKind::ModelDiverged),
        };
        self.estop_pending = false;
        self.clear_pending = false;
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Nanos = Nanos::from_millis(1);
    const A: ClientId = 0xA;
    const B: ClientId = 0xB;

    fn swim() -> Command {
        Command::Swim(SwimParams {
            amplitude: 0.5,
            frequency: 1.0,
            turn: 0.0,
            pitch: 0.0,
        })
    }

    fn nodes(ids: &[u8]) -> NodeSet {
        NodeSet::of(
            ids.iter()
                .map(|&i| anguilla_protocol::NodeId::new(i).unwrap()),
        )
    }

    fn ok_obs() -> Observations {
        Observations {
            all_enabled: true,
            gait_at_rest: true,
            ..Default::default()
        }
    }

    /// A supervisor swimming under client A at t = 3 ms.
    fn swimming() -> Supervisor {
        let mut s = Supervisor::new(SupervisorConfig::default());
        s.command(Nanos::ZERO, A, 1, Command::TakeControl).unwrap();
        s.command(MS, A, 2, Command::Enable).unwrap();
        s.tick(2 * MS, &ok_obs());
        assert_eq!(s.mode(), Mode::Ready);
        s.command(3 * MS, A, 3, swim()).unwrap();
        assert_eq!(s.mode(), Mode::Swimming);
        s
    }

    /// One judge: the supervisor alone accepts or refuses a Hold, on the
    /// sensor health it observed; a hold in force ends (the swim stopping)
    /// when the sensor fails.
    #[test]
    fn a_hold_is_judged_on_the_observed_sensor_alone() {
        let heading = Command::Hold(Hold {
            heading: Some(45.0),
            depth: None,
        });
        let mut s = swimming();
        for health in [
            SensorHealth::None,
            SensorHealth::Waiting,
            SensorHealth::Silent,
        ] {
            s.observe_sensor(4 * MS, health);
            assert_eq!(
                s.command(4 * MS, A, 4, heading),
                Err(Refusal::Sensor(health)),
                "{health:?}"
            );
            assert!(!s.hold().is_active(), "a refused hold leaves manual");
            // Manual needs no sensor.
            s.command(4 * MS, A, 5, Command::Hold(Hold::MANUAL))
                .unwrap();
            s = swimming();
        }
        s.observe_sensor(4 * MS, SensorHealth::Ok);
        s.command(4 * MS, A, 4, heading).unwrap();
        assert!(s.hold().is_active());
        assert!(!s.observe_sensor(5 * MS, SensorHealth::Ok), "nothing ends");
        assert!(s.hold().is_active());
        // The sensor fails: the hold ends and the swim stops smoothly.
        assert!(s.observe_sensor(6 * MS, SensorHealth::Stuck));
        assert!(!s.hold().is_active());
        assert_eq!(s.mode(), Mode::Stopping);
        assert_eq!(s.cause(), Cause::SensorLost);
    }

    /// Issue 47: a held swim is one request, taken whole or refused whole,
    /// from Ready: never a manual swim first, never a hold without its swim.
    #[test]
    fn a_held_swim_takes_its_gait_and_its_hold_or_neither() {
        let ready = || {
            let mut s = Supervisor::new(SupervisorConfig::default());
            s.command(Nanos::ZERO, A, 1, Command::TakeControl).unwrap();
            s.command(MS, A, 2, Command::Enable).unwrap();
            s.tick(2 * MS, &ok_obs());
            assert_eq!(s.mode(), Mode::Ready);
            s
        };
        let Command::Swim(p) = swim() else {
            unreachable!("swim() is a swim")
        };
        let held = Hold {
            heading: Some(60.0),
            depth: None,
        };
        // No healthy sensor: neither the swim nor the hold.
        let mut s = ready();
        s.observe_sensor(3 * MS, SensorHealth::Silent);
        assert_eq!(
            s.command(3 * MS, A, 3, Command::SwimHold(p, held)),
            Err(Refusal::Sensor(SensorHealth::Silent))
        );
        assert_eq!((s.mode(), s.hold().is_active()), (Mode::Ready, false));
        // A bad gait: neither either, whatever the sensor.
        let mut s = ready();
        s.observe_sensor(3 * MS, SensorHealth::Ok);
        let bad = SwimParams {
            frequency: f64::NAN,
            ..p
        };
        assert!(
            s.command(3 * MS, A, 3, Command::SwimHold(bad, held))
                .is_err()
        );
        assert_eq!((s.mode(), s.hold().is_active()), (Mode::Ready, false));
        // Both, in the one request.
        s.command(4 * MS, A, 4, Command::SwimHold(p, held)).unwrap();
        assert_eq!(s.mode(), Mode::Swimming);
        assert_eq!(s.hold(), held);
    }

    #[test]
    fn a_hold_set_at_rest_ends_with_an_estop_a_fault_or_a_release() {
        let hold = Command::Hold(Hold {
            heading: Some(90.0),
            depth: None,
        });
        // Ready again after a swim, a hold set for the next one.
        let ready_with_a_hold = || {
            let mut s = swimming();
            s.command(4 * MS, A, 4, Command::Stop).unwrap();
            let rest = Observations {
                gait_at_rest: true,
                ..ok_obs()
            };
            s.tick(5 * MS, &rest);
            assert_eq!(s.mode(), Mode::Ready);
            s.observe_sensor(5 * MS, SensorHealth::Ok);
            s.command(6 * MS, A, 5, hold).unwrap();
            assert!(s.hold().is_active(), "kept for the next swim");
            s
        };
        // E-stop.
        let mut s = ready_with_a_hold();
        s.command(7 * MS, B, 1, Command::EStop).unwrap();
        assert!(!s.hold().is_active(), "an e-stop ends it");
        // Release of control (another operator's swim must not inherit it).
        let mut s = ready_with_a_hold();
        s.command(7 * MS, A, 6, Command::ReleaseControl).unwrap();
        assert!(!s.hold().is_active(), "releasing control ends it");
        // A fault.
        let mut s = swimming();
        s.observe_sensor(4 * MS, SensorHealth::Ok);
        s.command(4 * MS, A, 4, hold).unwrap();
        let obs = Observations {
            node_fault: nodes(&[3]),
            ..ok_obs()
        };
        s.tick(5 * MS, &obs);
        assert_eq!(s.mode(), Mode::Fault);
        assert!(!s.hold().is_active(), "a fault ends it");
    }

    #[test]
    fn codes_round_trip() {
        for m in Mode::ALL {
            assert_eq!(Mode::from_code(m as u8), Some(m));
        }
        assert_eq!(Mode::from_code(7), None);
        for c in Cause::ALL {
            assert_eq!(Cause::from_code(c.code()), Some(c));
        }
        assert_eq!(Cause::OperatorSilent.code(), 2);
        assert_eq!(Cause::from_code(Cause::ALL.len() as u8), None);
    }

    #[test]
    fn lifecycle_enable_swim_stop() {
        let mut s = swimming();
        let d = s.tick(4 * MS, &ok_obs());
        assert_eq!(d.drive, Drive::Setpoints);
        assert_eq!(d.gait_target.amplitude, 0.5);
        s.command(5 * MS, A, 4, Command::Stop).unwrap();
        assert_eq!(s.mode(), Mode::Stopping);
        let not_yet = Observations {
            gait_at_rest: false,
            ..ok_obs()
        };
        assert_eq!(s.tick(6 * MS, &not_yet).gait_target, SwimParams::REST);
        assert_eq!(s.mode(), Mode::Stopping);
        s.tick(7 * MS, &ok_obs());
        assert_eq!(s.mode(), Mode::Ready);
        s.command(8 * MS, A, 5, Command::Disable).unwrap();
        assert_eq!(s.tick(9 * MS, &ok_obs()).drive, Drive::Disabled);
    }

    #[test]
    fn only_the_holder_commands_but_anyone_can_estop() {
        let mut s = swimming();
        let r = s.command(4 * MS, B, 1, Command::TakeControl).unwrap_err();
        assert_eq!(r, Refusal::ControlHeldBy(A));
        assert!(r.to_string().contains("holds control"));
        assert_eq!(
            s.command(4 * MS, B, 2, Command::Stop),
            Err(Refusal::ControlHeldBy(A))
        );
        assert_eq!(s.mode(), Mode::Swimming);
        s.command(5 * MS, B, 3, Command::EStop).unwrap();
        assert_eq!(s.mode(), Mode::EStop);
        let d = s.tick(6 * MS, &ok_obs());
        assert!(d.send_estop);
        assert_eq!(d.drive, Drive::Disabled);
        // Sent once per event.
        assert!(!s.tick(7 * MS, &ok_obs()).send_estop);
    }

    #[test]
    fn estop_latches_until_reset_by_the_holder() {
        let mut s = swimming();
        s.command(4 * MS, A, 4, Command::EStop).unwrap();
        assert!(matches!(
            s.command(5 * MS, A, 5, swim()),
            Err(Refusal::InvalidInMode {
                mode: Mode::EStop,
                ..
            })
        ));
        assert!(matches!(
            s.command(5 * MS, A, 6, Command::Enable),
            Err(Refusal::InvalidInMode { .. })
        ));
        for i in 0..10 {
            s.tick((6 + i) * MS, &ok_obs());
            assert_eq!(s.mode(), Mode::EStop);
        }
        s.command(20 * MS, A, 7, Command::Reset).unwrap();
        assert_eq!(s.mode(), Mode::Idle);
        assert!(s.tick(21 * MS, &ok_obs()).send_clear_faults);
        assert!(s.faults().is_empty());
    }

    #[test]
    fn operator_silence_stops_smoothly_then_releases_control() {
        let mut s = swimming();
        s.tick(3 * MS + 499 * MS, &ok_obs());
        assert_eq!(s.mode(), Mode::Swimming);
        let moving = Observations {
            gait_at_rest: false,
            ..ok_obs()
        };
        let d = s.tick(3 * MS + 500 * MS, &moving);
        assert_eq!(s.mode(), Mode::Stopping);
        assert_eq!(s.cause(), Cause::OperatorSilent);
        assert_eq!(d.drive, Drive::Setpoints, "stopping keeps driving the body");
        assert_eq!(d.gait_target, SwimParams::REST);
        assert_eq!(s.holder(), Some(A));
        s.tick(3 * MS + 3000 * MS, &ok_obs());
        assert_eq!(s.holder(), None);
        assert_eq!(s.mode(), Mode::Ready);
        assert_eq!(s.operator_silent_count(), 1);
        // B can now take control.
        s.command(3100 * MS, B, 1, Command::TakeControl).unwrap();
    }

    #[test]
    fn a_dead_holder_is_released_and_the_swim_stops() {
        let mut s = swimming();
        assert!(!s.release_dead(4 * MS, B), "B does not hold control");
        assert!(s.release_dead(4 * MS, A));
        assert_eq!(s.holder(), None);
        assert_eq!(s.mode(), Mode::Stopping);
        s.command(5 * MS, B, 1, Command::TakeControl).unwrap();
    }

    #[test]
    fn keep_alive_keeps_the_swim_going() {
        let mut s = swimming();
        for i in 1..20u64 {
            s.command(3 * MS + i * 200 * MS, A, 3 + i as u32, Command::KeepAlive)
                .unwrap();
            s.tick(3 * MS + i * 200 * MS + MS, &ok_obs());
            assert_eq!(s.mode(), Mode::Swimming);
        }
    }

    #[test]
    fn bad_swim_parameters_are_refused_with_the_field() {
        let mut s = swimming();
        let bad = |amplitude, frequency| {
            Command::Swim(SwimParams {
                amplitude,
                frequency,
                turn: 0.0,
                pitch: 0.0,
            })
        };
        let r = s.command(4 * MS, A, 10, bad(f64::NAN, 1.0)).unwrap_err();
        assert_eq!(r, Refusal::NonFinite(Field::Amplitude));
        let r = s.command(4 * MS, A, 11, bad(0.5, 9.0)).unwrap_err();
        assert!(
            r.to_string().contains("frequency (Hz) = 9 is out of range"),
            "{r}"
        );
        // The swim goes on with the previous parameters.
        assert_eq!(s.swim_params().amplitude, 0.5);
    }

    #[test]
    fn stale_sequence_numbers_are_refused() {
        let mut s = swimming();
        assert_eq!(
            s.command(4 * MS, A, 3, Command::Stop),
            Err(Refusal::StaleSequence { got: 3, last: 3 })
        );
        assert_eq!(s.mode(), Mode::Swimming);
    }

    #[test]
    fn an_estop_is_never_refused_for_its_sequence_number() {
        // A hostile client's attack: a number at the top of the range, then the
        // real operator's E-stop with a lower one (or the same one, again).
        let mut s = swimming();
        assert_eq!(s.command(4 * MS, A, u32::MAX, Command::KeepAlive), Ok(()));
        assert_eq!(s.command(5 * MS, A, 1, Command::EStop), Ok(()));
        assert_eq!(s.mode(), Mode::EStop);
        assert_eq!(s.command(6 * MS, A, 1, Command::EStop), Ok(()));
        assert_eq!(s.command(6 * MS, B, 0, Command::EStop), Ok(()));
        assert!(s.faults().contains(FaultKind::OperatorEStop));
    }

    #[test]
    fn faults_stop_the_swim_and_name_the_node() {
        let mut s = swimming();
        let obs = Observations {
            heartbeat_lost: nodes(&[7]),
            ..ok_obs()
        };
        let d = s.tick(4 * MS, &obs);
        assert_eq!(s.mode(), Mode::Fault);
        assert_eq!(d.gait_target, SwimParams::REST);
        assert_eq!(d.drive, Drive::Setpoints, "default policy holds");
        assert_eq!(s.faults().to_string(), "heartbeat lost (node 7)");
        // While the node stays silent, a reset is refused with the reason.
        let r = s.command(5 * MS, A, 4, Command::Reset).unwrap_err();
        assert_eq!(
            r.to_string(),
            "the fault is still present (heartbeat lost (node 7)); fix it, then reset"
        );
        assert_eq!(s.mode(), Mode::Fault);
        // Once it is back, the reset goes through.
        s.tick(6 * MS, &ok_obs());
        s.command(7 * MS, A, 5, Command::Reset).unwrap();
        assert_eq!(s.mode(), Mode::Idle);
    }

    /// A node that leaves Enabled where the nodes must be enabled (Ready,
    /// Swimming, Stopping) faults the robot, naming the node and what it
    /// reported: a reboot mid-swim, a Disable from another sender.
    #[test]
    fn a_node_that_goes_limp_while_enabled_faults_naming_it_and_what_it_said() {
        let cases = [
            (
                Observations {
                    booting: nodes(&[3]),
                    all_enabled: false,
                    ..ok_obs()
                },
                FaultKind::NodeRebooted,
                "actuator rebooted (node 3)",
            ),
            (
                Observations {
                    disabled: nodes(&[5]),
                    all_enabled: false,
                    ..ok_obs()
                },
                FaultKind::NodeDisabled,
                "actuator disabled (node 5)",
            ),
        ];
        for (obs, kind, text) in cases {
            // Swimming.
            let mut s = swimming();
            let d = s.tick(4 * MS, &obs);
            assert_eq!(s.mode(), Mode::Fault, "{text}");
            assert_eq!(s.cause(), Cause::Fault);
            assert!(s.faults().contains(kind));
            assert_eq!(s.faults().to_string(), text);
            assert_eq!(d.gait_target, SwimParams::REST, "the swim stops");
            // Stopping.
            let mut s = swimming();
            s.command(4 * MS, A, 4, Command::Stop).unwrap();
            s.tick(5 * MS, &obs);
            assert_eq!(s.mode(), Mode::Fault, "stopping: {text}");
            // Ready.
            let mut s = swimming();
            s.command(4 * MS, A, 4, Command::Stop).unwrap();
            s.tick(5 * MS, &ok_obs());
            assert_eq!(s.mode(), Mode::Ready);
            s.tick(6 * MS, &obs);
            assert_eq!(s.mode(), Mode::Fault, "ready: {text}");
            assert_eq!(s.faults().to_string(), text);
            // Not a fault to reset past once the node is enabled again: the
            // reset goes to Idle, where a limp node is what is asked for.
            s.tick(7 * MS, &ok_obs());
            s.command(8 * MS, A, 5, Command::Reset).unwrap();
            s.tick(9 * MS, &obs);
            assert_eq!(s.mode(), Mode::Idle, "{text}");
        }
    }

    /// A joint that does not follow (tracking error) or whose feedback is a
    /// copy (frozen) faults the robot naming it, where the drives follow
    /// setpoints; elsewhere the monitor does not judge, and neither does
    /// the supervisor.
    #[test]
    fn a_joint_that_does_not_follow_or_a_frozen_one_faults_naming_it() {
        let cases = [
            (
                Observations {
                    tracking_error: nodes(&[2]),
                    ..ok_obs()
                },
                "tracking error (node 2)",
            ),
            (
                Observations {
                    feedback_frozen: nodes(&[6]),
                    ..ok_obs()
                },
                "feedback frozen (node 6)",
            ),
        ];
        for (obs, text) in cases {
            let mut s = swimming();
            s.tick(4 * MS, &obs);
            assert_eq!(s.mode(), Mode::Fault, "{text}");
            assert_eq!(s.faults().to_string(), text);
            let mut s = Supervisor::new(SupervisorConfig::default());
            s.tick(MS, &obs);
            assert!(s.faults().is_empty(), "idle: {text}");
        }
    }

    /// Where a limp node is expected or already handled, its report is no
    /// new fault: Idle, Enabling (on its way), Fault, E-stop.
    #[test]
    fn a_limp_node_is_no_fault_while_idle_enabling_in_fault_or_estopped() {
        let limp = Observations {
            booting: nodes(&[1]),
            disabled: nodes(&[2]),
            all_enabled: false,
            ..ok_obs()
        };
        let mut s = Supervisor::new(SupervisorConfig::default());
        s.tick(MS, &limp);
        assert_eq!((s.mode(), s.faults()), (Mode::Idle, FaultSet::default()));
        s.command(MS, A, 1, Command::TakeControl).unwrap();
        s.command(MS, A, 2, Command::Enable).unwrap();
        s.tick(2 * MS, &limp);
        assert_eq!(s.mode(), Mode::Enabling);
        assert!(s.faults().is_empty(), "{}", s.faults());
        // Enabled now: Ready, and the first period there is judged on
        // Enabling's terms; from the next on, a limp node is a fault.
        s.tick(3 * MS, &ok_obs());
        assert_eq!(s.mode(), Mode::Ready);
        // In Fault (another cause) a node going limp adds nothing.
        let mut s = swimming();
        s.tick(
            4 * MS,
            &Observations {
                node_fault: nodes(&[4]),
                ..ok_obs()
            },
        );
        s.tick(5 * MS, &limp);
        assert_eq!(s.faults().to_string(), "actuator fault (node 4)");
        // E-stopped: the nodes obey it.
        let mut s = swimming();
        s.command(4 * MS, A, 4, Command::EStop).unwrap();
        s.tick(5 * MS, &limp);
        assert_eq!(s.faults().to_string(), "operator e-stop");
    }

    #[test]
    fn reset_clears_node_faults_and_ignores_their_stale_reports() {
        let mut s = swimming();
        let faulty = Observations {
            node_fault: nodes(&[3]),
            ..ok_obs()
        };
        s.tick(4 * MS, &faulty);
        assert_eq!(s.mode(), Mode::Fault);
        s.command(5 * MS, A, 4, Command::Reset).unwrap();
        let d = s.tick(6 * MS, &faulty);
        assert!(d.send_clear_faults);
        assert_eq!(s.mode(), Mode::Idle, "stale report during the settle time");
        // A fault still reported after the settle time latches again.
        s.command(7 * MS, A, 5, Command::Enable).unwrap();
        s.tick(400 * MS, &faulty);
        assert_eq!(s.mode(), Mode::Fault);
    }

    #[test]
    fn disable_in_fault_goes_limp_but_keeps_the_fault() {
        let mut s = swimming();
        let faulty = Observations {
            node_fault: nodes(&[1]),
            ..ok_obs()
        };
        assert_eq!(s.tick(4 * MS, &faulty).drive, Drive::Setpoints);
        s.command(5 * MS, A, 4, Command::Disable).unwrap();
        assert_eq!(s.tick(6 * MS, &faulty).drive, Drive::Disabled);
        assert_eq!(s.mode(), Mode::Fault);
    }

    #[test]
    fn disable_policy_and_bus_off_disable_at_once() {
        let cfg = SupervisorConfig {
            fault_policy: FaultPolicy::Disable,
            ..Default::default()
        };
        let mut s = Supervisor::new(cfg);
        s.command(Nanos::ZERO, A, 1, Command::TakeControl).unwrap();
        s.command(Nanos::ZERO, A, 2, Command::Enable).unwrap();
        s.tick(MS, &ok_obs());
        let d = s.tick(
            2 * MS,
            &Observations {
                node_fault: nodes(&[2]),
                ..ok_obs()
            },
        );
        assert_eq!(d.drive, Drive::Disabled);
        let mut s = swimming();
        let d = s.tick(
            4 * MS,
            &Observations {
                bus_off: true,
                ..ok_obs()
            },
        );
        assert_eq!(s.mode(), Mode::Fault);
        assert_eq!(d.drive, Drive::Disabled);
    }

    #[test]
    fn hold_with_every_node_lost_drives_nothing() {
        let mut s = swimming();
        let d = s.tick(
            4 * MS,
            &Observations {
                heartbeat_lost: nodes(&[1, 2]),
                ..ok_obs()
            },
        );
        assert_eq!(s.mode(), Mode::Fault);
        assert_eq!(d.drive, Drive::Setpoints, "the healthy ones hold");
        let d = s.tick(
            5 * MS,
            &Observations {
                heartbeat_lost: nodes(&[1, 2]),
                all_lost: true,
                ..ok_obs()
            },
        );
        assert_eq!(d.drive, Drive::Disabled, "no one left to hold");
    }

    #[test]
    fn a_gone_adapter_is_a_fault_named_as_such_until_it_is_back() {
        let mut s = swimming();
        let gone = Observations {
            bus_gone: true,
            ..ok_obs()
        };
        let d = s.tick(4 * MS, &gone);
        assert_eq!(s.mode(), Mode::Fault);
        assert_eq!(d.drive, Drive::Disabled, "nothing to hold with");
        assert!(s.faults().contains(FaultKind::AdapterGone));
        assert_eq!(s.faults().to_string(), "adapter gone");
        let r = s.command(5 * MS, A, 4, Command::Reset).unwrap_err();
        assert_eq!(
            r.to_string(),
            "the fault is still present (adapter gone); fix it, then reset"
        );
        s.tick(6 * MS, &ok_obs());
        assert_eq!(s.command(7 * MS, A, 5, Command::Reset), Ok(()));
        assert_eq!(s.mode(), Mode::Idle);
    }

    #[test]
    fn enable_times_out_into_a_fault() {
        let mut s = Supervisor::new(SupervisorConfig::default());
        s.command(Nanos::ZERO, A, 1, Command::TakeControl).unwrap();
        s.command(Nanos::ZERO, A, 2, Command::Enable).unwrap();
        let none = Observations::default();
        s.tick(999 * MS, &none);
        assert_eq!(s.mode(), Mode::Enabling);
        s.tick(1000 * MS, &none);
        assert_eq!(s.mode(), Mode::Fault);
        assert!(s.faults().contains(FaultKind::EnableTimeout));
    }

    #[test]
    fn model_divergence_drops_feedforward() {
        let mut s = swimming();
        let d = s.tick(
            4 * MS,
            &Observations {
                model_diverged: true,
                ..ok_obs()
            },
        );
        assert!(d.drop_feedforward);
        assert_eq!(s.mode(), Mode::Fault);
    }

    /// The nodes E-stopped by an operator's E-stop are not a fault of
    /// theirs: the faults say "operator e-stop" and name no node.
    #[test]
    fn nodes_obeying_an_operator_estop_are_no_fault() {
        let mut s = Supervisor::new(SupervisorConfig::default());
        s.command(MS, A, 1, Command::EStop).unwrap();
        assert_eq!(s.mode(), Mode::EStop);
        assert_eq!(s.cause(), Cause::Command);
        let obs = Observations {
            estop_nodes: NodeSet::first(12),
            ..Default::default()
        };
        s.tick(2 * MS, &obs);
        assert!(s.faults().contains(FaultKind::OperatorEStop));
        assert!(!s.faults().contains(FaultKind::BusEStop), "{}", s.faults());
        assert_eq!(s.faults().nodes, 0);
        // What docs/ipc.md says (anguilla_ipc::layout::estop_markdown):
        // the operator E-stop's cause and its bit alone.
        assert_eq!(s.cause(), FaultKind::OperatorEStop.cause());
        assert_eq!(s.faults().kinds, FaultKind::OperatorEStop.bit());
        assert_eq!(s.mode(), Mode::EStop);
    }

    #[test]
    fn bus_estop_latches_even_without_a_client() {
        let mut s = Supervisor::new(SupervisorConfig::default());
        s.tick(
            MS,
            &Observations {
                bus_estop: true,
                ..Default::default()
            },
        );
        assert_eq!(s.mode(), Mode::EStop);
        assert!(s.faults().contains(FaultKind::BusEStop));
    }

    /// A foreign drive command (a one-byte Disable, `083#02`; a Set zero)
    /// is an E-stop from the bus in every mode, naming the nodes it was
    /// aimed at, latched until reset like any E-stop.
    #[test]
    fn a_foreign_drive_command_is_an_estop_naming_its_nodes() {
        let foreign = Observations {
            foreign_command: nodes(&[3]),
            ..ok_obs()
        };
        let mut s = swimming();
        let d = s.tick(4 * MS, &foreign);
        assert_eq!(s.mode(), Mode::EStop);
        assert_eq!(s.cause(), Cause::Fault);
        assert!(d.send_estop, "every node told to stop at once");
        assert_eq!(d.drive, Drive::Disabled);
        assert_eq!(s.faults().to_string(), "foreign drive command (node 3)");
        // Latched: gone from the bus, still E-stopped.
        for i in 5..10 {
            s.tick(i * MS, &ok_obs());
            assert_eq!(s.mode(), Mode::EStop);
        }
        s.command(10 * MS, A, 4, Command::Reset).unwrap();
        assert_eq!(s.mode(), Mode::Idle);
        // In Idle too: a foreign Enable would stiffen joints nobody drives.
        s.tick(11 * MS, &foreign);
        assert_eq!(s.mode(), Mode::EStop);
    }

    #[test]
    fn invalid_transitions_say_what_to_do() {
        let mut s = Supervisor::new(SupervisorConfig::default());
        s.command(Nanos::ZERO, A, 1, Command::TakeControl).unwrap();
        let r = s.command(Nanos::ZERO, A, 2, swim()).unwrap_err();
        assert_eq!(
            r.to_string(),
            "'swim' is not valid in mode idle: enable and wait for ready"
        );
        let mut s = swimming();
        let r = s.command(4 * MS, A, 4, Command::Disable).unwrap_err();
        assert!(r.to_string().contains("stop first"), "{r}");
    }

    #[test]
    fn sequence_table_is_bounded_and_keeps_the_holder() {
        let mut s = swimming();
        for c in 100..100 + 40u128 {
            // Refused (A holds control), but the sequence is taken first.
            let _ = s.command(4 * MS, c, 1, Command::KeepAlive);
        }
        // The holder's entry survived eviction: its old sequence is still stale.
        assert!(matches!(
            s.command(5 * MS, A, 3, Command::Reset),
            Err(Refusal::StaleSequence { .. })
        ));
    }
}
