//! What every command's module shares: a body's words ([`Body`]), why a
//! request cannot be read ([`RequestError`]), and the named fields an
//! operator tool received a command as ([`Fields`], its JSON form).

use crate::payload::LAYOUT_VERSION;
use crate::vocabulary::CommandKind;

/// 32-bit words in a [`CommandRequest`](super::CommandRequest)'s body: the
/// most parameters one command can carry (28 bytes).
pub const BODY_WORDS: usize = 7;

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

/// Why a [`CommandRequest`](super::CommandRequest) could not be read at all.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RequestError {
    /// The sender uses another layout version.
    #[error("layout version {0} is not the daemon's ({LAYOUT_VERSION}); update the tool")]
    Version(u32),
    /// The command code is not one of [`code`](super::code).
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

/// The named fields of one command as an operator tool received it (a
/// JSON object: `anguilla_teleop::json::command_from_json`, the Foxglove
/// command channel): what each command's module reads its parameters
/// from. Every error names the field and what was expected.
pub trait Fields {
    /// The command's name, for errors.
    fn command(&self) -> &str;
    /// The number `key`: `None` if absent (or null); an error if it is
    /// not a number.
    fn number(&self, key: &str) -> Result<Option<f64>, String>;
    /// The boolean `key`: `None` if absent (or null); an error if it is
    /// not one.
    fn boolean(&self, key: &str) -> Result<Option<bool>, String>;

    /// The number `key`, which must be there.
    fn required(&self, key: &str) -> Result<f64, String> {
        self.number(key)?
            .ok_or_else(|| format!("{} needs a number \"{key}\"", self.command()))
    }

    /// The flag `key`, false if absent.
    fn flag(&self, key: &str) -> Result<bool, String> {
        Ok(self.boolean(key)?.unwrap_or(false))
    }

    /// The whole number `key` (0 ..= 2³² − 1), which must be there.
    fn count(&self, key: &str) -> Result<u32, String> {
        let x = self.required(key)?;
        if x.fract() == 0.0 && (0.0..=f64::from(u32::MAX)).contains(&x) {
            Ok(x as u32)
        } else {
            Err(format!(
                "\"{key}\" of {} must be a whole number >= 0, not {x}",
                self.command()
            ))
        }
    }
}
