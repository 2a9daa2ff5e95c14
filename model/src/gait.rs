//! Curvature laws: the paper's gaits (42)–(46), a parametric gait for the
//! daemon, and a curvature source driven by measured joint motion.

use crate::error::{ModelError, Result};
use core::f64::consts::PI;
use nalgebra::Vector3;

/// Material curvature `K_d = K2 E2 + K3 E3` (1/m) at one abscissa and its
/// first two time derivatives. The `x` (twist) components are always 0.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Curvature {
    /// `K_d`.
    pub k: Vector3<f64>,
    /// `dK_d/dt`.
    pub k_dot: Vector3<f64>,
    /// `d²K_d/dt²`.
    pub k_ddot: Vector3<f64>,
}

/// Where the imposed curvature comes from. The dynamics are generic over it.
pub trait CurvatureSource {
    /// Writes the curvature at normalized abscissae `x[i]` (X1 / length, in
    /// `[0, 1]`) at time `self.time() + tau` into `out[i]`. Must not allocate.
    fn curvature(&self, tau: f64, x: &[f64], out: &mut [Curvature]);
    /// Advances the source's own time (and internal state) by `dt`.
    fn advance(&mut self, dt: f64);
    /// Current time of the source (s).
    fn time(&self) -> f64;
    /// Whether the curvature is a law of the source's time alone:
    /// `curvature(tau)` before `advance(dt)` equals `curvature(tau - dt)`
    /// after it, and nothing else changes it. The model then keeps a
    /// step's last shape (at `tau = dt`) as the next step's first instead
    /// of integrating it again. `false` by default (always integrated):
    /// sources whose parameters a caller changes between steps, or that
    /// follow measurements, must keep it.
    fn is_law_of_time(&self) -> bool {
        false
    }
}

/// `sin, cos` of `a0 + slope * x[i]` for every `x[i]`, by the angle-addition
/// recurrence when `x` is uniformly spaced (the model's grid), else directly.
/// Calls `f(i, sin, cos)`.
#[inline]
fn for_each_sin_cos(x: &[f64], a0: f64, slope: f64, mut f: impl FnMut(usize, f64, f64)) {
    let n = x.len();
    if n == 0 {
        return;
    }
    let dx = if n > 1 { x[1] - x[0] } else { 0.0 };
    let uniform = n > 2 && ((x[n - 1] - x[0]) - dx * (n - 1) as f64).abs() < 1e-12;
    if !uniform {
        for (i, &xi) in x.iter().enumerate() {
            let (s, c) = (a0 + slope * xi).sin_cos();
            f(i, s, c);
        }
        return;
    }
    let (sd, cd) = (slope * dx).sin_cos();
    let (mut s, mut c) = (a0 + slope * x[0]).sin_cos();
    for i in 0..n {
        f(i, s, c);
        // re-anchor every 64 points to bound round-off growth
        if (i + 1) % 64 == 0 && i + 1 < n {
            (s, c) = (a0 + slope * x[i + 1]).sin_cos();
        } else {
            (s, c) = (s * cd + c * sd, c * cd - s * sd);
        }
    }
}

/// Sinusoidal ramp `f_r(t, t_i, t_f)` of (43) and its first two time
/// derivatives.
pub fn ramp(t: f64, ti: f64, tf: f64) -> [f64; 3] {
    if t < ti {
        [0.0, 0.0, 0.0]
    } else if t >= tf {
        [1.0, 0.0, 0.0]
    } else {
        let d = tf - ti;
        let tau = (t - ti) / d;
        let (s, c) = (2.0 * PI * tau).sin_cos();
        [tau - s / (2.0 * PI), (1.0 - c) / d, 2.0 * PI * s / (d * d)]
    }
}

fn one_minus(r: [f64; 3]) -> [f64; 3] {
    [1.0 - r[0], -r[1], -r[2]]
}

/// Parameters of the propulsive wave `K_f3` of (44).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wave {
    /// Wavelength `lambda` (m, in body lengths for other bodies).
    pub lambda: f64,
    /// Period `T` (s).
    pub period: f64,
    /// Amplitude polynomial `f_a = a2 X² + a1 X + a0` (1/m).
    pub a: [f64; 3],
    /// Phase shift `phi` (in periods).
    pub phi: f64,
}

impl Wave {
    /// `K_f3(X1, t)` of (44) and its first two time derivatives.
    pub fn eval(&self, x: f64, t: f64) -> [f64; 3] {
        let (s, c) = (self.phase0(t) + self.slope() * x).sin_cos();
        self.eval_sc(x, s, c)
    }

    /// Phase of (44) at `X1 = 0`.
    fn phase0(&self, t: f64) -> f64 {
        2.0 * PI * (-t / self.period + self.phi)
    }

    /// Phase slope `2 pi / lambda` of (44).
    fn slope(&self) -> f64 {
        2.0 * PI / self.lambda
    }

    /// (44) given `sin, cos` of its phase at `(x, t)`.
    #[inline]
    fn eval_sc(&self, x: f64, s: f64, c: f64) -> [f64; 3] {
        let fa = self.a[2] * x * x + self.a[1] * x + self.a[0];
        let w = 2.0 * PI / self.period;
        [fa * s, -fa * w * c, -fa * w * w * s]
    }
}

/// Turning schedule of section 7.4.2: how `alpha(t)` and `beta(t)` of (45)
/// switch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TurnKind {
    /// Inertial turn with propulsion before and after ("T.i.p.").
    InertialPropelled,
    /// Propulsive turn ("T.p.").
    Propulsive,
    /// Pure inertial turn ("T.i."), no propulsion.
    Inertial,
}

/// A gait of the paper.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GaitLaw {
    /// Forward (and stopping) gait (42)–(44): `K3 = f_r(t,0,T) K_f3`.
    Forward(Wave),
    /// Turning gait (45) with the schedule `kind` and switching times
    /// `t1..t4` of Table 3.
    Turn {
        /// Propulsive wave (unused by `TurnKind::Inertial`).
        wave: Wave,
        /// Schedule.
        kind: TurnKind,
        /// Constant yaw curvature `K_c3` (1/m).
        kc3: f64,
        /// Switching times `t1, t2, t3, t4` (s).
        times: [f64; 4],
    },
    /// Spiral (46): `f_r(t,0,T) (K_f3 t3 + K_c2 t2 + K_c3 t3)`.
    Spiral {
        /// Propulsive wave.
        wave: Wave,
        /// Constant pitch curvature `K_c2` (1/m).
        kc2: f64,
        /// Constant yaw curvature `K_c3` (1/m).
        kc3: f64,
    },
}

impl GaitLaw {
    /// `(alpha, beta)` of (45) with their derivatives, for a turn.
    fn turn_weights(kind: TurnKind, period: f64, tt: [f64; 4], t: f64) -> ([f64; 3], [f64; 3]) {
        let z = [0.0; 3];
        match kind {
            TurnKind::InertialPropelled => {
                if t < period {
                    (ramp(t, 0.0, period), z)
                } else if t < tt[1] {
                    let r = ramp(t, period, tt[0]);
                    (one_minus(r), r)
                } else {
                    let r = ramp(t, tt[1], tt[2]);
                    (r, one_minus(r))
                }
            }
            TurnKind::Propulsive => {
                if t < period {
                    (ramp(t, 0.0, period), z)
                } else if t < tt[1] {
                    ([1.0, 0.0, 0.0], ramp(t, period, tt[0]))
                } else {
                    ([1.0, 0.0, 0.0], one_minus(ramp(t, tt[1], tt[2])))
                }
            }
            TurnKind::Inertial => {
                if t < tt[0] {
                    (z, z)
                } else if t < tt[2] {
                    (z, ramp(t, tt[0], tt[1]))
                } else {
                    (z, one_minus(ramp(t, tt[2], tt[3])))
                }
            }
        }
    }

    /// The propulsive wave of the law.
    pub fn wave(&self) -> Wave {
        match *self {
            GaitLaw::Forward(w)
            | GaitLaw::Turn { wave: w, .. }
            | GaitLaw::Spiral { wave: w, .. } => w,
        }
    }

    /// `(K3, K2)` laws with derivatives at `(x, t)`.
    pub fn eval(&self, x: f64, t: f64) -> Curvature {
        let w = self.wave();
        let (s, c) = (w.phase0(t) + w.slope() * x).sin_cos();
        self.eval_sc(x, t, s, c)
    }

    /// [`GaitLaw::eval`] given `sin, cos` of the wave phase at `(x, t)`.
    fn eval_sc(&self, x: f64, t: f64, sn: f64, cs: f64) -> Curvature {
        // product rule for (f g), (f g)', (f g)''
        fn mul(f: [f64; 3], g: [f64; 3]) -> [f64; 3] {
            [
                f[0] * g[0],
                f[1] * g[0] + f[0] * g[1],
                f[2] * g[0] + 2.0 * f[1] * g[1] + f[0] * g[2],
            ]
        }
        let (k2, k3) = match *self {
            GaitLaw::Forward(w) => ([0.0; 3], mul(ramp(t, 0.0, w.period), w.eval_sc(x, sn, cs))),
            GaitLaw::Turn {
                wave,
                kind,
                kc3,
                times,
            } => {
                let (al, be) = Self::turn_weights(kind, wave.period, times, t);
                let prop = if al == [0.0; 3] {
                    [0.0; 3]
                } else {
                    mul(al, wave.eval_sc(x, sn, cs))
                };
                (
                    [0.0; 3],
                    [
                        prop[0] + kc3 * be[0],
                        prop[1] + kc3 * be[1],
                        prop[2] + kc3 * be[2],
                    ],
                )
            }
            GaitLaw::Spiral { wave, kc2, kc3 } => {
                let r = ramp(t, 0.0, wave.period);
                let f = wave.eval_sc(x, sn, cs);
                (
                    [kc2 * r[0], kc2 * r[1], kc2 * r[2]],
                    mul(r, [f[0] + kc3, f[1], f[2]]),
                )
            }
        };
        Curvature {
            k: Vector3::new(0.0, k2[0], k3[0]),
            k_dot: Vector3::new(0.0, k2[1], k3[1]),
            k_ddot: Vector3::new(0.0, k2[2], k3[2]),
        }
    }
}

/// A named gait of Tables 1, 3, 5 and 7: the law and the launch speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NamedGait {
    /// Name as in the paper (`F1`..`F7`, `T1`..`T6`, `STOP`, `SPIRAL`).
    pub name: &'static str,
    /// Curvature law.
    pub law: GaitLaw,
    /// Initial head velocity along `t1(0)` (m/s), `V_init`.
    pub v_init: f64,
}

const fn wave(lambda: f64, period: f64, a2: f64, a1: f64, a0: f64, phi: f64) -> Wave {
    Wave {
        lambda,
        period,
        a: [a0, a1, a2],
        phi,
    }
}

const fn fwd(name: &'static str, w: Wave, v_init: f64) -> NamedGait {
    NamedGait {
        name,
        law: GaitLaw::Forward(w),
        v_init,
    }
}

const fn turn(name: &'static str, kind: TurnKind, kc3: f64, times: [f64; 4]) -> NamedGait {
    NamedGait {
        name,
        law: GaitLaw::Turn {
            wave: wave(1.0, 1.0, 2.0, 0.5, 1.0, 0.25),
            kind,
            kc3,
            times,
        },
        v_init: -0.6,
    }
}

/// Every named gait of Tables 1, 3, 5 and 7.
pub const GAITS: [NamedGait; 15] = [
    fwd("F1", wave(1.0, 1.0, 2.0, 0.5, 1.0, 0.0), 0.0),
    fwd("F2", wave(1.25, 1.0, 2.0, 1.0, 0.0, 0.0), 0.0),
    fwd("F3", wave(1.0, 0.5, 2.0, 0.5, 1.0, 0.0), -0.6),
    fwd("F4", wave(1.0, 1.5, 2.0, 0.5, 1.0, 0.0), -0.6),
    fwd("F5", wave(1.0, 1.0, 1.0, 0.5, 2.0, 0.0), -0.6),
    fwd("F6", wave(0.75, 1.0, 1.0, 0.5, 2.0, 0.0), -0.6),
    fwd("F7", wave(1.0, 1.0, 3.5, -4.5, 2.0, 0.0), -0.6),
    turn("T1", TurnKind::InertialPropelled, 2.0, [1.5, 2.0, 2.5, 0.0]),
    turn("T2", TurnKind::InertialPropelled, 2.0, [1.5, 2.5, 3.0, 0.0]),
    turn("T3", TurnKind::InertialPropelled, 2.0, [1.5, 3.5, 4.0, 0.0]),
    turn("T4", TurnKind::Propulsive, 1.0, [1.5, 3.5, 4.0, 0.0]),
    turn("T5", TurnKind::Inertial, 1.0, [0.25, 0.75, 1.75, 2.25]),
    turn("T6", TurnKind::Inertial, 2.0, [0.25, 1.25, 4.25, 5.25]),
    fwd("STOP", wave(-1.0, 1.0, 0.5, 0.5, 0.5, 0.0), -1.5),
    NamedGait {
        name: "SPIRAL",
        law: GaitLaw::Spiral {
            wave: wave(1.0, 1.0, 2.0, 0.5, 1.0, 0.0),
            kc2: 1.0,
            kc3: 1.0,
        },
        v_init: -0.6,
    },
];

/// Looks a named gait up (case-insensitive).
pub fn named_gait(name: &str) -> Option<NamedGait> {
    GAITS
        .iter()
        .find(|g| g.name.eq_ignore_ascii_case(name))
        .copied()
}

/// Comma-separated list of the gait names.
pub fn gait_names() -> String {
    GAITS.iter().map(|g| g.name).collect::<Vec<_>>().join(", ")
}

/// A paper gait as a [`CurvatureSource`] with its own clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LawSource {
    /// The law.
    pub law: GaitLaw,
    /// Current time (s).
    pub t: f64,
}

impl LawSource {
    /// Starts `law` at `t = 0`.
    pub fn new(law: GaitLaw) -> Self {
        Self { law, t: 0.0 }
    }
}

impl CurvatureSource for LawSource {
    fn curvature(&self, tau: f64, x: &[f64], out: &mut [Curvature]) {
        let t = self.t + tau;
        let w = self.law.wave();
        for_each_sin_cos(x, w.phase0(t), w.slope(), |i, s, c| {
            if let Some(o) = out.get_mut(i) {
                *o = self.law.eval_sc(x[i], t, s, c);
            }
        });
    }
    fn advance(&mut self, dt: f64) {
        self.t += dt;
    }
    fn time(&self) -> f64 {
        self.t
    }
    fn is_law_of_time(&self) -> bool {
        true
    }
}

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

/// Measured motion of one universal joint.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct JointMotion {
    /// Pitch angle (rad, about `t2`), rate and acceleration.
    pub pitch: [f64; 3],
    /// Yaw angle (rad, about `t3`), rate and acceleration.
    pub yaw: [f64; 3],
}

/// Curvature spread over the joints of a discrete robot, for the simulated
/// robot: joint `j` (at `X = j/(n+1)`) spreads its angles over its span
/// `[X_j - h/2, X_j + h/2]`, `h = 1/(n+1)`, with a raised-cosine density whose
/// integral over the span is 1, so the curvature integrated over the span
/// (times the body length) equals the joint angle. Rates and accelerations
/// are spread the same way; within a step the angles are extrapolated to
/// second order.
#[derive(Debug, Clone, PartialEq)]
pub struct JointCurvature {
    t: f64,
    length: f64,
    joints: Vec<JointMotion>,
}

impl JointCurvature {
    /// `n` joints on a body of `length` (m), all straight.
    pub fn new(n: usize, length: f64) -> Self {
        Self {
            t: 0.0,
            length,
            joints: vec![JointMotion::default(); n],
        }
    }

    /// Joint motions, to be overwritten with measurements each period.
    pub fn joints_mut(&mut self) -> &mut [JointMotion] {
        &mut self.joints
    }

    /// The joint motions as last set.
    pub fn joints(&self) -> &[JointMotion] {
        &self.joints
    }
}

impl CurvatureSource for JointCurvature {
    fn curvature(&self, tau: f64, x: &[f64], out: &mut [Curvature]) {
        let ext = |a: [f64; 3]| {
            [
                a[0] + a[1] * tau + 0.5 * a[2] * tau * tau,
                a[1] + a[2] * tau,
                a[2],
            ]
        };
        spread_joints(self.joints.len(), self.length, x, out, |j| {
            let m = &self.joints[j];
            (ext(m.pitch), ext(m.yaw))
        });
    }
    fn advance(&mut self, dt: f64) {
        self.t += dt;
    }
    fn time(&self) -> f64 {
        self.t
    }
}

/// The joints' motion over one step from their angles and rates at its
/// start and at its end: a cubic Hermite curve per axis, which the
/// integrator's stages evaluate anywhere in the step. (A [`JointCurvature`]
/// extrapolates from the start with the acceleration held; the simulated
/// robot's body driven so at a 2 ms step swam as one with 22–38 % more
/// lateral drag than the same body driven along the curve:
/// docs/calibration.md.) Spread over the body as [`JointCurvature`]
/// spreads them; not a law of time (each step's curve is set anew).
#[derive(Debug, Clone, PartialEq)]
pub struct JointSegment {
    t: f64,
    h: f64,
    length: f64,
    start: Vec<JointMotion>,
    end: Vec<JointMotion>,
}

impl JointSegment {
    /// `n` joints on a body of `length` (m), all straight, over a step of
    /// 1 s until [`JointSegment::span_mut`] sets it.
    pub fn new(n: usize, length: f64) -> Self {
        Self {
            t: 0.0,
            h: 1.0,
            length,
            start: vec![JointMotion::default(); n],
            end: vec![JointMotion::default(); n],
        }
    }

    /// Sets the step's duration `h` (s, positive) and gives the joints'
    /// motion at its start and at its end to be written: each axis's
    /// `[angle, rate, _]` (the acceleration is the curve's own).
    pub fn span_mut(&mut self, h: f64) -> (&mut [JointMotion], &mut [JointMotion]) {
        self.h = h;
        (&mut self.start, &mut self.end)
    }
}

impl CurvatureSource for JointSegment {
    fn curvature(&self, tau: f64, x: &[f64], out: &mut [Curvature]) {
        let s = tau / self.h;
        spread_joints(self.start.len(), self.length, x, out, |j| {
            let (a, b) = (&self.start[j], &self.end[j]);
            (
                hermite(a.pitch, b.pitch, self.h, s),
                hermite(a.yaw, b.yaw, self.h, s),
            )
        });
    }
    fn advance(&mut self, dt: f64) {
        self.t += dt;
    }
    fn time(&self) -> f64 {
        self.t
    }
}

/// `[value, rate, acceleration]` at the fraction `s` of a span of `h`
/// seconds of the cubic Hermite curve from `a`'s `[value, rate]` to `b`'s
/// (their third entries unused); beyond `0..=1` the cubic goes on.
pub(crate) fn hermite(a: [f64; 3], b: [f64; 3], h: f64, s: f64) -> [f64; 3] {
    let (p0, m0, p1, m1) = (a[0], a[1] * h, b[0], b[1] * h);
    let (s2, s3) = (s * s, s * s * s);
    let value = (2.0 * s3 - 3.0 * s2 + 1.0) * p0
        + (s3 - 2.0 * s2 + s) * m0
        + (-2.0 * s3 + 3.0 * s2) * p1
        + (s3 - s2) * m1;
    let rate = (6.0 * s2 - 6.0 * s) * p0
        + (3.0 * s2 - 4.0 * s + 1.0) * m0
        + (-6.0 * s2 + 6.0 * s) * p1
        + (3.0 * s2 - 2.0 * s) * m1;
    let acc = (12.0 * s - 6.0) * p0
        + (6.0 * s - 4.0) * m0
        + (-12.0 * s + 6.0) * p1
        + (6.0 * s - 2.0) * m1;
    [value, rate / h, acc / (h * h)]
}

/// The curvature at normalized abscissae `x` of `n` joints spread as
/// [`JointCurvature`] spreads them over a body of `length`, joint `j`'s
/// pitch and yaw `[angle, rate, acceleration]` given by `motion(j)`.
/// Allocates nothing.
pub(crate) fn spread_joints(
    n: usize,
    length: f64,
    x: &[f64],
    out: &mut [Curvature],
    motion: impl Fn(usize) -> ([f64; 3], [f64; 3]),
) {
    let h = 1.0 / (n as f64 + 1.0);
    for (o, &xx) in out.iter_mut().zip(x) {
        *o = Curvature::default();
        if n == 0 {
            continue;
        }
        let j = (xx / h).round() as isize;
        if j < 1 || j as usize > n {
            continue;
        }
        let u = (xx - j as f64 * h) / h;
        if u.abs() > 0.5 {
            continue;
        }
        let dens = (1.0 + (2.0 * PI * u).cos()) / (h * length);
        let (p, y) = motion(j as usize - 1);
        o.k = Vector3::new(0.0, p[0], y[0]) * dens;
        o.k_dot = Vector3::new(0.0, p[1], y[1]) * dens;
        o.k_ddot = Vector3::new(0.0, p[2], y[2]) * dens;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fd_check(src: &mut impl CurvatureSource, x: f64, tol: f64) {
        let h = 1e-4;
        let mut o = [Curvature::default(); 3];
        src.curvature(-h, &[x], &mut o[0..1]);
        src.curvature(0.0, &[x], &mut o[1..2]);
        src.curvature(h, &[x], &mut o[2..3]);
        let d1 = (o[2].k - o[0].k) / (2.0 * h);
        let d2 = (o[2].k_dot - o[0].k_dot) / (2.0 * h);
        let t1 = tol * (1.0 + o[1].k_dot.norm());
        let t2 = tol * (1.0 + o[1].k_ddot.norm());
        assert!((d1 - o[1].k_dot).norm() < t1, "{d1} vs {}", o[1].k_dot);
        assert!((d2 - o[1].k_ddot).norm() < t2, "{d2} vs {}", o[1].k_ddot);
    }

    #[test]
    fn analytic_derivatives_match_finite_differences() {
        // central differences with h = 1e-4: truncation ~ h² |K'''| ≈ 1e-8
        // times (2 pi)^3 amplitudes ~ 1e3 -> 1e-5; tolerance 1e-4.
        for g in GAITS {
            for &t in &[0.3, 0.77, 1.2, 1.6, 2.2, 3.7, 4.6, 5.0] {
                for &x in &[0.0, 0.3, 0.9] {
                    let mut s = LawSource::new(g.law);
                    s.t = t;
                    fd_check(&mut s, x, 1e-4);
                }
            }
        }
    }

    #[test]
    fn ramp_is_c2() {
        let h = 1e-6;
        for &(t, a, b) in &[(0.0, 0.0, 1.0), (1.0, 0.0, 1.0), (2.0, 1.5, 2.0)] {
            let l = ramp(t - h, a, b);
            let r = ramp(t + h, a, b);
            for k in 0..3 {
                // jump over 2h bounded by 2h max|f'''| = 2e-6 (2 pi)^2/d^3 < 3e-3
                assert!((l[k] - r[k]).abs() < 3e-3, "{t} {k}");
            }
        }
    }

    #[test]
    fn parametric_gait_is_c2_across_parameter_jumps() {
        let mut g = ParametricGait::from_rest(GaitParams::default(), 0.2).unwrap();
        let dt = 1e-3;
        let x = [0.7];
        let mut prev = [Curvature::default()];
        g.curvature(0.0, &x, &mut prev);
        let mut max_jump = [0.0f64; 3];
        for i in 0..3000 {
            if i == 1000 {
                g.set_target(&GaitParams {
                    period: 0.6,
                    wavelength: 0.8,
                    kc3: 1.5,
                    kc2: -0.5,
                    ..GaitParams::default()
                })
                .unwrap();
            }
            // derivative consistency inside the step
            if i % 250 == 7 {
                fd_check(&mut g, 0.7, 5e-3);
            }
            g.advance(dt);
            let mut c = [Curvature::default()];
            g.curvature(0.0, &x, &mut c);
            max_jump[0] = max_jump[0].max((c[0].k - prev[0].k).norm());
            max_jump[1] = max_jump[1].max((c[0].k_dot - prev[0].k_dot).norm());
            max_jump[2] = max_jump[2].max((c[0].k_ddot - prev[0].k_ddot).norm());
            prev = c;
        }
        // continuity: per-ms changes bounded by (rate × dt); K'' changes by
        // at most K''' dt ~ (2 pi)^3 · 3.4 · 1e-3 / 0.6^3 ~ 4 with faster period.
        assert!(max_jump[0] < 0.05, "{max_jump:?}");
        assert!(max_jump[1] < 0.5, "{max_jump:?}");
        assert!(max_jump[2] < 5.0, "{max_jump:?}");
        let p = g.params();
        // triple pole after 10 time constants: error e^-10 (1 + 10 + 50) ≈ 3e-3 of the jump
        assert!(
            (p.period - 0.6).abs() < 1e-2 && (p.kc3 - 1.5).abs() < 1e-2,
            "{p:?}"
        );
    }

    #[test]
    fn bad_gait_parameters_are_rejected_and_the_target_kept() {
        let mut g = ParametricGait::new(GaitParams::default(), 0.2).unwrap();
        let e = g
            .set_target(&GaitParams {
                period: 0.0,
                ..GaitParams::default()
            })
            .unwrap_err();
        assert!(e.to_string().contains("period"), "{e}");
        let e = g
            .set_target(&GaitParams {
                wavelength: f64::NAN,
                ..GaitParams::default()
            })
            .unwrap_err();
        assert!(e.to_string().contains("wavelength"), "{e}");
        assert!(ParametricGait::new(GaitParams::default(), 0.0).is_err());
        g.advance(0.01);
        assert!((g.params().period - 1.0).abs() < 1e-12);
    }

    #[test]
    fn joint_curvature_integrates_to_joint_angle() {
        let mut j = JointCurvature::new(4, 1.0);
        j.joints_mut()[1].yaw = [0.3, 0.0, 0.0];
        let n = 4000;
        let xs: Vec<f64> = (0..=n).map(|i| i as f64 / n as f64).collect();
        let mut o = vec![Curvature::default(); n + 1];
        j.curvature(0.0, &xs, &mut o);
        let s: f64 = o.iter().map(|c| c.k.z).sum::<f64>() / n as f64;
        assert!((s - 0.3).abs() < 1e-6, "{s}");
    }

    #[test]
    fn a_joint_segment_runs_from_its_start_to_its_end_along_its_rates() {
        let mut j = JointSegment::new(3, 1.0);
        let h = 0.002;
        let (a, b) = j.span_mut(h);
        a[1].pitch = [0.1, 2.0, 0.0];
        b[1].pitch = [0.1045, 2.5, 0.0];
        a[1].yaw = [-0.2, -1.0, 0.0];
        b[1].yaw = [-0.2021, -1.1, 0.0];
        // joint 2's span is centred at x = 2/4
        let x = [0.5];
        let dens = 2.0 / (0.25 * 1.0);
        let mut o = [Curvature::default(); 1];
        j.curvature(0.0, &x, &mut o);
        assert!((o[0].k.y / dens - 0.1).abs() < 1e-12 && (o[0].k_dot.y / dens - 2.0).abs() < 1e-9);
        j.curvature(h, &x, &mut o);
        assert!(
            (o[0].k.y / dens - 0.1045).abs() < 1e-12,
            "{}",
            o[0].k.y / dens
        );
        assert!((o[0].k_dot.z / dens + 1.1).abs() < 1e-9);
        // rate and acceleration are the angle's derivatives within the step
        fd_check(&mut j, 0.5, 1e-4);
        // so is the acceleration the rate's, where the pitch rate grows by
        // 0.5 rad/s over the step: 250 rad/s² on average
        let mut acc = 0.0;
        for i in 0..100 {
            j.curvature(h * (i as f64 + 0.5) / 100.0, &x, &mut o);
            acc += o[0].k_ddot.y / dens / 100.0;
        }
        assert!((acc - 250.0).abs() < 1e-6, "{acc}");
    }

    #[test]
    fn every_table_gait_is_named() {
        assert_eq!(GAITS.len(), 15);
        assert!(named_gait("f1").is_some());
        assert!(named_gait("X9").is_none());
        assert!(gait_names().contains("SPIRAL"));
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { cases: 24, ..Default::default() })]
        /// Random target sequences (fixed seed by proptest's default config):
        /// the curvature stays finite and its per-step changes bounded by its
        /// rates (C0/C1 continuity in the discrete sense).
        #[test]
        fn parametric_gait_random_targets_stay_finite_and_continuous(
            targets in proptest::collection::vec(
                (0.3f64..2.0, 0.4f64..2.0, 0.0f64..3.0, -2.0f64..2.0, -1.0f64..1.0), 1..5)
        ) {
            let mut g = ParametricGait::from_rest(GaitParams::default(), 0.1).unwrap();
            let dt = 1e-3;
            let x = [0.0, 0.5, 1.0];
            let mut prev = [Curvature::default(); 3];
            g.curvature(0.0, &x, &mut prev);
            for (k, &(lambda, period, a2, kc3, kc2)) in targets.iter().enumerate() {
                g.set_target(&GaitParams { wavelength: lambda, period, amplitude: [1.0, 0.5, a2], phase: 0.1 * k as f64, kc3, kc2 }).unwrap();
                for _ in 0..400 {
                    g.advance(dt);
                    let mut c = [Curvature::default(); 3];
                    g.curvature(0.0, &x, &mut c);
                    for (a, b) in c.iter().zip(&prev) {
                        proptest::prop_assert!(a.k.iter().chain(a.k_dot.iter()).chain(a.k_ddot.iter()).all(|v| v.is_finite()));
                        // |dK| <= max|K'| dt with margin 2: K' bounded by the rates seen
                        let bound = 2.0 * dt * (a.k_dot.norm().max(b.k_dot.norm()) + 1e-9) + 1e-6;
                        proptest::prop_assert!((a.k - b.k).norm() <= bound, "{} > {}", (a.k - b.k).norm(), bound);
                    }
                    prev = c;
                }
            }
        }
    }
}
