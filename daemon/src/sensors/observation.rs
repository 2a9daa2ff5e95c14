//! What a sensor hands the estimate (`crate::nav::Nav::observe`): typed
//! observations with their time and uncertainty, whatever the sensor and
//! its wire. The head sensor's own samples (attitude, rates, depth) are
//! the estimate's process and are read by it directly.

use anguilla_protocol::time::Nanos;

/// One observation.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Observation {
    /// Where the nose was at `at` (the daemon's clock): `x`, `y` (m) in the
    /// estimate's local frame, with the horizontal standard deviation
    /// `sigma` (m).
    PositionFix {
        /// When it was measured.
        at: Nanos,
        /// x (m).
        x: f64,
        /// y (m).
        y: f64,
        /// Standard deviation (m).
        sigma: f64,
    },
    /// The robot's velocity over ground at `at`: `vx`, `vy` (m/s) in the
    /// estimate's local frame, with the standard deviation `sigma` (m/s,
    /// per axis).
    VelocityOverGround {
        /// When it was measured.
        at: Nanos,
        /// x (m/s).
        vx: f64,
        /// y (m/s).
        vy: f64,
        /// Standard deviation (m/s).
        sigma: f64,
    },
}
