//! The command service's payloads: the request, a fixed head (layout
//! version, code, sequence) and a body whose layout the code chooses, and
//! the daemon's reply. A command's parameters live in its own body type,
//! so a new command adds no field to any other command's layout; commands
//! without parameters send a zero body.

use core::fmt::{self, Write as _};

use iceoryx2::prelude::*;

use crate::payload::{LAYOUT_VERSION, Raw, sealed::Sealed};
use crate::vocabulary::{Command, CommandKind, Follow, Hold, SwimParams, Waypoint, hold_bits};

/// Command codes of [`CommandRequest::code`], from [`CommandKind`]'s table.
pub mod code {
    use crate::vocabulary::CommandKind;

    /// Enable the actuators.
    pub const ENABLE: u32 = CommandKind::Enable.code();
    /// Disable the actuators.
    pub const DISABLE: u32 = CommandKind::Disable.code();
    /// Swim with the gait of the request's [`SwimBody`](super::SwimBody).
    pub const SWIM: u32 = CommandKind::Swim.code();
    /// Stop swimming smoothly.
    pub const STOP: u32 = CommandKind::Stop.code();
    /// Emergency stop (accepted from any client).
    pub const ESTOP: u32 = CommandKind::EStop.code();
    /// Clear a fault or an E-stop.
    pub const RESET: u32 = CommandKind::Reset.code();
    /// Take control authority.
    pub const TAKE_CONTROL: u32 = CommandKind::TakeControl.code();
    /// Release control authority.
    pub const RELEASE_CONTROL: u32 = CommandKind::ReleaseControl.code();
    /// Keep control and the swim alive.
    pub const KEEP_ALIVE: u32 = CommandKind::KeepAlive.code();
    /// Set the autopilot's holds from the request's [`HoldBody`](super::HoldBody).
    pub const HOLD: u32 = CommandKind::Hold.code();
    /// Swim with the gait and the holds of the request's
    /// [`SwimHoldBody`](super::SwimHoldBody), in one request.
    pub const SWIM_HOLD: u32 = CommandKind::SwimHold.code();
    /// Load one waypoint of a path from the request's
    /// [`WaypointBody`](super::WaypointBody).
    pub const WAYPOINT: u32 = CommandKind::Waypoint.code();
    /// Follow the path loaded, with the request's
    /// [`FollowBody`](super::FollowBody).
    pub const FOLLOW: u32 = CommandKind::Follow.code();
}

/// 32-bit words in a [`CommandRequest`]'s body: the most parameters one
/// command can carry (28 bytes).
pub const BODY_WORDS: usize = 7;

/// A command from an operator tool. Who sent it is not a field: the
/// daemon knows it from the iceoryx2 client port it arrived on.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::CommandRequest")]
pub struct CommandRequest {
    /// [`LAYOUT_VERSION`] of the sender.
    pub layout_version: u32,
    /// One of the [`code`] constants.
    pub code: u32,
    /// Increases with every command from this client port (a repeated or
    /// older number is refused as a duplicate, except for an E-stop).
    pub sequence: u32,
    /// The command's parameters, laid out by `code`: [`SwimBody`] for
    /// SWIM, [`HoldBody`] for HOLD, [`SwimHoldBody`] for SWIM-HOLD,
    /// [`WaypointBody`] for WAYPOINT, [`FollowBody`] for FOLLOW, zero for
    /// the others (ignored). A float
    /// is its IEEE 754 bits; words past a body's size are zero.
    pub body: [u32; BODY_WORDS],
}

/// The parameters of one command, as the words of a request's body, in
/// the order of its `#[repr(C)]` fields (every field 4 bytes), so that a
/// C or Python client may overlay the struct on the body.
pub trait Body: Sized {
    /// The command this body belongs to.
    const KIND: CommandKind;
    /// The body's words.
    fn to_words(&self) -> [u32; BODY_WORDS];
    /// The body read from a request's words.
    fn from_words(words: &[u32; BODY_WORDS]) -> Self;
}

/// SWIM's body: the gait.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct SwimBody {
    /// Swim amplitude, fraction of the maximum (0..=1).
    pub amplitude: f32,
    /// Swim frequency (Hz).
    pub frequency: f32,
    /// Yaw turn curvature (1/m).
    pub turn: f32,
    /// Pitch curvature (1/m).
    pub pitch: f32,
}

impl Body for SwimBody {
    const KIND: CommandKind = CommandKind::Swim;
    fn to_words(&self) -> [u32; BODY_WORDS] {
        let mut w = [0; BODY_WORDS];
        w[..4].copy_from_slice(&[
            self.amplitude.to_bits(),
            self.frequency.to_bits(),
            self.turn.to_bits(),
            self.pitch.to_bits(),
        ]);
        w
    }
    fn from_words(w: &[u32; BODY_WORDS]) -> Self {
        Self {
            amplitude: f32::from_bits(w[0]),
            frequency: f32::from_bits(w[1]),
            turn: f32::from_bits(w[2]),
            pitch: f32::from_bits(w[3]),
        }
    }
}

/// HOLD's body: what the autopilot holds, and where.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct HoldBody {
    /// What to hold: bit 0 heading, bit 1 depth ([`hold_bits`]); 0 manual.
    pub hold: u32,
    /// Heading to hold (deg, counter-clockwise seen from above), with bit 0.
    pub heading: f32,
    /// Depth to hold (m below the surface), with bit 1.
    pub depth: f32,
}

impl Body for HoldBody {
    const KIND: CommandKind = CommandKind::Hold;
    fn to_words(&self) -> [u32; BODY_WORDS] {
        let mut w = [0; BODY_WORDS];
        w[..3].copy_from_slice(&[self.hold, self.heading.to_bits(), self.depth.to_bits()]);
        w
    }
    fn from_words(w: &[u32; BODY_WORDS]) -> Self {
        Self {
            hold: w[0],
            heading: f32::from_bits(w[1]),
            depth: f32::from_bits(w[2]),
        }
    }
}

/// SWIM-HOLD's body: the gait ([`SwimBody`]'s fields) and what the
/// autopilot holds ([`HoldBody`]'s), one after the other.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct SwimHoldBody {
    /// Swim amplitude, fraction of the maximum (0..=1).
    pub amplitude: f32,
    /// Swim frequency (Hz).
    pub frequency: f32,
    /// Yaw turn curvature (1/m); the autopilot's while a heading is held.
    pub turn: f32,
    /// Pitch curvature (1/m); the autopilot's while a depth is held.
    pub pitch: f32,
    /// What to hold: bit 0 heading, bit 1 depth ([`hold_bits`]); 0 manual.
    pub hold: u32,
    /// Heading to hold (deg), with bit 0.
    pub heading: f32,
    /// Depth to hold (m below the surface), with bit 1.
    pub depth: f32,
}

impl SwimHoldBody {
    /// The gait's body and the hold's, one after the other.
    pub fn join(s: SwimBody, h: HoldBody) -> Self {
        Self {
            amplitude: s.amplitude,
            frequency: s.frequency,
            turn: s.turn,
            pitch: s.pitch,
            hold: h.hold,
            heading: h.heading,
            depth: h.depth,
        }
    }

    /// The gait's body and the hold's.
    pub fn parts(&self) -> (SwimBody, HoldBody) {
        let s = SwimBody {
            amplitude: self.amplitude,
            frequency: self.frequency,
            turn: self.turn,
            pitch: self.pitch,
        };
        let h = HoldBody {
            hold: self.hold,
            heading: self.heading,
            depth: self.depth,
        };
        (s, h)
    }
}

impl Body for SwimHoldBody {
    const KIND: CommandKind = CommandKind::SwimHold;
    fn to_words(&self) -> [u32; BODY_WORDS] {
        let (s, h) = self.parts();
        let mut w = s.to_words();
        w[4..].copy_from_slice(&h.to_words()[..3]);
        w
    }
    fn from_words(w: &[u32; BODY_WORDS]) -> Self {
        let mut rest = [0; BODY_WORDS];
        rest[..3].copy_from_slice(&w[4..]);
        Self::join(SwimBody::from_words(w), HoldBody::from_words(&rest))
    }
}

impl SwimBody {
    fn of(p: &SwimParams) -> Self {
        Self {
            amplitude: p.amplitude as f32,
            frequency: p.frequency as f32,
            turn: p.turn as f32,
            pitch: p.pitch as f32,
        }
    }

    fn params(&self) -> SwimParams {
        SwimParams {
            amplitude: self.amplitude as f64,
            frequency: self.frequency as f64,
            turn: self.turn as f64,
            pitch: self.pitch as f64,
        }
    }
}

impl HoldBody {
    fn of(h: &Hold) -> Self {
        Self {
            hold: u32::from(h.bits()),
            heading: h.heading.unwrap_or(0.0) as f32,
            depth: h.depth.unwrap_or(0.0) as f32,
        }
    }

    /// The hold, or why its bits are not one.
    fn read(&self) -> Result<Hold, RequestError> {
        if self.hold & !u32::from(hold_bits::HEADING | hold_bits::DEPTH) != 0 {
            return Err(RequestError::HoldBits(self.hold));
        }
        let on = |bit: u8, v: f32| (self.hold & u32::from(bit) != 0).then_some(v as f64);
        Ok(Hold {
            heading: on(hold_bits::HEADING, self.heading),
            depth: on(hold_bits::DEPTH, self.depth),
        })
    }
}

/// WAYPOINT's body: one waypoint of the path being loaded.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct WaypointBody {
    /// Its place in the path, from 0 (0 starts a new path).
    pub index: u32,
    /// x (m), in the estimate's local frame.
    pub x: f32,
    /// y (m).
    pub y: f32,
    /// The depth to hold on the leg ending there (m below the surface);
    /// NaN: none.
    pub depth: f32,
}

impl Body for WaypointBody {
    const KIND: CommandKind = CommandKind::Waypoint;
    fn to_words(&self) -> [u32; BODY_WORDS] {
        let mut w = [0; BODY_WORDS];
        w[..4].copy_from_slice(&[
            self.index,
            self.x.to_bits(),
            self.y.to_bits(),
            self.depth.to_bits(),
        ]);
        w
    }
    fn from_words(w: &[u32; BODY_WORDS]) -> Self {
        Self {
            index: w[0],
            x: f32::from_bits(w[1]),
            y: f32::from_bits(w[2]),
            depth: f32::from_bits(w[3]),
        }
    }
}

impl WaypointBody {
    fn of(p: &Waypoint) -> Self {
        Self {
            index: p.index,
            x: p.x as f32,
            y: p.y as f32,
            depth: p.depth.map_or(f32::NAN, |d| d as f32),
        }
    }

    fn waypoint(&self) -> Waypoint {
        Waypoint {
            index: self.index,
            x: self.x as f64,
            y: self.y as f64,
            depth: (!self.depth.is_nan()).then_some(self.depth as f64),
        }
    }
}

/// The bits of [`FollowBody::flags`].
pub mod follow_bits {
    /// After the last waypoint, back to the first.
    pub const LOOP: u32 = 1 << 0;
    /// The first leg runs from where the robot is to waypoint 0.
    pub const FROM_HERE: u32 = 1 << 1;
    /// Resume the interrupted path on its leg.
    pub const RESUME: u32 = 1 << 2;
}

/// FOLLOW's body: the gait and how the path loaded is followed.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct FollowBody {
    /// Swim amplitude, fraction of the maximum (0..=1).
    pub amplitude: f32,
    /// Swim frequency (Hz).
    pub frequency: f32,
    /// The path's waypoints: the number loaded.
    pub count: u32,
    /// [`follow_bits`].
    pub flags: u32,
}

impl Body for FollowBody {
    const KIND: CommandKind = CommandKind::Follow;
    fn to_words(&self) -> [u32; BODY_WORDS] {
        let mut w = [0; BODY_WORDS];
        w[..4].copy_from_slice(&[
            self.amplitude.to_bits(),
            self.frequency.to_bits(),
            self.count,
            self.flags,
        ]);
        w
    }
    fn from_words(w: &[u32; BODY_WORDS]) -> Self {
        Self {
            amplitude: f32::from_bits(w[0]),
            frequency: f32::from_bits(w[1]),
            count: w[2],
            flags: w[3],
        }
    }
}

impl FollowBody {
    fn of(f: &Follow) -> Self {
        let bit = |on: bool, b: u32| if on { b } else { 0 };
        Self {
            amplitude: f.swim.amplitude as f32,
            frequency: f.swim.frequency as f32,
            count: f.count,
            flags: bit(f.looped, follow_bits::LOOP)
                | bit(f.from_here, follow_bits::FROM_HERE)
                | bit(f.resume, follow_bits::RESUME),
        }
    }

    /// The command, or why its flags are not one.
    fn read(&self) -> Result<Follow, RequestError> {
        if self.flags & !(follow_bits::LOOP | follow_bits::FROM_HERE | follow_bits::RESUME) != 0 {
            return Err(RequestError::FollowBits(self.flags));
        }
        Ok(Follow {
            swim: SwimParams {
                amplitude: self.amplitude as f64,
                frequency: self.frequency as f64,
                turn: 0.0,
                pitch: 0.0,
            },
            count: self.count,
            looped: self.flags & follow_bits::LOOP != 0,
            from_here: self.flags & follow_bits::FROM_HERE != 0,
            resume: self.flags & follow_bits::RESUME != 0,
        })
    }
}

const _: () = assert!(size_of::<SwimBody>() <= 4 * BODY_WORDS);
const _: () = assert!(size_of::<WaypointBody>() <= 4 * BODY_WORDS);
const _: () = assert!(size_of::<FollowBody>() <= 4 * BODY_WORDS);
const _: () = assert!(size_of::<SwimHoldBody>() <= 4 * BODY_WORDS);
const _: () = assert!(size_of::<HoldBody>() <= 4 * BODY_WORDS);

impl CommandRequest {
    /// A request for `cmd` with sequence number `sequence`.
    pub fn new(cmd: Command, sequence: u32) -> Self {
        let body = match cmd {
            Command::Swim(p) => SwimBody::of(&p).to_words(),
            Command::Hold(h) => HoldBody::of(&h).to_words(),
            Command::SwimHold(p, h) => {
                SwimHoldBody::join(SwimBody::of(&p), HoldBody::of(&h)).to_words()
            }
            Command::Waypoint(w) => WaypointBody::of(&w).to_words(),
            Command::Follow(f) => FollowBody::of(&f).to_words(),
            // No parameters: an empty body. Every command is named here, so
            // a new one with parameters is not sent without them.
            Command::Enable
            | Command::Disable
            | Command::Stop
            | Command::EStop
            | Command::Reset
            | Command::TakeControl
            | Command::ReleaseControl
            | Command::KeepAlive => [0; BODY_WORDS],
        };
        Self {
            layout_version: LAYOUT_VERSION,
            code: cmd.kind().code(),
            sequence,
            body,
        }
    }

    /// A request recorded under an older layout read as this one, so that
    /// sessions recorded then still replay: layout 5 (before the body:
    /// SWIM's four floats in words 3..7, HOLD's bits and floats in words
    /// 7..10, a 40-byte request too) is moved into the body; layouts 6
    /// to 11 (whose requests are this layout's; 7 to 12 changed the
    /// state snapshot only, or added commands) are relabelled; any other
    /// request unchanged.
    pub fn from_older_layout(old: Self) -> Self {
        if (6..LAYOUT_VERSION).contains(&old.layout_version) {
            return Self {
                layout_version: LAYOUT_VERSION,
                ..old
            };
        }
        if old.layout_version != 5 {
            return old;
        }
        let mut words = [0u32; 3 + BODY_WORDS];
        words[..3].copy_from_slice(&[old.layout_version, old.code, old.sequence]);
        words[3..].copy_from_slice(&old.body);
        let mut body = [0; BODY_WORDS];
        match CommandKind::from_code(old.code) {
            Some(CommandKind::Swim) => body[..4].copy_from_slice(&words[3..7]),
            Some(CommandKind::Hold) => body[..3].copy_from_slice(&words[7..10]),
            // Layout 5's other requests carried no parameters (SWIM-HOLD
            // came with layout 10); an unknown code is refused when read,
            // as it was then.
            Some(
                CommandKind::SwimHold
                | CommandKind::Waypoint
                | CommandKind::Follow
                | CommandKind::Enable
                | CommandKind::Disable
                | CommandKind::Stop
                | CommandKind::EStop
                | CommandKind::Reset
                | CommandKind::TakeControl
                | CommandKind::ReleaseControl
                | CommandKind::KeepAlive,
            )
            | None => {}
        }
        Self {
            layout_version: LAYOUT_VERSION,
            body,
            ..old
        }
    }

    /// The body read as `B`, whatever the code says.
    pub fn body_as<B: Body>(&self) -> B {
        B::from_words(&self.body)
    }

    /// Whether this is an E-stop, whatever else it says (the layout version
    /// included): an E-stop is never refused for being malformed.
    pub fn is_estop(&self) -> bool {
        self.code == code::ESTOP
    }

    /// The command, or why the request cannot be read.
    pub fn command(&self) -> Result<Command, RequestError> {
        if self.is_estop() {
            return Ok(Command::EStop);
        }
        if self.layout_version != LAYOUT_VERSION {
            return Err(RequestError::Version(self.layout_version));
        }
        let Some(kind) = CommandKind::from_code(self.code) else {
            return Err(RequestError::UnknownCode(self.code));
        };
        Ok(match kind {
            CommandKind::Enable => Command::Enable,
            CommandKind::Disable => Command::Disable,
            CommandKind::Swim => Command::Swim(self.body_as::<SwimBody>().params()),
            CommandKind::Stop => Command::Stop,
            CommandKind::EStop => Command::EStop,
            CommandKind::Reset => Command::Reset,
            CommandKind::TakeControl => Command::TakeControl,
            CommandKind::ReleaseControl => Command::ReleaseControl,
            CommandKind::KeepAlive => Command::KeepAlive,
            CommandKind::Hold => Command::Hold(self.body_as::<HoldBody>().read()?),
            CommandKind::SwimHold => {
                let (swim, hold) = self.body_as::<SwimHoldBody>().parts();
                Command::SwimHold(swim.params(), hold.read()?)
            }
            CommandKind::Waypoint => Command::Waypoint(self.body_as::<WaypointBody>().waypoint()),
            CommandKind::Follow => Command::Follow(self.body_as::<FollowBody>().read()?),
        })
    }
}

/// Why a [`CommandRequest`] could not be read at all.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RequestError {
    /// The sender uses another layout version.
    #[error("layout version {0} is not the daemon's ({LAYOUT_VERSION}); update the tool")]
    Version(u32),
    /// The command code is not one of [`code`].
    #[error("unknown command code {0} (expected 1..={n})", n = CommandKind::ALL.len())]
    UnknownCode(u32),
    /// A HOLD or SWIM-HOLD request's `hold` has bits beyond heading (1)
    /// and depth (2).
    #[error("hold bits {0:#x} unknown (expected 0..=3: 1 heading, 2 depth)")]
    HoldBits(u32),
    /// A FOLLOW request's `flags` has bits beyond loop (1) and from-here
    /// (2).
    #[error("follow flags {0:#x} unknown (expected 0..=7: 1 loop, 2 from here, 4 resume)")]
    FollowBits(u32),
}

/// Bytes of reason text in a [`CommandReply`].
pub const REASON_LEN: usize = 120;

/// The daemon's answer to one [`CommandRequest`].
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::CommandReply")]
pub struct CommandReply {
    /// The request's sequence number.
    pub sequence: u32,
    /// 1 accepted, 0 refused.
    pub accepted: u8,
    /// The mode after handling the command (as in [`StateSnapshot::mode`](crate::StateSnapshot::mode)).
    pub mode: u8,
    /// Bytes of `reason` in use.
    pub reason_len: u16,
    /// Why it was refused: UTF-8, `reason_len` bytes, zero padded.
    pub reason: [u8; REASON_LEN],
}

impl CommandReply {
    /// An acceptance.
    pub fn accepted(req: &CommandRequest, mode: u8) -> Self {
        Self {
            sequence: req.sequence,
            accepted: 1,
            mode,
            reason_len: 0,
            reason: [0; REASON_LEN],
        }
    }

    /// A refusal whose reason is `why`'s `Display` (cut to [`REASON_LEN`]
    /// bytes on a character boundary, ending in "…" when cut). Allocates
    /// nothing.
    pub fn refused(req: &CommandRequest, mode: u8, why: &dyn fmt::Display) -> Self {
        let mut w = FixedText::default();
        if write!(w, "{why}").is_err() {
            // Cut: say so with "…" (3 bytes), on a character boundary.
            let mut end = w.len.min(REASON_LEN - 3);
            while end > 0 && (w.buf[end] & 0xC0) == 0x80 {
                end -= 1;
            }
            w.buf[end..end + 3].copy_from_slice("…".as_bytes());
            w.buf[end + 3..].fill(0);
            w.len = end + 3;
        }
        Self {
            sequence: req.sequence,
            accepted: 0,
            mode,
            reason_len: w.len as u16,
            reason: w.buf,
        }
    }

    /// The reason text ("" when accepted).
    pub fn reason(&self) -> &str {
        let n = (self.reason_len as usize).min(REASON_LEN);
        core::str::from_utf8(&self.reason[..n]).unwrap_or("(reason is not UTF-8)")
    }
}

#[derive(Debug)]
struct FixedText {
    buf: [u8; REASON_LEN],
    len: usize,
}

impl Default for FixedText {
    fn default() -> Self {
        Self {
            buf: [0; REASON_LEN],
            len: 0,
        }
    }
}

impl fmt::Write for FixedText {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for ch in s.chars() {
            let mut tmp = [0u8; 4];
            let enc = ch.encode_utf8(&mut tmp).as_bytes();
            if self.len + enc.len() > REASON_LEN {
                return Err(fmt::Error);
            }
            self.buf[self.len..self.len + enc.len()].copy_from_slice(enc);
            self.len += enc.len();
        }
        Ok(())
    }
}

impl Sealed for CommandRequest {}
impl Sealed for CommandReply {}
impl Raw for CommandRequest {}
impl Raw for CommandReply {}
