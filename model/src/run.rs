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
    let (mut s_speed, mut n_speed) = (0.0, 0usize);
    let (mut s_last, mut n_last) = (0.0, 0usize);
    let (mut s_yaw, mut n_yaw) = (0.0, 0usize);
    let mut s_roll = 0.0;
    let mut yaw_prev = 0.0;
    let mut yaw_unwrapped = 0.0;
    for k in 0..steps {
        let before = head;
        let yaw_before = yaw_unwrapped;
        let r = step(model, &mut ws, &mut src, &mut head)?;
        // averages are over the instants t_k = k dt of the window (t_end - w, t_end]
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
        if t > t_end - win_speed + 1e-9 {
            s_speed += -v1;
            n_speed += 1;
        }
        if t > t_end - win_period + 1e-9 {
            s_last += -v1;
            n_last += 1;
        }
        if t > t_end - win_yaw + 1e-9 {
            s_yaw += yaw_unwrapped;
            n_yaw += 1;
        }
        s_roll += head.roll_rate();
        observe(&r, &before, &head, &ws, yaw_before);
    }
    let avg = |s: f64, n: usize| if n > 0 { s / n as f64 } else { 0.0 };
    Ok(Summary {
        mean_forward_speed: avg(s_speed, n_speed),
        mean_yaw_deg: avg(s_yaw, n_yaw).to_degrees(),
        mean_roll_rate: avg(s_roll, steps),
        final_v1: head.v1(),
        last_period_forward_speed: avg(s_last, n_last),
        duration: t_end,
    })
}
