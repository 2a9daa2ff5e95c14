//! WAYPOINT: one waypoint of the path being loaded
//! ([`Command::Waypoint`]).

use super::body::{BODY_WORDS, Body, Fields};
#[cfg(doc)]
use crate::vocabulary::Command;
use crate::vocabulary::{CommandKind, Waypoint};

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
    pub(super) fn of(p: &Waypoint) -> Self {
        Self {
            index: p.index,
            x: p.x as f32,
            y: p.y as f32,
            depth: p.depth.map_or(f32::NAN, |d| d as f32),
        }
    }

    pub(super) fn waypoint(&self) -> Waypoint {
        Waypoint {
            index: self.index,
            x: self.x as f64,
            y: self.y as f64,
            depth: (!self.depth.is_nan()).then_some(self.depth as f64),
        }
    }
}

/// The waypoint from its JSON form: `index`, `x`, `y` (m), optionally
/// `depth` (m).
pub(super) fn from_fields(f: &dyn Fields) -> Result<Waypoint, String> {
    Ok(Waypoint {
        index: f.count("index")?,
        x: f.required("x")?,
        y: f.required("y")?,
        depth: f.number("depth")?,
    })
}
