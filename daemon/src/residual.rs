//! The live torque residual (`[monitor]`): per joint and axis, the
//! measured torque less the model's prediction (the feed-forward), low-
//! passed over `residual-tau` and divided by the prediction's low-passed
//! magnitude plus `residual-floor`. The swim's own torques oscillate about
//! zero and average out; what stays is a bias the model does not know: a
//! snag, fouling, a failing actuator, a tether pulling, or coefficients
//! fitted to another body. Beyond ±`residual-band` for `residual-hold` it
//! raises an operator alarm (not a fault) naming the joint and the sign;
//! it clears below 70 % of the band.
//!
//! A family whose drives report no torque (ODrive) has no residual. The
//! monitor judges only while swimming (the drives follow the model's
//! setpoints); it rests at zero otherwise. Nothing here allocates after
//! [`ResidualMonitor::new`].

use anguilla_protocol::time::Nanos;

use crate::config::MonitorConfig;

/// One axis's residual.
#[derive(Debug, Clone, Copy, Default)]
struct Axis {
    error: f64,
    magnitude: f64,
    beyond_since: Option<Nanos>,
    alarm: i8,
}

/// Every joint's residual.
#[derive(Debug, Clone)]
pub struct ResidualMonitor {
    tau: f64,
    band: f64,
    hold: Nanos,
    floor: f64,
    axes: Vec<[Axis; 2]>,
}

impl ResidualMonitor {
    /// The monitor of `joints` joints under `cfg`.
    pub fn new(cfg: &MonitorConfig, joints: usize) -> Self {
        Self {
            tau: cfg.residual_tau,
            band: cfg.residual_band,
            hold: Nanos::from_secs_f64(cfg.residual_hold),
            floor: cfg.residual_floor,
            axes: vec![[Axis::default(); 2]; joints],
        }
    }

    /// The low-pass's gain for a step of `dt` s (compute once a period).
    pub fn gain(&self, dt: f64) -> f64 {
        1.0 - (-dt / self.tau).exp()
    }

    /// Joint `j`'s axis `axis` (0 pitch, 1 yaw) at `now`: `measured` torque
    /// (`None`: not measured, or not judged now: the residual rests at 0),
    /// `predicted` torque, with the low-pass gain `k` ([`Self::gain`]).
    pub fn update(
        &mut self,
        now: Nanos,
        k: f64,
        j: usize,
        axis: usize,
        measured: Option<f64>,
        predicted: f64,
    ) {
        let Some(a) = self.axes.get_mut(j).and_then(|p| p.get_mut(axis)) else {
            return;
        };
        let Some(m) = measured.filter(|m| m.is_finite() && predicted.is_finite()) else {
            *a = Axis::default();
            return;
        };
        a.error += k * (m - predicted - a.error);
        a.magnitude += k * (predicted.abs() - a.magnitude);
        let r = a.error / (a.magnitude + self.floor);
        if r.abs() > self.band {
            let since = *a.beyond_since.get_or_insert(now);
            if now.saturating_sub(since) >= self.hold {
                a.alarm = if r > 0.0 { 1 } else { -1 };
            }
        } else if r.abs() < 0.7 * self.band {
            a.beyond_since = None;
            a.alarm = 0;
        }
    }

    /// The normalised residual of joint `j`'s axis.
    pub fn residual(&self, j: usize, axis: usize) -> f64 {
        self.axes
            .get(j)
            .map_or(0.0, |p| p[axis].error / (p[axis].magnitude + self.floor))
    }

    /// Joint `j`'s axis alarm: +1 (the joint needs more torque than the
    /// model says), −1 (less), 0 none.
    pub fn alarm(&self, j: usize, axis: usize) -> i8 {
        self.axes.get(j).map_or(0, |p| p[axis].alarm)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Nanos = Nanos::from_millis(1);

    fn monitor() -> ResidualMonitor {
        let cfg = MonitorConfig {
            residual_band: 1.0,
            ..MonitorConfig::default()
        };
        ResidualMonitor::new(&cfg, 2)
    }

    /// A 1 Hz torque the model predicts within 30 %: no alarm; the same
    /// with a constant 1 N·m extra on joint 1's yaw: its alarm, positive,
    /// within a second and a half; it clears when the extra goes.
    #[test]
    fn a_bias_raises_the_alarm_and_the_swim_does_not() {
        let mut m = monitor();
        let dt = 0.01;
        let k = m.gain(dt);
        let mut alarmed_at = None;
        for i in 0..3000u64 {
            let t = i as f64 * dt;
            let now = Nanos::from_millis(10 * i);
            let predicted = 0.8 * (std::f64::consts::TAU * t).sin();
            let snag = if (10.0..20.0).contains(&t) { 1.0 } else { 0.0 };
            for j in 0..2 {
                for a in 0..2 {
                    let extra = if (j, a) == (1, 1) { snag } else { 0.0 };
                    m.update(now, k, j, a, Some(1.3 * predicted + extra), predicted);
                }
            }
            if !(10.0..25.0).contains(&t) {
                assert!(
                    (0..2).all(|j| m.alarm(j, 0) == 0 && m.alarm(j, 1) == 0),
                    "t {t}"
                );
            }
            if m.alarm(1, 1) == 1 && alarmed_at.is_none() {
                alarmed_at = Some(t);
            }
            assert_eq!(m.alarm(0, 1), 0);
        }
        let at = alarmed_at.expect("the snag raised the alarm");
        assert!((10.0..11.5).contains(&at), "alarm at {at} s");
        assert!(m.residual(1, 1).abs() < 0.7, "{}", m.residual(1, 1));
        // A drive that measures nothing rests at zero.
        m.update(100 * MS, k, 1, 1, None, 0.5);
        assert_eq!((m.residual(1, 1), m.alarm(1, 1)), (0.0, 0));
    }
}
