//! The model replaying a recorded swim, and how far it is from the
//! recording: the channels compared, their residuals and their errors.

use super::swim::Swim;
use crate::body::Body;
use crate::dynamics::{HeadState, Model, ModelConfig, Workspace, body_axis, step};
use crate::error::Result;
use crate::gait::{CurvatureSource, hermite, spread_joints};
use crate::{Curvature, Integrator};

/// The window (s) over which speed, turn rate and depth rate are taken: a
/// whole tail beat at 1 Hz, so the head's sway averages out.
pub const WINDOW: f64 = 1.0;
/// The grid (s) on which they are compared.
pub const GRID: f64 = 0.1;

/// The floors of the groups' scales: speed (m/s), turn rate (rad/s), depth
/// rate (m/s), head sway (rad), torque (N·m). A group whose measured RMS is below its
/// floor is divided by the floor (a swim that never dives weighs its
/// depth rate in centimetres per second, not in its own noise).
pub const FLOORS: [f64; GROUPS] = [0.02, 0.02, 0.01, 0.01, 0.02];

/// The residual groups: speed, turn, dive, sway, torque.
pub const GROUPS: usize = 5;

/// The drive's own terms in a measured torque, fitted with every body
/// (nuisances, not the water's): its reflected inertia `J`, viscous
/// friction `b` and torque lag, `τ_measured(t) = τ_model(t − lag) + J θ̈ + b θ̇`.
pub const DRIVE: usize = 3;
/// The torque group's index.
pub(super) const TORQUE: usize = 4;

/// What the model did replaying one swim: its pose after every step and
/// its joint torques at every step's start.
#[derive(Debug, Clone, Default)]
pub struct Trace {
    /// Times (s) of the poses.
    pub t: Vec<f64>,
    /// The nose's horizontal position `[x, y]` (m).
    pub xy: Vec<[f64; 2]>,
    /// The body's heading (rad, counter-clockwise, unwrapped).
    pub heading: Vec<f64>,
    /// The nose's depth (m, down).
    pub depth: Vec<f64>,
    /// The head's roll rate (rad/s).
    pub roll_rate: Vec<f64>,
    /// The head's yaw (rad, unwrapped).
    pub head_yaw: Vec<f64>,
    /// Times (s) of the torques.
    pub torque_t: Vec<f64>,
    /// Torques `[pitch, yaw]` of every joint at every step, row by row.
    pub torque: Vec<[f64; 2]>,
}

/// The compared channels of one swim on the grid: forward speed (m/s),
/// turn rate (rad/s) and depth rate (m/s), each over [`WINDOW`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Channels {
    /// Grid times (s).
    pub t: Vec<f64>,
    /// Horizontal speed of the nose.
    pub speed: Vec<f64>,
    /// Turn rate.
    pub turn: Vec<f64>,
    /// Depth rate.
    pub dive: Vec<f64>,
    /// The head's sway: the RMS of its yaw about a straight line over the
    /// window (rad), the tail beat's recoil, which lateral drag resists.
    pub sway: Vec<f64>,
}

/// The recorded side, computed once: each swim's channels and joint
/// accelerations, and the groups' scales.
#[derive(Debug, Clone)]
pub struct Measured {
    pub(super) channels: Vec<Channels>,
    /// Per swim, per sample, per joint: accelerations `[pitch, yaw]`.
    pub(super) accel: Vec<Vec<Vec<[f64; 2]>>>,
    /// Scales of speed, turn, dive, sway, torque.
    pub(super) scales: [f64; GROUPS],
    /// Counts of speed, turn, dive, sway and torque residuals.
    pub(super) counts: [usize; GROUPS],
    /// How far apart one axis's consecutive torque residuals are (two
    /// per joint: they are pushed sample by sample, joint by joint).
    pub(super) torque_stride: usize,
    /// The drives' reflected inertia, viscous friction and torque lag, if
    /// known; otherwise fitted with every body by least squares.
    pub(super) actuator: Option<[f64; DRIVE]>,
}

fn interp(t: &[f64], v: impl Fn(usize) -> f64, at: f64) -> f64 {
    let i = t.partition_point(|&x| x <= at).clamp(1, t.len().max(2) - 1);
    let (t0, t1) = (t[i - 1], t[i]);
    let u = if t1 > t0 {
        ((at - t0) / (t1 - t0)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    v(i - 1) + u * (v(i) - v(i - 1))
}

fn wrap(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for x in v.filter(|x| x.is_finite()) {
        s += x * x;
        n += 1;
    }
    if n == 0 { 0.0 } else { (s / n as f64).sqrt() }
}

impl Measured {
    /// The recorded channels and accelerations of `swims`.
    pub fn of(swims: &[Swim], torque_weight: f64) -> Self {
        let channels: Vec<Channels> = swims.iter().map(measured_channels).collect();
        let accel = swims.iter().map(accelerations).collect();
        let all = |f: fn(&Channels) -> &Vec<f64>| rms(channels.iter().flat_map(f).copied());
        let count = |f: fn(&Channels) -> &Vec<f64>| {
            channels
                .iter()
                .flat_map(f)
                .filter(|v| v.is_finite())
                .count()
        };
        let torque = rms(swims
            .iter()
            .flat_map(|s| &s.samples)
            .flat_map(|s| &s.torque)
            .flatten()
            .copied());
        let raw = [
            all(|c| &c.speed),
            all(|c| &c.turn),
            all(|c| &c.dive),
            all(|c| &c.sway),
            torque,
        ];
        let mut scales: [f64; GROUPS] = std::array::from_fn(|i| raw[i].max(FLOORS[i]));
        scales[TORQUE] /= torque_weight.max(1e-9).sqrt();
        let counts = [
            count(|c| &c.speed),
            count(|c| &c.turn),
            count(|c| &c.dive),
            count(|c| &c.sway),
            swims
                .iter()
                .flat_map(|s| &s.samples)
                .flat_map(|s| &s.torque)
                .flatten()
                .filter(|v| v.is_finite())
                .count(),
        ];
        Self {
            channels,
            accel,
            scales,
            counts,
            torque_stride: 2 * swims.first().map_or(1, Swim::joints),
            actuator: None,
        }
    }
}

/// The grid of a swim: every [`GRID`] within its samples, half a window
/// from either end.
fn grid(swim: &Swim) -> Vec<f64> {
    let (Some(a), Some(b)) = (swim.samples.first(), swim.samples.last()) else {
        return Vec::new();
    };
    let (start, end) = (a.t + WINDOW / 2.0, b.t - WINDOW / 2.0);
    let n = ((end - start) / GRID).floor();
    if n.is_nan() || n < 0.0 {
        return Vec::new();
    }
    (0..=n as usize).map(|i| start + i as f64 * GRID).collect()
}

/// A pose series: times, and a value `[a, b]` at each.
type Series<'a> = (&'a [f64], &'a dyn Fn(usize) -> [f64; 2]);

/// How far short of a window's end a series may stop and still cover it
/// (s): the grid's first window starts at the swim's first sample, which
/// `(t + WINDOW / 2) - WINDOW / 2` may miss by a rounding.
const COVER_SLACK: f64 = 1e-6;

/// Whether `ts` covers the window around `g`.
fn covers(ts: &[f64], g: f64) -> bool {
    ts.len() >= 2
        && ts[0] <= g - WINDOW / 2.0 + COVER_SLACK
        && ts[ts.len() - 1] >= g + WINDOW / 2.0 - COVER_SLACK
}

/// The channels over `grid` (NaN where the series do not cover a window)
/// of the nose's horizontal track `[x, y]` and of the attitude
/// `[unwrapped heading, depth]`.
fn channels_of(
    grid: &[f64],
    track: Option<Series>,
    att: Option<Series>,
    yaw: Option<(&[f64], &[f64])>,
) -> Channels {
    let nan = vec![f64::NAN; grid.len()];
    let mut c = Channels {
        t: grid.to_vec(),
        speed: nan.clone(),
        turn: nan.clone(),
        dive: nan.clone(),
        sway: nan,
    };
    for (i, &g) in grid.iter().enumerate() {
        let (a, b) = (g - WINDOW / 2.0, g + WINDOW / 2.0);
        if let Some((t, xy)) = track
            && covers(t, g)
        {
            let p = |at| [interp(t, |k| xy(k)[0], at), interp(t, |k| xy(k)[1], at)];
            let (pa, pb) = (p(a), p(b));
            c.speed[i] = (pb[0] - pa[0]).hypot(pb[1] - pa[1]) / WINDOW;
        }
        if let Some((t, hd)) = att
            && covers(t, g)
        {
            let v = |at, ax: usize| interp(t, |k| hd(k)[ax], at);
            c.turn[i] = (v(b, 0) - v(a, 0)) / WINDOW;
            c.dive[i] = (v(b, 1) - v(a, 1)) / WINDOW;
        }
        if let Some((t, y)) = yaw
            && covers(t, g)
        {
            c.sway[i] = sway(t, y, a, b);
        }
    }
    c
}

/// The RMS of `y` about its least-squares line over the samples in
/// `[a, b]` (NaN with fewer than five).
fn sway(t: &[f64], y: &[f64], a: f64, b: f64) -> f64 {
    let (i0, i1) = (
        t.partition_point(|&x| x < a),
        t.partition_point(|&x| x <= b),
    );
    let n = i1.saturating_sub(i0);
    if n < 5 {
        return f64::NAN;
    }
    let (ts, ys) = (&t[i0..i1], &y[i0..i1]);
    let nf = n as f64;
    let tm = ts.iter().sum::<f64>() / nf;
    let ym = ys.iter().sum::<f64>() / nf;
    let (mut stt, mut sty) = (0.0, 0.0);
    for (x, v) in ts.iter().zip(ys) {
        stt += (x - tm) * (x - tm);
        sty += (x - tm) * (v - ym);
    }
    let slope = if stt > 0.0 { sty / stt } else { 0.0 };
    let ss: f64 = ts
        .iter()
        .zip(ys)
        .map(|(x, v)| {
            let r = v - ym - slope * (x - tm);
            r * r
        })
        .sum();
    (ss / nf).sqrt()
}

fn measured_channels(swim: &Swim) -> Channels {
    let tt: Vec<f64> = swim.track.iter().map(|p| p[0]).collect();
    let ta: Vec<f64> = swim.attitude.iter().map(|p| p[0]).collect();
    let mut heading = Vec::with_capacity(ta.len());
    for p in &swim.attitude {
        let h = match heading.last() {
            Some(&last) => last + wrap(p[1] - last),
            None => p[1],
        };
        heading.push(h);
    }
    let ty: Vec<f64> = swim.head_yaw.iter().map(|p| p[0]).collect();
    let mut yaw: Vec<f64> = Vec::with_capacity(ty.len());
    for p in &swim.head_yaw {
        let y = match yaw.last() {
            Some(&last) => last + wrap(p[1] - last),
            None => p[1],
        };
        yaw.push(y);
    }
    let xy = |i: usize| [swim.track[i][1], swim.track[i][2]];
    let att = |i: usize| [heading[i], swim.attitude[i][2]];
    channels_of(
        &grid(swim),
        (!tt.is_empty()).then_some((&tt[..], &xy as &dyn Fn(usize) -> [f64; 2])),
        (!ta.is_empty()).then_some((&ta[..], &att as &dyn Fn(usize) -> [f64; 2])),
        (!ty.is_empty()).then_some((&ty[..], &yaw[..])),
    )
}

/// Joint accelerations at every sample: central differences of the
/// measured rates (one-sided at the ends).
fn accelerations(swim: &Swim) -> Vec<Vec<[f64; 2]>> {
    let s = &swim.samples;
    let n = s.len();
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
            let dt = s[b].t - s[a].t;
            (0..swim.joints())
                .map(|j| {
                    std::array::from_fn(|ax| {
                        if dt > 0.0 {
                            (s[b].rate[j][ax] - s[a].rate[j][ax]) / dt
                        } else {
                            0.0
                        }
                    })
                })
                .collect()
        })
        .collect()
}

/// Joint `j`'s pitch and yaw `[angle, rate, acceleration]` at `t` from a
/// cubic Hermite curve through the samples (angles and rates at both ends
/// of the segment `k`).
fn joint_at(swim: &Swim, k: usize, t: f64, j: usize) -> ([f64; 3], [f64; 3]) {
    let kb = (k + 1).min(swim.samples.len() - 1);
    let (a, b) = (&swim.samples[k], &swim.samples[kb]);
    let h = (b.t - a.t).max(1e-9);
    let s = ((t - a.t) / h).clamp(0.0, 1.0);
    let axis = |ax: usize| {
        hermite(
            [a.angle[j][ax], a.rate[j][ax], 0.0],
            [b.angle[j][ax], b.rate[j][ax], 0.0],
            h,
            s,
        )
    };
    (axis(0), axis(1))
}

/// The recorded joint motion as a law of time: every stage of a step sees
/// the joints where the Hermite curve through the samples has them then.
/// (Extrapolated from the step's start instead, as the simulated robot's
/// [`JointCurvature`](crate::JointCurvature) was, the joints'
/// acceleration is off by the jerk times the step within it, and the fit
/// at 5 ms found `c2` 8.7 % lower than at 2.5 ms: RK4 is fourth-order only
/// in a source it can evaluate anywhere.)
struct Recorded<'a> {
    swim: &'a Swim,
    t: f64,
    length: f64,
}

impl CurvatureSource for Recorded<'_> {
    fn curvature(&self, tau: f64, x: &[f64], out: &mut [Curvature]) {
        let at = self.t + tau;
        let s = &self.swim.samples;
        // the segment holding `at` (the first or last beyond the ends)
        let k = s
            .partition_point(|p| p.t <= at)
            .clamp(1, s.len().max(2) - 1)
            - 1;
        spread_joints(self.swim.joints(), self.length, x, out, |j| {
            joint_at(self.swim, k, at, j)
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

/// Replays `swim` on the model of `body` (`nodes` space nodes, time step
/// `dt`, RK4), from rest, its joints moving as recorded.
pub fn simulate(body: &Body, swim: &Swim, nodes: usize, dt: f64) -> Result<Trace> {
    let joints = swim.joints();
    let model = Model::new(ModelConfig {
        body: body.clone(),
        nodes,
        dt,
        joints,
        integrator: Integrator::Rk4,
    })?;
    let mut ws = Workspace::new(&model);
    let mut head = HeadState::launch(0.0);
    let t0 = swim.samples[0].t;
    let end = swim.samples[swim.samples.len() - 1].t;
    let mut src = Recorded {
        swim,
        t: t0,
        length: body.length,
    };
    // to the last sample or just past it: the last window ends there
    let steps = ((end - t0) / dt - 1e-9).ceil().max(0.0) as usize;
    let mut tr = Trace {
        t: Vec::with_capacity(steps + 1),
        xy: Vec::with_capacity(steps + 1),
        heading: Vec::with_capacity(steps + 1),
        depth: Vec::with_capacity(steps + 1),
        roll_rate: Vec::with_capacity(steps + 1),
        head_yaw: Vec::with_capacity(steps + 1),
        torque_t: Vec::with_capacity(steps),
        torque: Vec::with_capacity(steps * joints),
    };
    let mut last_heading = f64::NAN;
    for i in 0..=steps {
        let t = t0 + i as f64 * dt;
        if i > 0 {
            // the torques are the step's start's (its first evaluation)
            step(&model, &mut ws, &mut src, &mut head)?;
            tr.torque_t.push(t - dt);
            tr.torque
                .extend(ws.joints().iter().map(|j| j.actuator_torque()));
        } else {
            crate::evaluate(&model, &mut ws, &src, &head)?;
        }
        let forward = head.orientation * body_axis(ws.shape());
        let raw = forward.y.atan2(forward.x);
        let heading = if last_heading.is_nan() {
            raw
        } else {
            last_heading + wrap(raw - last_heading)
        };
        last_heading = heading;
        tr.t.push(t);
        tr.xy.push([head.position.x, head.position.y]);
        tr.heading.push(heading);
        tr.depth.push(-head.position.z);
        tr.roll_rate.push(head.roll_rate());
        let yaw = head.yaw();
        tr.head_yaw.push(match tr.head_yaw.last() {
            Some(&last) => last + wrap(yaw - last),
            None => yaw,
        });
    }
    Ok(tr)
}

/// The model's channels of a trace on the grid of `swim`.
fn model_channels(tr: &Trace, swim: &Swim) -> Channels {
    // the head's yaw at the recording's instants, so that both sways are
    // sampled alike
    let ty: Vec<f64> = swim.head_yaw.iter().map(|p| p[0]).collect();
    let yaw: Vec<f64> = ty
        .iter()
        .map(|&t| interp(&tr.t, |i| tr.head_yaw[i], t))
        .collect();
    let xy = |i: usize| tr.xy[i];
    let att = |i: usize| [tr.heading[i], tr.depth[i]];
    channels_of(
        &grid(swim),
        Some((&tr.t[..], &xy as &dyn Fn(usize) -> [f64; 2])),
        Some((&tr.t[..], &att as &dyn Fn(usize) -> [f64; 2])),
        (!ty.is_empty()).then_some((&ty[..], &yaw[..])),
    )
}

/// The errors of a body against swims, in their units.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Evaluation {
    /// The weighted cost (the fit's objective: the groups' mean squared
    /// errors over their scales, summed).
    pub cost: f64,
    /// RMS errors: speed (m/s), turn rate (rad/s), depth rate (m/s), head
    /// sway (rad), torque (N·m); NaN where the swims have no such channel.
    pub rms: [f64; GROUPS],
    /// The drives' own reflected inertia (kg·m²), viscous friction
    /// (N·m·s/rad) and torque lag (s) the torques were fitted with.
    pub actuator: [f64; DRIVE],
    /// Per swim: its name, its mean measured speed and the model's (m/s),
    /// its torque RMS error (N·m).
    pub swims: Vec<SwimError>,
    /// RMS roll rate of the replayed head (rad/s).
    pub roll_rate_rms: f64,
}

/// One swim's errors.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SwimError {
    /// The swim's name.
    pub name: String,
    /// Its mean measured speed over the grid (m/s; NaN without a track).
    pub speed: f64,
    /// The model's (m/s).
    pub model_speed: f64,
    /// Its torque RMS error (N·m).
    pub torque_rms: f64,
    /// The largest mean torque error of one axis over a
    /// [`BIAS_WINDOW`] (what the model and the drive's terms leave: a
    /// swim's own error oscillates and averages out, a snag does not).
    pub worst_bias: Option<TorqueBias>,
}

/// The window (s) over which [`TorqueBias`] averages one axis's torque
/// error.
pub const BIAS_WINDOW: f64 = 2.0;

/// One axis's torque error averaged over windows: the worst window's.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TorqueBias {
    /// The axis: joint (from 0, head first) and 0 pitch, 1 yaw.
    pub joint: usize,
    /// 0 pitch, 1 yaw.
    pub axis: usize,
    /// From the first to the last window (s from the swim's first
    /// sample) whose mean is beyond half the worst.
    pub from: f64,
    /// Until (s).
    pub until: f64,
    /// The worst window's mean error (N·m; measured less the model).
    pub mean: f64,
    /// The median |mean| over every axis and window (N·m).
    pub typical: f64,
}

/// The worst [`TorqueBias`] of one swim's torque errors `(sample, axis
/// index j·2+ax, error)`.
fn worst_bias(s: &Swim, errors: &[(usize, usize, f64)]) -> Option<TorqueBias> {
    let t0 = s.samples.first()?.t;
    let windows = (s.duration() / BIAS_WINDOW).floor() as usize + 1;
    let axes = 2 * s.joints();
    let mut sum = vec![(0.0f64, 0usize); windows * axes];
    for &(k, a, e) in errors {
        let w = (((s.samples[k].t - t0) / BIAS_WINDOW) as usize).min(windows - 1);
        let c = &mut sum[w * axes + a];
        c.0 += e;
        c.1 += 1;
    }
    let means: Vec<f64> = sum
        .iter()
        .map(|&(e, n)| if n > 0 { e / n as f64 } else { f64::NAN })
        .collect();
    let mut abs: Vec<f64> = means
        .iter()
        .filter(|m| m.is_finite())
        .map(|m| m.abs())
        .collect();
    if abs.is_empty() {
        return None;
    }
    abs.sort_by(f64::total_cmp);
    let typical = abs[abs.len() / 2];
    let (i, &mean) = means
        .iter()
        .enumerate()
        .filter(|(_, m)| m.is_finite())
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
    let a = i % axes;
    let beyond: Vec<usize> = (0..windows)
        .filter(|w| means[w * axes + a].abs() > 0.5 * mean.abs())
        .collect();
    Some(TorqueBias {
        joint: a / 2,
        axis: a % 2,
        from: BIAS_WINDOW * beyond[0] as f64,
        until: (BIAS_WINDOW * (beyond[beyond.len() - 1] + 1) as f64).min(s.duration()),
        mean,
        typical,
    })
}

impl SwimError {
    /// The model's speed error relative to the measured speed.
    pub fn speed_error(&self) -> f64 {
        (self.model_speed - self.speed) / self.speed
    }
}

// Joints and axes index parallel arrays (samples, accelerations, traces).
#[allow(clippy::needless_range_loop)]
/// The weighted residuals of `traces` against `swims` into `out` (grouped:
/// speed, turn, dive, torque; each group in time order) and what they
/// mean in units.
pub(super) fn residuals(
    traces: &[Trace],
    swims: &[Swim],
    m: &Measured,
    out: &mut Vec<f64>,
) -> Evaluation {
    out.clear();
    let mut ev = Evaluation::default();
    let chans: Vec<Channels> = traces
        .iter()
        .zip(swims)
        .map(|(tr, s)| model_channels(tr, s))
        .collect();
    // every measured torque, per swim: the measured less the model's, and
    // what the drive's own J, b and lag act on: the axis's acceleration
    // and rate, and the model's torque's rate of change (a torque measured
    // `lag` late is the model's less `lag` times its rate)
    // (the torque less the model's, the drive's regressors, its axis)
    type Sample = (f64, [f64; DRIVE], (usize, usize));
    let torques: Vec<Vec<Sample>> = traces
        .iter()
        .zip(swims)
        .zip(&m.accel)
        .map(|((tr, s), acc)| {
            let n = s.joints();
            let h = match tr.torque_t.as_slice() {
                [a, b, ..] => b - a,
                _ => 0.0,
            };
            let mut v = Vec::new();
            for (k, smp) in s.samples.iter().enumerate() {
                for j in 0..n {
                    for ax in 0..2 {
                        let meas = smp.torque[j][ax];
                        if meas.is_finite() {
                            let at = |t: f64| interp(&tr.torque_t, |i| tr.torque[i * n + j][ax], t);
                            let model = at(smp.t);
                            let rate = if h > 0.0 {
                                (at(smp.t + h) - at(smp.t - h)) / (2.0 * h)
                            } else {
                                0.0
                            };
                            v.push((
                                meas - model,
                                [acc[k][j][ax], smp.rate[j][ax], -rate],
                                (k, 2 * j + ax),
                            ));
                        }
                    }
                }
            }
            v
        })
        .collect();
    // J, b and the lag: least squares of (measured - model) on them, the
    // lag no less than zero (a drive measures a torque after it acts)
    let jb = if let Some(known) = m.actuator {
        known
    } else {
        let mut ata = nalgebra::Matrix3::<f64>::zeros();
        let mut atb = nalgebra::Vector3::<f64>::zeros();
        for &(e, x, _) in torques.iter().flatten() {
            let x = nalgebra::Vector3::from(x);
            ata += x * x.transpose();
            atb += x * e;
        }
        match drive_terms(&ata, &atb, DRIVE) {
            Some(y) if y[2] >= 0.0 => y,
            _ => drive_terms(&ata, &atb, 2).unwrap_or([0.0; DRIVE]),
        }
    };
    ev.actuator = jb;
    let mut sums = [0.0f64; GROUPS];
    let mut counts = [0usize; GROUPS];
    let mut push = |g: usize, e: f64, out: &mut Vec<f64>| {
        if e.is_finite() {
            sums[g] += e * e;
            counts[g] += 1;
            out.push(e / (m.scales[g] * (m.counts[g].max(1) as f64).sqrt()));
        } else {
            // a model that did not get there: a large, finite residual
            out.push(10.0 / (m.counts[g].max(1) as f64).sqrt());
        }
    };
    for g in 0..TORQUE {
        for (mc, c) in m.channels.iter().zip(&chans) {
            let (a, b) = match g {
                0 => (&mc.speed, &c.speed),
                1 => (&mc.turn, &c.turn),
                2 => (&mc.dive, &c.dive),
                _ => (&mc.sway, &c.sway),
            };
            for (x, y) in a.iter().zip(b) {
                if x.is_finite() {
                    push(g, y - x, out);
                }
            }
        }
    }
    let mut roll = (0.0, 0usize);
    for (((tr, s), tq), (mc, c)) in traces
        .iter()
        .zip(swims)
        .zip(&torques)
        .zip(m.channels.iter().zip(&chans))
    {
        let (mut se, mut cnt) = (0.0, 0usize);
        let mut errors = Vec::with_capacity(tq.len());
        for &(e_model, x, (k, a)) in tq {
            let e = jb[0] * x[0] + jb[1] * x[1] + jb[2] * x[2] - e_model;
            se += e * e;
            cnt += 1;
            push(TORQUE, e, out);
            // measured less the model and the drive's terms
            errors.push((k, a, -e));
        }
        // the means over the grid points the recording has
        let (mut sm, mut sp, mut cn) = (0.0, 0.0, 0usize);
        for (x, y) in mc.speed.iter().zip(&c.speed) {
            if x.is_finite() && y.is_finite() {
                sm += x;
                sp += y;
                cn += 1;
            }
        }
        let (speed, model_speed) = if cn > 0 {
            (sm / cn as f64, sp / cn as f64)
        } else {
            (f64::NAN, f64::NAN)
        };
        ev.swims.push(SwimError {
            name: s.name.clone(),
            speed,
            model_speed,
            torque_rms: if cnt > 0 {
                (se / cnt as f64).sqrt()
            } else {
                f64::NAN
            },
            worst_bias: worst_bias(s, &errors),
        });
        for r in &tr.roll_rate {
            roll.0 += r * r;
            roll.1 += 1;
        }
    }
    ev.roll_rate_rms = (roll.0 / roll.1.max(1) as f64).sqrt();
    ev.rms = std::array::from_fn(|g| {
        if counts[g] > 0 {
            (sums[g] / counts[g] as f64).sqrt()
        } else {
            f64::NAN
        }
    });
    ev.cost = out.iter().map(|r| r * r).sum();
    ev
}

/// The least-squares solution of the normal equations `ata y = atb` over
/// the first `p` of the drive's terms (the others zero); `None` when those
/// columns are not independent.
fn drive_terms(
    ata: &nalgebra::Matrix3<f64>,
    atb: &nalgebra::Vector3<f64>,
    p: usize,
) -> Option<[f64; DRIVE]> {
    let a = ata.view((0, 0), (p, p)).into_owned();
    let b = atb.rows(0, p).into_owned();
    // columns scaled to unit norm, so that the test of rank is fair
    let d = nalgebra::DVector::from_fn(p, |i, _| a[(i, i)].sqrt().max(1e-300));
    let scaled = a.component_div(&(&d * d.transpose()));
    if scaled.determinant() <= 1e-12 {
        return None;
    }
    let y = scaled
        .cholesky()?
        .solve(&b.component_div(&d))
        .component_div(&d);
    let mut out = [0.0; DRIVE];
    out[..p].copy_from_slice(y.as_slice());
    Some(out)
}

/// The errors of `body` against `swims` (one replay each).
pub fn evaluate(
    body: &Body,
    swims: &[Swim],
    m: &Measured,
    nodes: usize,
    dt: f64,
) -> Result<Evaluation> {
    let traces = swims
        .iter()
        .map(|s| simulate(body, s, nodes, dt))
        .collect::<Result<Vec<_>>>()?;
    let mut out = Vec::new();
    Ok(residuals(&traces, swims, m, &mut out))
}
