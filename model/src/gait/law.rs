//! The paper's curvature laws (42)–(46): the propulsive [`Wave`], the
//! forward, turning and spiral [`GaitLaw`]s, the named gaits of its tables
//! ([`GAITS`]), and a law as a [`CurvatureSource`] ([`LawSource`]).

use core::f64::consts::PI;
use nalgebra::Vector3;

use super::{Curvature, CurvatureSource, for_each_sin_cos};

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
