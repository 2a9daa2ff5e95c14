//! HOLD: what the autopilot holds while swimming ([`Command::Hold`]).

use super::body::{BODY_WORDS, Body, Fields, RequestError};
#[cfg(doc)]
use crate::vocabulary::Command;
use crate::vocabulary::{CommandKind, Hold, hold_bits, wrap_heading};

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

impl HoldBody {
    pub(super) fn of(h: &Hold) -> Self {
        Self {
            hold: u32::from(h.bits()),
            heading: h.heading.unwrap_or(0.0) as f32,
            depth: h.depth.unwrap_or(0.0) as f32,
        }
    }

    /// The hold, or why its bits are not one.
    pub(super) fn read(&self) -> Result<Hold, RequestError> {
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

/// The hold from its JSON form: `heading` (deg, wrapped into 0 ..< 360)
/// and/or `depth` (m); neither: manual.
pub(super) fn from_fields(f: &dyn Fields) -> Result<Hold, String> {
    Ok(Hold {
        heading: f.number("heading")?.map(wrap_heading),
        depth: f.number("depth")?,
    })
}
