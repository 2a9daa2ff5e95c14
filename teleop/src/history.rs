//! Ring buffers of the monitor's plots: the last seconds of a few signals.

use anguilla_ipc::StateSnapshot;

/// A time series keeping the points of the last `window` seconds.
#[derive(Debug, Clone)]
pub struct Series {
    window: f64,
    points: Vec<(f64, f64)>,
}

impl Series {
    /// An empty series over `window` seconds.
    pub fn new(window: f64) -> Self {
        Self {
            window,
            points: Vec::new(),
        }
    }

    /// Adds `(t, y)` and forgets the points older than `t - window`.
    /// A time going backwards (daemon restart) clears the series.
    pub fn push(&mut self, t: f64, y: f64) {
        if self.points.last().is_some_and(|&(last, _)| t < last) {
            self.points.clear();
        }
        self.points.push((t, y));
        let old = self.points.partition_point(|&(t0, _)| t0 < t - self.window);
        self.points.drain(..old);
    }

    /// The points, oldest first, as one slice (for a chart dataset).
    pub fn points(&self) -> &[(f64, f64)] {
        &self.points
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there is no point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Smallest and largest value, if any.
    pub fn y_range(&self) -> Option<(f64, f64)> {
        self.points.iter().fold(None, |acc, &(_, y)| match acc {
            None => Some((y, y)),
            Some((lo, hi)) => Some((lo.min(y), hi.max(y))),
        })
    }
}

/// The monitor's signals over the last seconds, for one joint chosen to plot.
#[derive(Debug, Clone)]
pub struct History {
    /// Index of the plotted joint (0 = head).
    pub joint: usize,
    /// Commanded yaw angle of the joint (rad).
    pub commanded_angle: Series,
    /// Measured yaw angle of the joint (rad).
    pub measured_angle: Series,
    /// Predicted yaw torque of the joint (N·m).
    pub predicted_torque: Series,
    /// Measured yaw torque of the joint (N·m).
    pub measured_torque: Series,
    /// Predicted head speed (m/s).
    pub head_speed: Series,
    /// Loop wake-up jitter, 99th percentile (µs).
    pub jitter_p99: Series,
}

impl History {
    /// Empty buffers over `window` seconds for joint `joint`.
    pub fn new(window: f64, joint: usize) -> Self {
        Self {
            joint,
            commanded_angle: Series::new(window),
            measured_angle: Series::new(window),
            predicted_torque: Series::new(window),
            measured_torque: Series::new(window),
            head_speed: Series::new(window),
            jitter_p99: Series::new(window),
        }
    }

    /// Records one snapshot (at its own time stamp).
    pub fn push(&mut self, s: &StateSnapshot) {
        let t = s.time_ns as f64 * 1e-9;
        let n = (s.joint_count as usize).min(s.joints.len());
        if n > 0 {
            let j = &s.joints[self.joint.min(n - 1)];
            self.commanded_angle.push(t, j.commanded_yaw as f64);
            self.measured_angle.push(t, j.measured_yaw as f64);
            self.predicted_torque.push(t, j.predicted_yaw_torque as f64);
            self.measured_torque.push(t, j.measured_yaw_torque as f64);
        }
        self.head_speed.push(t, s.predicted_head_speed as f64);
        self.jitter_p99
            .push(t, s.loop_stats.jitter_p99_ns as f64 * 1e-3);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn series_keeps_only_the_window() {
        let mut s = Series::new(2.0);
        for i in 0..100 {
            s.push(i as f64 * 0.1, i as f64);
        }
        // Points within [9.9 - 2, 9.9]: t = 7.9 .. 9.9, 21 points (allowing
        // for the rounding of 0.1 steps at the edge: 20 or 21).
        assert!((20..=21).contains(&s.len()), "{}", s.len());
        assert_eq!(s.points().last().map(|p| p.1), Some(99.0));
        assert_eq!(s.y_range(), Some((s.points()[0].1, 99.0)));
        s.push(1.0, 5.0);
        assert_eq!(s.len(), 1, "time went backwards: restarted");
    }

    #[test]
    fn history_reads_the_chosen_joint() {
        let mut h = History::new(5.0, 3);
        let mut snap = StateSnapshot {
            joint_count: 12,
            time_ns: 1_000_000_000,
            predicted_head_speed: 0.25,
            ..Default::default()
        };
        snap.joints[3].commanded_yaw = 0.1;
        snap.joints[3].measured_yaw = 0.09;
        snap.loop_stats.jitter_p99_ns = 15_000;
        h.push(&snap);
        assert_eq!(h.commanded_angle.points(), &[(1.0, 0.1f32 as f64)]);
        assert_eq!(h.measured_angle.points(), &[(1.0, 0.09f32 as f64)]);
        assert_eq!(h.head_speed.points(), &[(1.0, 0.25)]);
        assert_eq!(h.jitter_p99.points(), &[(1.0, 15.0)]);
    }
}
