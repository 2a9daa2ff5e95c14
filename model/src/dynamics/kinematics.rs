//! Kinematics: the shape and the deformation velocity and acceleration
//! fields along the body (34)–(36) from the curvature, and their mapping
//! onto the joints of the discrete robot (section 2, figure 2).

use super::model::Model;
use super::state::JointState;
use super::workspace::Workspace;
use crate::gait::{Curvature, CurvatureSource};
use nalgebra::{Matrix3, Vector3};

/// Kinematic state along `X1` (head frame).
#[derive(Clone, Copy)]
struct Kin {
    q: Matrix3<f64>,
    p: Vector3<f64>,
    w: Vector3<f64>,
    v: Vector3<f64>,
    al: Vector3<f64>,
    ac: Vector3<f64>,
}

impl Kin {
    /// Space derivative: (34), (35), (36). `R K^` and `R K` are expanded
    /// column by column (`R = [t1 t2 t3]`).
    #[inline(always)]
    fn deriv(&self, c: &Curvature) -> Kin {
        let t1 = self.q.column(0).into_owned();
        let t2 = self.q.column(1).into_owned();
        let t3 = self.q.column(2).into_owned();
        let k = &c.k;
        let rk = |v: &Vector3<f64>| t1 * v.x + t2 * v.y + t3 * v.z;
        let qkd = rk(&c.k_dot);
        let wt1 = self.w.cross(&t1);
        Kin {
            q: Matrix3::from_columns(&[
                t2 * k.z - t3 * k.y,
                t3 * k.x - t1 * k.z,
                t1 * k.y - t2 * k.x,
            ]),
            p: t1,
            w: qkd,
            v: wt1,
            al: rk(&c.k_ddot) + self.w.cross(&qkd),
            ac: self.al.cross(&t1) + self.w.cross(&wt1),
        }
    }
    #[inline(always)]
    fn axpy(&self, h: f64, d: &Kin) -> Kin {
        Kin {
            q: self.q + d.q * h,
            p: self.p + d.p * h,
            w: self.w + d.w * h,
            v: self.v + d.v * h,
            al: self.al + d.al * h,
            ac: self.ac + d.ac * h,
        }
    }
}

/// Space integration of the kinematics (34)–(36) from the head (head frame)
/// with the head at rest: the shape `(R, r)` and the deformation velocity
/// and acceleration fields. The head twist is superposed afterwards (see
/// [`forward_head`](super::forward::forward_head)), so one pass serves every time stage at the same instant.
pub(super) fn kinematics(model: &Model, ws: &mut Workspace) {
    ws.inertia = None;
    let h = model.h;
    let mut y = Kin {
        q: Matrix3::identity(),
        p: Vector3::zeros(),
        w: Vector3::zeros(),
        v: Vector3::zeros(),
        al: Vector3::zeros(),
        ac: Vector3::zeros(),
    };
    for i in 0..=model.n {
        ws.q[i] = y.q;
        ws.p[i] = y.p;
        ws.we[i] = y.w;
        ws.ve[i] = y.v;
        ws.al[i] = y.al;
        ws.ac[i] = y.ac;
        if i == model.n {
            break;
        }
        let c0 = ws.curv[2 * i];
        let cm = ws.curv[2 * i + 1];
        let c1 = ws.curv[2 * i + 2];
        let k1 = y.deriv(&c0);
        let k2 = y.axpy(h / 2.0, &k1).deriv(&cm);
        let k3 = y.axpy(h / 2.0, &k2).deriv(&cm);
        let k4 = y.axpy(h, &k3).deriv(&c1);
        y = Kin {
            q: y.q + (k1.q + (k2.q + k3.q) * 2.0 + k4.q) * (h / 6.0),
            p: y.p + (k1.p + (k2.p + k3.p) * 2.0 + k4.p) * (h / 6.0),
            w: y.w + (k1.w + (k2.w + k3.w) * 2.0 + k4.w) * (h / 6.0),
            v: y.v + (k1.v + (k2.v + k3.v) * 2.0 + k4.v) * (h / 6.0),
            al: y.al + (k1.al + (k2.al + k3.al) * 2.0 + k4.al) * (h / 6.0),
            ac: y.ac + (k1.ac + (k2.ac + k3.ac) * 2.0 + k4.ac) * (h / 6.0),
        };
    }
}

/// Samples the curvature at `tau` and integrates the shape, unless the
/// workspace already holds the shape of this `tau` within the current step.
pub(super) fn shape<S: CurvatureSource + ?Sized>(
    model: &Model,
    ws: &mut Workspace,
    src: &S,
    tau: f64,
) {
    if ws.shape_tau == Some(tau) {
        return;
    }
    src.curvature(tau, &model.x_fine, &mut ws.curv);
    kinematics(model, ws);
    ws.shape_tau = Some(tau);
}

/// Joint angles, rates and torques of the discrete robot (section 2 and
/// figure 2): relative rotation of the platforms on either side of each
/// joint, decomposed as pitch about `t2` then yaw about the rotated `t3`.
pub(super) fn joints(model: &Model, ws: &mut Workspace) {
    for j in 1..=model.joints {
        let a = model.platform_node(j - 1);
        let b = model.platform_node(j);
        let qa = ws.q[a];
        let rel = qa.transpose() * ws.q[b];
        let pitch = rel[(0, 2)].atan2(rel[(2, 2)]);
        let yaw = rel[(1, 0)].atan2(rel[(1, 1)]);
        let w = qa.transpose() * (ws.we[b] - ws.we[a]);
        let (sp, cp) = pitch.sin_cos();
        let jn = model.joint_node(j);
        ws.joints[j - 1] = JointState {
            pitch,
            yaw,
            pitch_rate: w.y,
            yaw_rate: w.x * sp + w.z * cp,
            c2: ws.torque[jn][0],
            c3: ws.torque[jn][1],
        };
    }
}

/// Joint angles and rates of the curvature of `src` at its current time,
/// without dynamics (posture moves). Torques are left untouched.
pub fn posture<'a, S: CurvatureSource + ?Sized>(
    model: &Model,
    ws: &'a mut Workspace,
    src: &S,
) -> &'a [JointState] {
    ws.shape_tau = None;
    ws.shape_carry = None;
    shape(model, ws, src, 0.0);
    ws.shape_tau = None;
    joints(model, ws);
    &ws.joints
}
