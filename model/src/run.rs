//! Running a named gait and summarizing it the way the paper's tables do
//! (no I/O: the caller observes each step through a closure). The tables
//! themselves are in [`crate::paper`].

use crate::dynamics::{HeadState, Model, StepReport, Workspace, step};
use crate::error::Result;
use crate::gait::{GaitLaw, LawSource, NamedGait};

/// Averages of one run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Summary {
    /// `-V1` at the head averaged over the last 5 whole gait periods (m/s).
    /// Every mean is the trapezoid rule over the step instants of its
    /// window, the window's ends included.
    pub mean_forward_speed: f64,
    /// Head yaw (unwrapped) averaged over the last 5 s (deg).
    pub mean_yaw_deg: f64,
    /// `omega . t1` at the head averaged over the whole run (rad/s).
    pub mean_roll_rate: f64,
    /// `V1` at the head at the end of the run (m/s).
    pub final_v1: f64,
    /// `-V1` averaged over the last whole gait period (m/s).
    pub last_period_forward_speed: f64,
    /// Simulated duration (s).
    pub duration: f64,
}

/// Gait period used for averaging (1 s for the purely inertial turns).
pub fn gait_period(g: &NamedGait) -> f64 {
    match g.law {
        GaitLaw::Forward(w) | GaitLaw::Spiral { wave: w, .. } | GaitLaw::Turn { wave: w, .. } => {
            w.period
        }
    }
}

/// Runs `gait` for `duration` seconds on `model` from the launch state of
/// the paper, calling `observe(report, head_before, head_after, workspace,
/// unwrapped_yaw_before)` after every step (the report, joints and torques
/// are those of `head_before`; the workspace shape is that of `head_after`),
/// and returns the table averages.
pub fn run_gait(
    model: &Model,
    gait: &NamedGait,
    duration: f64,
    mut observe: impl FnMut(&StepReport, &HeadState, &HeadState, &Workspace, f64),
) -> Result<Summary> {
    let dt = model.dt();
    let mut ws = Workspace::new(model);
    let mut src = LawSource::new(gait.law);
    let mut head = HeadState::launch(gait.v_init);
    let steps = (duration / dt).round() as usize;
    let period = gait_period(gait);
    let t_end = steps as f64 * dt;
    let win_speed = (5.0 * period).min(t_end);
    let win_period = period.min(t_end);
    let win_yaw = 5.0f64.min(t_end);
    let mut speed = Mean::new(t_end - win_speed, -head.v1());
    let mut last = Mean::new(t_end - win_period, -head.v1());
    let mut yaw_mean = Mean::new(t_end - win_yaw, 0.0);
    let mut roll = Mean::new(0.0, head.roll_rate());
    let mut yaw_prev = 0.0;
    let mut yaw_unwrapped = 0.0;
    for k in 0..steps {
        let before = head;
        let yaw_before = yaw_unwrapped;
        let r = step(model, &mut ws, &mut src, &mut head)?;
        let t = (k + 1) as f64 * dt;
        let yaw = head.yaw();
        let mut d = yaw - yaw_prev;
        if d > core::f64::consts::PI {
            d -= 2.0 * core::f64::consts::PI;
        } else if d < -core::f64::consts::PI {
            d += 2.0 * core::f64::consts::PI;
        }
        yaw_unwrapped += d;
        yaw_prev = yaw;
        let v1 = head.v1();
        speed.add(t, -v1);
        last.add(t, -v1);
        yaw_mean.add(t, yaw_unwrapped);
        roll.add(t, head.roll_rate());
        observe(&r, &before, &head, &ws, yaw_before);
    }
    Ok(Summary {
        mean_forward_speed: speed.value(),
        mean_yaw_deg: yaw_mean.value().to_degrees(),
        mean_roll_rate: roll.value(),
        final_v1: head.v1(),
        last_period_forward_speed: last.value(),
        duration: t_end,
    })
}

/// The mean of a quantity sampled at the step instants over the window
/// `[start, t_end]`, by the trapezoid rule: second order in the step, so a
/// table's average does not move with `dt` (the rectangle rule this
/// replaced was off by half a step's change of the quantity over the
/// window: 0.2 % of SPIRAL's roll rate at dt = 0.01 s).
#[derive(Debug, Clone, Copy)]
struct Mean {
    start: f64,
    /// Sum of the samples in the window.
    sum: f64,
    first: Option<f64>,
    last: f64,
    count: usize,
}

impl Mean {
    /// A window from `start`, with the sample `at_zero` of `t = 0`.
    fn new(start: f64, at_zero: f64) -> Self {
        let mut m = Mean {
            start,
            sum: 0.0,
            first: None,
            last: 0.0,
            count: 0,
        };
        m.add(0.0, at_zero);
        m
    }
    fn add(&mut self, t: f64, value: f64) {
        if t < self.start - 1e-9 {
            return;
        }
        self.first.get_or_insert(value);
        self.sum += value;
        self.last = value;
        self.count += 1;
    }
    /// The trapezoid mean over the samples' span; the one sample if there
    /// is one, `0` if none.
    fn value(&self) -> f64 {
        match (self.first, self.count) {
            (None, _) => 0.0,
            (Some(v), 1) => v,
            (Some(first), n) => (self.sum - 0.5 * (first + self.last)) / (n - 1) as f64,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Mean;

    /// The trapezoid rule is exact for a straight line, whatever the step
    /// and wherever the window starts; samples before the window do not
    /// count.
    #[test]
    fn the_mean_is_the_trapezoid_rule_over_the_window() {
        for dt in [0.01f64, 0.025, 0.3] {
            let mut m = Mean::new(1.0, 7.0);
            let steps = (3.0 / dt).round() as usize;
            for k in 1..=steps {
                let t = k as f64 * dt;
                m.add(t, 2.0 * t + 1.0);
            }
            let t_end = steps as f64 * dt;
            let first = (1.0 / dt - 1e-9).ceil() * dt;
            let exact = 1.0 + first + t_end;
            assert!(
                (m.value() - exact).abs() < 1e-9,
                "dt {dt}: {} vs {exact}",
                m.value()
            );
        }
        // a window from 0 takes the sample at t = 0
        let mut m = Mean::new(0.0, 0.0);
        m.add(1.0, 1.0);
        assert_eq!(m.value(), 0.5);
        assert_eq!(Mean::new(5.0, 3.0).value(), 0.0);
    }
}
