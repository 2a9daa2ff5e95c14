//! `cmd_vel` as a swim: the swim a twist asks for ([`swim_of`]), through
//! the body's speed table (which amplitude swims a speed,
//! [`anguilla_model::SpeedTable`]). Pure: no Zenoh, no daemon.

use anguilla_ipc::vocabulary::SwimParams;

use crate::ros2::msgs;

pub use anguilla_model::{SPEED_RUNGS, SpeedTable};

/// A `cmd_vel`'s swim, and the speed it swims.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwistSwim {
    /// The swim command.
    pub params: SwimParams,
    /// The speed asked for and the speed swum (m/s, steady): different
    /// when the speed asked for was beyond reach (faster than full
    /// amplitude swims, or than `ros2-max-speed`) and clamped.
    pub speed: (f64, f64),
}

impl TwistSwim {
    /// The speed asked for was beyond reach and clamped.
    pub fn clamped(&self) -> bool {
        self.speed.1 < self.speed.0
    }
}

/// The swim a `cmd_vel` asks for (docs/ros2.md): `linear.x` (m/s), at most
/// `max_speed` and the table's fastest, as the amplitude that swims it
/// steadily ([`SpeedTable::amplitude_for`]; an eel does not swim backwards:
/// 0 below 0); `angular.z` (rad/s, left positive) as the turn curvature
/// `angular.z / v` (1/m), with `v` the speed swum but at least 0.1 m/s;
/// `linear.z` (m/s, up positive) as the pitch curvature `−linear.z / v`
/// (1/m, the daemon's is dive positive); at `frequency` (the table's).
/// Each is clamped to the daemon's limits when known. Not finite: `None`.
pub fn swim_of(
    t: &msgs::Twist,
    speeds: &SpeedTable,
    max_speed: f64,
    frequency: f64,
    limits: Option<&anguilla_ipc::LimitsSnapshot>,
) -> Option<TwistSwim> {
    let (x, z, wz) = (t.linear[0], t.linear[2], t.angular[2]);
    if ![x, z, wz].iter().all(|v| v.is_finite()) {
        return None;
    }
    let asked = x.max(0.0);
    let swum = asked.min(max_speed).min(speeds.max_speed());
    let (amplitude, _) = speeds.amplitude_for(swum);
    let v = swum.max(0.1);
    let clamp = |value: f64, max: Option<f32>| match max {
        Some(m) if m > 0.0 => value.clamp(-f64::from(m), f64::from(m)),
        _ => value,
    };
    Some(TwistSwim {
        params: SwimParams {
            amplitude: amplitude.clamp(0.0, 1.0),
            frequency: clamp(frequency, limits.map(|l| l.max_frequency)),
            turn: clamp(wz / v, limits.map(|l| l.max_turn)),
            pitch: clamp(-z / v, limits.map(|l| l.max_pitch)),
        },
        speed: (asked, swum),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_twist_maps_to_a_swim_within_the_daemons_limits() {
        let limits = anguilla_ipc::LimitsSnapshot {
            max_frequency: 2.0,
            max_turn: 1.0,
            max_pitch: 0.5,
            ..Default::default()
        };
        let t = |x: f64, z: f64, wz: f64| msgs::Twist {
            linear: [x, 0.0, z],
            angular: [0.0, 0.0, wz],
        };
        // speed proportional to amplitude, 0.4 m/s at full
        let lin = SpeedTable::linear(0.4);
        let p = swim_of(&t(0.2, 0.0, 0.1), &lin, 1.0, 1.0, Some(&limits)).unwrap();
        assert_eq!(
            (
                p.params.amplitude,
                p.params.frequency,
                p.params.turn,
                p.params.pitch
            ),
            (0.5, 1.0, 0.5, 0.0)
        );
        assert!(!p.clamped());
        // faster than the maximum, backwards, turning hard on the spot,
        // climbing steeply: each within its range
        let p = swim_of(&t(9.0, 0.0, 0.0), &lin, 1.0, 1.0, None).unwrap();
        assert_eq!((p.params.amplitude, p.speed), (1.0, (9.0, 0.4)));
        assert!(p.clamped());
        // ros2-max-speed below the body's fastest: clamped to it
        let p = swim_of(&t(0.35, 0.0, 0.0), &lin, 0.3, 1.0, None).unwrap();
        assert!((p.params.amplitude - 0.75).abs() < 1e-12 && p.clamped());
        let p = swim_of(&t(-0.3, 0.2, 1.0), &lin, 1.0, 3.0, Some(&limits)).unwrap();
        assert_eq!(
            (
                p.params.amplitude,
                p.params.frequency,
                p.params.turn,
                p.params.pitch
            ),
            (0.0, 2.0, 1.0, -0.5)
        );
        assert!(!p.clamped());
        for bad in [f64::NAN, f64::INFINITY] {
            assert!(swim_of(&t(bad, 0.0, 0.0), &lin, 1.0, 1.0, None).is_none());
            assert!(swim_of(&t(0.1, 0.0, bad), &lin, 1.0, 1.0, None).is_none());
        }
    }
}
