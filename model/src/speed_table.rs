//! A body's steady forward speed against its gait's amplitude, and its
//! inverse: which amplitude swims a speed. `anguilla_daemon::speed`
//! measures the table by swimming the model; `anguilla link`'s ROS 2
//! `cmd_vel` and `anguilla ctl follow --speed` read it backwards.

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

#[cfg(test)]
mod tests {
    use super::*;

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
