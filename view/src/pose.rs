//! The head's pose in the world from a stream of state snapshots: what the
//! recording's `/tf` and the ROS 2 node's `tf` both say (one computation
//! for both). The world frame has x and y level and z up (REP 103); its
//! origin is where the estimate started. With a head sensor the pose is
//! the daemon's estimate as the snapshot carries it (`nav`: x, y, depth and
//! attitude), so `ctl status`, the recording, Foxglove and ROS 2 show one
//! position; without one, the model's prediction integrated here.

use anguilla_ipc::StateSnapshot;

/// A pose: translation (m) and rotation (unit quaternion x, y, z, w).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// x, y, z (m).
    pub translation: [f64; 3],
    /// x, y, z, w.
    pub rotation: [f64; 4],
}

/// The quaternion of roll about x, then pitch about y, then yaw about z
/// (applied to a vector: `Rz(yaw) Ry(pitch) Rx(roll)`), as x, y, z, w.
pub fn quaternion_rpy(roll: f64, pitch: f64, yaw: f64) -> [f64; 4] {
    let (sr, cr) = (roll / 2.0).sin_cos();
    let (sp, cp) = (pitch / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    [
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    ]
}

fn finite(v: f32) -> f64 {
    if v.is_finite() { f64::from(v) } else { 0.0 }
}

/// The head's track: the model's predicted speed and turn rate integrated
/// in the plane (the predicted pose), beside the daemon's estimate.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct HeadTrack {
    last_ns: Option<u64>,
    x: f64,
    y: f64,
    yaw: f64,
}

impl HeadTrack {
    /// Advances to `s`; returns the head's pose as estimated (with a head
    /// sensor that has samples: the snapshot's heading, pitch, roll, depth
    /// and x, y) or else as predicted, and the predicted pose (the plane,
    /// the integrated turn). Values that are not finite count as 0.
    pub fn update(&mut self, s: &StateSnapshot) -> (Pose, Pose) {
        let dt = self
            .last_ns
            .map_or(0.0, |l| s.time_ns.saturating_sub(l) as f64 * 1e-9);
        self.last_ns = Some(s.time_ns);
        self.yaw += finite(s.predicted_turn_rate) * dt;
        self.x += finite(s.predicted_head_speed) * self.yaw.cos() * dt;
        self.y += finite(s.predicted_head_speed) * self.yaw.sin() * dt;
        let predicted = Pose {
            translation: [self.x, self.y, 0.0],
            rotation: quaternion_rpy(0.0, 0.0, self.yaw),
        };
        let nav = &s.nav;
        let measured = [
            nav.roll_deg,
            nav.pitch_deg,
            nav.heading_deg,
            nav.depth_m,
            nav.x_m,
            nav.y_m,
        ];
        let head = if nav.samples > 0 && measured.iter().all(|v| v.is_finite()) {
            // REP 103: pitch about y is nose-down positive (the daemon's
            // is nose-up); roll right side down and the heading
            // anticlockwise, as the daemon's.
            Pose {
                translation: [
                    f64::from(nav.x_m),
                    f64::from(nav.y_m),
                    -f64::from(nav.depth_m),
                ],
                rotation: quaternion_rpy(
                    f64::from(nav.roll_deg).to_radians(),
                    -f64::from(nav.pitch_deg).to_radians(),
                    f64::from(nav.heading_deg).to_radians(),
                ),
            }
        } else {
            predicted
        };
        (head, predicted)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_steady_turn_draws_a_circle_and_the_sensor_sets_the_attitude() {
        let mut t = HeadTrack::default();
        let mut s = StateSnapshot {
            predicted_head_speed: 0.5,
            predicted_turn_rate: 0.5,
            ..StateSnapshot::default()
        };
        // a quarter turn (π s at 0.5 rad/s) in 1 ms steps: radius 1 m
        let steps = (std::f64::consts::PI * 1000.0).round() as u64;
        let mut last = None;
        for k in 0..=steps {
            s.time_ns = k * 1_000_000;
            last = Some(t.update(&s));
        }
        let (head, predicted) = last.unwrap();
        assert_eq!(head, predicted, "no sensor: the predicted pose");
        let [x, y, _] = predicted.translation;
        assert!((x - 1.0).abs() < 2e-3 && (y - 1.0).abs() < 2e-3, "{x} {y}");
        let q = predicted.rotation;
        let half = std::f64::consts::FRAC_PI_4;
        assert!((q[2] - half.sin()).abs() < 1e-3 && (q[3] - half.cos()).abs() < 1e-3);
        s.nav.samples = 1;
        s.nav.heading_deg = 90.0;
        s.nav.depth_m = 2.0;
        s.nav.x_m = 3.5;
        s.nav.y_m = -1.25;
        s.time_ns += 1_000_000;
        let (head, _) = t.update(&s);
        assert_eq!(
            head.translation,
            [3.5, -1.25, -2.0],
            "the daemon's estimate"
        );
        assert!((head.rotation[2] - half.sin()).abs() < 1e-9);
        s.nav.roll_deg = f32::NAN;
        s.time_ns += 1_000_000;
        let (head, predicted) = t.update(&s);
        assert_eq!(
            head, predicted,
            "a sensor value that is not finite: predicted"
        );
    }
}
