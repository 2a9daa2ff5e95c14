//! Path following: integral line-of-sight guidance (docs/autopilot.md,
//! "Following a path").
//!
//! A path is loaded one waypoint a request ([`Guidance::load`]) and
//! followed on [`Command::Follow`](anguilla_ipc::Command::Follow)
//! ([`Guidance::start`]). Every period, on the leg from waypoint `a` to
//! `b` (direction `γ`), the body's centre gives the cross-track error `e`
//! (positive left) and the heading asked of the heading hold is
//! the integral line-of-sight law (Børhaug, Pavlov, Pettersen, CDC 2008;
//! the form of MSS `ILOSpsi.m`):
//!
//! ```text
//! ψ_d   = γ − atan((e + κ y_int) / Δ)
//! ẏ_int = Δ e / ((e + κ y_int)² + Δ²)
//! ```
//!
//! with the look-ahead `Δ` (m) and the integral gain `κ` (m/s) of
//! `[guidance]`. In a current the robot must crab: plain line of sight
//! (κ = 0) settles where `atan(e/Δ)` is the crab angle, an offset of
//! `Δ V / √(U² − V²)` for a sideways current `V` at speed `U`; the
//! integral term takes that angle over and the offset goes. A new leg's
//! integral starts at the crab angle the estimated current asks for on
//! it (0 without a current estimate), so a turn does not start over.
//!
//! The next leg starts within `switch-radius` of a waypoint (about the
//! radius the body turns at, so the turn starts before the corner), the
//! last waypoint is reached within `acceptance-radius`, or either when the
//! robot passes the normal to the leg through the waypoint. The geofence (a circle about
//! the origin, a polygon, or both) is checked when loading, when starting
//! and every period. Nothing here allocates after [`Guidance::new`].

use core::fmt;

use anguilla_ipc::{Follow, GuideSnapshot, GuideState, MAX_WAYPOINTS, PositionHealth, Waypoint};

use crate::config::{Config, MAX_FENCE_VERTICES};

#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Point {
    x: f64,
    y: f64,
    depth: Option<f64>,
}

/// Why a waypoint or a path was refused.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PathRefusal {
    /// Waypoints are loaded in order, from 0.
    Order {
        /// The index sent.
        got: u32,
        /// The one expected (the number loaded).
        expected: u32,
    },
    /// More than [`MAX_WAYPOINTS`].
    Full,
    /// A coordinate or depth is not a finite number.
    NonFinite(u32),
    /// A depth out of `0 ..= max-depth`.
    Depth {
        /// The waypoint.
        index: u32,
        /// Its depth (m).
        depth: f64,
        /// `[autopilot] max-depth` (m).
        max: f64,
    },
    /// A waypoint outside the geofence.
    OutsideFence {
        /// The waypoint.
        index: u32,
        /// x (m).
        x: f64,
        /// y (m).
        y: f64,
    },
    /// A waypoint at the place of the one before: a leg of no length.
    SamePlace(u32),
    /// The count sent is not the number loaded.
    Count {
        /// The count sent.
        got: u32,
        /// The number loaded.
        loaded: u32,
    },
    /// Too few waypoints for a path (2, or 1 from here).
    TooFew {
        /// The number loaded.
        loaded: u32,
        /// The least.
        needed: u32,
    },
    /// The robot is outside the geofence.
    RobotOutsideFence {
        /// x (m).
        x: f64,
        /// y (m).
        y: f64,
    },
    /// The position is not good enough to follow a path.
    Position(PositionHealth),
    /// No head sensor: no heading, no position.
    NoSensor,
    /// A resume, and no path was interrupted.
    NothingToResume(GuideState),
}

impl fmt::Display for PathRefusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            PathRefusal::Order { got, expected } => write!(
                f,
                "waypoint {got} is out of order (expected {expected}, or 0 to start a new path)"
            ),
            PathRefusal::Full => write!(f, "a path holds at most {MAX_WAYPOINTS} waypoints"),
            PathRefusal::NonFinite(i) => write!(f, "waypoint {i}: not a finite number"),
            PathRefusal::Depth { index, depth, max } => write!(
                f,
                "waypoint {index}: depth {depth} m is out of range (expected 0 ..= {max} m)"
            ),
            PathRefusal::OutsideFence { index, x, y } => write!(
                f,
                "waypoint {index} ({x:.2}, {y:.2}) m is outside the geofence ([guidance])"
            ),
            PathRefusal::SamePlace(i) => {
                write!(
                    f,
                    "waypoint {i} is where the one before is: a leg of no length"
                )
            }
            PathRefusal::Count { got, loaded } => write!(
                f,
                "the path has {loaded} waypoints loaded, not {got}: load it again"
            ),
            PathRefusal::TooFew { loaded, needed } => write!(
                f,
                "{loaded} waypoints loaded; a path needs at least {needed}"
            ),
            PathRefusal::RobotOutsideFence { x, y } => write!(
                f,
                "the robot ({x:.2}, {y:.2}) m is outside the geofence: swim it back by hand"
            ),
            PathRefusal::Position(h) => write!(
                f,
                "the position is '{}': a path needs a position that is not lost or waiting",
                h.name()
            ),
            PathRefusal::NothingToResume(g) => write!(
                f,
                "no path to resume: the last one is '{}' (only one a command interrupted resumes)",
                g.name()
            ),
            PathRefusal::NoSensor => write!(
                f,
                "no head sensor is configured ([sensor] node): a path needs a heading and a position"
            ),
        }
    }
}

/// The geofence of `[guidance]`: inside the circle (if any) and inside
/// the polygon (if any).
#[derive(Debug, Clone, Copy)]
struct Fence {
    radius: f64,
    vertices: [[f64; 2]; MAX_FENCE_VERTICES],
    n: usize,
}

impl Fence {
    fn contains(&self, x: f64, y: f64) -> bool {
        if self.radius > 0.0 && x.hypot(y) > self.radius {
            return false;
        }
        self.n < 3 || inside_polygon(&self.vertices[..self.n], x, y)
    }
}

/// Whether `x`, `y` is inside the polygon `p` (even-odd rule).
fn inside_polygon(p: &[[f64; 2]], x: f64, y: f64) -> bool {
    let mut inside = false;
    let mut j = p.len() - 1;
    for i in 0..p.len() {
        let ([xi, yi], [xj, yj]) = (p[i], p[j]);
        if (yi > y) != (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi {
            inside = !inside;
        }
        j = i;
    }
    inside
}

/// What the guidance asks of the autopilot this period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Steer {
    /// The heading to hold (deg, counter-clockwise from x, `[0, 360)`).
    pub heading: f64,
    /// The depth to hold (m), if the path sets one.
    pub depth: Option<f64>,
}

/// The path loaded, the one followed, and the guidance's state.
#[derive(Debug, Clone)]
pub struct Guidance {
    look_ahead: f64,
    integral: f64,
    radius: f64,
    switch_radius: f64,
    max_depth: f64,
    fence: Fence,
    loaded: [Point; MAX_WAYPOINTS],
    loaded_len: usize,
    path: [Point; MAX_WAYPOINTS + 1],
    len: usize,
    /// Where a loop starts again (1 when the path starts from here).
    loop_start: usize,
    looped: bool,
    from: usize,
    to: usize,
    y_int: f64,
    depth: Option<f64>,
    state: GuideState,
    steer: Steer,
    cross: f64,
    along: f64,
    to_go: f64,
    /// Whether the last position seen was inside the fence.
    inside: Option<bool>,
    /// How far the body's centre is behind the nose (m): half its length.
    centre_behind: f64,
}

impl Guidance {
    /// The guidance of `cfg`'s `[guidance]`, no path loaded.
    pub fn new(cfg: &Config) -> Self {
        let g = &cfg.guidance;
        let mut vertices = [[0.0; 2]; MAX_FENCE_VERTICES];
        let n = g.fence.len().min(MAX_FENCE_VERTICES);
        vertices[..n].copy_from_slice(&g.fence[..n]);
        Self {
            look_ahead: g.look_ahead,
            integral: g.integral,
            radius: g.acceptance_radius,
            switch_radius: g.switch_radius,
            max_depth: cfg.autopilot.max_depth,
            fence: Fence {
                radius: g.fence_radius,
                vertices,
                n,
            },
            loaded: [Point::default(); MAX_WAYPOINTS],
            loaded_len: 0,
            path: [Point::default(); MAX_WAYPOINTS + 1],
            len: 0,
            loop_start: 0,
            looped: false,
            from: 0,
            to: 0,
            y_int: 0.0,
            depth: None,
            state: GuideState::Off,
            steer: Steer {
                heading: 0.0,
                depth: None,
            },
            cross: 0.0,
            along: 0.0,
            to_go: 0.0,
            inside: None,
            centre_behind: cfg.model.body().length / 2.0,
        }
    }

    /// Whether `w` may be loaded next.
    pub fn check_waypoint(&self, w: &Waypoint) -> Result<(), PathRefusal> {
        let expected = if w.index == 0 { 0 } else { self.loaded_len };
        if w.index as usize != expected {
            return Err(PathRefusal::Order {
                got: w.index,
                expected: self.loaded_len as u32,
            });
        }
        if expected >= MAX_WAYPOINTS {
            return Err(PathRefusal::Full);
        }
        if !(w.x.is_finite() && w.y.is_finite() && w.depth.is_none_or(f64::is_finite)) {
            return Err(PathRefusal::NonFinite(w.index));
        }
        if let Some(d) = w.depth
            && !(0.0..=self.max_depth).contains(&d)
        {
            return Err(PathRefusal::Depth {
                index: w.index,
                depth: d,
                max: self.max_depth,
            });
        }
        if !self.fence.contains(w.x, w.y) {
            return Err(PathRefusal::OutsideFence {
                index: w.index,
                x: w.x,
                y: w.y,
            });
        }
        if expected > 0 {
            let p = self.loaded[expected - 1];
            if (p.x - w.x).hypot(p.y - w.y) < 1e-3 {
                return Err(PathRefusal::SamePlace(w.index));
            }
        }
        Ok(())
    }

    /// Loads `w` (after [`Guidance::check_waypoint`]); index 0 forgets the
    /// path loaded before (not the one followed).
    pub fn load(&mut self, w: &Waypoint) {
        if w.index == 0 {
            self.loaded_len = 0;
        }
        if self.loaded_len < MAX_WAYPOINTS {
            self.loaded[self.loaded_len] = Point {
                x: w.x,
                y: w.y,
                depth: w.depth,
            };
            self.loaded_len += 1;
        }
    }

    /// Waypoints loaded.
    pub fn loaded(&self) -> usize {
        self.loaded_len
    }

    /// Whether the loaded path may be followed from `at` with the
    /// position's `health`.
    pub fn check_follow(
        &self,
        f: &Follow,
        at: Option<(f64, f64)>,
        health: PositionHealth,
    ) -> Result<(), PathRefusal> {
        let Some((x, y)) = at else {
            return Err(PathRefusal::NoSensor);
        };
        if matches!(health, PositionHealth::Lost | PositionHealth::Waiting) {
            return Err(PathRefusal::Position(health));
        }
        if !self.fence.contains(x, y) {
            return Err(PathRefusal::RobotOutsideFence { x, y });
        }
        if f.resume {
            let n = (self.len - self.loop_start) as u32;
            return if self.state != GuideState::Interrupted {
                Err(PathRefusal::NothingToResume(self.state))
            } else if f.count != n {
                Err(PathRefusal::Count {
                    got: f.count,
                    loaded: n,
                })
            } else {
                Ok(())
            };
        }
        let loaded = self.loaded_len as u32;
        if f.count != loaded {
            return Err(PathRefusal::Count {
                got: f.count,
                loaded,
            });
        }
        let needed = if f.from_here { 1 } else { 2 };
        if loaded < needed {
            return Err(PathRefusal::TooFew { loaded, needed });
        }
        if f.from_here {
            let p = self.loaded[0];
            if (p.x - x).hypot(p.y - y) < 1e-3 {
                return Err(PathRefusal::SamePlace(0));
            }
        }
        Ok(())
    }

    /// Starts following the loaded path from `at` (after
    /// [`Guidance::check_follow`]).
    pub fn start(&mut self, f: &Follow, at: (f64, f64)) {
        let mut n = 0;
        if f.from_here {
            self.path[0] = Point {
                x: at.0,
                y: at.1,
                depth: None,
            };
            n = 1;
        }
        self.path[n..n + self.loaded_len].copy_from_slice(&self.loaded[..self.loaded_len]);
        self.len = n + self.loaded_len;
        self.loop_start = n;
        self.looped = f.looped && self.loaded_len >= 2;
        self.from = 0;
        self.to = 1;
        self.y_int = 0.0;
        self.depth = self.path[1].depth;
        self.state = GuideState::Following;
        self.cross = 0.0;
        self.along = 0.0;
    }

    /// Takes the interrupted path up again on its leg (after
    /// [`Guidance::check_follow`] of a resume), its integral seeded from
    /// the estimated `current` at `speed` as on a new leg.
    pub fn resume(&mut self, current: (f64, f64), speed: f64) {
        if self.state == GuideState::Interrupted && self.len > 0 {
            self.state = GuideState::Following;
            self.y_int = self.crab_integral(current, speed);
        }
    }

    /// Whether a path is being followed.
    pub fn following(&self) -> bool {
        self.state == GuideState::Following
    }

    /// Ends the path being followed, if any, with `why`.
    pub fn end(&mut self, why: GuideState) {
        if self.following() {
            self.state = why;
        }
    }

    /// The path's state.
    pub fn state(&self) -> GuideState {
        self.state
    }

    /// The last heading asked (deg).
    pub fn heading(&self) -> f64 {
        self.steer.heading
    }

    /// The depth the path holds (m), if any.
    pub fn depth(&self) -> Option<f64> {
        self.depth
    }

    /// Whether the robot at `x`, `y` has just left the fence (inside the
    /// last time it was looked at, outside now).
    pub fn left_fence(&mut self, x: f64, y: f64) -> bool {
        let inside = self.fence.contains(x, y);
        let left = self.inside == Some(true) && !inside;
        self.inside = Some(inside);
        left
    }

    /// One period of `dt` seconds at `at`, the estimated `current` (m/s)
    /// and forward `speed` (m/s): the heading and depth to hold, or `None`
    /// once the last waypoint is reached (the state is then
    /// [`GuideState::Done`]) or no path is followed.
    pub fn steer(
        &mut self,
        dt: f64,
        at: (f64, f64),
        current: (f64, f64),
        speed: f64,
    ) -> Option<Steer> {
        if !self.following() {
            return None;
        }
        // Switch legs past every waypoint reached (at most a lap).
        for _ in 0..self.len {
            let b = self.path[self.to];
            let (gamma, length) = self.leg();
            let along = (at.0 - self.path[self.from].x) * gamma.cos()
                + (at.1 - self.path[self.from].y) * gamma.sin();
            let last = self.to + 1 == self.len && !self.looped;
            let radius = if last {
                self.radius
            } else {
                self.switch_radius
            };
            if (at.0 - b.x).hypot(at.1 - b.y) >= radius && along < length {
                break;
            }
            let next = if self.to + 1 < self.len {
                self.to + 1
            } else if self.looped {
                self.loop_start
            } else {
                self.state = GuideState::Done;
                return None;
            };
            self.from = self.to;
            self.to = next;
            if let Some(d) = self.path[self.to].depth {
                self.depth = Some(d);
            }
            self.y_int = self.crab_integral(current, speed);
        }
        let a = self.path[self.from];
        let (gamma, _) = self.leg();
        let (rx, ry) = (at.0 - a.x, at.1 - a.y);
        self.along = rx * gamma.cos() + ry * gamma.sin();
        // The body's centre is what follows the leg. `at` is the nose's
        // estimate; crabbing at `asin(V⊥ / U)` into the current, the
        // centre, half the body's length behind it along the heading, is
        // `c V⊥ / U` to the left of the nose's track (0.07 m on the
        // built-in robot across 0.1 m/s). Taken from the estimated
        // current, not the swinging heading: steering the centre itself
        // couples the turn into the error (a turn towards the leg first
        // swings the centre away) and slowed the join by half.
        let crab = self.crab_sin(current, speed);
        let e = -rx * gamma.sin() + ry * gamma.cos() + self.centre_behind * crab;
        self.cross = e;
        // The centre's along-track distance too: behind the nose by
        // `c cos(crab)`, so that along and cross name one point.
        self.along -= self.centre_behind * (1.0 - crab * crab).sqrt();
        let b = self.path[self.to];
        self.to_go = (at.0 - b.x).hypot(at.1 - b.y);
        let d = self.look_ahead;
        let s = e + self.integral * self.y_int;
        if self.integral > 0.0 {
            self.y_int += dt * d * e / (s * s + d * d);
        }
        let psi = gamma - (s / d).atan();
        self.steer = Steer {
            heading: psi.to_degrees().rem_euclid(360.0),
            depth: self.depth,
        };
        Some(self.steer)
    }

    /// The leg's direction (rad) and length (m).
    fn leg(&self) -> (f64, f64) {
        let (a, b) = (self.path[self.from], self.path[self.to]);
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        (dy.atan2(dx), dx.hypot(dy))
    }

    /// The integral state whose term is the crab angle the `current`
    /// asks for on the leg at `speed`: `κ y_int = Δ tan(asin(V⊥ / U))`
    /// (0 with plain line of sight, or too slow a swim to crab).
    fn crab_integral(&self, current: (f64, f64), speed: f64) -> f64 {
        if self.integral <= 0.0 {
            return 0.0;
        }
        let sin = self.crab_sin(current, speed);
        self.look_ahead * (sin / (1.0 - sin * sin).sqrt()) / self.integral
    }

    /// `V⊥ / U`, the sine of the crab angle the `current` asks for on the
    /// leg at `speed` (`V⊥` across the leg, positive left), within ±0.7;
    /// 0 for too slow a swim to crab, or values that are not finite.
    fn crab_sin(&self, current: (f64, f64), speed: f64) -> f64 {
        if !(speed >= 0.1 && current.0.is_finite() && current.1.is_finite()) {
            return 0.0;
        }
        let (gamma, _) = self.leg();
        let across = -current.0 * gamma.sin() + current.1 * gamma.cos();
        (across / speed).clamp(-0.7, 0.7)
    }

    /// The snapshot's fields.
    pub fn fill(&self, s: &mut GuideSnapshot) {
        s.state = self.state as u8;
        s.looped = self.looped as u8;
        if self.state == GuideState::Off {
            return;
        }
        let (a, b) = (self.path[self.from], self.path[self.to]);
        let (_, length) = self.leg();
        // The index in the operator's path (not counting a start here).
        let n = self.len - self.loop_start;
        s.leg = (self.to.saturating_sub(self.loop_start)) as u16;
        s.waypoints = n as u16;
        s.cross_track_m = self.cross as f32;
        s.along_track_m = self.along as f32;
        s.leg_length_m = length as f32;
        s.heading_deg = self.steer.heading as f32;
        s.integral_m = (self.integral * self.y_int) as f32;
        s.from_x = a.x as f32;
        s.from_y = a.y as f32;
        s.to_x = b.x as f32;
        s.to_y = b.y as f32;
        s.to_go_m = self.to_go as f32;
    }
}

#[cfg(test)]
mod tests;
