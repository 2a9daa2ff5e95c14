//! Inverse dynamics `G_int` (17)–(20): the internal wrench `n_*`, `c_*`
//! along the body, the torques `C2`, `C3` and the tail closure residual.

use super::kinematics::joints;
use super::model::Model;
use super::state::HeadState;
use super::workspace::Workspace;
use nalgebra::{Vector3, Vector6};

/// Inverse dynamics `G_int` (17)–(20) with the head acceleration
/// `(omega_dot_h, v_dot_h)` (head frame), on the fields of the last
/// [`forward_head`](super::forward::forward_head) call: internal wrench `n_*`, `c_*`, torques `C2`, `C3` and
/// the tail closure residual.
pub(super) fn inverse_head(model: &Model, ws: &mut Workspace, wd: Vector3<f64>, vd: Vector3<f64>) {
    let rho = model.body.rho_fluid;
    let n = model.n;
    let h = model.h;
    for i in 0..=n {
        let s = &model.sec[i];
        let qt = ws.q[i].transpose();
        let mm = Vector3::from(s.mm);
        let fl = mm.component_mul(&(qt * (vd + wd.cross(&ws.p[i])))) + ws.bf[i];
        ws.f[i] = ws.q[i] * fl;
        let mi = Vector3::from(s.mi);
        let tl = mi.component_mul(&(qt * wd)) + ws.bt[i];
        // reuse `bt`-sized buffer cstar for tau temporarily
        ws.cstar[i] = ws.q[i] * tl;
    }
    // n_*(0) = -n_-: nose loads (22), (23), relative to the water
    let v1 = ws.head_v1;
    let n0 = Vector3::new(
        0.5 * rho * model.k_o * v1 * v1.abs() + model.m_o * (vd.x - ws.head_u_dot1),
        0.0,
        0.0,
    );
    cumulative(h, n0, &ws.f, &mut ws.nstar);
    // c_*' = tau - t1 x n_*
    for i in 0..=n {
        let t1 = ws.q[i].column(0).into_owned();
        ws.f[i] = ws.cstar[i] - t1.cross(&ws.nstar[i]);
    }
    cumulative(h, Vector3::zeros(), &ws.f, &mut ws.cstar);
    for i in 0..=n {
        let s = &model.sec[i];
        let om = ws.om_loc[i];
        let c = ws.q[i].transpose() * ws.cstar[i]
            - Vector3::new(ws.v_loc[i].x * s.if1 * om.x, 0.0, 0.0);
        ws.torque[i] = [c.y, c.z];
    }
    let rc = ws.cstar[n] - ws.tail_c;
    let rn = ws.nstar[n] - ws.tail_n;
    ws.residual = Vector6::new(rc.x, rc.y, rc.z, rn.x, rn.y, rn.z);
}

/// Fourth-order cumulative quadrature on a uniform grid (even count of
/// intervals): Simpson on pairs, `(5, 8, -1)/12` for odd nodes.
fn cumulative(h: f64, init: Vector3<f64>, f: &[Vector3<f64>], out: &mut [Vector3<f64>]) {
    out[0] = init;
    let mut j = 0;
    while j + 2 < f.len() {
        out[j + 1] = out[j] + (f[j] * 5.0 + f[j + 1] * 8.0 - f[j + 2]) * (h / 12.0);
        out[j + 2] = out[j] + (f[j] + f[j + 1] * 4.0 + f[j + 2]) * (h / 3.0);
        j += 2;
    }
}

/// Inverse dynamics `G_int` at the instant of the last [`evaluate`](super::evaluate) (same
/// fields) but with a given head acceleration (earth frame) — for checks
/// that compare discretizations.
pub fn inverse_with(
    model: &Model,
    ws: &mut Workspace,
    head: &HeadState,
    omega_dot: Vector3<f64>,
    v_dot: Vector3<f64>,
) {
    let rt = head
        .orientation
        .to_rotation_matrix()
        .into_inner()
        .transpose();
    inverse_head(model, ws, rt * omega_dot, rt * v_dot);
    joints(model, ws);
}
