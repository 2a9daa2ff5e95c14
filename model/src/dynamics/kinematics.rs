//! Kinematics: the shape and the deformation velocity and acceleration
//! fields along the body (34)–(36) from the curvature, and their mapping
//! onto the joints of the discrete robot (section 2, figure 2).

use super::model::Model;
use super::state::JointState;
use super::workspace::Workspace;
use crate::gait::{Curvature, CurvatureSource};
use nalgebra::{Matrix3, Vector3};

/// Kinematic state along `X1` (head frame), flat so that the RK4 updates
/// run as one vectorized loop: `R = [t1 t2 t3]` by columns (0..9), then
/// `r`, the deformation angular velocity `w` and velocity `v`, and their
/// accelerations `al` and `ac` (3 each).
#[derive(Clone, Copy)]
struct Kin([f64; KIN]);

const KIN: usize = 24;
const P: usize = 9;
const W: usize = 12;
const V: usize = 15;
const AL: usize = 18;
const AC: usize = 21;

#[inline(always)]
fn v3(y: &[f64; KIN], at: usize) -> Vector3<f64> {
    Vector3::new(y[at], y[at + 1], y[at + 2])
}

#[inline(always)]
fn put(y: &mut [f64; KIN], at: usize, v: Vector3<f64>) {
    y[at] = v.x;
    y[at + 1] = v.y;
    y[at + 2] = v.z;
}

impl Kin {
    fn start() -> Kin {
        let mut y = [0.0; KIN];
        (y[0], y[4], y[8]) = (1.0, 1.0, 1.0);
        Kin(y)
    }
    /// Space derivative: (34), (35), (36). `R K^` and `R K` are expanded
    /// column by column (`R = [t1 t2 t3]`).
    #[inline(always)]
    fn deriv(&self, c: &Curvature) -> Kin {
        let y = &self.0;
        let (t1, t2, t3) = (v3(y, 0), v3(y, 3), v3(y, 6));
        let (w, al) = (v3(y, W), v3(y, AL));
        let k = &c.k;
        let rk = |v: &Vector3<f64>| t1 * v.x + t2 * v.y + t3 * v.z;
        let qkd = rk(&c.k_dot);
        let wt1 = w.cross(&t1);
        let mut d = [0.0; KIN];
        put(&mut d, 0, t2 * k.z - t3 * k.y);
        put(&mut d, 3, t3 * k.x - t1 * k.z);
        put(&mut d, 6, t1 * k.y - t2 * k.x);
        put(&mut d, P, t1);
        put(&mut d, W, qkd);
        put(&mut d, V, wt1);
        put(&mut d, AL, rk(&c.k_ddot) + w.cross(&qkd));
        put(&mut d, AC, al.cross(&t1) + w.cross(&wt1));
        Kin(d)
    }
    #[inline(always)]
    fn axpy(&self, h: f64, d: &Kin) -> Kin {
        let mut out = self.0;
        for (o, di) in out.iter_mut().zip(&d.0) {
            *o += di * h;
        }
        Kin(out)
    }
}

/// Space integration of the kinematics (34)–(36) from the head (head frame)
/// with the head at rest: the shape `(R, r)` and the deformation velocity
/// and acceleration fields. The head twist is superposed afterwards (see
/// [`forward_head`](super::forward::forward_head)), so one pass serves every time stage at the same instant.
pub(super) fn kinematics(model: &Model, ws: &mut Workspace) {
    ws.inertia = None;
    let h = model.h;
    let mut y = Kin::start();
    for i in 0..=model.n {
        let a = &y.0;
        ws.q[i] = Matrix3::from_column_slice(&a[0..9]);
        ws.p[i] = v3(a, P);
        ws.we[i] = v3(a, W);
        ws.ve[i] = v3(a, V);
        ws.al[i] = v3(a, AL);
        ws.ac[i] = v3(a, AC);
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
        for j in 0..KIN {
            y.0[j] += (k1.0[j] + (k2.0[j] + k3.0[j]) * 2.0 + k4.0[j]) * (h / 6.0);
        }
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
