//! The preallocated workspace (Pinocchio's `Data`): every per-node buffer
//! the passes write, sized once for a [`Model`].

use super::model::Model;
use super::state::JointState;
use crate::current::Current;
use crate::gait::Curvature;
use nalgebra::{Cholesky, Const, Matrix3, Vector3, Vector6};

/// Preallocated per-node buffers; a step writes here and allocates nothing.
#[derive(Debug, Clone)]
pub struct Workspace {
    pub(super) curv: Vec<Curvature>,
    pub(super) q: Vec<Matrix3<f64>>,
    pub(super) p: Vec<Vector3<f64>>,
    pub(super) v: Vec<Vector3<f64>>,
    pub(super) we: Vec<Vector3<f64>>,
    pub(super) ve: Vec<Vector3<f64>>,
    pub(super) al: Vec<Vector3<f64>>,
    pub(super) ac: Vec<Vector3<f64>>,
    /// The curvature time (relative to the source's) of the shape held.
    pub(super) shape_tau: Option<f64>,
    /// The source's time at which the shape held is its shape at `tau = 0`
    /// (set by a step that ended on it; see `kinematics::shape`).
    pub(super) shape_carry: Option<f64>,
    /// The head inertia `I_o` (29) of the shape held, factored; `None`
    /// after the shape changed.
    pub(super) inertia: Option<Cholesky<f64, Const<6>>>,
    pub(super) om_loc: Vec<Vector3<f64>>,
    pub(super) v_loc: Vec<Vector3<f64>>,
    pub(super) bf: Vec<Vector3<f64>>,
    pub(super) bt: Vec<Vector3<f64>>,
    pub(super) f: Vec<Vector3<f64>>,
    pub(super) nstar: Vec<Vector3<f64>>,
    pub(super) cstar: Vec<Vector3<f64>>,
    pub(super) torque: Vec<[f64; 2]>,
    pub(super) joints: Vec<JointState>,
    pub(super) tail_n: Vector3<f64>,
    pub(super) tail_c: Vector3<f64>,
    pub(super) residual: Vector6<f64>,
    pub(super) head_v1: f64,
    /// `u_dot . t1(0)` at the last forward pass (nose added mass).
    pub(super) head_u_dot1: f64,
    pub(super) current: Current,
    /// The water's surface, its z (m, up) in the earth frame, if any.
    pub(super) surface: Option<f64>,
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
            v: z.clone(),
            we: z.clone(),
            ve: z.clone(),
            shape_tau: None,
            shape_carry: None,
            inertia: None,
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
            head_u_dot1: 0.0,
            current: Current::ZERO,
            surface: None,
        }
    }

    /// Sets the water's current for the following [`evaluate`](super::evaluate)
    /// and [`step`](super::step) calls (still water, [`Current::ZERO`], until
    /// set). Allocates nothing: the control loop may change it every period.
    pub fn set_current(&mut self, current: Current) {
        self.current = current;
    }
    /// The water's current the dynamics use.
    pub fn current(&self) -> Current {
        self.current
    }
    /// Sets the water's surface for the following [`evaluate`](super::evaluate)
    /// and [`step`](super::step) calls: its height `z` (m, the earth
    /// frame's z, up), or `None` (the default: water everywhere, the
    /// model bit for bit as without). A section partly or wholly above it
    /// loses that part of its buoyancy and of its drag (the module docs,
    /// "The water's surface"). Allocates nothing.
    pub fn set_surface(&mut self, z: Option<f64>) {
        self.surface = z;
    }
    /// The water's surface the dynamics use ([`Workspace::set_surface`]).
    pub fn surface(&self) -> Option<f64> {
        self.surface
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
    /// Section frames `R = [t1 t2 t3]` relative to the head's, at every
    /// node (head frame).
    pub fn frames(&self) -> &[Matrix3<f64>] {
        &self.q
    }
    /// The deformation's angular velocity of each section relative to the
    /// head (head frame, rad/s), at every node.
    pub fn deformation_rates(&self) -> &[Vector3<f64>] {
        &self.we
    }
    /// The deformation's velocity of each node relative to the head (head
    /// frame, m/s).
    pub fn deformation_velocities(&self) -> &[Vector3<f64>] {
        &self.ve
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
}
