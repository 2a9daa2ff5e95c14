//! Trapezoidal motion profiles: time-optimal, velocity- and
//! acceleration-limited, re-plannable from any state.
//!
//! A [`Trapezoid`] takes one scalar from its current position and velocity to
//! a target position at rest, in the least time that the limits allow. It has
//! at most three phases of constant acceleration (reach the cruise velocity,
//! cruise, brake), and handles every starting state:
//!
//! - at rest, moving towards the target, or moving away from it;
//! - moving faster than the velocity limit (it first brakes to the limit);
//! - too fast to stop before the target (it brakes through the target and
//!   comes back).
//!
//! The daemon shapes every gait parameter (speed, frequency, turn and pitch
//! curvature) and every posture move with it; replanning whenever the target
//! changes, from the profile's own current state, keeps position and velocity
//! continuous. The acceleration is piecewise constant, so what it drives is
//! continuous with a continuous first derivative (C¹).
//!
//! ```
//! use anguilla_daemon::profile::{Limits, Trapezoid};
//! let limits = Limits::new(2.0, 4.0)?; // 2 units/s, 4 units/s²
//! let p = Trapezoid::plan(0.0, 0.0, 1.0, limits)?;
//! assert!((p.duration() - 1.0).abs() < 1e-12); // 0.5 s up, 0.5 s down
//! assert_eq!(p.sample(p.duration()).position, 1.0);
//! # Ok::<(), anguilla_daemon::profile::ProfileError>(())
//! ```

/// Velocity and acceleration limits of a profile (both strictly positive).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    v_max: f64,
    a_max: f64,
}

/// What was wrong with the inputs of a profile.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ProfileError {
    /// The velocity limit is not a positive finite number.
    #[error("velocity limit {0} is invalid (expected a finite value > 0)")]
    BadVelocityLimit(f64),
    /// The acceleration limit is not a positive finite number.
    #[error("acceleration limit {0} is invalid (expected a finite value > 0)")]
    BadAccelerationLimit(f64),
    /// The start position, start velocity or target is not finite.
    #[error("profile {what} is not finite ({value})")]
    NonFinite {
        /// Which input: "start position", "start velocity" or "target".
        what: &'static str,
        /// The value given.
        value: f64,
    },
}

impl Limits {
    /// Limits of `v_max` (units/s) and `a_max` (units/s²), both finite and > 0.
    pub fn new(v_max: f64, a_max: f64) -> Result<Self, ProfileError> {
        if !(v_max.is_finite() && v_max > 0.0) {
            return Err(ProfileError::BadVelocityLimit(v_max));
        }
        if !(a_max.is_finite() && a_max > 0.0) {
            return Err(ProfileError::BadAccelerationLimit(a_max));
        }
        Ok(Self { v_max, a_max })
    }

    /// The velocity limit.
    pub fn v_max(&self) -> f64 {
        self.v_max
    }

    /// The acceleration limit.
    pub fn a_max(&self) -> f64 {
        self.a_max
    }
}

/// Position, velocity and acceleration of a profile at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfileState {
    /// Position (units).
    pub position: f64,
    /// Velocity (units/s).
    pub velocity: f64,
    /// Acceleration (units/s²).
    pub acceleration: f64,
}

/// One phase of constant acceleration.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Phase {
    duration: f64,
    acceleration: f64,
}

/// A planned trapezoidal profile: up to three phases of constant acceleration
/// from `(p0, v0)` to `(target, 0)`. `Copy`, allocation-free.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trapezoid {
    p0: f64,
    v0: f64,
    target: f64,
    phases: [Phase; 3],
}

impl Trapezoid {
    /// Plans the time-optimal profile from position `p0` and velocity `v0` to
    /// rest at `target`, within `limits`.
    ///
    /// A start velocity above the limit is allowed (the profile brakes to the
    /// limit first); every other phase respects both limits.
    pub fn plan(p0: f64, v0: f64, target: f64, limits: Limits) -> Result<Self, ProfileError> {
        for (what, value) in [
            ("start position", p0),
            ("start velocity", v0),
            ("target", target),
        ] {
            if !value.is_finite() {
                return Err(ProfileError::NonFinite { what, value });
            }
        }
        let Limits { v_max, a_max: a } = limits;
        let d = target - p0;
        // Displacement if we braked at once.
        let d_stop = v0 * v0.abs() / (2.0 * a);
        let rest = Phase {
            duration: 0.0,
            acceleration: 0.0,
        };
        let gap = d - d_stop;
        if gap == 0.0 {
            // Braking now lands exactly on the target.
            let brake = Phase {
                duration: v0.abs() / a,
                acceleration: -v0.signum() * a,
            };
            return Ok(Self {
                p0,
                v0,
                target,
                phases: [brake, rest, rest],
            });
        }
        // Direction of the peak velocity.
        let s = gap.signum();
        let v_cruise = s * v_max;
        // Phase 1: from v0 to the cruise velocity (accelerating or braking).
        let a1 = if s * v0 <= v_max { s * a } else { -s * a };
        let t1 = (v_cruise - v0).abs() / a;
        let d1 = (v_cruise * v_cruise - v0 * v0) / (2.0 * a1);
        let t3 = v_max / a;
        let d3 = s * v_max * v_max / (2.0 * a);
        let d2 = d - d1 - d3;
        let phases = if s * d2 >= 0.0 {
            [
                Phase {
                    duration: t1,
                    acceleration: a1,
                },
                Phase {
                    duration: d2 / v_cruise,
                    acceleration: 0.0,
                },
                Phase {
                    duration: t3,
                    acceleration: -s * a,
                },
            ]
        } else {
            // Triangular: the peak stays below the limit. Here s·v0 is below
            // the peak, whose square is s·a·d + v0²/2 (> 0 since s = sign(d − d_stop)).
            let v_peak = s * (s * a * d + 0.5 * v0 * v0).max(0.0).sqrt();
            [
                Phase {
                    duration: ((v_peak - v0) / (s * a)).max(0.0),
                    acceleration: s * a,
                },
                rest,
                Phase {
                    duration: v_peak.abs() / a,
                    acceleration: -s * a,
                },
            ]
        };
        Ok(Self {
            p0,
            v0,
            target,
            phases,
        })
    }

    /// A profile that stays at rest at `p`.
    pub fn hold(p: f64) -> Self {
        let rest = Phase {
            duration: 0.0,
            acceleration: 0.0,
        };
        Self {
            p0: p,
            v0: 0.0,
            target: p,
            phases: [rest; 3],
        }
    }

    /// Total duration (s).
    pub fn duration(&self) -> f64 {
        self.phases.iter().map(|p| p.duration).sum()
    }

    /// The target position.
    pub fn target(&self) -> f64 {
        self.target
    }

    /// The state `t` seconds after the start of the profile. Before 0 it is
    /// the start state; after [`duration`](Self::duration) it is exactly the
    /// target, at rest.
    pub fn sample(&self, t: f64) -> ProfileState {
        if t >= self.duration() {
            return ProfileState {
                position: self.target,
                velocity: 0.0,
                acceleration: 0.0,
            };
        }
        let mut p = self.p0;
        let mut v = self.v0;
        let mut left = t.max(0.0);
        for ph in &self.phases {
            if left <= ph.duration {
                return ProfileState {
                    position: p + v * left + 0.5 * ph.acceleration * left * left,
                    velocity: v + ph.acceleration * left,
                    acceleration: ph.acceleration,
                };
            }
            p += v * ph.duration + 0.5 * ph.acceleration * ph.duration * ph.duration;
            v += ph.acceleration * ph.duration;
            left -= ph.duration;
        }
        ProfileState {
            position: self.target,
            velocity: 0.0,
            acceleration: 0.0,
        }
    }
}

/// A scalar that follows its target along trapezoidal profiles, replanning
/// from its own current state whenever the target changes. The daemon keeps
/// one per gait parameter; `advance` is called once per control period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Follower {
    limits: Limits,
    profile: Trapezoid,
    elapsed: f64,
    state: ProfileState,
}

impl Follower {
    /// A follower at rest at `p`.
    pub fn new(p: f64, limits: Limits) -> Self {
        Self {
            limits,
            profile: Trapezoid::hold(p),
            elapsed: 0.0,
            state: ProfileState {
                position: p,
                velocity: 0.0,
                acceleration: 0.0,
            },
        }
    }

    /// Sets a new target; replans from the current state if it changed.
    pub fn set_target(&mut self, target: f64) -> Result<(), ProfileError> {
        if target == self.profile.target() {
            return Ok(());
        }
        self.profile = Trapezoid::plan(
            self.state.position,
            self.state.velocity,
            target,
            self.limits,
        )?;
        self.elapsed = 0.0;
        Ok(())
    }

    /// Changes the limits; the current motion is replanned under them.
    pub fn set_limits(&mut self, limits: Limits) -> Result<(), ProfileError> {
        self.limits = limits;
        self.profile = Trapezoid::plan(
            self.state.position,
            self.state.velocity,
            self.profile.target(),
            limits,
        )?;
        self.elapsed = 0.0;
        Ok(())
    }

    /// Jumps to `p` at rest (used when a fault resets the motion).
    pub fn reset(&mut self, p: f64) {
        *self = Self::new(p, self.limits);
    }

    /// Advances by `dt` seconds and returns the new state.
    pub fn advance(&mut self, dt: f64) -> ProfileState {
        self.elapsed += dt;
        self.state = self.profile.sample(self.elapsed);
        self.state
    }

    /// The current state.
    pub fn state(&self) -> ProfileState {
        self.state
    }

    /// The current target.
    pub fn target(&self) -> f64 {
        self.profile.target()
    }

    /// Whether the follower is at rest on its target.
    pub fn settled(&self) -> bool {
        self.elapsed >= self.profile.duration()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn lim(v: f64, a: f64) -> Limits {
        Limits::new(v, a).unwrap()
    }

    #[test]
    fn rejects_bad_limits_and_inputs() {
        assert_eq!(
            Limits::new(0.0, 1.0),
            Err(ProfileError::BadVelocityLimit(0.0))
        );
        assert!(Limits::new(1.0, f64::NAN).is_err());
        assert!(Limits::new(f64::INFINITY, 1.0).is_err());
        let e = Trapezoid::plan(0.0, f64::NAN, 1.0, lim(1.0, 1.0)).unwrap_err();
        assert!(e.to_string().contains("start velocity"), "{e}");
    }

    #[test]
    fn rest_to_rest_with_cruise_matches_closed_form() {
        // 10 units at 2 u/s, 1 u/s²: 2 s up (2 u), 3 s cruise (6 u), 2 s down (2 u).
        let p = Trapezoid::plan(0.0, 0.0, 10.0, lim(2.0, 1.0)).unwrap();
        assert!((p.duration() - 7.0).abs() < 1e-12);
        let mid = p.sample(3.5);
        assert!((mid.velocity - 2.0).abs() < 1e-12);
        assert!((mid.position - 5.0).abs() < 1e-12);
    }

    #[test]
    fn triangular_when_limit_is_not_reached() {
        // 1 unit at 1 u/s²: peak sqrt(1) = 1 u/s < 10: 1 s up, 1 s down.
        let p = Trapezoid::plan(0.0, 0.0, 1.0, lim(10.0, 1.0)).unwrap();
        assert!((p.duration() - 2.0).abs() < 1e-12);
        assert!((p.sample(1.0).velocity - 1.0).abs() < 1e-12);
    }

    #[test]
    fn overshoots_and_returns_when_too_fast_to_stop() {
        // At 2 u/s, braking at 1 u/s² needs 2 u; the target is 1 u ahead.
        let p = Trapezoid::plan(0.0, 2.0, 1.0, lim(3.0, 1.0)).unwrap();
        let max_pos = (0..=1000)
            .map(|i| p.sample(p.duration() * i as f64 / 1000.0).position)
            .fold(f64::MIN, f64::max);
        assert!((max_pos - 2.0).abs() < 1e-3, "peak {max_pos}");
        assert_eq!(p.sample(p.duration()).position, 1.0);
    }

    #[test]
    fn brakes_to_the_limit_when_starting_too_fast() {
        let p = Trapezoid::plan(0.0, 5.0, 100.0, lim(1.0, 2.0)).unwrap();
        assert!((p.sample(2.0).velocity - 1.0).abs() < 1e-12);
        assert!(p.sample(0.5).acceleration < 0.0);
    }

    #[test]
    fn follower_replans_continuously() {
        let mut f = Follower::new(0.0, lim(1.0, 1.0));
        f.set_target(5.0).unwrap();
        let mut last = f.state();
        for i in 0..4000 {
            if i == 700 {
                f.set_target(-3.0).unwrap();
            }
            let s = f.advance(0.001);
            assert!((s.position - last.position).abs() <= 1.0 * 0.001 + 1e-9);
            assert!((s.velocity - last.velocity).abs() <= 1.0 * 0.001 + 1e-9);
            last = s;
        }
        // 7 s after the reversal is enough to arrive and settle.
        let s = f.advance(7.0);
        assert_eq!(s.position, -3.0);
        assert!(f.settled());
    }

    proptest! {
        #[test]
        fn plan_respects_limits_and_lands_on_target(
            p0 in -10.0f64..10.0, v0 in -5.0f64..5.0, target in -10.0f64..10.0,
            v_max in 0.1f64..5.0, a_max in 0.1f64..20.0,
        ) {
            let l = lim(v_max, a_max);
            let p = Trapezoid::plan(p0, v0, target, l).unwrap();
            let t_end = p.duration();
            prop_assert!(t_end.is_finite() && t_end >= 0.0);
            // End state from the phases themselves (not the clamp in sample).
            let end = {
                let mut pos = p0; let mut vel = v0;
                for ph in &p.phases {
                    pos += vel * ph.duration + 0.5 * ph.acceleration * ph.duration * ph.duration;
                    vel += ph.acceleration * ph.duration;
                }
                (pos, vel)
            };
            // Tolerance: the phases are closed-form; errors are rounding of
            // quantities of order |p|+v²/a ~ 1e3 at most.
            prop_assert!((end.0 - target).abs() < 1e-7 * (1.0 + target.abs() + v0 * v0 / a_max), "end {:?}", end);
            prop_assert!(end.1.abs() < 1e-9 * (1.0 + v0.abs()), "end {:?}", end);
            let n = 200;
            for i in 0..=n {
                let s = p.sample(t_end * i as f64 / n as f64);
                prop_assert!(s.acceleration.abs() <= a_max * (1.0 + 1e-12));
                // Only a start above the limit may exceed it, and never grows.
                prop_assert!(s.velocity.abs() <= v_max.max(v0.abs()) + 1e-9);
                prop_assert!(s.position.is_finite());
            }
        }

        #[test]
        fn plan_is_time_optimal_against_slower_limits(
            v_frac in -0.9f64..0.9, d in -10.0f64..10.0,
            v_max in 0.5f64..5.0, a_max in 0.5f64..20.0,
        ) {
            // From a start within both sets of limits, every motion allowed
            // by the tighter limits is allowed by the looser ones, so the
            // optimum under tighter limits can never be faster: a check that
            // fails if the planner wastes time in some branch. (From a start
            // above the velocity limit the sets are not nested — the plan
            // must brake at once — so v0 stays inside 0.9 v_max.)
            let v0 = v_frac * v_max * 0.9;
            let fast = Trapezoid::plan(0.0, v0, d, lim(v_max, a_max)).unwrap().duration();
            let slow = Trapezoid::plan(0.0, v0, d, lim(v_max * 0.9, a_max * 0.9)).unwrap().duration();
            prop_assert!(fast <= slow + 1e-9, "fast {fast} slow {slow}");
        }
    }
}
