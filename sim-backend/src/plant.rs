//! The swimming body as the plant: a thin adapter over `anguilla-model`.
//!
//! The model is driven by the joints' *achieved* motion, not by an imposed
//! gait, so the simulated robot swims, turns and dives as its joints
//! actually move: each physics step swims the body from the last step to
//! this one with its joints on the cubic curve from their angles and rates
//! then to their angles and rates now (a [`JointSegment`]; extrapolated
//! from the step's start with a held acceleration, as a
//! [`JointCurvature`] would, the body swam as one with 22–38 % more
//! lateral drag than the model at the same 2 ms step: docs/calibration.md). Each
//! step returns the torque the body demands at every joint axis now, which
//! becomes the actuators' load until the next step; servos with dynamics
//! get it coupled implicitly to their torques and followed along its rate
//! within the step ([`Plant::coupled_loads`]: held over the step, with the
//! coupling held between linearisations, the load a servo felt was 19 %
//! RMS off the model's inverse dynamics at its motion on a 1.8 Hz wave and
//! lagged it by 8 ms; now 4 %, no lag).
//!
//! **Sign of the load.** The model's internal torque `c(X1)` is the torque
//! the rear part exerts on the front part (`model/README.md`,
//! `docs/MODEL-NOTES.md`); the actuator of a joint turns the rear platform
//! relative to the front one, so the torque it must produce for the motion
//! is `−C` (a rigid-body library's joint torque). The load of an axis is
//! therefore `[−C2, −C3]` (`JointState::actuator_torque`): an ideal servo's motor torque equals it, and the
//! actuators do positive net work on the fluid while swimming (checked by a
//! test below).
//!
//! Everything the model needs is kept here so that changes of the model's
//! API are reconciled in one place.

use crate::actuator::Load;
use anguilla_model::{
    Current, HeadState, Integrator, JointCurvature, JointSegment, Model, ModelConfig, ModelError,
    Workspace, evaluate, step,
};

/// Configuration of the body plant.
#[derive(Debug, Clone, PartialEq)]
pub struct PlantConfig {
    /// Number of joints (one per node).
    pub joints: usize,
    /// Physics step (s): the head state is integrated, and the loads
    /// updated, at this period.
    pub dt: f64,
    /// Requested number of space intervals of the model (rounded up by the
    /// model to a multiple of `2 (joints + 1)`).
    pub nodes: usize,
    /// Head speed along `t1` at the start (m/s, negative is head first).
    pub v_init: f64,
    /// Also compute the loads without the joints' own accelerations
    /// ([`Plant::rate_loads`]), for actuators with dynamics (one more model
    /// evaluation per step).
    pub rate_loads: bool,
    /// The water's uniform current at the start (earth frame); still water
    /// by default. [`Plant::set_current`] changes it during a run.
    pub current: Current,
    /// The body: its geometry, mass and ballast, and its hydrodynamic
    /// coefficients and laws. The paper's by default; a simulated robot
    /// may be given another than the daemon's model (`docs/calibration.md`).
    pub body: anguilla_model::Body,
    /// Seconds between two linearisations of the servos' coupling to the
    /// body about its current shape ([`Plant::couple_servos`]), rounded to
    /// whole physics steps; 0: only when coupled.
    pub recouple_period: f64,
}

impl Default for PlantConfig {
    fn default() -> Self {
        Self {
            joints: 12,
            // 2 ms: RK4 at this step is far below the model's space
            // discretization error (the model is converged at 20 ms), and
            // the loads follow the servos' motion closely.
            dt: 0.002,
            nodes: 52,
            v_init: 0.0,
            rate_loads: false,
            current: Current::ZERO,
            body: anguilla_model::Body::paper(),
            // 20 ms: a bent body's joint-space inertia differs from the
            // straight one's by tens of per cent (a turn, a climb), and
            // changes little over a fiftieth of a tail beat
            recouple_period: 0.02,
        }
    }
}

/// How far a joint's angle may be from where the mean of its rates over a
/// physics step `dt` takes it, as `PLACED_ACCEL · dt² / 8` (rad), before
/// [`Plant::step`] calls it placed rather than moved: the gap a change of
/// acceleration of `PLACED_ACCEL` (rad/s²) within the step leaves. A
/// servo's acceleration changes by at most twice its torque limit over
/// its inertia within a step (400 rad/s² for the default servo); a set
/// pose or an ideal servo's setpoint step is a gap of its own (1 mrad at
/// the 2 ms step).
const PLACED_ACCEL: f64 = 2000.0;

/// The body: model, workspace, joint-driven curvature and head state.
#[derive(Debug, Clone)]
pub struct Plant {
    model: Model,
    ws: Workspace,
    src: JointCurvature,
    /// The joints' motion over the last step, from `prev` to the input.
    seg: JointSegment,
    head: HeadState,
    /// The joints at the previous step: the start of the next segment,
    /// and the rates of the acceleration estimate.
    prev: Vec<JointInput>,
    /// Whether `prev` holds a previous step.
    primed: bool,
    /// Joint accelerations of the current step.
    acc: Vec<[f64; 2]>,
    /// Loads `[pitch, yaw]` (N·m) per joint from the last step.
    loads: Vec<[f64; 2]>,
    /// The same without the joints' own accelerations.
    rate_loads: Option<Vec<[f64; 2]>>,
    /// The servos' coupling to the body, once [`Plant::couple_servos`]
    /// was called.
    coupling: Option<Coupling>,
    /// [`PlantConfig::recouple_period`] in physics steps (0: never).
    recouple_every: usize,
    /// Physics steps since the coupling was last linearised.
    since_coupled: usize,
    /// Scratch: the residual torques of the coupled load.
    residual: Vec<f64>,
    /// The coupled loads and net torques of the last
    /// [`Plant::coupled_loads`], whence the loads' rates.
    last_coupled: Vec<[f64; 2]>,
    last_net: Vec<[f64; 2]>,
    /// Whether they are there to take a rate from (not after a change
    /// that makes the next load a jump: a new coupling, a failed step or
    /// linearisation, a new current, a head put back).
    coupled_primed: bool,
    /// Whether the last [`Plant::step`] succeeded (after a failed one the
    /// loads are zero: no rate is taken across that).
    step_ok: bool,
}

/// The servos' coupling to the body: `K = M (J I + M)^-1` about a shape,
/// and what computing it again needs, kept so that it allocates nothing.
///
/// Between two linearisations `K` and `M` are extrapolated along their
/// change since the one before (the shape moves smoothly): held, they were
/// what most of the simulated servos' load error was, growing with the
/// time since the last linearisation (docs/calibration.md).
#[derive(Debug, Clone)]
struct Coupling {
    /// Each axis's reflected inertia (kg·m²; infinite: jammed).
    inertia: Vec<[f64; 2]>,
    /// `K` (row-major, 2n x 2n).
    k: Vec<f64>,
    /// The body's joint-space inertia `M` about the shape (2n x 2n).
    m: Vec<f64>,
    /// `K` and `M`'s change since the linearisation before (zero after
    /// the first, or a failed one).
    k_trend: Vec<f64>,
    m_trend: Vec<f64>,
    /// Whether the last linearisation succeeded one period ago (the
    /// trends are then the change over one period).
    trend_ok: bool,
    /// Scratch of the inversion of `J I + M` over the free axes.
    a: Vec<f64>,
    inv: Vec<f64>,
    /// The free axes.
    free: Vec<usize>,
    /// The model it is computed on (coarser than the plant's).
    model: Model,
    /// Scratch of the model's evaluations.
    ws: Workspace,
    src: JointCurvature,
    base: Vec<[f64; 2]>,
}

/// One joint's measured motion, as the actuators achieve it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct JointInput {
    /// Angles `[pitch, yaw]` (rad).
    pub angle: [f64; 2],
    /// Rates `[pitch, yaw]` (rad/s).
    pub rate: [f64; 2],
}

impl Plant {
    /// A straight body at rest (or launched at `v_init`) at the origin.
    pub fn new(cfg: PlantConfig) -> Result<Self, ModelError> {
        let model = Model::new(ModelConfig {
            nodes: cfg.nodes,
            dt: cfg.dt,
            joints: cfg.joints,
            integrator: Integrator::Rk4,
            body: cfg.body,
        })?;
        let mut ws = Workspace::new(&model);
        ws.set_current(cfg.current);
        let length = model.body().length;
        Ok(Self {
            src: JointCurvature::new(cfg.joints, length),
            seg: JointSegment::new(cfg.joints, length),
            ws,
            model,
            head: HeadState::launch(cfg.v_init),
            prev: vec![JointInput::default(); cfg.joints],
            primed: false,
            acc: vec![[0.0; 2]; cfg.joints],
            loads: vec![[0.0; 2]; cfg.joints],
            rate_loads: cfg.rate_loads.then(|| vec![[0.0; 2]; cfg.joints]),
            coupling: None,
            recouple_every: if cfg.recouple_period > 0.0 {
                ((cfg.recouple_period / cfg.dt).round() as usize).max(1)
            } else {
                0
            },
            since_coupled: 0,
            residual: vec![0.0; 2 * cfg.joints],
            last_coupled: vec![[0.0; 2]; cfg.joints],
            last_net: vec![[0.0; 2]; cfg.joints],
            coupled_primed: false,
            step_ok: true,
        })
    }

    /// The body's joint-space inertia `M0` (N·m per rad/s², row-major,
    /// `2n x 2n`, index `2 (j - 1) + axis`) for the straight body at rest,
    /// free-floating, added mass included: column `k` is the load change when
    /// joint axis `k` alone accelerates at 1 rad/s².
    pub fn joint_inertia(&self) -> Result<Vec<f64>, ModelError> {
        let n = self.joints();
        let mut ws = Workspace::new(&self.model);
        let mut src = JointCurvature::new(n, self.model.body().length);
        let mut out = vec![0.0; 4 * n * n];
        let mut base = vec![[0.0; 2]; n];
        inertia_about(&self.model, &mut ws, &mut src, &mut base, &mut out)?;
        Ok(out)
    }

    /// Couples servos of reflected inertia `inertia[j][axis]` (kg·m²) to
    /// the body implicitly, linearised about its shape now and again every
    /// [`PlantConfig::recouple_period`]: see [`Plant::coupled_loads`].
    /// A jammed axis is given an infinite inertia (`f64::INFINITY`): it
    /// does not move, and its neighbours feel it. Allocates (call it at
    /// set-up and on fault changes, not every tick); the relinearisations
    /// in [`Plant::step`] do not.
    pub fn couple_servos(&mut self, inertia: &[[f64; 2]]) -> Result<(), ModelError> {
        let n = self.joints();
        let m = 2 * n;
        let model = Model::new(ModelConfig {
            // the coarsest the model takes (two intervals a joint): the
            // robot's torques matched the model's inverse dynamics as
            // closely as with the plant's own nodes (docs/calibration.md)
            nodes: 2 * (n + 1),
            dt: self.model.dt(),
            joints: n,
            integrator: Integrator::Rk4,
            body: self.model.body().clone(),
        })?;
        let mut c = Coupling {
            inertia: (0..n)
                .map(|j| inertia.get(j).copied().unwrap_or([f64::INFINITY; 2]))
                .collect(),
            k: vec![0.0; m * m],
            m: vec![0.0; m * m],
            k_trend: vec![0.0; m * m],
            m_trend: vec![0.0; m * m],
            trend_ok: false,
            a: vec![0.0; m * m],
            inv: vec![0.0; m * m],
            free: Vec::with_capacity(m),
            ws: Workspace::new(&model),
            model,
            src: JointCurvature::new(n, self.model.body().length),
            base: vec![[0.0; 2]; n],
        };
        // the first linearisation has no trend (`trend_ok` false)
        c.linearise(&self.src)?;
        self.coupling = Some(c);
        self.since_coupled = 0;
        self.coupled_primed = false;
        Ok(())
    }

    /// The loads for servos coupled with [`Plant::couple_servos`], given each
    /// axis's motor torque and friction torque now: the rate-dependent load
    /// plus the body's inertial reaction to the acceleration these torques
    /// will give, `L = C_rate + K (tau - friction - C_rate)` with
    /// `K = M (J I + M)^-1` (`M` the joint-space inertia about the body's
    /// shape, extrapolated from the last two linearisations), solved for all
    /// joints at once so that the loop is stable whatever the ratio of body
    /// to servo inertia. Each axis's [`Load`] also carries `K`'s diagonal
    /// (the share of its own torque's changes the load takes up within the
    /// step) and the rate at which the rest of it changes, from this call's
    /// load and the last one's (0 on the first call after a new coupling or
    /// a failed step). Without coupling each axis gets the rate loads (or
    /// the loads, without rate loads), held. Writes into `out`; allocates
    /// nothing.
    pub fn coupled_loads(
        &mut self,
        tau: &[[f64; 2]],
        friction: &[[f64; 2]],
        out: &mut [[Load; 2]],
    ) {
        let held = |out: &mut [[Load; 2]], loads: &[[f64; 2]]| {
            for (o, l) in out.iter_mut().zip(loads) {
                *o = l.map(|torque| Load {
                    torque,
                    ..Load::default()
                });
            }
        };
        let Some(rl) = &self.rate_loads else {
            held(out, &self.loads);
            return;
        };
        let Some(c) = &self.coupling else {
            held(out, rl);
            return;
        };
        let s = self.blend();
        let m = self.residual.len();
        for (i, r) in self.residual.iter_mut().enumerate() {
            let (j, a) = (i / 2, i % 2);
            let net = tau.get(j).map_or(0.0, |t| t[a]) - friction.get(j).map_or(0.0, |f| f[a]);
            *r = net - rl[j][a];
        }
        let dt = self.model.dt();
        for (i, o) in out
            .iter_mut()
            .flat_map(|x| x.iter_mut())
            .enumerate()
            .take(m)
        {
            let torque = rl[i / 2][i % 2] + c.k_row(i, s, self.residual.iter().copied());
            let gain = c.k[i * m + i] + s * c.k_trend[i * m + i];
            let net = self.residual[i] + rl[i / 2][i % 2];
            let (last, last_net) = (
                &mut self.last_coupled[i / 2][i % 2],
                &mut self.last_net[i / 2][i % 2],
            );
            let rate = if self.coupled_primed && self.step_ok {
                ((torque - *last) - gain * (net - *last_net)) / dt
            } else {
                0.0
            };
            (*last, *last_net) = (torque, net);
            *o = Load { torque, gain, rate };
        }
        self.coupled_primed = self.step_ok;
    }

    /// How far the coupling is extrapolated from its last linearisation,
    /// in linearisation periods (0..1).
    fn blend(&self) -> f64 {
        if self.recouple_every > 0 {
            self.since_coupled as f64 / self.recouple_every as f64
        } else {
            0.0
        }
    }

    /// The physics step (s).
    pub fn dt(&self) -> f64 {
        self.model.dt()
    }

    /// Number of joints.
    pub fn joints(&self) -> usize {
        self.loads.len()
    }

    /// The head state (ground truth).
    pub fn head(&self) -> &HeadState {
        &self.head
    }

    /// The body's shape at the last step: each node's position from the
    /// nose, in the model's head frame `(t1, t2, t3)` (m).
    pub fn shape(&self) -> &[nalgebra::Vector3<f64>] {
        self.ws.shape()
    }

    /// The tail's true state, from the head's and the body's shape at the
    /// last step: what a tail IMU measures (earth frame; its frame is the
    /// last section's, `t1` along the body towards the tail).
    pub fn tail(&self) -> crate::sensor::HeadTruth {
        let h = &self.head;
        let n = self.ws.shape().len().saturating_sub(1);
        let frame = self
            .ws
            .frames()
            .get(n)
            .copied()
            .unwrap_or_else(nalgebra::Matrix3::identity);
        let p = self.ws.shape().get(n).copied().unwrap_or_default();
        let we = self
            .ws
            .deformation_rates()
            .get(n)
            .copied()
            .unwrap_or_default();
        let ve = self
            .ws
            .deformation_velocities()
            .get(n)
            .copied()
            .unwrap_or_default();
        let r = h.orientation;
        let q = r * nalgebra::UnitQuaternion::from_matrix(&frame);
        let arm = r * p;
        let position = h.position + arm;
        let velocity = h.velocity + h.omega.cross(&arm) + r * ve;
        let omega = h.omega + r * we;
        crate::sensor::HeadTruth {
            position: [position.x, position.y, position.z],
            orientation: [q.w, q.i, q.j, q.k],
            velocity: [velocity.x, velocity.y, velocity.z],
            angular_velocity: [omega.x, omega.y, omega.z],
        }
    }

    /// The water's surface, `z_surface` (m, the model's z, up) above the
    /// origin: a nose above it is put back on it and stops rising (its
    /// upward velocity dropped), the rest of the body following the head's
    /// frame as always. With [`Plant::set_water_surface`] the part of the
    /// body out of the water also loses its buoyancy and its drag; no
    /// waves. The simulated robot cannot swim on above the water (issue
    /// 46: it did, to a depth of −1.6 m). Returns whether the nose is at
    /// the surface.
    pub fn surface(&mut self, z_surface: f64) -> bool {
        if self.head.position.z < z_surface {
            return false;
        }
        self.head.position.z = z_surface;
        self.head.velocity.z = self.head.velocity.z.min(0.0);
        true
    }

    /// Puts the head back at the origin with the given state (a test's
    /// initial condition); the joints keep their motion.
    pub fn reset_head(&mut self, head: HeadState) {
        self.head = head;
        self.coupled_primed = false;
    }

    /// Sets the water's current (earth frame) from the next step on: the
    /// body is carried by it and its hydrodynamic loads change
    /// (`anguilla_model::dynamics`, "Currents"). Allocates nothing.
    pub fn set_current(&mut self, current: Current) {
        self.ws.set_current(current);
        self.coupled_primed = false;
    }

    /// The water's surface at height `z_surface` (m, the model's z, up)
    /// from the next step on, or none: a section partly or wholly above it
    /// loses that part of its buoyancy and of its drag
    /// (`anguilla_model::Workspace::set_surface`), so a nose lifted out of
    /// the water is heavy and falls back. Allocates nothing.
    pub fn set_water_surface(&mut self, z_surface: Option<f64>) {
        if self.ws.surface() != z_surface {
            self.ws.set_surface(z_surface);
            self.coupled_primed = false;
        }
    }

    /// The water's current.
    pub fn current(&self) -> Current {
        self.ws.current()
    }

    /// The loads `[pitch, yaw]` (N·m) each joint's actuators see: `−C`
    /// (with coupled servos, the rate loads plus the coupling's inertia
    /// times the accelerations).
    pub fn loads(&self) -> &[[f64; 2]] {
        &self.loads
    }

    /// The loads of the last step with the joints' accelerations taken as
    /// zero (if [`PlantConfig::rate_loads`]): pose- and rate-dependent
    /// torques only. Servos with dynamics get these plus the inertial
    /// reaction solved implicitly ([`Plant::coupled_loads`]): feeding the
    /// full load back one step late is an unstable loop (the body's
    /// joint-space inertia, added mass included, is comparable to or larger
    /// than a servo's reflected inertia and strongly coupled between joints).
    pub fn rate_loads(&self) -> Option<&[[f64; 2]]> {
        self.rate_loads.as_deref()
    }

    /// One physics step: the body swims from the last step's instant to
    /// now with its joints moving from where they were then to `input`
    /// (angles and rates now) along a cubic curve ([`JointSegment`]), and
    /// the loads now are computed (accelerations: the rates' difference
    /// over the step). The first call only sets the joints (and moves the
    /// head's clock). Returns the loads. On a model error the head state
    /// is unchanged and the loads (and rate loads) are zeroed.
    pub fn step(&mut self, input: &[JointInput]) -> Result<&[[f64; 2]], ModelError> {
        let dt = self.model.dt();
        let mut failed = None;
        if self.primed {
            let (a, b) = self.seg.span_mut(dt);
            for (j, (a, b)) in a.iter_mut().zip(b.iter_mut()).enumerate() {
                let (p, q) = (self.prev[j], input.get(j).copied().unwrap_or_default());
                // a joint placed rather than moved (a pose set, an ideal
                // servo's step) starts the step where its rates would have
                // brought it: a curve through the jump would be an impulse
                let start = |ax: usize| {
                    let moved = 0.5 * dt * (p.rate[ax] + q.rate[ax]);
                    if (q.angle[ax] - p.angle[ax] - moved).abs() > PLACED_ACCEL * dt * dt / 8.0 {
                        q.angle[ax] - moved
                    } else {
                        p.angle[ax]
                    }
                };
                a.pitch = [start(0), p.rate[0], 0.0];
                a.yaw = [start(1), p.rate[1], 0.0];
                b.pitch = [q.angle[0], q.rate[0], 0.0];
                b.yaw = [q.angle[1], q.rate[1], 0.0];
            }
            failed = step(&self.model, &mut self.ws, &mut self.seg, &mut self.head).err();
        } else {
            // the joints were where they are: the body did not move, its
            // clock did
            self.head.t += dt;
        }
        for (j, m) in self.src.joints_mut().iter_mut().enumerate() {
            let inp = input.get(j).copied().unwrap_or_default();
            self.acc[j] = if self.primed {
                [
                    (inp.rate[0] - self.prev[j].rate[0]) / dt,
                    (inp.rate[1] - self.prev[j].rate[1]) / dt,
                ]
            } else {
                [0.0; 2]
            };
            m.pitch = [inp.angle[0], inp.rate[0], 0.0];
            m.yaw = [inp.angle[1], inp.rate[1], 0.0];
            self.prev[j] = inp;
        }
        self.primed = true;
        let zero = |loads: &mut Vec<[f64; 2]>, rl: &mut Option<Vec<[f64; 2]>>| {
            loads.iter_mut().for_each(|l| *l = [0.0; 2]);
            if let Some(rl) = rl {
                rl.iter_mut().for_each(|l| *l = [0.0; 2]);
            }
        };
        // true again only on success
        self.step_ok = false;
        if let Some(e) = failed {
            zero(&mut self.loads, &mut self.rate_loads);
            return Err(e);
        }
        if let Some(rl) = &mut self.rate_loads {
            match evaluate(&self.model, &mut self.ws, &self.src, &self.head) {
                Ok(_) => {
                    for (l, js) in rl.iter_mut().zip(self.ws.joints()) {
                        *l = js.actuator_torque();
                    }
                }
                Err(e) => {
                    zero(&mut self.loads, &mut self.rate_loads);
                    return Err(e);
                }
            }
        }
        for (m, a) in self.src.joints_mut().iter_mut().zip(&self.acc) {
            m.pitch[2] = a[0];
            m.yaw[2] = a[1];
        }
        if let Some(c) = &mut self.coupling {
            self.since_coupled += 1;
            if self.recouple_every > 0 && self.since_coupled >= self.recouple_every {
                self.since_coupled = 0;
                // on failure (a singular inertia) the last coupling stays,
                // held: its load is not a continuation of the last
                if c.linearise(&self.src).is_err() {
                    self.coupled_primed = false;
                }
            }
        }
        // coupled servos: the rate loads plus the body's inertial reaction
        // to the accelerations, from the coupling's inertia (the model's
        // own evaluation would cost a fifth of the robot's time again)
        let s = self.blend();
        if let (Some(rl), Some(c)) = (&self.rate_loads, &self.coupling) {
            for (i, l) in self.loads.iter_mut().flat_map(|x| x.iter_mut()).enumerate() {
                *l = rl[i / 2][i % 2] + c.m_row(i, s, self.acc.iter().flatten().copied());
            }
            self.step_ok = true;
            return Ok(&self.loads);
        }
        match evaluate(&self.model, &mut self.ws, &self.src, &self.head) {
            Ok(_) => {
                for (l, js) in self.loads.iter_mut().zip(self.ws.joints()) {
                    *l = js.actuator_torque();
                }
                self.step_ok = true;
                Ok(&self.loads)
            }
            Err(e) => {
                self.loads.iter_mut().for_each(|l| *l = [0.0; 2]);
                Err(e)
            }
        }
    }

    /// The joint angles and rates of the model's own discrete robot at the
    /// last step (what the platforms' relative rotations are).
    pub fn model_joints(&self) -> impl Iterator<Item = JointInput> + '_ {
        self.ws.joints().iter().map(|j| JointInput {
            angle: [j.pitch, j.yaw],
            rate: [j.pitch_rate, j.yaw_rate],
        })
    }
}

impl Coupling {
    /// Row `i` of `K`, extrapolated `s` periods along its trend, times `x`.
    fn k_row(&self, i: usize, s: f64, x: impl Iterator<Item = f64>) -> f64 {
        blended_row(&self.k, &self.k_trend, 2 * self.base.len(), i, s, x)
    }

    /// The same of `M`.
    fn m_row(&self, i: usize, s: f64, x: impl Iterator<Item = f64>) -> f64 {
        blended_row(&self.m, &self.m_trend, 2 * self.base.len(), i, s, x)
    }

    /// `M` about the shape of `shape` (its joints' angles; at rest) and
    /// `K = M (J I + M)^-1` over the free axes (a jammed axis's row and
    /// column are zero: its load is the rate load, and the others do not
    /// see it accelerate). Allocates nothing; on error `K` is unchanged.
    fn linearise(&mut self, shape: &JointCurvature) -> Result<(), ModelError> {
        let r = self.linearise_anew(shape);
        if r.is_err() {
            // back to the last (the trends hold it), held from now on,
            // and the next one's change is over more than one period: no
            // trend from it either
            for ((m, t), (k, kt)) in self
                .m
                .iter_mut()
                .zip(&mut self.m_trend)
                .zip(self.k.iter_mut().zip(&mut self.k_trend))
            {
                (*m, *t, *k, *kt) = (*t, 0.0, *kt, 0.0);
            }
            self.trend_ok = false;
            return r;
        }
        let ok = self.trend_ok;
        for ((m, t), (k, kt)) in self
            .m
            .iter()
            .zip(&mut self.m_trend)
            .zip(self.k.iter().zip(&mut self.k_trend))
        {
            (*t, *kt) = if ok { (m - *t, k - *kt) } else { (0.0, 0.0) };
        }
        self.trend_ok = true;
        Ok(())
    }

    /// [`Coupling::linearise`]'s work, the last `M` and `K` kept in the
    /// trends' place.
    fn linearise_anew(&mut self, shape: &JointCurvature) -> Result<(), ModelError> {
        self.m_trend.copy_from_slice(&self.m);
        self.k_trend.copy_from_slice(&self.k);
        for (d, s) in self.src.joints_mut().iter_mut().zip(shape.joints()) {
            d.pitch = [s.pitch[0], 0.0, 0.0];
            d.yaw = [s.yaw[0], 0.0, 0.0];
        }
        inertia_about(
            &self.model,
            &mut self.ws,
            &mut self.src,
            &mut self.base,
            &mut self.m,
        )?;
        let m = self.base.len() * 2;
        self.free.clear();
        self.free
            .extend((0..m).filter(|&i| self.inertia[i / 2][i % 2].is_finite()));
        let (free, f) = (&self.free, self.free.len());
        for (r, &i) in free.iter().enumerate() {
            for (c, &j) in free.iter().enumerate() {
                self.a[r * f + c] = self.m[i * m + j];
            }
            self.a[r * f + r] += self.inertia[i / 2][i % 2];
        }
        if !invert(&mut self.a[..f * f], &mut self.inv[..f * f], f) {
            return Err(ModelError::NonFinite {
                quantity: "joint-space inertia (singular)",
                time: 0.0,
            });
        }
        self.k.fill(0.0);
        for &i in free {
            for (c, &j) in free.iter().enumerate() {
                self.k[i * m + j] = free
                    .iter()
                    .enumerate()
                    .map(|(l, &ll)| self.m[i * m + ll] * self.inv[l * f + c])
                    .sum();
            }
        }
        Ok(())
    }
}

/// Row `i` of the row-major `m x m` matrix `a + s trend` times `x`.
fn blended_row(
    a: &[f64],
    trend: &[f64],
    m: usize,
    i: usize,
    s: f64,
    x: impl Iterator<Item = f64>,
) -> f64 {
    a[i * m..(i + 1) * m]
        .iter()
        .zip(&trend[i * m..(i + 1) * m])
        .zip(x)
        .map(|((a, t), x)| (a + s * t) * x)
        .sum()
}

/// The body's joint-space inertia (row-major into `out`, `2n x 2n`) with
/// its joints at `src`'s angles, at rest, the head free and level: the
/// load change when each axis alone accelerates at 1 rad/s². `src`'s rates
/// and accelerations are overwritten; `base` is scratch.
fn inertia_about(
    model: &Model,
    ws: &mut Workspace,
    src: &mut JointCurvature,
    base: &mut [[f64; 2]],
    out: &mut [f64],
) -> Result<(), ModelError> {
    let m = 2 * base.len();
    let head = HeadState::launch(0.0);
    for jm in src.joints_mut() {
        jm.pitch[1..].fill(0.0);
        jm.yaw[1..].fill(0.0);
    }
    evaluate(model, ws, src, &head)?;
    for (b, js) in base.iter_mut().zip(ws.joints()) {
        *b = js.actuator_torque();
    }
    for col in 0..m {
        for (j, jm) in src.joints_mut().iter_mut().enumerate() {
            jm.pitch[2] = if 2 * j == col { 1.0 } else { 0.0 };
            jm.yaw[2] = if 2 * j + 1 == col { 1.0 } else { 0.0 };
        }
        evaluate(model, ws, src, &head)?;
        for (k, js) in ws.joints().iter().enumerate() {
            let load = js.actuator_torque();
            out[(2 * k) * m + col] = load[0] - base[k][0];
            out[(2 * k + 1) * m + col] = load[1] - base[k][1];
        }
    }
    Ok(())
}

/// Inverts the `m x m` row-major matrix `a` into `inv` (Gauss–Jordan with
/// partial pivoting; `a` is destroyed); false if singular.
fn invert(a: &mut [f64], inv: &mut [f64], m: usize) -> bool {
    inv.fill(0.0);
    for i in 0..m {
        inv[i * m + i] = 1.0;
    }
    for c in 0..m {
        let Some(p) = (c..m).max_by(|&x, &y| a[x * m + c].abs().total_cmp(&a[y * m + c].abs()))
        else {
            return false;
        };
        if a[p * m + c].abs() < 1e-12 || !a[p * m + c].is_finite() {
            return false;
        }
        if p != c {
            for k in 0..m {
                a.swap(p * m + k, c * m + k);
                inv.swap(p * m + k, c * m + k);
            }
        }
        let d = a[c * m + c];
        for k in 0..m {
            a[c * m + k] /= d;
            inv[c * m + k] /= d;
        }
        for r in 0..m {
            if r != c {
                let f = a[r * m + c];
                if f != 0.0 {
                    for k in 0..m {
                        a[r * m + k] -= f * a[c * m + k];
                        inv[r * m + k] -= f * inv[c * m + k];
                    }
                }
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::actuator::Load;
    use anguilla_model::gait::named_gait;
    use anguilla_model::{LawSource, posture};

    /// Joint motion of the gait of `src` at its time for `model`'s joints.
    fn gait_joints(model: &Model, ws: &mut Workspace, src: &LawSource) -> Vec<JointInput> {
        posture(model, ws, src)
            .iter()
            .map(|j| JointInput {
                angle: [j.pitch, j.yaw],
                rate: [j.pitch_rate, j.yaw_rate],
            })
            .collect()
    }

    #[test]
    fn joint_inertia_is_symmetric_with_a_positive_diagonal() {
        let p = Plant::new(PlantConfig {
            joints: 6,
            ..PlantConfig::default()
        })
        .unwrap();
        let m0 = p.joint_inertia().unwrap();
        let m = 12;
        let diag: Vec<f64> = (0..m).map(|i| m0[i * m + i]).collect();
        eprintln!("joint-space inertia diagonal (kg m^2): {diag:.4?}");
        let scale = diag.iter().cloned().fold(0.0, f64::max);
        for i in 0..m {
            assert!(m0[i * m + i] > 0.0, "{i}: {}", m0[i * m + i]);
            for j in 0..m {
                // A mechanical inertia is symmetric; the discretization
                // (curvature spread over each joint's span) keeps it so to
                // a few percent of the largest entry.
                let d = (m0[i * m + j] - m0[j * m + i]).abs();
                assert!(
                    d < 0.05 * scale,
                    "{i},{j}: {} vs {}",
                    m0[i * m + j],
                    m0[j * m + i]
                );
            }
        }
        let (mut a, mut inv) = (m0.clone(), vec![0.0; m * m]);
        assert!(invert(&mut a, &mut inv, m));
        for i in 0..m {
            let e: f64 = (0..m).map(|l| m0[i * m + l] * inv[l * m + i]).sum();
            assert!((e - 1.0).abs() < 1e-9, "{e}");
        }
    }

    #[test]
    fn a_jammed_axis_is_removed_from_the_coupling() {
        let mut p = Plant::new(PlantConfig {
            joints: 3,
            rate_loads: true,
            ..PlantConfig::default()
        })
        .unwrap();
        let mut inertia = vec![[0.02; 2]; 3];
        inertia[1][1] = f64::INFINITY;
        p.couple_servos(&inertia).unwrap();
        let k = &p.coupling.as_ref().unwrap().k;
        let m = 6;
        for i in 0..m {
            assert_eq!(k[3 * m + i], 0.0);
            assert_eq!(k[i * m + 3], 0.0);
        }
        assert!(k[0] > 0.0 && k[0] < 1.0, "{}", k[0]);
    }

    #[test]
    fn a_joint_placed_rather_than_moved_does_not_kick_the_body() {
        let mut p = Plant::new(PlantConfig {
            joints: 4,
            ..PlantConfig::default()
        })
        .unwrap();
        let mut input = [JointInput::default(); 4];
        p.step(&input).unwrap();
        p.step(&input).unwrap();
        // 0.3 rad in one step with no rate: a pose set, not a motion (a
        // curve through it would be 450 000 rad/s² and the head's velocity
        // would diverge)
        input[1].angle = [0.3, -0.2];
        p.step(&input).unwrap();
        p.step(&input).unwrap();
        assert!(p.head().velocity.norm() < 1e-6, "{}", p.head().velocity);
        // a motion along its rates is followed: the head recoils
        input[1].rate = [2.0, 0.0];
        input[1].angle[0] += 0.002 * 1.0;
        p.step(&input).unwrap();
        input[1].angle[0] += 0.002 * 2.0;
        p.step(&input).unwrap();
        assert!(p.head().omega.norm() > 1e-4, "{}", p.head().omega);
    }

    #[test]
    fn the_coupling_follows_the_bodys_shape() {
        let mut p = Plant::new(PlantConfig {
            joints: 4,
            rate_loads: true,
            // three physics steps
            recouple_period: 0.006,
            ..PlantConfig::default()
        })
        .unwrap();
        p.couple_servos(&[[0.02; 2]; 4]).unwrap();
        let straight = p.coupling.as_ref().unwrap().k.clone();
        let bent = [JointInput {
            angle: [0.3, 0.5],
            rate: [0.0; 2],
        }; 4];
        let k = |p: &Plant| p.coupling.as_ref().unwrap().k.clone();
        let apart = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
        };
        for _ in 0..2 {
            p.step(&bent).unwrap();
        }
        assert_eq!(k(&p), straight, "not before recouple_every steps");
        p.step(&bent).unwrap();
        let moved = apart(&k(&p), &straight);
        // K's entries are fractions (0..1 on the diagonal); a hundredth
        // is a change, not rounding
        assert!(moved > 0.01, "a bent body couples otherwise: {moved}");
        // the same as a coupling computed afresh about the bent shape
        let mut fresh = p.clone();
        fresh.couple_servos(&[[0.02; 2]; 4]).unwrap();
        assert!(apart(&k(&p), &k(&fresh)) < 1e-12);
    }

    /// Servos coupled to the body as the simulated robot couples them
    /// (eight 0.25 ms servo steps a 2 ms physics step, the load set once a
    /// physics step) swimming a travelling wave at 1.8 Hz: the load each
    /// feels is the model's inverse dynamics at its motion, within 8 % RMS
    /// and with no lag (4.1 % and −0.06 ms measured; with the load and the
    /// coupling held over the step, 19.0 % and 8.07 ms). The bounds: twice
    /// the error measured, still under half the held one's; an eighth of
    /// the held lag.
    #[test]
    fn the_servos_loads_follow_the_bodys_model_within_a_step() {
        use crate::actuator::{Actuator, ActuatorParams, Drive};
        use anguilla_model::{Integrator, ModelConfig};
        let (n, dt, sub) = (12, 0.002, 0.00025);
        let p = ActuatorParams::default();
        let mut plant = Plant::new(PlantConfig {
            joints: n,
            dt,
            rate_loads: true,
            ..PlantConfig::default()
        })
        .unwrap();
        plant.couple_servos(&vec![[p.inertia; 2]; n]).unwrap();
        let mut axes: Vec<[Actuator; 2]> = (0..n)
            .map(|_| [Actuator::new(p), Actuator::new(p)])
            .collect();
        let model = Model::new(ModelConfig {
            nodes: 52,
            dt,
            joints: n,
            integrator: Integrator::Rk4,
            body: anguilla_model::Body::paper(),
        })
        .unwrap();
        let mut ws = Workspace::new(&model);
        let mut src = JointCurvature::new(n, model.body().length);
        let (mut inputs, mut loads) = (
            vec![JointInput::default(); n],
            vec![[Load::default(); 2]; n],
        );
        let (mut tau, mut friction) = (vec![[0.0; 2]; n], vec![[0.0; 2]; n]);
        // joint 7's yaw: (felt, model)
        let mut seen = Vec::new();
        let w = 2.0 * std::f64::consts::PI * 1.8;
        let steps = (4.0 / dt) as usize;
        for k in 0..steps {
            for s in 0..8 {
                let t = k as f64 * dt + (s + 1) as f64 * sub;
                for (j, ax) in axes.iter_mut().enumerate() {
                    let amp = 0.05 + 0.25 * j as f64 / n as f64;
                    let ph = w * t - 2.0 * std::f64::consts::PI * j as f64 / n as f64;
                    ax[0].step(
                        sub,
                        Drive::Servo {
                            position: 0.0,
                            velocity: 0.0,
                            torque: 0.0,
                        },
                    );
                    ax[1].step(
                        sub,
                        Drive::Servo {
                            position: amp * ph.sin(),
                            velocity: amp * w * ph.cos(),
                            torque: 0.0,
                        },
                    );
                }
            }
            for (i, ax) in inputs.iter_mut().zip(&axes) {
                let (k0, k1) = (ax[0].kinematics(), ax[1].kinematics());
                *i = JointInput {
                    angle: [k0.0, k1.0],
                    rate: [k0.1, k1.1],
                };
            }
            plant.step(&inputs).unwrap();
            if k >= steps / 2 {
                for (m, ax) in src.joints_mut().iter_mut().zip(&axes) {
                    let (k0, k1) = (ax[0].kinematics(), ax[1].kinematics());
                    (m.pitch, m.yaw) = ([k0.0, k0.1, k0.2], [k1.0, k1.1, k1.2]);
                }
                evaluate(&model, &mut ws, &src, plant.head()).unwrap();
                let ax = &axes[6][1];
                let (_, rate, acc) = ax.kinematics();
                seen.push((
                    ax.torque() - p.inertia * acc - p.damping * rate,
                    ws.joints()[6].actuator_torque()[1],
                ));
            }
            for (j, ax) in axes.iter().enumerate() {
                tau[j] = [ax[0].torque(), ax[1].torque()];
                friction[j] = [
                    p.damping * ax[0].kinematics().1,
                    p.damping * ax[1].kinematics().1,
                ];
            }
            plant.coupled_loads(&tau, &friction, &mut loads);
            for (ax, l) in axes.iter_mut().zip(&loads) {
                ax[0].set_load(l[0]);
                ax[1].set_load(l[1]);
            }
        }
        // felt - model ≈ -lag · d(model)/dt, by least squares
        let (mut num, mut den, mut e2, mut c2) = (0.0, 0.0, 0.0, 0.0);
        for i in 1..seen.len() - 1 {
            let dc = (seen[i + 1].1 - seen[i - 1].1) / (2.0 * dt);
            let e = seen[i].0 - seen[i].1;
            (num, den) = (num - e * dc, den + dc * dc);
            (e2, c2) = (e2 + e * e, c2 + seen[i].1 * seen[i].1);
        }
        let (error, lag) = ((e2 / c2).sqrt(), num / den);
        eprintln!(
            "felt against the model: {:.1} % RMS, lag {:.2} ms",
            100.0 * error,
            1e3 * lag
        );
        assert!(error < 0.08, "{error}");
        assert!(lag.abs() < 0.001, "{lag}");
    }

    /// A load's rate is never taken across a jump: after a failed step
    /// (its loads zeroed), a new current or a head put back, the next
    /// loads are held for one step, and then followed again.
    #[test]
    fn no_load_rate_is_taken_across_a_failed_step_or_a_new_current() {
        let n = 4;
        let mut p = Plant::new(PlantConfig {
            joints: n,
            rate_loads: true,
            ..PlantConfig::default()
        })
        .unwrap();
        p.couple_servos(&vec![[0.02; 2]; n]).unwrap();
        let (tau, friction) = (vec![[0.05, -0.03]; n], vec![[0.0; 2]; n]);
        let mut out = vec![[Load::default(); 2]; n];
        let moving = |k: usize| -> Vec<JointInput> {
            (0..n)
                .map(|j| {
                    let ph = 0.02 * k as f64 * 6.0 + j as f64;
                    JointInput {
                        angle: [0.0, 0.3 * ph.sin()],
                        rate: [0.0, 0.3 * 6.0 * 10.0 * ph.cos()],
                    }
                })
                .collect()
        };
        let rates = |out: &[[Load; 2]]| {
            out.iter()
                .flatten()
                .map(|l| l.rate.abs())
                .fold(0.0, f64::max)
        };
        for k in 0..10 {
            p.step(&moving(k)).unwrap();
            p.coupled_loads(&tau, &friction, &mut out);
        }
        assert!(rates(&out) > 0.0, "a moving body's loads change");
        let mut bad = moving(10);
        bad[1].angle[1] = f64::NAN;
        assert!(p.step(&bad).is_err());
        p.coupled_loads(&tau, &friction, &mut out);
        assert_eq!(rates(&out), 0.0, "the failed step's zero loads are held");
        // the step after starts from the bad input and fails too
        let mut k = 11;
        while p.step(&moving(k)).is_err() {
            p.coupled_loads(&tau, &friction, &mut out);
            assert_eq!(rates(&out), 0.0);
            k += 1;
            assert!(k < 15, "the plant recovers");
        }
        p.coupled_loads(&tau, &friction, &mut out);
        assert_eq!(rates(&out), 0.0, "no rate from the zero loads to these");
        p.step(&moving(k + 1)).unwrap();
        p.coupled_loads(&tau, &friction, &mut out);
        assert!(rates(&out) > 0.0, "followed again");
        p.set_current(Current::steady([0.2, 0.0, 0.0]).unwrap());
        p.step(&moving(k + 2)).unwrap();
        p.coupled_loads(&tau, &friction, &mut out);
        assert_eq!(rates(&out), 0.0, "no rate across a new current");
    }

    #[test]
    fn actuators_do_positive_work_on_the_fluid_while_swimming() {
        // Feed F1's joint motion for 1.5 s: the mean actuator power
        // sum(load * rate) must be positive (the body pushes water back),
        // which fixes the sign of the load (−C, not C).
        let cfg = PlantConfig {
            dt: 0.005,
            ..PlantConfig::default()
        };
        let mut p = Plant::new(cfg.clone()).unwrap();
        let mut ws = Workspace::new(&p.model);
        let g = named_gait("F1").unwrap();
        let mut src = LawSource::new(g.law);
        let mut work = 0.0;
        let steps = (1.5 / cfg.dt) as usize;
        for _ in 0..steps {
            let input = gait_joints(&p.model, &mut ws, &src);
            let loads = p.step(&input).unwrap().to_vec();
            for (l, i) in loads.iter().zip(&input) {
                work += (l[0] * i.rate[0] + l[1] * i.rate[1]) * cfg.dt;
            }
            src.t += cfg.dt;
        }
        eprintln!("actuator work over 1.5 s of F1: {work} J");
        assert!(work > 0.0, "actuator work {work} J");
        // And the body swims head first (towards −e1).
        assert!(p.head().v1() < 0.0, "V1 = {}", p.head().v1());
    }
}
