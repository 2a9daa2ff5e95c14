//! The commands an operator tool sends: [`Command`], and its
//! [`CommandKind`] (code and name) without its parameters.

use core::fmt;

use super::path::{Follow, Waypoint};
use super::swim::{Hold, SwimParams};

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
    /// [`Command::SwimHold`].
    SwimHold = 11,
    /// [`Command::Waypoint`].
    Waypoint = 12,
    /// [`Command::Follow`].
    Follow = 13,
}

impl CommandKind {
    /// Every kind, in the order of their codes (1, 2, ...).
    pub const ALL: [CommandKind; 13] = [
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
        CommandKind::SwimHold,
        CommandKind::Waypoint,
        CommandKind::Follow,
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
            CommandKind::SwimHold => "swim-hold",
            CommandKind::Waypoint => "waypoint",
            CommandKind::Follow => "follow",
        }
    }

    /// The kind named `name` ([`CommandKind::name`]), if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The command of this kind when it has no parameters; `None` for
    /// those that carry some (a swim's gait, a hold's targets).
    pub const fn bare(self) -> Option<Command> {
        match self {
            CommandKind::Enable => Some(Command::Enable),
            CommandKind::Disable => Some(Command::Disable),
            CommandKind::Stop => Some(Command::Stop),
            CommandKind::EStop => Some(Command::EStop),
            CommandKind::Reset => Some(Command::Reset),
            CommandKind::TakeControl => Some(Command::TakeControl),
            CommandKind::ReleaseControl => Some(Command::ReleaseControl),
            CommandKind::KeepAlive => Some(Command::KeepAlive),
            CommandKind::Swim
            | CommandKind::Hold
            | CommandKind::SwimHold
            | CommandKind::Waypoint
            | CommandKind::Follow => None,
        }
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
    /// Swim (or change the gait) with what the autopilot holds, in one
    /// request: both are taken or neither is, so a held swim never starts
    /// manual (`ctl swim --heading`). An active hold needs a healthy head
    /// sensor, as [`Command::Hold`].
    SwimHold(SwimParams, Hold),
    /// Load one waypoint of a path (the holder only; any mode): index 0
    /// starts a new path.
    Waypoint(Waypoint),
    /// Swim along the path loaded, the guidance holding the heading
    /// (docs/autopilot.md, "Following a path"). Needs a healthy head
    /// sensor and a position that is not lost; any later swim, hold, stop
    /// or E-stop ends the path.
    Follow(Follow),
}

impl Command {
    /// Every command, once each (in the order of their request codes),
    /// those with parameters at rest: the table of their names.
    pub const ALL: [Command; 13] = [
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
        Command::SwimHold(SwimParams::REST, Hold::MANUAL),
        Command::Waypoint(Waypoint {
            index: 0,
            x: 0.0,
            y: 0.0,
            depth: None,
        }),
        Command::Follow(Follow {
            swim: SwimParams::REST,
            count: 0,
            looped: false,
            from_here: false,
            resume: false,
        }),
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
            Command::SwimHold(..) => CommandKind::SwimHold,
            Command::Waypoint(_) => CommandKind::Waypoint,
            Command::Follow(_) => CommandKind::Follow,
        }
    }

    /// What it asks of the swim: its gait, its hold (a held swim both; a
    /// path its gait, the hold being the guidance's; the other commands
    /// neither).
    pub const fn swim_and_hold(&self) -> (Option<SwimParams>, Option<Hold>) {
        match *self {
            Command::Swim(p) => (Some(p), None),
            Command::Hold(h) => (None, Some(h)),
            Command::SwimHold(p, h) => (Some(p), Some(h)),
            // A path holds a heading: the guidance's, set every period
            // (the value here stands in for it).
            Command::Follow(f) => (
                Some(f.swim),
                Some(Hold {
                    heading: Some(0.0),
                    depth: None,
                }),
            ),
            Command::Waypoint(_)
            | Command::Enable
            | Command::Disable
            | Command::Stop
            | Command::EStop
            | Command::Reset
            | Command::TakeControl
            | Command::ReleaseControl
            | Command::KeepAlive => (None, None),
        }
    }

    /// Lower-case name, as shown to operators ([`CommandKind::name`]).
    pub fn name(&self) -> &'static str {
        self.kind().name()
    }
}
