//! The daemon's gait: the wave (44) and constant curvatures, with
//! parameters that may change while it runs ([`ParametricGait`]).

use crate::error::{ModelError, Result};
use core::f64::consts::PI;
use nalgebra::Vector3;

use super::{Curvature, CurvatureSource, for_each_sin_cos};

/// Parameters of the [`ParametricGait`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaitParams {
    /// Wavelength `lambda` (body lengths), non-zero; negative reverses the
    /// wave (stopping).
    pub wavelength: f64,
    /// Period `T` (s), `> 0`.
    pub period: f64,
    /// Amplitude polynomial `[a0, a1, a2]` (1/m).
    pub amplitude: [f64; 3],
    /// Phase shift `phi` (periods).
    pub phase: f64,
    /// Constant yaw (turn) curvature `K_c3` (1/m).
    pub kc3: f64,
    /// Constant pitch curvature `K_c2` (1/m).
    pub kc2: f64,
}

impl Default for GaitParams {
    /// F1 of Table 1, no turn.
    fn default() -> Self {
        Self {
            wavelength: 1.0,
            period: 1.0,
            amplitude: [1.0, 0.5, 2.0],
            phase: 0.0,
            kc3: 0.0,
            kc2: 0.0,
        }
    }
}

impl GaitParams {
    /// Checks the parameters: finite, `period > 0`, `|wavelength| >= 0.01`.
    pub fn validate(&self) -> Result<()> {
        let all = [
            ("amplitude[0]", self.amplitude[0]),
            ("amplitude[1]", self.amplitude[1]),
            ("amplitude[2]", self.amplitude[2]),
            ("phase", self.phase),
            ("kc3", self.kc3),
            ("kc2", self.kc2),
        ];
        for (name, value) in all {
            if !value.is_finite() {
                return Err(ModelError::InvalidParameter {
                    name,
                    value,
                    range: "finite",
                });
            }
        }
        if !(self.period.is_finite() && self.period > 0.0) {
            return Err(ModelError::InvalidParameter {
                name: "period",
                value: self.period,
                range: "finite and > 0 s",
            });
        }
        if !(self.wavelength.is_finite() && self.wavelength.abs() >= 0.01) {
            return Err(ModelError::InvalidParameter {
                name: "wavelength",
                value: self.wavelength,
                range: "finite with |wavelength| >= 0.01 body lengths",
            });
        }
        Ok(())
    }
}

const NP: usize = 8; // a0 a1 a2 1/lambda 1/T phase kc2 kc3

fn pack(p: &GaitParams) -> [f64; NP] {
    [
        p.amplitude[0],
        p.amplitude[1],
        p.amplitude[2],
        1.0 / p.wavelength,
        1.0 / p.period,
        p.phase,
        p.kc2,
        p.kc3,
    ]
}

/// A parametric gait for the daemon: the wave (44) plus constant yaw and
/// pitch curvatures, whose parameters may change while it runs.
///
/// Each internal parameter (`a0, a1, a2, 1/lambda, 1/T, phi, K_c2, K_c3`)
/// follows its target through a critically damped third-order filter with
/// time constant `smoothing`, so parameter, rate and acceleration stay
/// continuous even when a target jumps; the wave phase is integrated
/// (`d theta/dt = 1/T`) rather than computed from `t/T`. The curvature and its
/// first two time derivatives are therefore continuous in time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParametricGait {
    t: f64,
    /// Integrated phase `∫ dt/T` (periods).
    theta: f64,
    /// Parameters, their first and second time derivatives.
    p: [[f64; 3]; NP],
    target: [f64; NP],
    omega: f64,
}

impl ParametricGait {
    /// A gait at rest on `initial` (already converged), smoothing time
    /// constant `smoothing` (s, `> 0`).
    pub fn new(initial: GaitParams, smoothing: f64) -> Result<Self> {
        initial.validate()?;
        if !(smoothing.is_finite() && smoothing > 0.0) {
            return Err(ModelError::InvalidParameter {
                name: "smoothing",
                value: smoothing,
                range: "finite and > 0 s",
            });
        }
        let v = pack(&initial);
        let mut p = [[0.0; 3]; NP];
        for (pi, vi) in p.iter_mut().zip(v) {
            pi[0] = vi;
        }
        Ok(Self {
            t: 0.0,
            theta: 0.0,
            p,
            target: v,
            omega: 1.0 / smoothing,
        })
    }

    /// A gait starting straight (zero amplitude and turn curvatures) with
    /// the wave of `initial`, which then ramps towards `initial`.
    pub fn from_rest(initial: GaitParams, smoothing: f64) -> Result<Self> {
        let mut g = Self::new(
            GaitParams {
                amplitude: [0.0; 3],
                kc2: 0.0,
                kc3: 0.0,
                ..initial
            },
            smoothing,
        )?;
        g.set_target(&initial)?;
        Ok(g)
    }

    /// Sets new target parameters (no allocation; callable every period).
    /// Invalid parameters are rejected and the previous target kept.
    pub fn set_target(&mut self, params: &GaitParams) -> Result<()> {
        params.validate()?;
        self.target = pack(params);
        Ok(())
    }

    /// Current (smoothed) parameters.
    pub fn params(&self) -> GaitParams {
        let q = |i: usize| self.p[i][0];
        GaitParams {
            amplitude: [q(0), q(1), q(2)],
            wavelength: 1.0 / q(3),
            period: 1.0 / q(4),
            phase: q(5),
            kc2: q(6),
            kc3: q(7),
        }
    }

    fn jerk(&self, i: usize, s: [f64; 3]) -> f64 {
        let w = self.omega;
        w * w * w * (self.target[i] - s[0]) - 3.0 * w * w * s[1] - 3.0 * w * s[2]
    }
}

impl CurvatureSource for ParametricGait {
    fn curvature(&self, tau: f64, x: &[f64], out: &mut [Curvature]) {
        // parameters extrapolated to second order within the step
        let mut v = [[0.0; 3]; NP];
        for (i, vi) in v.iter_mut().enumerate() {
            let s = self.p[i];
            *vi = [
                s[0] + s[1] * tau + 0.5 * s[2] * tau * tau,
                s[1] + s[2] * tau,
                s[2],
            ];
        }
        let f = self.p[4];
        let theta = self.theta + f[0] * tau + 0.5 * f[1] * tau * tau + f[2] * tau * tau * tau / 6.0;
        let tp = 2.0 * PI;
        for_each_sin_cos(x, tp * (v[5][0] - theta), tp * v[3][0], |i, s, c| {
            let xx = x[i];
            let amp = [
                v[0][0] + v[1][0] * xx + v[2][0] * xx * xx,
                v[0][1] + v[1][1] * xx + v[2][1] * xx * xx,
                v[0][2] + v[1][2] * xx + v[2][2] * xx * xx,
            ];
            let argd = tp * (xx * v[3][1] - v[4][0] + v[5][1]);
            let argdd = tp * (xx * v[3][2] - v[4][1] + v[5][2]);
            let k3 = amp[0] * s + v[7][0];
            let k3d = amp[1] * s + amp[0] * c * argd + v[7][1];
            let k3dd = amp[2] * s
                + 2.0 * amp[1] * c * argd
                + amp[0] * (-s * argd * argd + c * argdd)
                + v[7][2];
            if let Some(o) = out.get_mut(i) {
                *o = Curvature {
                    k: Vector3::new(0.0, v[6][0], k3),
                    k_dot: Vector3::new(0.0, v[6][1], k3d),
                    k_ddot: Vector3::new(0.0, v[6][2], k3dd),
                };
            }
        });
    }

    fn advance(&mut self, dt: f64) {
        // phase: exact for a quadratic 1/T over the step
        let f = self.p[4];
        self.theta += f[0] * dt + 0.5 * f[1] * dt * dt + f[2] * dt * dt * dt / 6.0;
        // filters: classical RK4 on (p, p', p'')
        for i in 0..NP {
            let s0 = self.p[i];
            let d = |s: [f64; 3]| [s[1], s[2], self.jerk(i, s)];
            let add = |s: [f64; 3], k: [f64; 3], h: f64| {
                [s[0] + h * k[0], s[1] + h * k[1], s[2] + h * k[2]]
            };
            let k1 = d(s0);
            let k2 = d(add(s0, k1, dt / 2.0));
            let k3 = d(add(s0, k2, dt / 2.0));
            let k4 = d(add(s0, k3, dt));
            for j in 0..3 {
                self.p[i][j] = s0[j] + dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
            }
        }
        self.t += dt;
    }

    fn time(&self) -> f64 {
        self.t
    }
}
