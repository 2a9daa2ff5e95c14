//! `[guidance]`: path following and the geofence (docs/autopilot.md,
//! "Following a path").

use serde::{Deserialize, Serialize};

use super::error::{ConfigError, fmt_f, range};

/// Most vertices a geofence polygon has.
pub const MAX_FENCE_VERTICES: usize = 32;

/// `[guidance]`: the integral line-of-sight law's look-ahead and integral
/// gain, when a waypoint counts as reached, and the geofence.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct GuidanceConfig {
    /// The look-ahead distance Δ (m): the heading aims at the point Δ
    /// ahead on the path.
    pub look_ahead: f64,
    /// The integral gain κ (m/s): 0 is plain line of sight.
    pub integral: f64,
    /// The path's last waypoint is reached within this distance (m), or
    /// when the robot passes the normal to the leg through it.
    pub acceptance_radius: f64,
    /// The next leg starts within this distance of a waypoint (m), or
    /// when the robot passes the normal through it: about the radius the
    /// body turns at, so the turn onto the next leg starts before the
    /// corner instead of overshooting it.
    pub switch_radius: f64,
    /// A geofence: a circle of this radius (m) about the estimate's
    /// origin; 0: none.
    pub fence_radius: f64,
    /// A geofence: a polygon's vertices `[x, y]` (m, the estimate's
    /// frame), at least 3; empty: none.
    pub fence: Vec<[f64; 2]>,
}

impl Default for GuidanceConfig {
    fn default() -> Self {
        Self {
            look_ahead: 1.5,
            integral: 0.25,
            acceptance_radius: 0.5,
            switch_radius: 1.5,
            fence_radius: 0.0,
            fence: Vec::new(),
        }
    }
}

impl GuidanceConfig {
    /// Checks `[guidance]`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        range(
            "guidance.look-ahead",
            self.look_ahead,
            0.1,
            100.0,
            "0.1 ..= 100 m",
        )?;
        range(
            "guidance.integral",
            self.integral,
            0.0,
            2.0,
            "0 ..= 2 m/s (0: plain line of sight)",
        )?;
        range(
            "guidance.acceptance-radius",
            self.acceptance_radius,
            0.05,
            100.0,
            "0.05 ..= 100 m",
        )?;
        range(
            "guidance.switch-radius",
            self.switch_radius,
            0.05,
            100.0,
            "0.05 ..= 100 m",
        )?;
        range(
            "guidance.fence-radius",
            self.fence_radius,
            0.0,
            100_000.0,
            "0 (none) ..= 100000 m",
        )?;
        let n = self.fence.len();
        if n != 0 && !(3..=MAX_FENCE_VERTICES).contains(&n) {
            return Err(ConfigError::Derived(format!(
                "guidance.fence has {n} vertices (expected none, or 3 ..= \
                 {MAX_FENCE_VERTICES} [x, y] pairs in metres)"
            )));
        }
        if let Some(i) = self
            .fence
            .iter()
            .position(|p| !(p[0].is_finite() && p[1].is_finite()))
        {
            return Err(ConfigError::Derived(format!(
                "guidance.fence vertex {} is not two finite numbers (expected [x, y] in metres)",
                i + 1
            )));
        }
        if n >= 3 && polygon_area(&self.fence).abs() < 1e-6 {
            return Err(ConfigError::Derived(
                "guidance.fence encloses no area (expected at least 3 vertices not on one line)"
                    .into(),
            ));
        }
        Ok(())
    }
}

/// The signed area of a polygon (m², positive counter-clockwise).
pub fn polygon_area(p: &[[f64; 2]]) -> f64 {
    let n = p.len();
    (0..n)
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        / 2.0
}

/// `[guidance]` in the commented default file ([`super::sections_toml`]).
pub(super) fn write_default(d: &GuidanceConfig, w: &mut dyn FnMut(String)) {
    w("[guidance]".into());
    w("# Path following (docs/autopilot.md, \"Following a path\"): integral line of".into());
    w("# sight, heading = leg direction - atan((e + integral * y_int) / look-ahead), the".into());
    w("# heading hold as the inner loop. look-ahead in m, integral in m/s (0: plain line".into());
    w("# of sight, which keeps an offset in a current). The next leg starts within".into());
    w("# switch-radius (m) of a waypoint, the last waypoint is reached within".into());
    w("# acceptance-radius (m), or either on passing the normal through the waypoint.".into());
    w(format!("look-ahead = {}", fmt_f(d.look_ahead)));
    w(format!("integral = {}", fmt_f(d.integral)));
    w(format!(
        "acceptance-radius = {}",
        fmt_f(d.acceptance_radius)
    ));
    w(format!("switch-radius = {}", fmt_f(d.switch_radius)));
    w("# A geofence, refused at load and enforced while swimming (crossing it stops".into());
    w("# the swim): a circle of fence-radius (m) about the estimate's origin (0: none),".into());
    w("# and/or a polygon, fence = [[x, y], ...] (m; empty: none).".into());
    w(format!("fence-radius = {}", fmt_f(d.fence_radius)));
    w("fence = []".into());
    w(String::new());
}
