//! Fast dynamics of an eel-like swimming robot.
//!
//! This crate implements the model of Boyer, Porez, Leroyer and Visonneau,
//! *Fast dynamics of an eel-like robot* (IEEE T-RO 2008), sections 2–7: it
//! owns the body geometry and inertia ([`Body`]), the reactive (Lighthill)
//! and resistive hydrodynamic terms, the gaits ([`gait`]), the forward
//! dynamics `G_ext` (29)–(31) that give the head acceleration, the inverse
//! dynamics `G_int` (17)–(20) that give the internal torques, the time
//! integration of the head, and the mapping onto the discrete robot (pitch
//! and yaw of each universal joint and its feedforward torques). It does no
//! I/O and a [`step`] allocates nothing: the [`Model`] is immutable and
//! validated, the [`Workspace`] is preallocated.
//!
//! Modules: [`body`] (geometry, inertia, hydrodynamic coefficients),
//! [`current`] (a uniform ambient current the body swims in), [`gait`]
//! (curvature laws and sources), [`dynamics`] (the algorithm, one file per
//! pass as in Pinocchio: `model` and `workspace` (the model and its
//! preallocated data), `kinematics` (34)–(36) and the joints, `forward`
//! `G_ext`, `inverse` `G_int`, `integrate` ([`evaluate`], [`step`]),
//! `diagnostics`), [`run`] (a named gait run and averaged like the paper's
//! tables), [`paper`] (the paper's Tables 2, 4, 6 and section 7.5 and our
//! reproduction table), [`error`].
//!
//! ```
//! use anguilla_model::{HeadState, Model, ModelConfig, Workspace, gait, step};
//!
//! let model = Model::new(ModelConfig { dt: 0.01, ..ModelConfig::default() })?;
//! let mut ws = Workspace::new(&model);
//! let f1 = gait::named_gait("F1").unwrap();
//! let mut src = gait::LawSource::new(f1.law);
//! let mut head = HeadState::launch(f1.v_init);
//! for _ in 0..100 {
//!     step(&model, &mut ws, &mut src, &mut head)?;
//! }
//! // after one second F1 has started to swim head first (towards -e1)
//! assert!(head.position.x < 0.0);
//! let joint = ws.joints()[5];
//! assert!(joint.yaw.is_finite() && joint.c3.is_finite());
//! # Ok::<(), anguilla_model::ModelError>(())
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod body;
pub mod current;
pub mod dynamics;
pub mod error;
pub mod gait;
pub mod identify;
pub mod paper;
pub mod run;
pub mod speed_table;

pub use body::{
    AxialDrag, Body, GRAVITY, Profile, TYPICAL_BALLAST, depth_at_pressure, pressure_at_depth,
};
pub use current::{Current, MAX_CURRENT};
pub use dynamics::{
    DEFAULT_DT, DEFAULT_NODES, Diagnostics, HeadState, Integrator, JointState, MAX_DT, Model,
    ModelConfig, StepReport, Workspace, body_axis, evaluate, forward_axes, forward_turn,
    inverse_with, posture, step, step_dyn,
};
pub use error::{ModelError, Result};
pub use gait::{
    Curvature, CurvatureSource, GaitParams, JointCurvature, JointMotion, JointSegment, LawSource,
    ParametricGait, hermite,
};
pub use speed_table::{SPEED_RUNGS, SpeedTable};
