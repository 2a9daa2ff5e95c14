//! Guided swimming: a path's [`Waypoint`]s, sent one a request, the
//! [`Follow`] that starts it, and how the daemon is doing on it
//! ([`GuideState`], `StateSnapshot::guide`; docs/autopilot.md, "Following
//! a path").

use core::fmt;

use super::swim::SwimParams;

/// Most waypoints a path holds.
pub const MAX_WAYPOINTS: usize = 64;

/// One waypoint of the path being loaded: the `index`-th (0 starts a new
/// path and forgets the one loaded before; the next must be the count
/// loaded so far), at `x`, `y` (m) in the estimate's local frame (its
/// origin where the estimate started), with a depth to hold on the leg
/// that ends there (m below the surface) or none.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Waypoint {
    /// Its place in the path, from 0.
    pub index: u32,
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// The depth to hold on the way to it (m), or none (the depth is the
    /// operator's, or the last held).
    pub depth: Option<f64>,
}

/// Follow the path loaded by [`Waypoint`]s: swim at `amplitude` and
/// `frequency`, the heading (and the waypoints' depths) the guidance's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Follow {
    /// The gait: amplitude and frequency (turn and pitch are the
    /// autopilot's and are ignored).
    pub swim: SwimParams,
    /// How many waypoints the path has: must be the number loaded (a path
    /// half loaded, or loaded by two tools at once, is refused).
    pub count: u32,
    /// After the last waypoint, back to the first, until stopped.
    pub looped: bool,
    /// The first leg runs from where the robot is when the path starts to
    /// waypoint 0 (`ctl goto`); otherwise the first leg is waypoint 0 to 1
    /// and the robot joins it from wherever it is.
    pub from_here: bool,
    /// Resume the path an operator's command interrupted
    /// ([`GuideState::Interrupted`]) on the leg it was on, instead of
    /// starting the one loaded (`count` is then the interrupted path's;
    /// `looped` and `from_here` are its own).
    pub resume: bool,
}

/// How the path is doing (`GuideSnapshot::state`). Codes 4 and up are
/// failures: the path was not finished.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum GuideState {
    /// No path since the start.
    Off = 0,
    /// Following it.
    Following = 1,
    /// The last waypoint was reached; the swim stops.
    Done = 2,
    /// An operator's command (a swim, a hold: the operator took over; a
    /// stop, an E-stop, control released) or the end of the swim
    /// interrupted it; [`Follow::resume`] takes it up again on its leg.
    Interrupted = 3,
    /// The position fix was lost (older than `[autopilot] fix-lost`): the
    /// swim stops, holding the last heading.
    FixLost = 4,
    /// The estimate crossed the geofence: the swim stops.
    Fence = 5,
}

impl GuideState {
    /// Every value, in the order of their codes.
    pub const ALL: [GuideState; 6] = [
        GuideState::Off,
        GuideState::Following,
        GuideState::Done,
        GuideState::Interrupted,
        GuideState::FixLost,
        GuideState::Fence,
    ];

    /// The state of a snapshot's code.
    pub fn from_code(code: u8) -> Option<GuideState> {
        Self::ALL.get(code as usize).copied()
    }

    /// Lower-case name, as shown to operators.
    pub fn name(self) -> &'static str {
        match self {
            GuideState::Off => "off",
            GuideState::Following => "following",
            GuideState::Done => "done",
            GuideState::Interrupted => "interrupted by a command",
            GuideState::FixLost => "stopped: position fix lost",
            GuideState::Fence => "stopped: geofence crossed",
        }
    }

    /// The path was not finished (fix lost, fence).
    pub fn failed(self) -> bool {
        self as u8 >= GuideState::FixLost as u8
    }
}

impl fmt::Display for GuideState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
