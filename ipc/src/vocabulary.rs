//! The operator vocabulary: modes, causes, commands, swim parameters,
//! refusals and fault sets — what the daemon and every operator tool say to
//! each other, independent of the transport.

use core::fmt;

/// Monotonic time in nanoseconds, from the daemon loop's clock (the one
/// time type of the bus, defined in `anguilla_protocol::time`).
pub use anguilla_protocol::time::Nanos;

/// A client's identity: the unique id of the iceoryx2 client port its
/// requests arrive on (chosen by iceoryx2, not by the client).
pub type ClientId = u128;

/// The daemon's operating mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Mode {
    /// Actuators disabled; the robot is limp.
    Idle = 0,
    /// Enable sent; waiting for every node to report it is enabled.
    Enabling = 1,
    /// Enabled and holding the body straight.
    Ready = 2,
    /// Swimming with the commanded gait.
    Swimming = 3,
    /// Ramping the gait down and straightening, then Ready.
    Stopping = 4,
    /// A fault stopped the swim; see the fault set. Cleared by reset.
    Fault = 5,
    /// Emergency stop: actuators disabled, latched until reset.
    EStop = 6,
}

impl Mode {
    /// Every mode, in the order of their codes (`mode as u8`).
    pub const ALL: [Mode; 7] = [
        Mode::Idle,
        Mode::Enabling,
        Mode::Ready,
        Mode::Swimming,
        Mode::Stopping,
        Mode::Fault,
        Mode::EStop,
    ];

    /// The mode of a snapshot's code (`StateSnapshot::mode`).
    pub fn from_code(code: u8) -> Option<Mode> {
        Self::ALL.get(code as usize).copied()
    }

    /// Lower-case name, as shown to operators.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Idle => "idle",
            Mode::Enabling => "enabling",
            Mode::Ready => "ready",
            Mode::Swimming => "swimming",
            Mode::Stopping => "stopping",
            Mode::Fault => "fault",
            Mode::EStop => "e-stop",
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Gait parameters an operator asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwimParams {
    /// Undulation amplitude as a fraction of the configured maximum, 0..=1
    /// (the operator's "speed" knob).
    pub amplitude: f64,
    /// Undulation frequency (Hz).
    pub frequency: f64,
    /// Yaw turn curvature K_c3 (1/m): positive turns left.
    pub turn: f64,
    /// Pitch curvature K_c2 (1/m): positive dives.
    pub pitch: f64,
}

impl SwimParams {
    /// No undulation, straight (what Stopping ramps towards).
    pub const REST: SwimParams = SwimParams {
        amplitude: 0.0,
        frequency: 0.0,
        turn: 0.0,
        pitch: 0.0,
    };
}

/// What the autopilot holds while swimming. `None` leaves that
/// axis to the operator's [`SwimParams::turn`] or [`SwimParams::pitch`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Hold {
    /// Heading to hold, degrees in the earth frame, counter-clockwise seen
    /// from above (a left turn increases it); any finite value, taken
    /// modulo 360.
    pub heading: Option<f64>,
    /// Depth to hold, metres below the surface (positive down).
    pub depth: Option<f64>,
}

impl Hold {
    /// Nothing held: the operator steers (manual).
    pub const MANUAL: Hold = Hold {
        heading: None,
        depth: None,
    };

    /// Whether anything is held.
    pub fn is_active(&self) -> bool {
        self.heading.is_some() || self.depth.is_some()
    }

    /// The mode's name: "manual", "heading", "depth" or "heading+depth".
    pub fn name(&self) -> &'static str {
        match (self.heading.is_some(), self.depth.is_some()) {
            (false, false) => "manual",
            (true, false) => "heading",
            (false, true) => "depth",
            (true, true) => "heading+depth",
        }
    }

    /// The snapshot's bits ([`hold_bits`]).
    pub fn bits(&self) -> u8 {
        let bit = |on: bool, b: u8| if on { b } else { 0 };
        bit(self.heading.is_some(), hold_bits::HEADING)
            | bit(self.depth.is_some(), hold_bits::DEPTH)
    }
}

/// The bits of `CommandRequest::hold` and `NavSnapshot::hold`.
pub mod hold_bits {
    /// A heading is held.
    pub const HEADING: u8 = 1 << 0;
    /// A depth is held.
    pub const DEPTH: u8 = 1 << 1;
}

/// How far off a held depth may be and count as held (m): the daemon's
/// [`HoldState::Holding`], and `ctl swim --for`'s "reached".
pub const HOLD_DEPTH_TOLERANCE: f64 = 0.2;
/// How far off a held heading may be and count as held (degrees).
pub const HOLD_HEADING_TOLERANCE: f64 = 10.0;
/// A depth estimate shallower than this (m) is at the surface
/// (`NavSnapshot::surfaced`).
pub const SURFACE_DEPTH: f64 = 0.05;

/// How one held quantity (heading or depth) is doing, as the daemon judges
/// it every control period (`NavSnapshot::heading_hold`, `depth_hold`;
/// docs/autopilot.md, "Hold states"). Codes 4 and up are failures: the
/// hold does not reach its target.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum HoldState {
    /// Not held.
    Off = 0,
    /// Held, waiting for the swim (a hold set at rest).
    Waiting = 1,
    /// Beyond the tolerance, the error shrinking (or the hold younger than
    /// its settle time).
    Converging = 2,
    /// Within the tolerance ([`HOLD_DEPTH_TOLERANCE`],
    /// [`HOLD_HEADING_TOLERANCE`]).
    Holding = 3,
    /// Beyond the tolerance and the error has not shrunk over the hold's
    /// settle time.
    NotConverging = 4,
    /// Cannot: at the surface and the target asks for a climb, or the body
    /// stays at the surface (depth).
    Surface = 5,
    /// Cannot: the command has been at its limit (turn rate, dive rate or
    /// curvature) while the error did not shrink.
    Limit = 6,
    /// Cannot: the gait swum has too little dive authority, or one whose
    /// sign the model's dive table does not know (it changes sign near
    /// this amplitude and frequency), and the error did not shrink (depth).
    Authority = 7,
}

impl HoldState {
    /// Every value, in the order of their codes.
    pub const ALL: [HoldState; 8] = [
        HoldState::Off,
        HoldState::Waiting,
        HoldState::Converging,
        HoldState::Holding,
        HoldState::NotConverging,
        HoldState::Surface,
        HoldState::Limit,
        HoldState::Authority,
    ];

    /// The state of a snapshot's code.
    pub fn from_code(code: u8) -> Option<HoldState> {
        Self::ALL.get(code as usize).copied()
    }

    /// Lower-case name, as shown to operators.
    pub fn name(self) -> &'static str {
        match self {
            HoldState::Off => "off",
            HoldState::Waiting => "waiting for the swim",
            HoldState::Converging => "converging",
            HoldState::Holding => "holding",
            HoldState::NotConverging => "not converging",
            HoldState::Surface => "cannot: at the surface",
            HoldState::Limit => "cannot: its command at its limit",
            HoldState::Authority => "cannot: this gait has no dive authority",
        }
    }

    /// The hold does not reach its target (not converging, or cannot).
    pub fn failed(self) -> bool {
        self as u8 >= HoldState::NotConverging as u8
    }
}

impl fmt::Display for HoldState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The head sensor's health as the daemon judges it (`NavSnapshot::sensor`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum SensorHealth {
    /// No head sensor is configured (`[sensor] node = 0`).
    None = 0,
    /// Samples arrive, plausible.
    Ok = 1,
    /// Configured, no sample yet (booting).
    Waiting = 2,
    /// No sample within the sensor timeout.
    Silent = 3,
    /// Samples arrive with their measured values frozen.
    Stuck = 4,
    /// The sensor reports an IMU or pressure fault in its error byte.
    Error = 5,
    /// The measurements disagree with the model's prediction beyond the
    /// configured bound (a gyro bias jump, a wrong estimate).
    Implausible = 6,
}

impl SensorHealth {
    /// Every value, in the order of their codes.
    pub const ALL: [SensorHealth; 7] = [
        SensorHealth::None,
        SensorHealth::Ok,
        SensorHealth::Waiting,
        SensorHealth::Silent,
        SensorHealth::Stuck,
        SensorHealth::Error,
        SensorHealth::Implausible,
    ];

    /// The health of a snapshot's code.
    pub fn from_code(code: u8) -> Option<SensorHealth> {
        Self::ALL.get(code as usize).copied()
    }

    /// Lower-case name, as shown to operators.
    pub fn name(self) -> &'static str {
        match self {
            SensorHealth::None => "no sensor",
            SensorHealth::Ok => "ok",
            SensorHealth::Waiting => "waiting",
            SensorHealth::Silent => "silent",
            SensorHealth::Stuck => "stuck",
            SensorHealth::Error => "sensor error",
            SensorHealth::Implausible => "implausible",
        }
    }
}

impl fmt::Display for SensorHealth {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What a sensor of the snapshot's list is ([`SensorEntry::kind`](crate::SensorEntry::kind)),
/// and what its values mean: a tool shows any sensor from this table alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum SensorKind {
    /// The head's IMU and pressure sensor and the navigation estimate
    /// built on it (`[sensor]`; the autopilot's). Its values are the
    /// estimate's, as `NavSnapshot`'s.
    HeadNav = 1,
    /// An IMU in the tail section (`[tail-imu]`): its attitude and rates
    /// as measured, no estimate.
    TailImu = 2,
}

impl SensorKind {
    /// Every kind, in the order of their codes.
    pub const ALL: [SensorKind; 2] = [SensorKind::HeadNav, SensorKind::TailImu];

    /// The kind of a snapshot's code (0: an empty entry).
    pub fn from_code(code: u8) -> Option<SensorKind> {
        Self::ALL.into_iter().find(|k| *k as u8 == code)
    }

    /// Lower-case name, as shown to operators and in recordings.
    pub const fn name(self) -> &'static str {
        match self {
            SensorKind::HeadNav => "head-nav",
            SensorKind::TailImu => "tail-imu",
        }
    }

    /// The meaning of [`SensorEntry::values`](crate::SensorEntry::values),
    /// in order: `(name, unit)`. Values past these are 0.
    pub const fn values(self) -> &'static [(&'static str, &'static str)] {
        match self {
            SensorKind::HeadNav => &[
                ("heading", "deg"),
                ("pitch", "deg"),
                ("roll", "deg"),
                ("depth", "m"),
                ("depth_rate", "m/s"),
                ("temperature", "degC"),
            ],
            SensorKind::TailImu => &[
                ("heading", "deg"),
                ("pitch", "deg"),
                ("roll", "deg"),
                ("rate_x", "rad/s"),
                ("rate_y", "rad/s"),
                ("rate_z", "rad/s"),
                ("temperature", "degC"),
            ],
        }
    }
}

impl fmt::Display for SensorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What a [`Command`] is, without its parameters: one table for its
/// request code ([`CommandRequest::code`](crate::CommandRequest::code)),
/// its name for operators and JSON clients, and what a refusal names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum CommandKind {
    /// [`Command::Enable`].
    Enable = 1,
    /// [`Command::Disable`].
    Disable = 2,
    /// [`Command::Swim`].
    Swim = 3,
    /// [`Command::Stop`].
    Stop = 4,
    /// [`Command::EStop`].
    EStop = 5,
    /// [`Command::Reset`].
    Reset = 6,
    /// [`Command::TakeControl`].
    TakeControl = 7,
    /// [`Command::ReleaseControl`].
    ReleaseControl = 8,
    /// [`Command::KeepAlive`].
    KeepAlive = 9,
    /// [`Command::Hold`].
    Hold = 10,
}

impl CommandKind {
    /// Every kind, in the order of their codes (1, 2, ...).
    pub const ALL: [CommandKind; 10] = [
        CommandKind::Enable,
        CommandKind::Disable,
        CommandKind::Swim,
        CommandKind::Stop,
        CommandKind::EStop,
        CommandKind::Reset,
        CommandKind::TakeControl,
        CommandKind::ReleaseControl,
        CommandKind::KeepAlive,
        CommandKind::Hold,
    ];

    /// Its request code.
    pub const fn code(self) -> u32 {
        self as u32
    }

    /// The kind of request code `code`, if any.
    pub const fn from_code(code: u32) -> Option<Self> {
        if code >= 1 && code as usize <= Self::ALL.len() {
            Some(Self::ALL[code as usize - 1])
        } else {
            None
        }
    }

    /// Lower-case name, as shown to operators and read from JSON.
    pub const fn name(self) -> &'static str {
        match self {
            CommandKind::Enable => "enable",
            CommandKind::Disable => "disable",
            CommandKind::Swim => "swim",
            CommandKind::Stop => "stop",
            CommandKind::EStop => "e-stop",
            CommandKind::Reset => "reset",
            CommandKind::TakeControl => "take-control",
            CommandKind::ReleaseControl => "release-control",
            CommandKind::KeepAlive => "keep-alive",
            CommandKind::Hold => "hold",
        }
    }

    /// The kind named `name` ([`CommandKind::name`]), if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Whether the command carries parameters (a swim's gait, a hold's
    /// targets).
    pub const fn has_parameters(self) -> bool {
        matches!(self, CommandKind::Swim | CommandKind::Hold)
    }
}

impl fmt::Display for CommandKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The commands an operator tool can send.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Command {
    /// Enable the actuators (Idle → Enabling → Ready).
    Enable,
    /// Disable the actuators (Ready or Fault → Idle).
    Disable,
    /// Swim, or change the gait while swimming.
    Swim(SwimParams),
    /// Stop swimming smoothly and hold straight.
    Stop,
    /// Emergency stop: accepted from any client, in any mode.
    EStop,
    /// Clear a fault or a latched E-stop (→ Idle).
    Reset,
    /// Ask for control authority.
    TakeControl,
    /// Give control authority up.
    ReleaseControl,
    /// Nothing but "I am still here" (keeps control and the swim alive).
    KeepAlive,
    /// Set what the autopilot holds while swimming: a heading, a depth,
    /// both, or neither (manual). Needs a healthy head sensor.
    Hold(Hold),
}

impl Command {
    /// Every command, once each (in the order of their request codes),
    /// those with parameters at rest: the table of their names.
    pub const ALL: [Command; 10] = [
        Command::Enable,
        Command::Disable,
        Command::Swim(SwimParams::REST),
        Command::Stop,
        Command::EStop,
        Command::Reset,
        Command::TakeControl,
        Command::ReleaseControl,
        Command::KeepAlive,
        Command::Hold(Hold::MANUAL),
    ];

    /// What it is, without its parameters.
    pub const fn kind(&self) -> CommandKind {
        match self {
            Command::Enable => CommandKind::Enable,
            Command::Disable => CommandKind::Disable,
            Command::Swim(_) => CommandKind::Swim,
            Command::Stop => CommandKind::Stop,
            Command::EStop => CommandKind::EStop,
            Command::Reset => CommandKind::Reset,
            Command::TakeControl => CommandKind::TakeControl,
            Command::ReleaseControl => CommandKind::ReleaseControl,
            Command::KeepAlive => CommandKind::KeepAlive,
            Command::Hold(_) => CommandKind::Hold,
        }
    }

    /// Lower-case name, as shown to operators ([`CommandKind::name`]).
    pub fn name(&self) -> &'static str {
        self.kind().name()
    }
}

/// Which swim parameter a range refusal is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    /// [`SwimParams::amplitude`].
    Amplitude,
    /// [`SwimParams::frequency`].
    Frequency,
    /// [`SwimParams::turn`].
    Turn,
    /// [`SwimParams::pitch`].
    Pitch,
    /// [`Hold::heading`].
    Heading,
    /// [`Hold::depth`].
    Depth,
}

impl Field {
    fn name(self) -> &'static str {
        match self {
            Field::Amplitude => "amplitude",
            Field::Frequency => "frequency (Hz)",
            Field::Turn => "turn curvature (1/m)",
            Field::Pitch => "pitch curvature (1/m)",
            Field::Heading => "heading (deg)",
            Field::Depth => "depth (m)",
        }
    }
}

/// Why a command was refused. `Copy`; its `Display` is the text the client shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Refusal {
    /// The command needs control authority and another client holds it.
    ControlHeldBy(ClientId),
    /// The command needs control authority and nobody holds it.
    NotInControl,
    /// The command is not valid in the current mode.
    InvalidInMode {
        /// The command refused.
        command: CommandKind,
        /// The mode it arrived in.
        mode: Mode,
        /// What would make it valid.
        hint: &'static str,
    },
    /// A swim parameter was NaN or infinite.
    NonFinite(Field),
    /// A swim parameter was outside its configured range.
    OutOfRange {
        /// The parameter.
        field: Field,
        /// The value sent.
        value: f64,
        /// Smallest accepted value.
        min: f64,
        /// Largest accepted value.
        max: f64,
    },
    /// The sequence number was not above the last one from this client
    /// port (a duplicate).
    StaleSequence {
        /// Sequence number received.
        got: u32,
        /// Last sequence number accepted from that client.
        last: u32,
    },
    /// Reset refused: the cause of the fault is still present.
    FaultPersists(FaultSet),
    /// More clients than the daemon tracks (their sequence numbers).
    TooManyClients,
    /// A hold needs a healthy head sensor; this is how it is.
    Sensor(SensorHealth),
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Refusal::ControlHeldBy(c) => write!(
                f,
                "client {c:032x} holds control; ask it to release, or wait for it to time out"
            ),
            Refusal::NotInControl => write!(f, "take control first"),
            Refusal::InvalidInMode {
                command,
                mode,
                hint,
            } => write!(f, "'{command}' is not valid in mode {mode}: {hint}"),
            Refusal::NonFinite(field) => write!(f, "{} is not a finite number", field.name()),
            Refusal::OutOfRange {
                field,
                value,
                min,
                max,
            } => write!(
                f,
                "{} = {value} is out of range (expected {min} ..= {max})",
                field.name()
            ),
            Refusal::StaleSequence { got, last } => write!(
                f,
                "sequence number {got} is not after this client's last one ({last}): every \
                 request uses up its number, accepted or refused"
            ),
            Refusal::FaultPersists(set) => {
                write!(f, "the fault is still present ({set}); fix it, then reset")
            }
            Refusal::TooManyClients => write!(f, "too many clients"),
            Refusal::Sensor(SensorHealth::None) => write!(
                f,
                "no head sensor is configured ([sensor] node); heading and depth hold need one"
            ),
            Refusal::Sensor(h) => write!(
                f,
                "the head sensor is {h}; heading and depth hold need it healthy"
            ),
        }
    }
}

/// A cause of a fault or a stop, one bit each in a [`FaultSet`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum FaultKind {
    /// A node's heartbeat stopped arriving.
    HeartbeatLost = 1 << 0,
    /// A node reported a fault in its heartbeat.
    NodeFault = 1 << 1,
    /// The bus went bus-off or the adapter disappeared.
    BusOff = 1 << 2,
    /// The model produced a non-finite or out-of-limit result.
    ModelDiverged = 1 << 3,
    /// An E-stop frame was seen on the bus (from a node or another tool).
    BusEStop = 1 << 4,
    /// An operator client sent an E-stop.
    OperatorEStop = 1 << 5,
    /// Nodes did not all report enabled within the enable timeout.
    EnableTimeout = 1 << 6,
    /// The bus adapter is gone (unplugged, its device closed).
    AdapterGone = 1 << 7,
    /// A node answered no SYNC for `control.feedback-timeout` periods,
    /// whatever its heartbeats say (a dead joint, or its heartbeats forged).
    FeedbackLost = 1 << 8,
    /// A node's heartbeat counter did not advance by one, again and again:
    /// two senders use its id (a second node, or a forger on the bus).
    DuplicateNode = 1 << 9,
    /// A node reported Boot while it should have been enabled (Ready,
    /// Swimming, Stopping): it rebooted, and its joint went limp.
    NodeRebooted = 1 << 10,
    /// A node reported Disabled while it should have been enabled (Ready,
    /// Swimming, Stopping): someone disabled it, or it did itself; its
    /// joint went limp.
    NodeDisabled = 1 << 11,
    /// Another sender on the bus told one of our drives to change state
    /// (anguilla: Enable, Disable, ClearFaults; CiA 402: an NMT command
    /// other than Stop, an RPDO; ODrive: Set axis state, Clear errors, Set
    /// controller mode; MIT: Enter motor mode, Set zero): taken as an
    /// E-stop from the bus.
    ForeignCommand = 1 << 12,
    /// A joint's measured angle stayed beyond the tracking band from its
    /// setpoint for the tracking time while the drives followed setpoints
    /// (limp, jammed, or not the joint the feedback claims).
    TrackingError = 1 << 13,
    /// A joint's fresh feedback stayed the same, bit for bit, while its
    /// setpoints moved it: a copier replaying a dead joint's frame, or a
    /// half-dead node.
    FeedbackFrozen = 1 << 14,
}

impl FaultKind {
    /// Every kind, in bit order.
    pub const ALL: [FaultKind; 15] = [
        FaultKind::HeartbeatLost,
        FaultKind::NodeFault,
        FaultKind::BusOff,
        FaultKind::ModelDiverged,
        FaultKind::BusEStop,
        FaultKind::OperatorEStop,
        FaultKind::EnableTimeout,
        FaultKind::AdapterGone,
        FaultKind::FeedbackLost,
        FaultKind::DuplicateNode,
        FaultKind::NodeRebooted,
        FaultKind::NodeDisabled,
        FaultKind::ForeignCommand,
        FaultKind::TrackingError,
        FaultKind::FeedbackFrozen,
    ];

    /// The cause (`StateSnapshot.cause`) the daemon shows when this kind
    /// takes it to E-stop or fault: an operator's E-stop is a command,
    /// everything else a fault. The daemon's supervisor takes it from
    /// here, and docs/ipc.md's E-stop sentence is generated from it.
    pub fn cause(self) -> Cause {
        if self == FaultKind::OperatorEStop {
            Cause::Command
        } else {
            Cause::Fault
        }
    }

    /// Its bit's value in `StateSnapshot.fault_kinds`.
    pub fn bit(self) -> u32 {
        self as u32
    }

    /// Short name, as shown to operators.
    pub fn name(self) -> &'static str {
        match self {
            FaultKind::HeartbeatLost => "heartbeat lost",
            FaultKind::NodeFault => "actuator fault",
            FaultKind::BusOff => "bus off",
            FaultKind::ModelDiverged => "model diverged",
            FaultKind::BusEStop => "e-stop on the bus",
            FaultKind::OperatorEStop => "operator e-stop",
            FaultKind::EnableTimeout => "enable timed out",
            FaultKind::AdapterGone => "adapter gone",
            FaultKind::FeedbackLost => "no feedback",
            FaultKind::DuplicateNode => "duplicate node id",
            FaultKind::NodeRebooted => "actuator rebooted",
            FaultKind::NodeDisabled => "actuator disabled",
            FaultKind::ForeignCommand => "foreign drive command",
            FaultKind::TrackingError => "tracking error",
            FaultKind::FeedbackFrozen => "feedback frozen",
        }
    }
}

/// A set of [`FaultKind`]s and the nodes involved. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FaultSet {
    /// One bit per [`FaultKind`].
    pub kinds: u32,
    /// Bit `i` set: node id `i` is involved (ids 0..=63).
    pub nodes: u64,
}

impl FaultSet {
    /// Whether there is no fault.
    pub fn is_empty(&self) -> bool {
        self.kinds == 0
    }

    /// Whether `kind` is in the set.
    pub fn contains(&self, kind: FaultKind) -> bool {
        self.kinds & kind as u32 != 0
    }

    /// Adds `kind` with the `nodes` involved.
    pub fn insert(&mut self, kind: FaultKind, nodes: u64) {
        self.kinds |= kind as u32;
        self.nodes |= nodes;
    }
}

impl fmt::Display for FaultSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_empty() {
            return f.write_str("no fault");
        }
        let mut first = true;
        for k in FaultKind::ALL {
            if self.contains(k) {
                if !first {
                    f.write_str(", ")?;
                }
                f.write_str(k.name())?;
                first = false;
            }
        }
        if self.nodes != 0 {
            f.write_str(" (node")?;
            for i in 0..64 {
                if self.nodes & (1 << i) != 0 {
                    write!(f, " {i}")?;
                }
            }
            f.write_str(")")?;
        }
        Ok(())
    }
}

/// Why the swim stopped or the mode last changed, for the operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cause {
    /// No change yet.
    None,
    /// An operator command.
    Command,
    /// The holder stopped sending commands.
    OperatorSilent,
    /// A fault; see the daemon's `Supervisor::faults`.
    Fault,
    /// The nodes reported enabled, or the ramp down finished.
    Progress,
    /// The autopilot lost its head sensor or its estimate became
    /// implausible: the swim stopped smoothly (`NavSnapshot::hold_exit`
    /// says why).
    SensorLost,
    /// The daemon is shutting down (SIGINT, SIGTERM or SIGHUP; `anguilla
    /// run --duration`): a swim stops smoothly, then every actuator is
    /// disabled. No operator asked.
    Shutdown,
}

impl Cause {
    /// Every cause, in the order of their codes.
    pub const ALL: [Cause; 7] = [
        Cause::None,
        Cause::Command,
        Cause::OperatorSilent,
        Cause::Fault,
        Cause::Progress,
        Cause::SensorLost,
        Cause::Shutdown,
    ];

    /// Its code in a snapshot (`StateSnapshot::cause`).
    pub fn code(self) -> u8 {
        Self::ALL.iter().position(|&c| c == self).unwrap_or(0) as u8
    }

    /// The cause of a snapshot's code.
    pub fn from_code(code: u8) -> Option<Cause> {
        Self::ALL.get(code as usize).copied()
    }

    /// What brought the mode about, in an operator's words (status lines,
    /// the mode-change log); [`Cause::name`] is the token of JSON outputs.
    pub fn words(self) -> &'static str {
        match self {
            Cause::None => "since the start",
            Cause::Command => "by an operator's command",
            Cause::OperatorSilent => "the operator fell silent",
            Cause::Fault => "by a fault",
            Cause::Progress => "step done",
            Cause::SensorLost => "the head sensor was lost",
            Cause::Shutdown => "the daemon is shutting down",
        }
    }

    /// Lower-case name: the token of JSON outputs and schemas.
    pub fn name(self) -> &'static str {
        match self {
            Cause::None => "none",
            Cause::Command => "command",
            Cause::OperatorSilent => "operator silent",
            Cause::Fault => "fault",
            Cause::Progress => "progress",
            Cause::SensorLost => "head sensor lost",
            Cause::Shutdown => "shutdown",
        }
    }
}
