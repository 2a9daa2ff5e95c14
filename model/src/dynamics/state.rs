//! What the passes share: the head state, a joint, the step report, and
//! the finiteness check every pass ends with.

use crate::error::{ModelError, Result};
use nalgebra::{UnitQuaternion, Vector3};

/// Head configuration `g_o` and twist `mu_o` (earth frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadState {
    /// Time (s).
    pub t: f64,
    /// Orientation `R_o` of the head frame `(t1, t2, t3)(0)`.
    pub orientation: UnitQuaternion<f64>,
    /// Position `r_o` of the nose (m).
    pub position: Vector3<f64>,
    /// Angular velocity `omega_o` (rad/s, earth frame).
    pub omega: Vector3<f64>,
    /// Linear velocity `v_o` of the nose (m/s, earth frame).
    pub velocity: Vector3<f64>,
}

impl HeadState {
    /// Straight body along `e1` at the origin, launched with `v_o = v_init t1`.
    pub fn launch(v_init: f64) -> Self {
        Self {
            t: 0.0,
            orientation: UnitQuaternion::identity(),
            position: Vector3::zeros(),
            omega: Vector3::zeros(),
            velocity: Vector3::new(v_init, 0.0, 0.0),
        }
    }
    /// `t1(0)` in the earth frame (points towards the tail).
    pub fn t1(&self) -> Vector3<f64> {
        self.orientation * Vector3::x()
    }
    /// `V1 = v . t1` at the head (negative when swimming head first).
    pub fn v1(&self) -> f64 {
        self.velocity.dot(&self.t1())
    }
    /// Roll rate `Omega1 = omega . t1` at the head (rad/s).
    pub fn roll_rate(&self) -> f64 {
        self.omega.dot(&self.t1())
    }
    /// Yaw of `t1(0)` about `e3` from `e1` (rad, in `(-pi, pi]`).
    pub fn yaw(&self) -> f64 {
        let t1 = self.t1();
        t1.y.atan2(t1.x)
    }
}

/// One joint of the discrete robot at one instant.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct JointState {
    /// Pitch angle (rad) of the universal joint (first rotation, about `t2`).
    pub pitch: f64,
    /// Yaw angle (rad) (second rotation, about the rotated `t3`).
    pub yaw: f64,
    /// Pitch rate (rad/s).
    pub pitch_rate: f64,
    /// Yaw rate (rad/s).
    pub yaw_rate: f64,
    /// Feedforward torque `C2 = c . t2` at the joint (N m), `c` being the
    /// torque the rear part exerts on the front part (the paper's sign; a
    /// rigid-body library's joint torque for the same motion is `-C2`).
    pub c2: f64,
    /// Feedforward torque `C3 = c . t3` at the joint (N m), same sign
    /// convention as `c2`.
    pub c3: f64,
}

impl JointState {
    /// The torques `[pitch, yaw]` (N m) the joint's actuators must produce
    /// for this motion: `[-C2, -C3]`. `C` is what the rear exerts on the
    /// front (the paper's sign, MODEL-NOTES); the actuator in the joint
    /// exerts the opposite, as a rigid-body library's joint torque does.
    /// Every user of the model's torques (the daemon's feed-forward, the
    /// simulated actuators' load) takes them from here.
    pub fn actuator_torque(&self) -> [f64; 2] {
        [-self.c2, -self.c3]
    }
}

/// What a step reports (values at the start of the step, time `t`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepReport {
    /// Time of the evaluated instant (s).
    pub t: f64,
    /// Head angular acceleration (earth frame).
    pub omega_dot: Vector3<f64>,
    /// Head linear acceleration (earth frame).
    pub v_dot: Vector3<f64>,
    /// `V1` at the head (m/s).
    pub v1: f64,
    /// Head forward speed `-V1` (m/s).
    pub forward_speed: f64,
    /// Head turn rate `omega . e3` (rad/s).
    pub turn_rate: f64,
}

pub(super) fn check(v: &Vector3<f64>, quantity: &'static str, time: f64) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(ModelError::NonFinite { quantity, time })
    }
}
