//! Curvature from the joints' motion: measured angles spread over the body
//! ([`JointCurvature`]), or a step's start and end joined by a cubic
//! ([`JointSegment`]).

use core::f64::consts::PI;
use nalgebra::Vector3;

use super::{Curvature, CurvatureSource};

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
pub fn hermite(a: [f64; 3], b: [f64; 3], h: f64, s: f64) -> [f64; 3] {
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
