//! What an operator asks of the swim: the gait ([`SwimParams`]) and what
//! the autopilot holds ([`Hold`]); and how a hold is doing ([`HoldState`]).

use core::fmt;

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

/// `deg` in 0 ..< 360, rounded to a thousandth of a degree so repeated
/// steps do not drift.
pub fn wrap_heading(deg: f64) -> f64 {
    let h = ((deg.rem_euclid(360.0)) * 1000.0).round() / 1000.0;
    if h >= 360.0 { 0.0 } else { h }
}
