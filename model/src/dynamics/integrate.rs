//! One instant and one time step: [`evaluate`] runs the forward and
//! inverse dynamics at the current instant; [`step`] then integrates the
//! head state over `dt` with the model's [`Integrator`].

use super::forward::{Flow, forward_earth, forward_head};
use super::inverse::inverse_head;
use super::kinematics::{joints, shape};
use super::model::{Integrator, Model};
use super::state::{HeadState, StepReport, check};
use super::workspace::Workspace;
use crate::error::{ModelError, Result};
use crate::gait::CurvatureSource;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// Forward and inverse dynamics at the current instant without advancing:
/// fills the workspace (joints, torques, fields) and returns the report.
pub fn evaluate<S: CurvatureSource + ?Sized>(
    model: &Model,
    ws: &mut Workspace,
    src: &S,
    head: &HeadState,
) -> Result<StepReport> {
    ws.shape_tau = None;
    ws.shape_carry = None;
    evaluate_held(model, ws, src, head)
}

/// [`evaluate`] on the shape the workspace holds for `tau = 0`, if any.
fn evaluate_held<S: CurvatureSource + ?Sized>(
    model: &Model,
    ws: &mut Workspace,
    src: &S,
    head: &HeadState,
) -> Result<StepReport> {
    let rot = head.orientation.to_rotation_matrix().into_inner();
    let rt = rot.transpose();
    shape(model, ws, src, 0.0);
    let flow = Flow::at(&ws.current, head.t, &rt, head.position.z, ws.surface);
    let (wd, vd) = forward_head(
        model,
        ws,
        rt * head.omega,
        rt * head.velocity,
        rt * model.gravity,
        &flow,
        head.t,
    )?;
    inverse_head(model, ws, wd, vd);
    joints(model, ws);
    let omega_dot = rot * wd;
    let v_dot = rot * vd;
    check(&omega_dot, "head angular acceleration", head.t)?;
    check(&v_dot, "head linear acceleration", head.t)?;
    if !ws
        .torque
        .iter()
        .all(|c| c[0].is_finite() && c[1].is_finite())
    {
        return Err(ModelError::NonFinite {
            quantity: "internal torque C",
            time: head.t,
        });
    }
    let v1 = head.v1();
    Ok(StepReport {
        t: head.t,
        omega_dot,
        v_dot,
        v1,
        forward_speed: -v1,
        turn_rate: head.omega.z,
    })
}

/// [`step`] with the source behind `dyn`: one instance, compiled in this
/// crate with its optimisation. A caller built without optimisation (the
/// daemon in a debug build: its feed-forward every period, its start-up
/// tables) that called [`step`] got its own unoptimised copy of the
/// integrator, as generic code is compiled where it is used.
pub fn step_dyn(
    model: &Model,
    ws: &mut Workspace,
    src: &mut dyn CurvatureSource,
    head: &mut HeadState,
) -> Result<StepReport> {
    step(model, ws, src, head)
}

/// One time step: forward + inverse dynamics at `head.t` (reported, and
/// written to the workspace: joints, torques), then RK4 integration of the
/// head state over `model.dt()` (orientation renormalized on SO(3)) and
/// `src.advance(dt)`. Allocates nothing. On error the head state is left
/// unchanged.
pub fn step<S: CurvatureSource + ?Sized>(
    model: &Model,
    ws: &mut Workspace,
    src: &mut S,
    head: &mut HeadState,
) -> Result<StepReport> {
    let dt = model.dt;
    // The last step's final shape is this step's first when the source is
    // a law of time and has not moved since (bit for bit the same: the
    // source's time `t + dt` before its advance is `t` after it).
    let carried = ws.shape_carry.take() == Some(src.time()) && src.is_law_of_time();
    ws.shape_tau = if carried { Some(0.0) } else { None };
    let report = evaluate_held(model, ws, src, head)?;
    let t = head.t;
    let q0 = *head.orientation.quaternion();
    let qdot = |q: &Quaternion<f64>, w: &Vector3<f64>| Quaternion::from_parts(0.0, *w) * q * 0.5;
    // stage 1 reuses the evaluation
    let k1 = (
        head.velocity,
        report.omega_dot,
        report.v_dot,
        qdot(&q0, &head.omega),
    );
    let stage = |frac: f64,
                 prev: &(Vector3<f64>, Vector3<f64>, Vector3<f64>, Quaternion<f64>),
                 ws: &mut Workspace| {
        let h = dt * frac;
        let q = UnitQuaternion::from_quaternion(q0 + prev.3 * h);
        let omega = head.omega + prev.1 * h;
        let vel = head.velocity + prev.2 * h;
        let rot = q.to_rotation_matrix().into_inner();
        let z = head.position.z + prev.0.z * h;
        let (wd, vd) = forward_earth(model, ws, src, h, &rot, omega, vel, z, t + h)?;
        Ok::<_, ModelError>((vel, wd, vd, qdot(q.quaternion(), &omega)))
    };
    let (pos, omega, vel, q) = match model.integrator {
        Integrator::Rk4 => {
            let k2 = stage(0.5, &k1, ws)?;
            let k3 = stage(0.5, &k2, ws)?;
            let k4 = stage(1.0, &k3, ws)?;
            let c = dt / 6.0;
            (
                head.position + (k1.0 + (k2.0 + k3.0) * 2.0 + k4.0) * c,
                head.omega + (k1.1 + (k2.1 + k3.1) * 2.0 + k4.1) * c,
                head.velocity + (k1.2 + (k2.2 + k3.2) * 2.0 + k4.2) * c,
                q0 + (k1.3 + (k2.3 + k3.3) * 2.0 + k4.3) * c,
            )
        }
        Integrator::SemiImplicitEuler => {
            let omega = head.omega + k1.1 * dt;
            let vel = head.velocity + k1.2 * dt;
            (
                head.position + vel * dt,
                omega,
                vel,
                q0 + qdot(&q0, &omega) * dt,
            )
        }
        Integrator::Midpoint => {
            let k2 = stage(0.5, &k1, ws)?;
            (
                head.position + k2.0 * dt,
                head.omega + k2.1 * dt,
                head.velocity + k2.2 * dt,
                q0 + k2.3 * dt,
            )
        }
    };
    let ends_on_dt = ws.shape_tau == Some(dt);
    ws.shape_tau = None;
    let t_new = t + dt;
    check(&pos, "head position", t_new)?;
    check(&omega, "head angular velocity", t_new)?;
    check(&vel, "head velocity", t_new)?;
    if !q.coords.iter().all(|x| x.is_finite()) || q.norm() < 1e-6 {
        return Err(ModelError::NonFinite {
            quantity: "head orientation",
            time: t_new,
        });
    }
    // a diverging integration (dt too large) is reported before it overflows
    if omega.norm() > 1e3 || vel.norm() > 1e3 {
        return Err(ModelError::Diverged {
            quantity: if vel.norm() > 1e3 {
                "head velocity"
            } else {
                "head angular velocity"
            },
            time: t_new,
        });
    }
    head.position = pos;
    head.omega = omega;
    head.velocity = vel;
    head.orientation = UnitQuaternion::from_quaternion(q);
    head.t = t_new;
    src.advance(dt);
    ws.shape_carry = (ends_on_dt && src.is_law_of_time()).then(|| src.time());
    Ok(report)
}
