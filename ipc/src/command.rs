//! The command service's payloads: the request, a fixed head (layout
//! version, code, sequence) and a body whose layout the code chooses, and
//! the daemon's reply.
//!
//! Each command with parameters is a module of its own, after mini-redis's
//! `src/cmd/`: its body type and words ([`Body`]), its encoding from and
//! decoding to the vocabulary's [`Command`], the errors of a body that is
//! not one, and its JSON form ([`Fields`]): [`swim`], [`hold`],
//! [`swim_hold`], [`waypoint`], [`follow`]. A new command adds no field to
//! any other command's layout; commands without parameters send a zero
//! body. Here, every dispatch over the commands is a `match` the compiler
//! checks: [`CommandRequest::new`], [`CommandRequest::command`],
//! [`Command::from_fields`].

pub mod body;
pub mod follow;
pub mod hold;
pub mod swim;
pub mod swim_hold;
pub mod waypoint;

use core::fmt::{self, Write as _};

use iceoryx2::prelude::*;

pub use body::{BODY_WORDS, Body, Fields, RequestError};
pub use follow::{FollowBody, follow_bits};
pub use hold::HoldBody;
pub use swim::SwimBody;
pub use swim_hold::SwimHoldBody;
pub use waypoint::WaypointBody;

use crate::payload::{LAYOUT_VERSION, Raw, sealed::Sealed};
use crate::vocabulary::{Command, CommandKind};

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

impl Command {
    /// The command of kind `kind` from its named fields (its JSON form):
    /// each command's module reads its own; a command without parameters
    /// reads none.
    pub fn from_fields(kind: CommandKind, f: &dyn Fields) -> Result<Command, String> {
        Ok(match kind {
            CommandKind::Swim => Command::Swim(swim::from_fields(f)?),
            CommandKind::Hold => Command::Hold(hold::from_fields(f)?),
            CommandKind::SwimHold => {
                Command::SwimHold(swim::from_fields(f)?, hold::from_fields(f)?)
            }
            CommandKind::Waypoint => Command::Waypoint(waypoint::from_fields(f)?),
            CommandKind::Follow => Command::Follow(follow::from_fields(f)?),
            CommandKind::Enable => Command::Enable,
            CommandKind::Disable => Command::Disable,
            CommandKind::Stop => Command::Stop,
            CommandKind::EStop => Command::EStop,
            CommandKind::Reset => Command::Reset,
            CommandKind::TakeControl => Command::TakeControl,
            CommandKind::ReleaseControl => Command::ReleaseControl,
            CommandKind::KeepAlive => Command::KeepAlive,
        })
    }
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
