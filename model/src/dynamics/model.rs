//! The immutable, validated model (Pinocchio's `Model`): discretization,
//! body constants at every node, quadrature weights.

use crate::body::{Body, Friction, Section};
use crate::error::{ModelError, Result};
use nalgebra::Vector3;

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
/// Default time step (s) of the paper's runs and `anguilla swim`: it
/// divides every switching time and period of the paper's gaits (0.25 s,
/// 0.75 s, 1.25 s, ...), so no RK4 step straddles a kink of a curvature
/// law. The paper tables move by at most 0.012 % from dt = 0.01 s
/// (model/README.md, "Time step"); the control loop and the simulated
/// robot step at their own period, not at this one.
pub const DEFAULT_DT: f64 = 0.025;
/// Largest accepted time step (s).
pub const MAX_DT: f64 = 0.05;
/// Space intervals the model accepts ([`ModelConfig::nodes`]).
pub const NODES_RANGE: std::ops::RangeInclusive<usize> = 2..=100_000;

/// The immutable, validated model: body constants at every node, quadrature
/// weights, discretization.
#[derive(Debug, Clone)]
pub struct Model {
    pub(super) body: Body,
    pub(super) n: usize,
    pub(super) dt: f64,
    pub(super) joints: usize,
    pub(super) integrator: Integrator,
    /// space step (m)
    pub(super) h: f64,
    /// normalized abscissae of nodes and mid-nodes (2n+1)
    pub(super) x_fine: Vec<f64>,
    pub(super) sec: Vec<Section>,
    /// The friction law (41) at every node, in the form a step evaluates.
    pub(super) friction: Vec<Friction>,
    /// Simpson weights (m)
    pub(super) w: Vec<f64>,
    pub(super) k_o: f64,
    pub(super) m_o: f64,
    pub(super) gravity: Vector3<f64>,
    pub(super) total_mass: f64,
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
        let friction = sec
            .iter()
            .enumerate()
            .map(|(i, s)| {
                Friction::with_law(i as f64 / n as f64 * len, s.perimeter, body.nu, body.axial)
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
            friction,
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
    pub(super) fn platform_node(&self, k: usize) -> usize {
        (2 * k + 1) * self.n / (2 * (self.joints + 1))
    }
}
