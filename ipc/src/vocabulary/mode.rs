//! What the daemon is doing and why: its [`Mode`], and the [`Cause`] of
//! its last change.

use core::fmt;

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
    /// A path was followed to its last waypoint: the swim stops smoothly.
    PathDone,
    /// The estimate crossed the geofence (`[guidance] fence`): the swim
    /// stops smoothly.
    Fence,
    /// A path was being followed and the position fix was lost (older
    /// than `[autopilot] fix-lost`): the swim stops smoothly, holding the
    /// last heading.
    FixLost,
}

impl Cause {
    /// Every cause, in the order of their codes.
    pub const ALL: [Cause; 10] = [
        Cause::None,
        Cause::Command,
        Cause::OperatorSilent,
        Cause::Fault,
        Cause::Progress,
        Cause::SensorLost,
        Cause::Shutdown,
        Cause::PathDone,
        Cause::Fence,
        Cause::FixLost,
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
            Cause::PathDone => "the path's last waypoint was reached",
            Cause::Fence => "the robot crossed the geofence",
            Cause::FixLost => "the position fix was lost while following a path",
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
            Cause::PathDone => "path done",
            Cause::Fence => "fence",
            Cause::FixLost => "fix lost",
        }
    }
}
