//! A uniform ambient current: the water's velocity `u(t)`, the same at every
//! point, in the earth frame.
//!
//! The hydrodynamic terms of the model see the body's motion *relative to the
//! water* (see [`crate::dynamics`], "Currents"). A [`Current`] is steady
//! (`u` constant) or oscillating about a mean, one sinusoid of a common
//! period with an amplitude per axis:
//!
//! `u(t) = u_mean + u_amp sin(2π t / T)`, `u̇(t) = (2π / T) u_amp cos(2π t / T)`,
//!
//! `t` being the model's time (`HeadState::t`). It is a small `Copy` value
//! with validating constructors: setting one in the control loop
//! ([`Workspace::set_current`](crate::Workspace::set_current)) allocates
//! nothing.
//!
//! ```
//! use anguilla_model::Current;
//! use nalgebra::Vector3;
//!
//! let river = Current::steady(Vector3::new(0.1, 0.0, 0.0))?;
//! assert_eq!(river.velocity(3.0), Vector3::new(0.1, 0.0, 0.0));
//! assert_eq!(river.acceleration(3.0), Vector3::zeros());
//! let swell = Current::oscillating(Vector3::zeros(), Vector3::new(0.0, 0.05, 0.0), 8.0)?;
//! assert!((swell.velocity(2.0).y - 0.05).abs() < 1e-12); // a quarter period
//! assert!(Current::steady([f64::NAN, 0.0, 0.0]).is_err());
//! # Ok::<(), anguilla_model::ModelError>(())
//! ```

use crate::error::{ModelError, Result};
use core::f64::consts::PI;
use nalgebra::Vector3;

/// Largest accepted current speed per axis, mean plus amplitude (m/s). The
/// model's drag laws are those of a swimmer at ~1 m/s; 5 m/s is already a
/// flood.
pub const MAX_CURRENT: f64 = 5.0;

/// A uniform current (earth frame): steady, or a sinusoid about a mean.
/// [`Current::ZERO`] (the default) is still water.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Current {
    mean: Vector3<f64>,
    amplitude: Vector3<f64>,
    /// `2π / T` (rad/s); 0 for a steady current.
    angular_frequency: f64,
}

impl Default for Current {
    fn default() -> Self {
        Self::ZERO
    }
}

impl Current {
    /// Still water.
    pub const ZERO: Current = Current {
        mean: Vector3::new(0.0, 0.0, 0.0),
        amplitude: Vector3::new(0.0, 0.0, 0.0),
        angular_frequency: 0.0,
    };

    /// A steady current of `velocity` (m/s, earth frame; a `Vector3` or
    /// `[vx, vy, vz]`); each component finite and within `±MAX_CURRENT`.
    pub fn steady(velocity: impl Into<Vector3<f64>>) -> Result<Self> {
        let velocity = velocity.into();
        check_speed(velocity.iter().map(|v| v.abs()))?;
        Ok(Self {
            mean: velocity,
            ..Self::ZERO
        })
    }

    /// `u(t) = mean + amplitude sin(2π t / period)` (m/s, earth frame, `t`
    /// the model's time in s): `period` finite and `> 0`, `|mean| +
    /// |amplitude|` within `MAX_CURRENT` on each axis.
    pub fn oscillating(mean: Vector3<f64>, amplitude: Vector3<f64>, period: f64) -> Result<Self> {
        check_speed(mean.iter().zip(&amplitude).map(|(m, a)| m.abs() + a.abs()))?;
        if !(period.is_finite() && period > 0.0) {
            return Err(ModelError::InvalidParameter {
                name: "current period",
                value: period,
                range: "(0, inf) s",
            });
        }
        Ok(Self {
            mean,
            amplitude,
            angular_frequency: 2.0 * PI / period,
        })
    }

    /// The water's velocity at time `t` (m/s, earth frame).
    #[inline]
    pub fn velocity(&self, t: f64) -> Vector3<f64> {
        if self.angular_frequency == 0.0 {
            self.mean
        } else {
            self.mean + self.amplitude * (self.angular_frequency * t).sin()
        }
    }

    /// The water's acceleration `u̇` at time `t` (m/s², earth frame); zero
    /// for a steady current.
    #[inline]
    pub fn acceleration(&self, t: f64) -> Vector3<f64> {
        if self.angular_frequency == 0.0 {
            Vector3::zeros()
        } else {
            self.amplitude * (self.angular_frequency * (self.angular_frequency * t).cos())
        }
    }

    /// The mean velocity (m/s, earth frame).
    pub fn mean(&self) -> Vector3<f64> {
        self.mean
    }

    /// The amplitude of the oscillation per axis (m/s; zero if steady).
    pub fn amplitude(&self) -> Vector3<f64> {
        self.amplitude
    }

    /// The period of the oscillation (s), `None` if steady.
    pub fn period(&self) -> Option<f64> {
        (self.angular_frequency != 0.0).then(|| 2.0 * PI / self.angular_frequency)
    }

    /// Whether the current ever accelerates (an oscillation of non-zero
    /// amplitude): only then does the model add the fluid-acceleration terms.
    pub fn is_steady(&self) -> bool {
        self.angular_frequency == 0.0 || self.amplitude == Vector3::zeros()
    }
}

fn check_speed(speeds: impl Iterator<Item = f64>) -> Result<()> {
    for s in speeds {
        if !(s.is_finite() && s <= MAX_CURRENT) {
            return Err(ModelError::InvalidParameter {
                name: "current",
                value: s,
                range: "finite, at most 5 m/s per axis (mean + amplitude)",
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn acceleration_is_the_derivative_of_velocity() {
        let c = Current::oscillating(
            Vector3::new(0.1, -0.2, 0.0),
            Vector3::new(0.05, 0.1, 0.02),
            3.0,
        )
        .unwrap();
        let h = 1e-5;
        for t in [0.0, 0.4, 1.7, 2.9] {
            let fd = (c.velocity(t + h) - c.velocity(t - h)) / (2.0 * h);
            // central difference: error ~ h² |u'''| ~ 1e-10 x 0.1 x 8
            assert!((fd - c.acceleration(t)).norm() < 1e-8, "t = {t}");
        }
        assert!((c.period().unwrap() - 3.0).abs() < 1e-12);
        assert!(!c.is_steady());
    }

    #[test]
    fn bad_currents_name_the_parameter() {
        let e = Current::steady(Vector3::new(0.0, 6.0, 0.0)).unwrap_err();
        assert!(e.to_string().contains("`current`"), "{e}");
        let e = Current::oscillating(Vector3::zeros(), Vector3::new(0.0, 0.0, f64::NAN), 1.0)
            .unwrap_err();
        assert!(e.to_string().contains("`current`"), "{e}");
        let e = Current::oscillating(
            Vector3::new(3.0, 0.0, 0.0),
            Vector3::new(3.0, 0.0, 0.0),
            1.0,
        )
        .unwrap_err();
        assert!(e.to_string().contains("`current`"), "{e}");
        for p in [0.0, -1.0, f64::INFINITY, f64::NAN] {
            let e = Current::oscillating(Vector3::zeros(), Vector3::zeros(), p).unwrap_err();
            assert!(e.to_string().contains("current period"), "{e}");
        }
        assert_eq!(Current::default(), Current::ZERO);
        assert!(Current::ZERO.is_steady() && Current::ZERO.period().is_none());
    }
}
