//! One bought drive's axis: from the joint's angle, rate and torque to the
//! motor's, and back ([`crate::config::AxisMap`]: direction, offset, gear).
//! The family's own unit (CiA 402 increments, ODrive turns) is the
//! family's.

use crate::config::AxisMap;

use std::f64::consts::TAU;

impl AxisMap {
    /// Motor angle (rad) for joint angle `theta` (rad).
    pub fn motor_angle(&self, theta: f64) -> f64 {
        self.direction * (theta - self.offset) * self.gear
    }

    /// Joint angle (rad) for motor angle `m` (rad).
    pub fn joint_angle(&self, m: f64) -> f64 {
        self.direction * m / self.gear + self.offset
    }

    /// Motor rate (rad/s) for joint rate `w` (rad/s).
    pub fn motor_rate(&self, w: f64) -> f64 {
        self.direction * w * self.gear
    }

    /// Joint rate (rad/s) for motor rate `m` (rad/s).
    pub fn joint_rate(&self, m: f64) -> f64 {
        self.direction * m / self.gear
    }

    /// Motor torque (N·m) for joint torque `tau` (N·m).
    pub fn motor_torque(&self, tau: f64) -> f64 {
        self.direction * tau / self.gear
    }

    /// Joint torque (N·m) for motor torque `m` (N·m).
    pub fn joint_torque(&self, m: f64) -> f64 {
        self.direction * m * self.gear
    }

    /// Motor turns for joint angle `theta` (ODrive positions).
    pub fn turns(&self, theta: f64) -> f64 {
        self.motor_angle(theta) / TAU
    }

    /// Joint angle for motor `turns`.
    pub fn from_turns(&self, turns: f64) -> f64 {
        self.joint_angle(turns * TAU)
    }

    /// Increments for joint angle `theta` (CiA 402 positions), saturated
    /// to i32.
    pub fn counts(&self, theta: f64) -> i32 {
        (self.motor_angle(theta) * self.counts_per_turn as f64 / TAU)
            .round()
            .clamp(i32::MIN as f64, i32::MAX as f64) as i32
    }

    /// Joint angle for `counts` increments.
    pub fn from_counts(&self, counts: i32) -> f64 {
        self.joint_angle(counts as f64 * TAU / self.counts_per_turn as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geared() -> AxisMap {
        AxisMap {
            node: 1,
            direction: -1.0,
            offset: 0.1,
            gear: 50.0,
            counts_per_turn: 4096,
            rated_torque: 0.0,
        }
    }

    #[test]
    fn conversions_round_trip_and_follow_direction_offset_and_gear() {
        let a = geared();
        // 0.1 rad is the joint at motor zero.
        assert_eq!(a.motor_angle(0.1), 0.0);
        // A quarter joint turn past the offset: 12.5 motor turns backwards.
        let theta = 0.1 + TAU / 4.0;
        assert!((a.turns(theta) + 12.5).abs() < 1e-12);
        assert_eq!(a.counts(theta), -12.5 as i32 * 4096 - 2048);
        assert!((a.from_counts(a.counts(theta)) - theta).abs() < TAU / 4096.0 / 50.0);
        assert!((a.from_turns(a.turns(0.7)) - 0.7).abs() < 1e-12);
        // Torque divides by the gear, rate multiplies.
        assert!((a.motor_torque(5.0) + 0.1).abs() < 1e-12);
        assert!((a.joint_torque(a.motor_torque(5.0)) - 5.0).abs() < 1e-12);
        assert!((a.motor_rate(1.0) + 50.0).abs() < 1e-12);
        assert!((a.joint_rate(a.motor_rate(1.0)) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn counts_saturate_instead_of_wrapping() {
        let a = AxisMap {
            gear: 1e4,
            counts_per_turn: 1 << 24,
            ..geared()
        };
        assert_eq!(a.counts(-1e3), i32::MAX);
        assert_eq!(a.counts(1e3), i32::MIN);
    }
}
