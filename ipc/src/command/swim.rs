//! SWIM: swim, or change the gait while swimming ([`Command::Swim`]).

use super::body::{BODY_WORDS, Body, Fields};
#[cfg(doc)]
use crate::vocabulary::Command;
use crate::vocabulary::{CommandKind, SwimParams};

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

impl SwimBody {
    pub(super) fn of(p: &SwimParams) -> Self {
        Self {
            amplitude: p.amplitude as f32,
            frequency: p.frequency as f32,
            turn: p.turn as f32,
            pitch: p.pitch as f32,
        }
    }

    pub(super) fn params(&self) -> SwimParams {
        SwimParams {
            amplitude: self.amplitude as f64,
            frequency: self.frequency as f64,
            turn: self.turn as f64,
            pitch: self.pitch as f64,
        }
    }
}

/// The gait from its JSON form: `amplitude` and `frequency`, optionally
/// `turn` and `pitch` (0 if absent). The daemon checks the ranges.
pub(super) fn from_fields(f: &dyn Fields) -> Result<SwimParams, String> {
    Ok(SwimParams {
        amplitude: f.required("amplitude")?,
        frequency: f.required("frequency")?,
        turn: f.number("turn")?.unwrap_or(0.0),
        pitch: f.number("pitch")?.unwrap_or(0.0),
    })
}
