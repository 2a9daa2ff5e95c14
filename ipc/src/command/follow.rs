//! FOLLOW: swim along the path loaded ([`Command::Follow`]).

use super::body::{BODY_WORDS, Body, Fields, RequestError};
#[cfg(doc)]
use crate::vocabulary::Command;
use crate::vocabulary::{CommandKind, Follow, SwimParams};

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
    pub(super) fn of(f: &Follow) -> Self {
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
    pub(super) fn read(&self) -> Result<Follow, RequestError> {
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

/// The command from its JSON form: `amplitude`, `frequency`, `count`, and
/// the flags `loop`, `from_here` and `resume` (false if absent). The
/// guidance steers: no turn, no pitch.
pub(super) fn from_fields(f: &dyn Fields) -> Result<Follow, String> {
    Ok(Follow {
        swim: SwimParams {
            amplitude: f.required("amplitude")?,
            frequency: f.required("frequency")?,
            turn: 0.0,
            pitch: 0.0,
        },
        count: f.count("count")?,
        looped: f.flag("loop")?,
        from_here: f.flag("from_here")?,
        resume: f.flag("resume")?,
    })
}
