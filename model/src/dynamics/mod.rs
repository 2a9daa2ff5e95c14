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
//!
//! Laid out as Pinocchio lays out its algorithms: an immutable model, a
//! preallocated workspace (Pinocchio's `Data`), and one file per pass, each a
//! function of `(model, workspace, inputs)` that writes into the workspace:
//!
//! | file | what |
//! |---|---|
//! | `dynamics/model.rs` | [`ModelConfig`], [`Integrator`], the validated [`Model`] (body constants at every node, quadrature weights) |
//! | `dynamics/workspace.rs` | [`Workspace`]: the per-node buffers every pass writes, and their accessors |
//! | `dynamics/kinematics.rs` | the shape and deformation fields (34)–(36) from the curvature; the joints of the discrete robot; [`posture`] |
//! | `dynamics/forward.rs` | forward dynamics `G_ext` (29)–(31): head inertia and wrench, the head acceleration |
//! | `dynamics/inverse.rs` | inverse dynamics `G_int` (17)–(20): internal wrench, torques `C2`, `C3`, tail closure; [`inverse_with`] |
//! | `dynamics/integrate.rs` | [`evaluate`] (one instant: forward, inverse, joints) and [`step`] (then the head integrated over `dt`) |
//! | `dynamics/diagnostics.rs` | [`Diagnostics`]: energy, power, momentum of the last evaluated instant |
//!
//! # Currents
//!
//! The water may flow: a uniform current `u(t)` (earth frame, the same at
//! every point; [`Current`](crate::Current), set with
//! [`Workspace::set_current`], still water by default). Every hydrodynamic
//! term sees the section's velocity relative to the water,
//!
//! `V_r = R^T (v − u)` (local frame; `v` the section's ground velocity),
//!
//! and the angular velocity `Ω` unchanged (a uniform flow does not rotate).
//! In `forward.rs`, with `m_f = diag(0, m_f2, m_f3)` the added mass, `A` the
//! section area, `a` the section's ground acceleration:
//!
//! * reactive (Lighthill) force and Munk moment, per unit length:
//!   `f = m_b R^T a + m_f R^T (a − u̇) + Ω × (m_f V_r) − m_f (Ω × V_r)
//!   − ρ_f A R^T u̇ − n̄(V_r)` and
//!   `τ = 𝕀 R^T α + Ω × (𝕀 Ω) + V_r × (m_f V_r)`: the added mass acts on the
//!   relative acceleration `R^T(a − u̇) − Ω × V_r` (the time derivative of
//!   `V_r`), and `ρ_f A u̇` is the Froude–Krylov force of the pressure
//!   gradient that accelerates the water;
//! * resistive (21)–(24): the drag `n̄` and the local Reynolds number of the
//!   friction law (41) use `V_r`; the nose pressure drag (22) uses `V_r1(0)`
//!   and the nose added mass (23) `m_o (v̇1 − u̇1)`;
//! * tail terms (16), (18), (20) and `c = c* − V_r1 I_f Ω` in the inverse
//!   dynamics: `V_r` (the fluid momentum crosses the section plane at the
//!   relative speed).
//!
//! The body's own inertia (`m_b`, gravity, buoyancy) keeps the ground
//! velocity, and the head state ([`HeadState`]) is integrated in the earth
//! frame as before. Equivalently: in the frame that moves with the water,
//! the equations are those of still water with gravity `g − u̇` (an
//! accelerating frame); a neutrally buoyant body (`ρ_b = ρ_f`) at rest in
//! the water is therefore carried along exactly, whatever `u(t)`
//! (test `an_oscillating_current_carries_a_passive_body_along`). For a
//! steady current `u̇ = 0` and the model is Galilean invariant: a swimmer in
//! a current `u` moves as in still water plus `u t`
//! (`tests/currents.rs`). The fluid-acceleration terms cost one 3-vector
//! per node and are computed only for an oscillating current; still water
//! ([`Current::ZERO`](crate::Current::ZERO)) runs the same floating-point
//! operations as the model without currents (bit-for-bit, tested).
//!
//! Limits: the current is uniform (no shear, no vortices, no wake of the
//! body), and the strip theory's added mass is that of a body in unbounded
//! potential flow, so a current that varies fast against the swimming
//! period is outside what the model was checked for. Reported speeds
//! ([`HeadState::v1`], [`StepReport::forward_speed`]) are ground speeds;
//! [`Diagnostics`]' energy and tail flux are in the water's frame.
//!
//! # The water's surface
//!
//! With [`Workspace::set_surface`] (the simulated robot sets it; the
//! daemon's feed-forward does not), each section's wetted part `w` is 1
//! when it is wholly below the surface, 0 wholly above, and linear in its
//! centre's depth between (over the section's vertical reach, from its
//! semi-axes and its roll). The section's drag (`n̄`'s resistive part and
//! the roll drag) is multiplied by `w`, and its buoyancy `ρ_f A g` by `w`
//! too, so the part out of the water keeps its weight alone: a nose
//! lifted out is heavy and falls back, a body thrown clear falls
//! (`tests/surface.rs`). Kept as under water, a simplification: the added
//! mass, the nose's pressure drag and the tail terms; no waves. With no
//! surface set, or a body wholly under it, the operations are those of
//! the model without one (bit for bit, tested).
//!
//! `state.rs` holds what the passes share: the head state, a joint, the
//! step report; this file the frames the daemon and the simulator read
//! them in.

use nalgebra::{UnitQuaternion, Vector3};

mod diagnostics;
mod forward;
mod integrate;
mod inverse;
mod kinematics;
mod model;
mod state;
mod workspace;

pub use diagnostics::Diagnostics;
pub use integrate::{evaluate, step, step_dyn};
pub use inverse::inverse_with;
pub use kinematics::posture;
pub use model::{DEFAULT_DT, DEFAULT_NODES, Integrator, MAX_DT, Model, ModelConfig, NODES_RANGE};
pub use state::{HeadState, JointState, StepReport};
pub use workspace::Workspace;

/// The turn by π about `t3` from the model's head frame `(t1, t2, t3)`
/// (`t1` towards the tail) to the robot's forward frame: x forward, y
/// left, z up — the head sensor's axes (protocol/README.md) and a
/// vehicle's usual ones. A forward-frame attitude is `orientation *
/// forward_turn()`; a model-frame vector `v` is `forward_turn() * v` in it.
pub fn forward_turn() -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), core::f64::consts::PI)
}

/// The body's mean axis in the model's head frame `(t1, t2, t3)`: the unit
/// direction from the centroid of `shape` (node positions from the nose,
/// [`Workspace::shape`]) to the nose. The head swings with every tail
/// beat; this axis is what the body's heading follows. A straight body
/// gives `−t1`, as does an empty or degenerate shape.
pub fn body_axis(shape: &[Vector3<f64>]) -> Vector3<f64> {
    if shape.is_empty() {
        return -Vector3::x();
    }
    let centroid = shape.iter().sum::<Vector3<f64>>() / shape.len() as f64;
    (-centroid)
        .try_normalize(1e-9)
        .unwrap_or_else(|| -Vector3::x())
}

/// A vector of the model's head frame in the forward frame
/// ([`forward_turn`]): `(−x, −y, z)`, exactly. The turn is its own inverse.
pub fn forward_axes(v: Vector3<f64>) -> Vector3<f64> {
    Vector3::new(-v.x, -v.y, v.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Straight along t1, the body points to −t1 (head first); bent to +y
    /// behind the head, the axis turns away from the bend; an empty shape
    /// is straight.
    #[test]
    fn the_body_axis_points_from_the_centroid_to_the_nose() {
        let straight: Vec<_> = (1..=4)
            .map(|i| Vector3::new(0.1 * f64::from(i), 0.0, 0.0))
            .collect();
        assert!((body_axis(&straight) + Vector3::x()).norm() < 1e-12);
        let bent: Vec<_> = (1..=4)
            .map(|i| Vector3::new(0.1 * f64::from(i), 0.02 * f64::from(i), 0.0))
            .collect();
        let a = body_axis(&bent);
        assert!((a.norm() - 1.0).abs() < 1e-12);
        assert!(a.x < 0.0 && a.y < 0.0, "{a}");
        assert_eq!(body_axis(&[]), -Vector3::x());
    }
}
