//! `cmd_vel` as a swim: the body's speed table (which amplitude swims a
//! speed) and the swim a twist asks for ([`swim_of`]). Pure: no Zenoh, no
//! daemon.

use anguilla_ipc::vocabulary::SwimParams;

use crate::ros2::msgs;

/// Rungs of a [`SpeedTable`]: amplitudes `0, 0.05, ..., 1`.
pub const SPEED_RUNGS: usize = 21;

/// A body's steady forward speed (m/s) at the amplitudes `i /
/// (SPEED_RUNGS - 1)`, at one frequency: how fast an amplitude swims, and
/// so which amplitude swims a speed ([`amplitude_for`](Self::amplitude_for)).
/// The speed of an undulating body is far from linear in its amplitude
/// (the built-in robot at 1 Hz: 0.03 m/s at 0.1, 0.33 at 0.4, 0.67 at 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedTable {
    speeds: [f64; SPEED_RUNGS],
}

impl SpeedTable {
    /// The table of `speeds` (m/s) at amplitudes `0 ..= 1`, made
    /// non-decreasing (a body that slows at its largest amplitudes is asked
    /// for the smallest amplitude that reaches a speed); not finite or
    /// negative entries count as 0.
    pub fn new(speeds: [f64; SPEED_RUNGS]) -> Self {
        let mut s = speeds.map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 });
        for i in 1..SPEED_RUNGS {
            s[i] = s[i].max(s[i - 1]);
        }
        Self { speeds: s }
    }

    /// Speed proportional to amplitude, `max_speed` at full amplitude (a
    /// stand-in where no model is at hand).
    pub fn linear(max_speed: f64) -> Self {
        Self::new(std::array::from_fn(|i| {
            max_speed * i as f64 / (SPEED_RUNGS - 1) as f64
        }))
    }

    /// The speeds (m/s) at amplitudes `i / (SPEED_RUNGS - 1)`.
    pub fn speeds(&self) -> &[f64; SPEED_RUNGS] {
        &self.speeds
    }

    /// The fastest steady speed (m/s): full amplitude's.
    pub fn max_speed(&self) -> f64 {
        self.speeds[SPEED_RUNGS - 1]
    }

    /// The amplitude (0 ..= 1) whose steady speed is `speed` (m/s), linear
    /// between the table's rungs, and whether it is within reach: beyond
    /// [`max_speed`](Self::max_speed), full amplitude and `false`; 0 or
    /// less, amplitude 0. No allocation.
    pub fn amplitude_for(&self, speed: f64) -> (f64, bool) {
        let s = &self.speeds;
        if speed.is_nan() || speed <= 0.0 {
            return (0.0, true);
        }
        if speed > s[SPEED_RUNGS - 1] {
            return (1.0, false);
        }
        let rung = 1.0 / (SPEED_RUNGS - 1) as f64;
        for i in 1..SPEED_RUNGS {
            if speed <= s[i] {
                let span = s[i] - s[i - 1];
                let frac = if span > 0.0 {
                    (speed - s[i - 1]) / span
                } else {
                    0.0
                };
                return (((i - 1) as f64 + frac) * rung, true);
            }
        }
        (1.0, true)
    }
}

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

    /// A body whose speed grows faster than its amplitude (as an eel's):
    /// the amplitude asked for a speed is the one whose steady speed it is,
    /// not the linear share of the fastest.
    #[test]
    fn a_speed_becomes_the_amplitude_that_swims_it() {
        // speed = 0.6 a² (m/s)
        let t = SpeedTable::new(std::array::from_fn(|i| {
            let a = i as f64 / (SPEED_RUNGS - 1) as f64;
            0.6 * a * a
        }));
        for want in [0.05, 0.15, 0.3, 0.45, 0.6] {
            let (a, ok) = t.amplitude_for(want);
            // linear between rungs 0.05 apart: within 3 % of the speed
            assert!(
                ok && (0.6 * a * a - want).abs() < 0.03 * want,
                "{want}: {a}"
            );
        }
        assert_eq!(t.amplitude_for(0.61), (1.0, false));
        assert_eq!(t.amplitude_for(0.0), (0.0, true));
        // a table that falls at its end, or holds nonsense, is made monotone
        let mut s = [0.5; SPEED_RUNGS];
        s[0] = 0.0;
        s[SPEED_RUNGS - 1] = 0.1;
        s[3] = f64::NAN;
        let t = SpeedTable::new(s);
        assert!(t.speeds().windows(2).all(|w| w[1] >= w[0]));
        assert_eq!(t.max_speed(), 0.5);
        assert_eq!(t.amplitude_for(0.5), (0.05, true));
    }
}
