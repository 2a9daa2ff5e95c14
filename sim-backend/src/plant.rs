//! The swimming body as the plant: a thin adapter over `anguilla-model`.
//!
//! The model is driven by the joints' *achieved* motion (a
//! [`JointCurvature`] source fed every physics step with the actuators'
//! angles and rates), not by an imposed gait, so the simulated robot swims,
//! turns and dives as its joints actually move. Each step returns the torque
//! the body demands at every joint axis, which becomes the actuators' load.
//!
//! **Sign of the load.** The model's internal torque `c(X1)` is the torque
//! the rear part exerts on the front part (`model/README.md`,
//! `docs/MODEL-NOTES.md`); the actuator of a joint turns the rear platform
//! relative to the front one, so the torque it must produce for the motion
//! is `−C` (a rigid-body library's joint torque). The load of an axis is
//! therefore `[−C2, −C3]`: an ideal servo's motor torque equals it, and the
//! actuators do positive net work on the fluid while swimming (checked by a
//! test below).
//!
//! Everything the model needs is kept here so that changes of the model's
//! API are reconciled in one place.

use anguilla_model::{
    HeadState, Integrator, JointCurvature, Model, ModelConfig, ModelError, Workspace, evaluate,
    step,
};

/// Configuration of the body plant.
#[derive(Debug, Clone, Copy, PartialEq)]
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
        }
    }
}

/// The body: model, workspace, joint-driven curvature and head state.
#[derive(Debug, Clone)]
pub struct Plant {
    model: Model,
    ws: Workspace,
    src: JointCurvature,
    head: HeadState,
    /// Joint rates at the previous step, for the acceleration estimate.
    prev_rates: Vec<[f64; 2]>,
    /// Whether `prev_rates` holds a previous step.
    primed: bool,
    /// Joint accelerations of the current step.
    acc: Vec<[f64; 2]>,
    /// Loads `[pitch, yaw]` (N·m) per joint from the last step.
    loads: Vec<[f64; 2]>,
    /// The same without the joints' own accelerations.
    rate_loads: Option<Vec<[f64; 2]>>,
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
            ..ModelConfig::default()
        })?;
        let ws = Workspace::new(&model);
        let length = model.body().length;
        Ok(Self {
            src: JointCurvature::new(cfg.joints, length),
            ws,
            model,
            head: HeadState::launch(cfg.v_init),
            prev_rates: vec![[0.0; 2]; cfg.joints],
            primed: false,
            acc: vec![[0.0; 2]; cfg.joints],
            loads: vec![[0.0; 2]; cfg.joints],
            rate_loads: cfg.rate_loads.then(|| vec![[0.0; 2]; cfg.joints]),
        })
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

    /// Puts the head back at the origin with the given state (a test's
    /// initial condition); the joints keep their motion.
    pub fn reset_head(&mut self, head: HeadState) {
        self.head = head;
    }

    /// The loads `[pitch, yaw]` (N·m) each joint's actuators see: `−C`.
    pub fn loads(&self) -> &[[f64; 2]] {
        &self.loads
    }

    /// The loads of the last step with the joints' accelerations taken as
    /// zero (if [`PlantConfig::rate_loads`]): what actuators with their own
    /// dynamics are given. The body's inertial reaction to the joints'
    /// accelerations (body and added mass, ~0.5 kg·m² at the front joints,
    /// 25 times a servo's reflected inertia) cannot be fed back explicitly
    /// one step late — that loop is unstable — so such actuators are modelled
    /// as dominated by their reflected inertia (a stiff geared servo), and
    /// see the velocity- and pose-dependent part of the load.
    pub fn rate_loads(&self) -> Option<&[[f64; 2]]> {
        self.rate_loads.as_deref()
    }

    /// One physics step with the joints at `input` (angles and rates now;
    /// accelerations are the rates' backward difference over the step).
    /// Returns the loads for the next step. On a model error the head state
    /// is unchanged and the loads are zeroed.
    pub fn step(&mut self, input: &[JointInput]) -> Result<&[[f64; 2]], ModelError> {
        let dt = self.model.dt();
        for (j, m) in self.src.joints_mut().iter_mut().enumerate() {
            let inp = input.get(j).copied().unwrap_or_default();
            self.acc[j] = if self.primed {
                [
                    (inp.rate[0] - self.prev_rates[j][0]) / dt,
                    (inp.rate[1] - self.prev_rates[j][1]) / dt,
                ]
            } else {
                [0.0; 2]
            };
            m.pitch = [inp.angle[0], inp.rate[0], 0.0];
            m.yaw = [inp.angle[1], inp.rate[1], 0.0];
            self.prev_rates[j] = inp.rate;
        }
        self.primed = true;
        if let Some(rl) = &mut self.rate_loads {
            match evaluate(&self.model, &mut self.ws, &self.src, &self.head) {
                Ok(_) => {
                    for (l, js) in rl.iter_mut().zip(self.ws.joints()) {
                        *l = [-js.c2, -js.c3];
                    }
                }
                Err(_) => rl.iter_mut().for_each(|l| *l = [0.0; 2]),
            }
        }
        for (m, a) in self.src.joints_mut().iter_mut().zip(&self.acc) {
            m.pitch[2] = a[0];
            m.yaw[2] = a[1];
        }
        match step(&self.model, &mut self.ws, &mut self.src, &mut self.head) {
            Ok(_) => {
                for (l, js) in self.loads.iter_mut().zip(self.ws.joints()) {
                    *l = [-js.c2, -js.c3];
                }
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

#[cfg(test)]
mod tests {
    use super::*;
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
    fn actuators_do_positive_work_on_the_fluid_while_swimming() {
        // Feed F1's joint motion for 1.5 s: the mean actuator power
        // sum(load * rate) must be positive (the body pushes water back),
        // which fixes the sign of the load (−C, not C).
        let cfg = PlantConfig {
            dt: 0.005,
            ..PlantConfig::default()
        };
        let mut p = Plant::new(cfg).unwrap();
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
