//! SWIM-HOLD: a swim and its hold in one request
//! ([`Command::SwimHold`]): both are taken or neither is. Its JSON form is
//! SWIM's fields and HOLD's.

use super::body::{BODY_WORDS, Body};
use super::hold::HoldBody;
use super::swim::SwimBody;
#[cfg(doc)]
use crate::vocabulary::Command;
use crate::vocabulary::CommandKind;

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
    /// What to hold: bit 0 heading, bit 1 depth ([`hold_bits`](crate::hold_bits)); 0 manual.
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
