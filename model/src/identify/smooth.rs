//! The recorded joint motion, smoothed: every axis's angles and rates
//! fused by a Kalman filter and a Rauch–Tung–Striebel smoother.
//!
//! A drive reports its angle and rate quantised (an encoder's count, a
//! CAN frame's bits) and a session keeps them at a fraction of the control
//! rate. A cubic Hermite curve through the raw samples puts the angle's
//! quantisation, divided by the square of the sample interval, into the
//! accelerations that drive the model's reactive forces: on the simulated
//! robot recorded over CAN FD (50 Hz, 1.5 mrad) that is about 6 rad/s² of
//! noise on a pitch joint whose true acceleration is a few rad/s², enough
//! to move the fitted coefficients by tens of percent.
//!
//! Each axis is a triple integrator (angle, rate, acceleration) driven by
//! white jerk of spectral density `q`, measured in angle and rate with the
//! noise of their quantum (`step / √12`, the smallest step the recording
//! shows). `q` is the value of a grid (half-decades) that maximises the
//! measurements' likelihood, chosen per axis: the data say how fast the
//! joint moves. The smoother's angles and rates replace the recorded ones
//! (the Hermite curve through them is then consistent with its rates).

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};

use super::swim::{JointSample, Swim};

/// The jerk densities tried ((rad/s³)²·s), in half-decades.
const Q_GRID: std::ops::RangeInclusive<i32> = -2..=16;

/// A measurement noise (standard deviation) never below this fraction of
/// the axis's RMS, so that a recording with exact values (a synthetic
/// swim) does not make the filter singular.
const NOISE_FLOOR: f64 = 1e-9;

/// The smallest step between two different consecutive values of any of
/// `series` (f32-rounded values that differ by less than `1e-6` of their
/// size are the same value); `None` when nothing moves.
fn quantum<'a>(series: impl Iterator<Item = &'a [f64]>) -> Option<f64> {
    let mut best: Option<f64> = None;
    for s in series {
        for w in s.windows(2) {
            let d = (w[1] - w[0]).abs();
            let tol = 1e-6 * w[0].abs().max(w[1].abs()).max(1e-3);
            if d > tol && d.is_finite() && best.is_none_or(|b| d < b) {
                best = Some(d);
            }
        }
    }
    best
}

/// One series per axis (pitch and yaw of joint 1 first) of `field`.
fn axes(swim: &Swim, field: fn(&JointSample) -> &Vec<[f64; 2]>) -> Vec<Vec<f64>> {
    (0..swim.joints())
        .flat_map(|j| (0..2).map(move |ax| (j, ax)))
        .map(|(j, ax)| swim.samples.iter().map(|s| field(s)[j][ax]).collect())
        .collect()
}

/// The smallest steps `[angle (rad), rate (rad/s)]` the recorded joint
/// motion of `swim` shows: its resolution, as quantised by the drives and
/// their bus frames (`None` when nothing moves).
pub fn steps(swim: &Swim) -> [Option<f64>; 2] {
    let (a, r) = (axes(swim, |s| &s.angle), axes(swim, |s| &s.rate));
    [
        quantum(a.iter().map(|v| &v[..])),
        quantum(r.iter().map(|v| &v[..])),
    ]
}

/// Recorded rates coarser than this (rad/s) bias the fit
/// (docs/calibration.md: classic CAN's 0.08 rad/s does, CAN FD's
/// 0.005 rad/s does not).
pub const COARSE_RATE: f64 = 0.02;

/// One axis's filter and smoother; `z` are `(t, angle, rate)`.
struct Axis<'a> {
    z: &'a [(f64, f64, f64)],
    r: Matrix2<f64>,
}

/// The filter's pass: (predicted means and covariances, updated ones,
/// log-likelihood).
type Pass = (
    Vec<Vector3<f64>>,
    Vec<Matrix3<f64>>,
    Vec<Vector3<f64>>,
    Vec<Matrix3<f64>>,
    f64,
);

impl Axis<'_> {
    fn transition(h: f64, q: f64) -> (Matrix3<f64>, Matrix3<f64>) {
        let f = Matrix3::new(1.0, h, h * h / 2.0, 0.0, 1.0, h, 0.0, 0.0, 1.0);
        let (h2, h3) = (h * h, h * h * h);
        let qm = Matrix3::new(
            h2 * h3 / 20.0,
            h2 * h2 / 8.0,
            h3 / 6.0,
            h2 * h2 / 8.0,
            h3 / 3.0,
            h2 / 2.0,
            h3 / 6.0,
            h2 / 2.0,
            h,
        ) * q;
        (f, qm)
    }

    fn filter(&self, q: f64) -> Pass {
        let n = self.z.len();
        let hm = Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        let (mut xp, mut pp, mut xu, mut pu) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        let (t0, a0, w0) = self.z[0];
        let mut x = Vector3::new(a0, w0, 0.0);
        // a vague start: the first measurements, any acceleration
        let mut p = Matrix3::from_diagonal(&Vector3::new(
            self.r[(0, 0)] * 1e2,
            self.r[(1, 1)] * 1e2,
            1e6,
        ));
        let mut last = t0;
        let mut ll = 0.0;
        for &(t, a, w) in self.z {
            if t > last {
                let (f, qm) = Self::transition(t - last, q);
                x = f * x;
                p = f * p * f.transpose() + qm;
                last = t;
            }
            xp.push(x);
            pp.push(p);
            let nu = Vector2::new(a, w) - hm * x;
            let s = hm * p * hm.transpose() + self.r;
            let Some(si) = s.try_inverse() else {
                ll = f64::NEG_INFINITY;
                xu.push(x);
                pu.push(p);
                continue;
            };
            ll -= 0.5 * ((nu.transpose() * si * nu)[(0, 0)] + s.determinant().max(1e-300).ln());
            let k = p * hm.transpose() * si;
            x += k * nu;
            // Joseph form: stays symmetric and positive
            let ikh = Matrix3::identity() - k * hm;
            p = ikh * p * ikh.transpose() + k * self.r * k.transpose();
            xu.push(x);
            pu.push(p);
        }
        (xp, pp, xu, pu, ll)
    }

    /// The smoothed (angle, rate) at every sample.
    fn smooth(&self, q: f64) -> Vec<(f64, f64)> {
        let (xp, pp, xu, pu, _) = self.filter(q);
        let n = self.z.len();
        let mut xs = xu.clone();
        for k in (0..n.saturating_sub(1)).rev() {
            let h = self.z[k + 1].0 - self.z[k].0;
            if h <= 0.0 {
                xs[k] = xs[k + 1];
                continue;
            }
            let (f, _) = Self::transition(h, q);
            let Some(pi) = pp[k + 1].try_inverse() else {
                continue;
            };
            let c = pu[k] * f.transpose() * pi;
            xs[k] = xu[k] + c * (xs[k + 1] - xp[k + 1]);
        }
        xs.iter().map(|x| (x[0], x[1])).collect()
    }
}

/// `swim` with every axis's angles and rates smoothed (the module's top
/// comment); torques, track and attitude unchanged. The jerk density
/// chosen per axis is returned with it, pitch and yaw of joint 1 first.
pub fn smooth(swim: &Swim) -> (Swim, Vec<[f64; 2]>) {
    let mut out = swim.clone();
    let n = swim.joints();
    let mut chosen = vec![[f64::NAN; 2]; n];
    if swim.samples.len() < 3 {
        return (out, chosen);
    }
    let (angles, rates) = (axes(swim, |s| &s.angle), axes(swim, |s| &s.rate));
    let rms = |v: &[Vec<f64>]| {
        let (s, c) = v
            .iter()
            .flatten()
            .fold((0.0, 0usize), |(s, c), x| (s + x * x, c + 1));
        (s / c.max(1) as f64).sqrt().max(1e-6)
    };
    let sd =
        |q: Option<f64>, scale: f64| q.map_or(0.0, |q| q / 12f64.sqrt()).max(NOISE_FLOOR * scale);
    let [qa, qw] = steps(swim);
    let sa = sd(qa, rms(&angles));
    let sw = sd(qw, rms(&rates));
    let r = Matrix2::new(sa * sa, 0.0, 0.0, sw * sw);
    for (i, (a, w)) in angles.iter().zip(&rates).enumerate() {
        let z: Vec<(f64, f64, f64)> = swim
            .samples
            .iter()
            .zip(a.iter().zip(w))
            .map(|(s, (&a, &w))| (s.t, a, w))
            .collect();
        let axis = Axis { z: &z, r };
        let q = Q_GRID
            .map(|e| 10f64.powf(e as f64 / 2.0))
            .map(|q| (q, axis.filter(q).4))
            .filter(|(_, ll)| ll.is_finite())
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map_or(1e4, |(q, _)| q);
        let (j, ax) = (i / 2, i % 2);
        chosen[j][ax] = q;
        for (s, (a, w)) in out.samples.iter_mut().zip(axis.smooth(q)) {
            s.angle[j][ax] = a;
            s.rate[j][ax] = w;
        }
    }
    (out, chosen)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sine sampled at 50 Hz, quantised to 1.5 mrad and 5 mrad/s: the
    /// smoothed curve's acceleration (from its rates) is several times
    /// closer to the truth than the raw Hermite's would be, and the
    /// angles stay within the quantum.
    #[test]
    fn quantised_motion_is_smoothed_towards_the_truth() {
        let (a, w) = (0.06, 2.0 * std::f64::consts::PI * 1.2);
        let qa = 2.0 * std::f64::consts::PI / 4096.0;
        let qw = 0.005;
        let quant = |v: f64, q: f64| (v / q).round() * q;
        let samples: Vec<JointSample> = (0..1500)
            .map(|k| {
                let t = k as f64 * 0.02;
                JointSample {
                    t,
                    angle: vec![[quant(a * (w * t).sin(), qa), 0.0]],
                    rate: vec![[quant(a * w * (w * t).cos(), qw), 0.0]],
                    torque: vec![[0.0; 2]],
                }
            })
            .collect();
        let swim = Swim {
            name: "sine".into(),
            samples,
            ..Swim::default()
        };
        // the recording's resolution, as `anguilla calibrate` reports it:
        // CAN FD's rate steps (5 mrad/s) are not coarse
        let [Some(sa), Some(sw)] = steps(&swim) else {
            panic!("the sine moves")
        };
        assert!((sa / qa - 1.0).abs() < 1e-6, "angle step {sa}");
        assert!((sw / qw - 1.0).abs() < 1e-6, "rate step {sw}");
        assert!(sw < COARSE_RATE, "CAN FD steps flagged as coarse");
        let (sm, q) = smooth(&swim);
        assert!(q[0][0].is_finite());
        // the accelerations a Hermite curve sees at the nodes: from the
        // angle differences and the rates
        let acc_err = |s: &Swim| {
            let mut e = 0.0;
            let n = s.samples.len();
            for k in 100..n - 100 {
                let (p, c) = (&s.samples[k], &s.samples[k + 1]);
                let h = c.t - p.t;
                let acc = (6.0 * (c.angle[0][0] - p.angle[0][0])
                    - h * (4.0 * p.rate[0][0] + 2.0 * c.rate[0][0]))
                    / (h * h);
                let truth = -a * w * w * (w * p.t).sin();
                e += (acc - truth).powi(2);
            }
            (e / (n - 200) as f64).sqrt()
        };
        let (raw, smoothed) = (acc_err(&swim), acc_err(&sm));
        assert!(smoothed < raw / 3.0, "raw {raw}, smoothed {smoothed}");
        for s in &sm.samples[100..1400] {
            let truth = a * (w * s.t).sin();
            assert!(
                (s.angle[0][0] - truth).abs() < qa,
                "{} vs {truth}",
                s.angle[0][0]
            );
        }
    }
}
