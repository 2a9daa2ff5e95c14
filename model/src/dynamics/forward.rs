//! Forward dynamics `G_ext` (29)–(31): the head inertia `I_o` and wrench
//! `F_o` assembled over the body, and the head acceleration they give.

use super::kinematics::shape;
use super::model::Model;
use super::workspace::Workspace;
use crate::body::Section;
use crate::current::Current;
use crate::error::{ModelError, Result};
use crate::gait::CurvatureSource;
use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

/// The water's current at one instant in the head frame (frozen, inertial):
/// its velocity `u` and acceleration `u_dot` (see the module docs of
/// [`dynamics`](super), "Currents").
#[derive(Debug, Clone, Copy)]
pub(super) struct Flow {
    pub(super) u: Vector3<f64>,
    pub(super) u_dot: Vector3<f64>,
    /// Whether `u_dot` is non-zero: only then are the fluid-acceleration
    /// terms computed (so still water is bit-for-bit the model without a
    /// current).
    pub(super) accelerating: bool,
    /// The water's surface, if any: the head's depth below it (m) and the
    /// earth's up in the head frame.
    pub(super) surface: Option<(f64, Vector3<f64>)>,
}

impl Flow {
    /// `current` at time `t`, rotated into the head frame by `rt = R_o^T`;
    /// the surface at height `surface` above a head at height `z` (earth
    /// frame, up).
    pub(super) fn at(
        current: &Current,
        t: f64,
        rt: &Matrix3<f64>,
        z: f64,
        surface: Option<f64>,
    ) -> Self {
        let still = *current == Current::ZERO;
        let accelerating = !current.is_steady();
        Flow {
            u: if still {
                Vector3::zeros()
            } else {
                rt * current.velocity(t)
            },
            u_dot: if accelerating {
                rt * current.acceleration(t)
            } else {
                Vector3::zeros()
            },
            accelerating,
            surface: surface.map(|s| (s - z, rt * Vector3::z())),
        }
    }
}

/// The part of section `s` (its centre `p` in the head frame, its local
/// frame `qt = Q^T` of the head frame) below the surface: 1 under water,
/// 0 wholly above, linear in between over the section's vertical reach.
fn wetted(
    surface: Option<(f64, Vector3<f64>)>,
    s: &Section,
    p: &Vector3<f64>,
    qt: &Matrix3<f64>,
) -> f64 {
    let Some((depth, up)) = surface else {
        return 1.0;
    };
    let d = depth - p.dot(&up);
    let u = qt * up;
    let reach = ((s.semi_axes[0] * u.y).powi(2) + (s.semi_axes[1] * u.z).powi(2)).sqrt();
    if reach <= 0.0 {
        return if d >= 0.0 { 1.0 } else { 0.0 };
    }
    (0.5 + 0.5 * d / reach).clamp(0.0, 1.0)
}

/// Forward dynamics `G_ext` (29)–(31) at one instant, head frame, in the
/// current `flow`. Fills the workspace fields and returns
/// `(omega_dot_o, v_dot_o)` in the head frame.
#[allow(clippy::too_many_arguments)] // internal pass
pub(super) fn forward_head(
    model: &Model,
    ws: &mut Workspace,
    omega_h: Vector3<f64>,
    vel_h: Vector3<f64>,
    grav_h: Vector3<f64>,
    flow: &Flow,
    t: f64,
) -> Result<(Vector3<f64>, Vector3<f64>)> {
    let rho = model.body.rho_fluid;
    // The head inertia `I_o` depends on the shape alone: assembled and
    // factored once per shape (RK4's two mid-step stages share one, and a
    // step's last stage the next step's first; see `kinematics::shape`).
    let assemble = ws.inertia.is_none();
    let mut a_vv = Matrix3::zeros();
    let mut a_wv = Matrix3::zeros();
    let mut a_ww = Matrix3::zeros();
    let mut rhs_f = Vector3::zeros();
    let mut rhs_t = Vector3::zeros();
    for i in 0..=model.n {
        let s = &model.sec[i];
        let q = ws.q[i];
        let qt = q.transpose();
        let p = ws.p[i];
        // superpose the head twist on the deformation fields (rigid transport
        // plus Coriolis 2 w_o x v_e and centripetal w_o x (w_o x p) terms)
        let wo_p = omega_h.cross(&p);
        let w_full = omega_h + ws.we[i];
        let v_full = vel_h + wo_p + ws.ve[i];
        let al_full = ws.al[i] + omega_h.cross(&ws.we[i]);
        let ac_full = ws.ac[i] + omega_h.cross(&wo_p) + 2.0 * omega_h.cross(&ws.ve[i]);
        ws.v[i] = v_full;
        let om = qt * w_full;
        // every hydrodynamic term sees the velocity relative to the water
        let vl = qt * (v_full - flow.u);
        ws.om_loc[i] = om;
        ws.v_loc[i] = vl;
        let mm = Vector3::from(s.mm);
        let mi = Vector3::from(s.mi);
        let mf = Vector3::from(s.mf);
        // resistive wrench (24) and buoyancy (25), local frame
        let k1_v = model.friction[i].k1_speed(vl.x);
        let mut nbar = -0.5
            * rho
            * Vector3::new(
                k1_v * vl.x,
                s.k2 * vl.y * vl.y.abs(),
                s.k3 * vl.z * vl.z.abs(),
            )
            + if s.buoyancy != 0.0 {
                s.buoyancy * (qt * grav_h)
            } else {
                Vector3::zeros()
            };
        let mut cbar_x = -0.5 * rho * s.k4 * om.x * om.x.abs();
        if flow.surface.is_some() {
            // Above the surface: no drag, and no buoyancy (the weight stays).
            let w = wetted(flow.surface, s, &p, &qt);
            if w < 1.0 {
                let buoyant = if s.buoyancy != 0.0 {
                    s.buoyancy * (qt * grav_h)
                } else {
                    Vector3::zeros()
                };
                nbar = (nbar - buoyant) * w + buoyant + (1.0 - w) * s.displaced * (qt * grav_h);
                cbar_x *= w;
            }
        }
        let mfv = mf.component_mul(&vl);
        let mut bf = mm.component_mul(&(qt * ac_full)) + om.cross(&mfv)
            - mf.component_mul(&om.cross(&vl))
            - nbar;
        if flow.accelerating {
            // added mass on the relative acceleration, and the Froude–Krylov
            // force of the pressure gradient that accelerates the water
            let d = s.displaced;
            bf -= Vector3::new(d, d + mf.y, d + mf.z).component_mul(&(qt * flow.u_dot));
        }
        let mut bt =
            mi.component_mul(&(qt * al_full)) + om.cross(&mi.component_mul(&om)) + vl.cross(&mfv);
        bt.x -= cbar_x;
        if s.ballast_moment != 0.0 {
            // The weight acts `h` below the axis (−t3): its moment about the
            // section's origin, an external torque like the drag's.
            bt -= s.ballast_moment * (-Vector3::z()).cross(&(qt * grav_h));
        }
        ws.bf[i] = bf;
        ws.bt[i] = bt;
        let wi = model.w[i];
        let bfh = q * bf;
        rhs_f -= bfh * wi;
        rhs_t -= (q * bt + p.cross(&bfh)) * wi;
    }
    if assemble {
        // The head inertia, in a loop of its own: it runs for a new shape
        // only, and the wrench's loop keeps fewer values live without it.
        for i in 0..=model.n {
            let s = &model.sec[i];
            let q = ws.q[i];
            let p = ws.p[i];
            let mm = Vector3::from(s.mm);
            let mi = Vector3::from(s.mi);
            let wi = model.w[i];
            // R diag(m) R^T = m1 I + (m2 - m1) t2 t2^T + (m3 - m1) t3 t3^T
            let t2 = q.column(1).into_owned();
            let t3 = q.column(2).into_owned();
            let sym = |m: &Vector3<f64>| {
                let mut a =
                    t2 * (t2.transpose() * (m.y - m.x)) + t3 * (t3.transpose() * (m.z - m.x));
                a[(0, 0)] += m.x;
                a[(1, 1)] += m.x;
                a[(2, 2)] += m.x;
                a
            };
            let mmh = sym(&mm);
            let mih = sym(&mi);
            // p^ M column by column, then (p^ M) p^ row by row (r^T p^ = (r x p)^T)
            let pm = Matrix3::from_columns(&[
                p.cross(&mmh.column(0).into_owned()),
                p.cross(&mmh.column(1).into_owned()),
                p.cross(&mmh.column(2).into_owned()),
            ]);
            let pmp = Matrix3::from_rows(&[
                pm.row(0).transpose().cross(&p).transpose(),
                pm.row(1).transpose().cross(&p).transpose(),
                pm.row(2).transpose().cross(&p).transpose(),
            ]);
            a_vv += mmh * wi;
            a_wv += pm * wi;
            a_ww += (mih - pmp) * wi;
        }
    }
    // tail boundary terms (16), (18), (20)
    let n = model.n;
    let s = &model.sec[n];
    let (om, vl) = (ws.om_loc[n], ws.v_loc[n]);
    let mf = Vector3::from(s.mf);
    let tf = 0.5 * (s.if1 * om.x * om.x + s.mf[1] * vl.y * vl.y + s.mf[2] * vl.z * vl.z);
    let nt = ws.q[n] * (vl.x * mf.component_mul(&vl) - Vector3::new(tf, 0.0, 0.0));
    let ct = ws.q[n] * Vector3::new(vl.x * s.if1 * om.x, 0.0, 0.0);
    ws.tail_n = nt;
    ws.tail_c = ct;
    rhs_f += nt;
    rhs_t += ct + ws.p[n].cross(&nt);
    // nose pressure drag (22) and added mass (23), relative to the water
    let v1 = vel_h.x - flow.u.x;
    ws.head_v1 = v1;
    ws.head_u_dot1 = flow.u_dot.x;
    rhs_f.x -= 0.5 * rho * model.k_o * v1 * v1.abs();
    if flow.accelerating {
        rhs_f.x += model.m_o * flow.u_dot.x;
    }
    if assemble {
        a_vv[(0, 0)] += model.m_o;
        let mut a = Matrix6::zeros();
        a.fixed_view_mut::<3, 3>(0, 0).copy_from(&a_ww);
        a.fixed_view_mut::<3, 3>(0, 3).copy_from(&a_wv);
        a.fixed_view_mut::<3, 3>(3, 0).copy_from(&a_wv.transpose());
        a.fixed_view_mut::<3, 3>(3, 3).copy_from(&a_vv);
        ws.inertia = Some(
            a.cholesky()
                .ok_or(ModelError::SingularInertia { time: t })?,
        );
    }
    let rhs = Vector6::new(rhs_t.x, rhs_t.y, rhs_t.z, rhs_f.x, rhs_f.y, rhs_f.z);
    if !rhs.iter().all(|v| v.is_finite()) {
        return Err(ModelError::NonFinite {
            quantity: "head wrench F_o (31)",
            time: t,
        });
    }
    let Some(chol) = &ws.inertia else {
        return Err(ModelError::SingularInertia { time: t });
    };
    let u = chol.solve(&rhs);
    Ok((
        Vector3::new(u[0], u[1], u[2]),
        Vector3::new(u[3], u[4], u[5]),
    ))
}

/// Forward dynamics (29) in the earth frame for `head` with the curvature of
/// `src` at `src.time() + tau`: returns `(omega_dot_o, v_dot_o)`.
#[allow(clippy::too_many_arguments)] // internal stage helper
pub(super) fn forward_earth<S: CurvatureSource + ?Sized>(
    model: &Model,
    ws: &mut Workspace,
    src: &S,
    tau: f64,
    rot: &Matrix3<f64>,
    omega: Vector3<f64>,
    vel: Vector3<f64>,
    z: f64,
    t: f64,
) -> Result<(Vector3<f64>, Vector3<f64>)> {
    shape(model, ws, src, tau);
    let rt = rot.transpose();
    let flow = Flow::at(&ws.current, t, &rt, z, ws.surface);
    let (wd, vd) = forward_head(
        model,
        ws,
        rt * omega,
        rt * vel,
        rt * model.gravity,
        &flow,
        t,
    )?;
    Ok((rot * wd, rot * vd))
}
