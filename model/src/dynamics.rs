//! The fast algorithm of section 6: forward dynamics `G_ext` (29)–(31),
//! inverse dynamics `G_int` (17)–(20), time integration of the head, and the
//! mapping onto a discrete chain of universal joints.
//!
//! All fields are computed in the head frame (the frame of the section at
//! `X1 = 0`, frozen at the current instant), so the body shape only depends on
//! the curvature law. Space integration: classical RK4 along `X1` for the
//! kinematics (34)–(36) with the curvature sampled at nodes and mid-nodes,
//! composite Simpson for the integrals (30)–(31) and a fourth-order
//! cumulative rule for the internal wrench (17), (19). Time integration:
//! classical RK4 of the head state, the orientation a unit quaternion
//! renormalized after each step.

use crate::body::{Body, Section, friction_coefficient};
use crate::error::{ModelError, Result};
use crate::gait::{Curvature, CurvatureSource};
use nalgebra::{Matrix3, Matrix6, Quaternion, UnitQuaternion, Vector3, Vector6};

/// Discretization and body of a [`Model`].
#[derive(Debug, Clone, PartialEq)]
pub struct ModelConfig {
    /// The body.
    pub body: Body,
    /// Requested number of space intervals along the body, `>= 2`. Rounded up
    /// to a multiple of `2 (joints + 1)` so that every joint and platform
    /// centre is a node.
    pub nodes: usize,
    /// Time step (s), in `(0, 0.05]`.
    pub dt: f64,
    /// Number of joints `n` of the discrete robot (at `X1 = j/(n+1)`).
    pub joints: usize,
    /// Time integrator of the head state.
    pub integrator: Integrator,
}

/// Time integrator of the head state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Integrator {
    /// Classical fourth-order Runge–Kutta (the paper's), 4 stages per step.
    #[default]
    Rk4,
    /// Explicit midpoint rule, 2 stages per step: for the 1 kHz control
    /// period, where `dt²` errors are far below the model's.
    Midpoint,
    /// Semi-implicit (symplectic) Euler, 1 stage per step: velocities first,
    /// then the pose with the new velocities. First order; for the 1 kHz
    /// control period when the step budget is tight.
    SemiImplicitEuler,
}

impl Default for ModelConfig {
    fn default() -> Self {
        Self {
            body: Body::paper(),
            nodes: DEFAULT_NODES,
            dt: DEFAULT_DT,
            joints: 12,
            integrator: Integrator::Rk4,
        }
    }
}

/// Default number of space intervals (F1's mean speed converged to 0.5 %).
pub const DEFAULT_NODES: usize = 52;
/// Default time step (s).
pub const DEFAULT_DT: f64 = 0.01;
/// Largest accepted time step (s).
pub const MAX_DT: f64 = 0.05;
/// Space intervals the model accepts ([`ModelConfig::nodes`]).
pub const NODES_RANGE: std::ops::RangeInclusive<usize> = 2..=100_000;

/// The immutable, validated model: body constants at every node, quadrature
/// weights, discretization.
#[derive(Debug, Clone)]
pub struct Model {
    body: Body,
    n: usize,
    dt: f64,
    joints: usize,
    integrator: Integrator,
    /// space step (m)
    h: f64,
    /// normalized abscissae of nodes and mid-nodes (2n+1)
    x_fine: Vec<f64>,
    sec: Vec<Section>,
    /// Simpson weights (m)
    w: Vec<f64>,
    k_o: f64,
    m_o: f64,
    gravity: Vector3<f64>,
    total_mass: f64,
}

impl Model {
    /// Validates `config` and precomputes the body constants.
    pub fn new(config: ModelConfig) -> Result<Self> {
        config.body.validate()?;
        if !NODES_RANGE.contains(&config.nodes) {
            return Err(ModelError::InvalidParameter {
                name: "nodes",
                value: config.nodes as f64,
                range: "2..=100000",
            });
        }
        if !(config.dt.is_finite() && config.dt > 0.0 && config.dt <= MAX_DT) {
            return Err(ModelError::InvalidParameter {
                name: "dt",
                value: config.dt,
                range: "(0, 0.05] s",
            });
        }
        if config.joints > 1000 {
            return Err(ModelError::InvalidParameter {
                name: "joints",
                value: config.joints as f64,
                range: "0..=1000",
            });
        }
        let m = 2 * (config.joints + 1);
        let n = config.nodes.div_ceil(m) * m;
        let body = config.body;
        let len = body.length;
        let h = len / n as f64;
        let x_fine: Vec<f64> = (0..=2 * n).map(|i| i as f64 / (2 * n) as f64).collect();
        let sec: Vec<Section> = (0..=n).map(|i| body.section(i as f64 / n as f64)).collect();
        let w: Vec<f64> = (0..=n)
            .map(|i| {
                let c = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                c * h / 3.0
            })
            .collect();
        let total_mass = sec.iter().zip(&w).map(|(s, w)| s.mass * w).sum();
        let (k_o, m_o) = if body.resistive {
            (body.k_o(), body.m_o())
        } else {
            (0.0, 0.0)
        };
        let gravity = Vector3::from(body.gravity);
        Ok(Self {
            n,
            dt: config.dt,
            joints: config.joints,
            integrator: config.integrator,
            h,
            x_fine,
            sec,
            w,
            k_o,
            m_o,
            gravity,
            total_mass,
            body,
        })
    }

    /// Number of space intervals actually used (multiple of `2(n+1)`).
    pub fn intervals(&self) -> usize {
        self.n
    }
    /// Time step (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }
    /// Number of joints of the discrete robot.
    pub fn joints(&self) -> usize {
        self.joints
    }
    /// The body.
    pub fn body(&self) -> &Body {
        &self.body
    }
    /// Body mass (kg) by the model's quadrature.
    pub fn mass(&self) -> f64 {
        self.total_mass
    }
    /// Arc length of node `i` (m).
    pub fn node_s(&self, i: usize) -> f64 {
        i as f64 * self.h
    }
    /// Node index of joint `j` (1-based).
    pub fn joint_node(&self, j: usize) -> usize {
        j * self.n / (self.joints + 1)
    }
    fn platform_node(&self, k: usize) -> usize {
        (2 * k + 1) * self.n / (2 * (self.joints + 1))
    }
}

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

/// Energy and momentum diagnostics of the last evaluated instant.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Diagnostics {
    /// Kinetic energy of body and added fluid `∫ mu . I mu / 2` (J).
    pub energy: f64,
    /// Power delivered by the actuators `-∫ C . dK/dt` (W).
    pub actuator_power: f64,
    /// Energy flux through the tail plane `(V1 T_f)(1)` (W).
    pub tail_flux: f64,
    /// Linear momentum of the body alone (earth frame).
    pub momentum: Vector3<f64>,
    /// Angular momentum of the body alone about the earth origin.
    pub angular_momentum: Vector3<f64>,
    /// Centre of mass of the body (earth frame).
    pub centre_of_mass: Vector3<f64>,
}

/// Preallocated per-node buffers; a step writes here and allocates nothing.
#[derive(Debug, Clone)]
pub struct Workspace {
    curv: Vec<Curvature>,
    q: Vec<Matrix3<f64>>,
    p: Vec<Vector3<f64>>,
    w: Vec<Vector3<f64>>,
    v: Vec<Vector3<f64>>,
    we: Vec<Vector3<f64>>,
    ve: Vec<Vector3<f64>>,
    al: Vec<Vector3<f64>>,
    ac: Vec<Vector3<f64>>,
    shape_tau: Option<f64>,
    om_loc: Vec<Vector3<f64>>,
    v_loc: Vec<Vector3<f64>>,
    bf: Vec<Vector3<f64>>,
    bt: Vec<Vector3<f64>>,
    f: Vec<Vector3<f64>>,
    nstar: Vec<Vector3<f64>>,
    cstar: Vec<Vector3<f64>>,
    torque: Vec<[f64; 2]>,
    joints: Vec<JointState>,
    tail_n: Vector3<f64>,
    tail_c: Vector3<f64>,
    residual: Vector6<f64>,
    head_v1: f64,
}

impl Workspace {
    /// Buffers sized for `model`.
    pub fn new(model: &Model) -> Self {
        let n = model.n + 1;
        let z = vec![Vector3::zeros(); n];
        Self {
            curv: vec![Curvature::default(); 2 * model.n + 1],
            q: vec![Matrix3::identity(); n],
            p: z.clone(),
            w: z.clone(),
            v: z.clone(),
            we: z.clone(),
            ve: z.clone(),
            shape_tau: None,
            al: z.clone(),
            ac: z.clone(),
            om_loc: z.clone(),
            v_loc: z.clone(),
            bf: z.clone(),
            bt: z.clone(),
            f: z.clone(),
            nstar: z.clone(),
            cstar: z,
            torque: vec![[0.0; 2]; n],
            joints: vec![JointState::default(); model.joints],
            tail_n: Vector3::zeros(),
            tail_c: Vector3::zeros(),
            residual: Vector6::zeros(),
            head_v1: 0.0,
        }
    }

    /// Joints of the discrete robot at the last evaluated instant.
    pub fn joints(&self) -> &[JointState] {
        &self.joints
    }
    /// `(C2, C3)` (N m) at every node of the last evaluated instant.
    pub fn torques(&self) -> &[[f64; 2]] {
        &self.torque
    }
    /// Node positions relative to the nose, in the head frame (m).
    pub fn shape(&self) -> &[Vector3<f64>] {
        &self.p
    }
    /// Internal force `n_*` (head frame) at every node.
    pub fn n_star(&self) -> &[Vector3<f64>] {
        &self.nstar
    }
    /// Internal torque `c_*` (head frame) at every node.
    pub fn c_star(&self) -> &[Vector3<f64>] {
        &self.cstar
    }
    /// Tail closure residual `(c_*(1) - c_d, n_*(1) - n_d)` of (18), (20),
    /// (head frame), of the last inverse dynamics: the figure-20 check.
    pub fn tail_residual(&self) -> Vector6<f64> {
        self.residual
    }

    /// Energy, power and momentum of the instant of the last [`evaluate`] for
    /// `head` (after [`step`] the velocity fields are those of its last
    /// integration stage, so call [`evaluate`] first).
    pub fn diagnostics(&self, model: &Model, head: &HeadState) -> Diagnostics {
        let r = head.orientation.to_rotation_matrix();
        let mut d = Diagnostics::default();
        let mut com = Vector3::zeros();
        for i in 0..=model.n {
            let s = &model.sec[i];
            let wi = model.w[i];
            let om = self.om_loc[i];
            let vl = self.v_loc[i];
            let mi = Vector3::from(s.mi);
            let mm = Vector3::from(s.mm);
            d.energy +=
                wi * 0.5 * (om.dot(&mi.component_mul(&om)) + vl.dot(&mm.component_mul(&vl)));
            let c = &self.curv[2 * i];
            d.actuator_power -=
                wi * (self.torque[i][0] * c.k_dot.y + self.torque[i][1] * c.k_dot.z);
            let pos = head.position + r * self.p[i];
            let vel = r * self.v[i];
            d.momentum += wi * s.mass * vel;
            let ib = Vector3::new(s.mi[0] - s.if1, s.mi[1], s.mi[2]);
            let ang = r * (self.q[i] * ib.component_mul(&om));
            d.angular_momentum += wi * (ang + pos.cross(&(s.mass * vel)));
            com += wi * s.mass * pos;
        }
        d.centre_of_mass = com / model.total_mass;
        let n = model.n;
        let s = &model.sec[n];
        let (om, vl) = (self.om_loc[n], self.v_loc[n]);
        let tf = 0.5 * (s.if1 * om.x * om.x + s.mf[1] * vl.y * vl.y + s.mf[2] * vl.z * vl.z);
        d.tail_flux = vl.x * tf;
        d
    }
}

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
/// [`forward_head`]), so one pass serves every time stage at the same instant.
fn kinematics(model: &Model, ws: &mut Workspace) {
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

/// Forward dynamics `G_ext` (29)–(31) at one instant, head frame. Fills the
/// workspace fields and returns `(omega_dot_o, v_dot_o)` in the head frame.
fn forward_head(
    model: &Model,
    ws: &mut Workspace,
    omega_h: Vector3<f64>,
    vel_h: Vector3<f64>,
    grav_h: Vector3<f64>,
    t: f64,
) -> Result<(Vector3<f64>, Vector3<f64>)> {
    let rho = model.body.rho_fluid;
    let nu = model.body.nu;
    let len = model.body.length;
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
        ws.w[i] = w_full;
        ws.v[i] = v_full;
        let om = qt * w_full;
        let vl = qt * v_full;
        ws.om_loc[i] = om;
        ws.v_loc[i] = vl;
        let mm = Vector3::from(s.mm);
        let mi = Vector3::from(s.mi);
        let mf = Vector3::from(s.mf);
        // resistive wrench (24) and buoyancy (25), local frame
        let x = i as f64 / model.n as f64 * len;
        let k1 = if s.perimeter > 0.0 && x > 0.0 && vl.x != 0.0 {
            friction_coefficient(x * vl.x.abs() / nu) * s.perimeter
        } else {
            0.0
        };
        let nbar = -0.5
            * rho
            * Vector3::new(
                k1 * vl.x * vl.x.abs(),
                s.k2 * vl.y * vl.y.abs(),
                s.k3 * vl.z * vl.z.abs(),
            )
            + if s.buoyancy != 0.0 {
                s.buoyancy * (qt * grav_h)
            } else {
                Vector3::zeros()
            };
        let cbar_x = -0.5 * rho * s.k4 * om.x * om.x.abs();
        let mfv = mf.component_mul(&vl);
        let bf = mm.component_mul(&(qt * ac_full)) + om.cross(&mfv)
            - mf.component_mul(&om.cross(&vl))
            - nbar;
        let mut bt =
            mi.component_mul(&(qt * al_full)) + om.cross(&mi.component_mul(&om)) + vl.cross(&mfv);
        bt.x -= cbar_x;
        ws.bf[i] = bf;
        ws.bt[i] = bt;
        let wi = model.w[i];
        // R diag(m) R^T = m1 I + (m2 - m1) t2 t2^T + (m3 - m1) t3 t3^T
        let t2 = q.column(1).into_owned();
        let t3 = q.column(2).into_owned();
        let sym = |m: &Vector3<f64>| {
            let mut a = t2 * (t2.transpose() * (m.y - m.x)) + t3 * (t3.transpose() * (m.z - m.x));
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
        let bfh = q * bf;
        rhs_f -= bfh * wi;
        rhs_t -= (q * bt + p.cross(&bfh)) * wi;
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
    // nose pressure drag (22) and added mass (23)
    let v1 = vel_h.x;
    ws.head_v1 = v1;
    rhs_f.x -= 0.5 * rho * model.k_o * v1 * v1.abs();
    a_vv[(0, 0)] += model.m_o;
    let mut a = Matrix6::zeros();
    a.fixed_view_mut::<3, 3>(0, 0).copy_from(&a_ww);
    a.fixed_view_mut::<3, 3>(0, 3).copy_from(&a_wv);
    a.fixed_view_mut::<3, 3>(3, 0).copy_from(&a_wv.transpose());
    a.fixed_view_mut::<3, 3>(3, 3).copy_from(&a_vv);
    let rhs = Vector6::new(rhs_t.x, rhs_t.y, rhs_t.z, rhs_f.x, rhs_f.y, rhs_f.z);
    if !rhs.iter().all(|v| v.is_finite()) {
        return Err(ModelError::NonFinite {
            quantity: "head wrench F_o (31)",
            time: t,
        });
    }
    let chol = a
        .cholesky()
        .ok_or(ModelError::SingularInertia { time: t })?;
    let u = chol.solve(&rhs);
    Ok((
        Vector3::new(u[0], u[1], u[2]),
        Vector3::new(u[3], u[4], u[5]),
    ))
}

/// Inverse dynamics `G_int` (17)–(20) with the head acceleration
/// `(omega_dot_h, v_dot_h)` (head frame), on the fields of the last
/// [`forward_head`] call: internal wrench `n_*`, `c_*`, torques `C2`, `C3` and
/// the tail closure residual.
fn inverse_head(model: &Model, ws: &mut Workspace, wd: Vector3<f64>, vd: Vector3<f64>) {
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
    // n_*(0) = -n_-: nose loads (22), (23)
    let v1 = ws.head_v1;
    let n0 = Vector3::new(
        0.5 * rho * model.k_o * v1 * v1.abs() + model.m_o * vd.x,
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

/// Joint angles, rates and torques of the discrete robot (section 2 and
/// figure 2): relative rotation of the platforms on either side of each
/// joint, decomposed as pitch about `t2` then yaw about the rotated `t3`.
fn joints(model: &Model, ws: &mut Workspace) {
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

/// Samples the curvature at `tau` and integrates the shape, unless the
/// workspace already holds the shape of this `tau` within the current step.
fn shape<S: CurvatureSource + ?Sized>(model: &Model, ws: &mut Workspace, src: &S, tau: f64) {
    if ws.shape_tau == Some(tau) {
        return;
    }
    src.curvature(tau, &model.x_fine, &mut ws.curv);
    kinematics(model, ws);
    ws.shape_tau = Some(tau);
}

/// Joint angles and rates of the curvature of `src` at its current time,
/// without dynamics (posture moves). Torques are left untouched.
pub fn posture<'a, S: CurvatureSource + ?Sized>(
    model: &Model,
    ws: &'a mut Workspace,
    src: &S,
) -> &'a [JointState] {
    ws.shape_tau = None;
    shape(model, ws, src, 0.0);
    ws.shape_tau = None;
    joints(model, ws);
    &ws.joints
}

/// Forward dynamics (29) in the earth frame for `head` with the curvature of
/// `src` at `src.time() + tau`: returns `(omega_dot_o, v_dot_o)`.
#[allow(clippy::too_many_arguments)] // internal stage helper
fn forward_earth<S: CurvatureSource + ?Sized>(
    model: &Model,
    ws: &mut Workspace,
    src: &S,
    tau: f64,
    rot: &Matrix3<f64>,
    omega: Vector3<f64>,
    vel: Vector3<f64>,
    t: f64,
) -> Result<(Vector3<f64>, Vector3<f64>)> {
    shape(model, ws, src, tau);
    let rt = rot.transpose();
    let (wd, vd) = forward_head(model, ws, rt * omega, rt * vel, rt * model.gravity, t)?;
    Ok((rot * wd, rot * vd))
}

/// Forward and inverse dynamics at the current instant without advancing:
/// fills the workspace (joints, torques, fields) and returns the report.
pub fn evaluate<S: CurvatureSource + ?Sized>(
    model: &Model,
    ws: &mut Workspace,
    src: &S,
    head: &HeadState,
) -> Result<StepReport> {
    let rot = head.orientation.to_rotation_matrix().into_inner();
    let rt = rot.transpose();
    ws.shape_tau = None;
    shape(model, ws, src, 0.0);
    let (wd, vd) = forward_head(
        model,
        ws,
        rt * head.omega,
        rt * head.velocity,
        rt * model.gravity,
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

/// Inverse dynamics `G_int` at the instant of the last [`evaluate`] (same
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

fn check(v: &Vector3<f64>, quantity: &'static str, time: f64) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(ModelError::NonFinite { quantity, time })
    }
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
    let report = evaluate(model, ws, src, head)?;
    let dt = model.dt;
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
        let (wd, vd) = forward_earth(model, ws, src, h, &rot, omega, vel, t + h)?;
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
    Ok(report)
}
