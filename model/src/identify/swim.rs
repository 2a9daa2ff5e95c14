//! A recorded swim, as the fit takes it.

/// One sample of every joint at one instant, as a session records it.
#[derive(Debug, Clone, PartialEq)]
pub struct JointSample {
    /// Time (s, the session's clock).
    pub t: f64,
    /// Measured angles `[pitch, yaw]` (rad), joint 1 first.
    pub angle: Vec<[f64; 2]>,
    /// Measured rates `[pitch, yaw]` (rad/s).
    pub rate: Vec<[f64; 2]>,
    /// Measured torques `[pitch, yaw]` (N·m); NaN where not measured.
    pub torque: Vec<[f64; 2]>,
}

/// A recorded swim: what a session holds that the fit uses.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Swim {
    /// What it is called in reports (its file).
    pub name: String,
    /// Joint samples, in time order (at least two, `joints` each).
    pub samples: Vec<JointSample>,
    /// The nose's horizontal position `[t, x, y]` (s, m, m), in time
    /// order: motion capture, an overhead camera, or the simulation's
    /// ground truth. Empty: no speed in the fit.
    pub track: Vec<[f64; 3]>,
    /// The body's heading and the nose's depth `[t, heading, depth]` (s,
    /// rad counter-clockwise, m down), in time order: the head sensor, or
    /// the ground truth. Empty: no turning or diving in the fit.
    pub attitude: Vec<[f64; 3]>,
    /// The head's yaw `[t, yaw]` (s, rad: the direction of the head's
    /// axis, which sways with every tail beat), in time order: a head
    /// IMU's attitude, or the ground truth. Empty: no sway in the fit.
    pub head_yaw: Vec<[f64; 2]>,
}

impl Swim {
    /// Number of joints.
    pub fn joints(&self) -> usize {
        self.samples.first().map_or(0, |s| s.angle.len())
    }

    /// Checks what the fit relies on; the error says what is wrong.
    pub fn validate(&self) -> std::result::Result<(), String> {
        let n = self.joints();
        if self.samples.len() < 2 || n == 0 {
            return Err(format!(
                "{}: needs at least two joint samples of at least one joint (has {})",
                self.name,
                self.samples.len()
            ));
        }
        for (i, s) in self.samples.iter().enumerate() {
            if s.angle.len() != n || s.rate.len() != n || s.torque.len() != n {
                return Err(format!(
                    "{}: joint sample {i} has {} angles, {} rates, {} torques (expected {n})",
                    self.name,
                    s.angle.len(),
                    s.rate.len(),
                    s.torque.len()
                ));
            }
            let finite = s
                .angle
                .iter()
                .chain(&s.rate)
                .flatten()
                .all(|v| v.is_finite());
            if !s.t.is_finite() || !finite {
                return Err(format!(
                    "{}: joint sample {i} (t = {} s) has a value that is not a number",
                    self.name, s.t
                ));
            }
            if i > 0 && s.t <= self.samples[i - 1].t {
                return Err(format!(
                    "{}: joint sample {i} (t = {} s) is not after the one before",
                    self.name, s.t
                ));
            }
        }
        if self
            .head_yaw
            .iter()
            .any(|p| p.iter().any(|v| !v.is_finite()))
            || self.head_yaw.windows(2).any(|w| w[1][0] <= w[0][0])
        {
            return Err(format!(
                "{}: the head's yaw must be numbers in increasing time",
                self.name
            ));
        }
        for (what, series) in [("track", &self.track), ("attitude", &self.attitude)] {
            if series.iter().any(|p| p.iter().any(|v| !v.is_finite()))
                || series.windows(2).any(|w| w[1][0] <= w[0][0])
            {
                return Err(format!(
                    "{}: the {what} must be numbers in increasing time",
                    self.name
                ));
            }
        }
        Ok(())
    }

    /// Duration (s) of the joint samples.
    pub fn duration(&self) -> f64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => b.t - a.t,
            _ => 0.0,
        }
    }
}
