//! Guided swimming on the lockstep rig: position sensors made from the
//! simulation's truth ([`Fixes`]), a path loaded and followed as `ctl
//! follow` does ([`follow`]), and the cross-track error measured on the
//! truth, the body's centroid averaged over each gait period
//! ([`Track`]). Used by the daemon's `tests/guidance.rs` and
//! `benches/guidance.rs`.

use std::collections::VecDeque;

use anguilla_daemon::sensors::Observation;
use anguilla_ipc::vocabulary::{Command, Follow, Nanos, SwimParams, Waypoint};

use crate::lockstep::Rig;

/// One simulated position sensor.
#[derive(Debug, Clone, Copy)]
enum Kind {
    /// Position fixes.
    Position,
    /// Velocity over ground.
    Velocity,
}

#[derive(Debug, Clone, Copy)]
struct Source {
    kind: Kind,
    period: f64,
    sigma: f64,
    latency: f64,
    dropout: f64,
    next: f64,
}

/// Position sensors made from the truth, handed to the controller as a
/// host's observations, each with its rate, noise (Gaussian, seeded),
/// latency and dropouts.
pub struct Fixes {
    sources: Vec<Source>,
    queue: VecDeque<(f64, Observation)>,
    rng: u64,
    /// Observations handed over, and those the estimate took.
    pub handed: u32,
    /// Observations the estimate took.
    pub taken: u32,
}

impl Fixes {
    fn new(sources: Vec<Source>, seed: u64) -> Self {
        Self {
            sources,
            queue: VecDeque::new(),
            rng: seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1,
            handed: 0,
            taken: 0,
        }
    }

    /// Motion capture in a tank: the nose's position at 10 Hz, σ 1 cm,
    /// no latency, none lost (what "truth positions" means here).
    pub fn truth(seed: u64) -> Self {
        Self::new(
            vec![Source {
                kind: Kind::Position,
                period: 0.1,
                sigma: 0.01,
                latency: 0.0,
                dropout: 0.0,
                next: 0.0,
            }],
            seed,
        )
    }

    /// A USBL at 1 Hz (σ 0.1 m, 0.3 s late, 5 % lost) and a DVL at 5 Hz
    /// (σ 0.01 m/s, 5 % lost), as the benchmark asks.
    pub fn usbl_dvl(seed: u64) -> Self {
        Self::new(
            vec![
                Source {
                    kind: Kind::Position,
                    period: 1.0,
                    sigma: 0.1,
                    latency: 0.3,
                    dropout: 0.05,
                    next: 0.0,
                },
                Source {
                    kind: Kind::Velocity,
                    period: 0.2,
                    sigma: 0.01,
                    latency: 0.0,
                    dropout: 0.05,
                    next: 0.0,
                },
            ],
            seed,
        )
    }

    fn uniform(&mut self) -> f64 {
        // xorshift64*
        self.rng ^= self.rng >> 12;
        self.rng ^= self.rng << 25;
        self.rng ^= self.rng >> 27;
        (self.rng.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn gauss(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-12), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    /// After a period of `rig`: measures what is due, hands over what has
    /// arrived.
    pub fn poll(&mut self, rig: &mut Rig) {
        let now = rig.time();
        let truth = rig.truth();
        for i in 0..self.sources.len() {
            let s = self.sources[i];
            if now + 1e-9 < s.next {
                continue;
            }
            self.sources[i].next = s.next + s.period;
            if self.uniform() < s.dropout {
                continue;
            }
            let at = Nanos::from_secs_f64(now);
            let (nx, ny) = (self.gauss() * s.sigma, self.gauss() * s.sigma);
            let obs = match s.kind {
                Kind::Position => Observation::PositionFix {
                    at,
                    x: truth.position[0] + nx,
                    y: truth.position[1] + ny,
                    sigma: s.sigma,
                },
                Kind::Velocity => Observation::VelocityOverGround {
                    at,
                    vx: truth.velocity[0] + nx,
                    vy: truth.velocity[1] + ny,
                    sigma: s.sigma,
                },
            };
            self.queue.push_back((now + s.latency, obs));
        }
        while let Some(&(due, obs)) = self.queue.front() {
            if due > now + 1e-9 {
                break;
            }
            self.queue.pop_front();
            self.handed += 1;
            self.taken += rig.ctl.observe(&obs) as u32;
        }
    }
}

/// Loads `points` as a path and follows it at full amplitude and 1 Hz
/// (`ctl follow`: the waypoints one a request, then the follow).
pub fn follow(rig: &mut Rig, points: &[(f64, f64)], looped: bool, from_here: bool) {
    for (i, &(x, y)) in points.iter().enumerate() {
        rig.ok(Command::Waypoint(Waypoint {
            index: i as u32,
            x,
            y,
            depth: None,
        }));
    }
    rig.ok(Command::Follow(Follow {
        swim: SwimParams {
            amplitude: 1.0,
            frequency: 1.0,
            turn: 0.0,
            pitch: 0.0,
        },
        count: points.len() as u32,
        looped,
        from_here,
        resume: false,
    }));
}

/// The nose's true position averaged over the last gait period (which
/// removes the tail beat's sway), and the body's centroid's: `centroid`
/// metres behind the nose along the body's true heading (the direction
/// from the centroid to the nose; half the body's length, exact for a
/// straight body: a bent one's centroid is a few centimetres nearer the
/// nose, which moves a cross-track error by under 0.005 m at the crab
/// angles here).
pub struct Track {
    ring: Vec<[f64; 4]>,
    next: usize,
    centroid: f64,
}

/// A gait period's averaged positions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Averaged {
    /// The nose's (m).
    pub nose: (f64, f64),
    /// The body's centroid's (m).
    pub centroid: (f64, f64),
}

impl Track {
    /// Averaging over `samples` control periods (one gait period), the
    /// centroid `centroid` metres behind the nose.
    pub fn new(samples: usize, centroid: f64) -> Self {
        Self {
            ring: Vec::with_capacity(samples),
            next: 0,
            centroid,
        }
    }

    /// Adds the truth of `rig`; returns the averaged positions once a
    /// whole gait period is in.
    pub fn push(&mut self, rig: &Rig) -> Option<Averaged> {
        let t = rig.truth();
        let p = t.position;
        let (sin, cos) = t.heading.sin_cos();
        let c = self.centroid;
        let v = [p[0], p[1], p[0] - c * cos, p[1] - c * sin];
        if self.ring.len() < self.ring.capacity() {
            self.ring.push(v);
        } else {
            self.ring[self.next] = v;
            self.next = (self.next + 1) % self.ring.len();
        }
        (self.ring.len() == self.ring.capacity()).then(|| {
            let n = self.ring.len() as f64;
            let mut sum = [0.0; 4];
            for v in &self.ring {
                for (s, x) in sum.iter_mut().zip(v) {
                    *s += x;
                }
            }
            Averaged {
                nose: (sum[0] / n, sum[1] / n),
                centroid: (sum[2] / n, sum[3] / n),
            }
        })
    }
}

/// The signed distance of `p` from the line through `a` and `b`
/// (positive left of its direction), and how far along it from `a`.
pub fn cross_track(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    let g = (b.1 - a.1).atan2(b.0 - a.0);
    let (rx, ry) = (p.0 - a.0, p.1 - a.1);
    (-rx * g.sin() + ry * g.cos(), rx * g.cos() + ry * g.sin())
}

/// Ready, with the estimate begun (the fixes going on).
pub fn ready(rig: &mut Rig, fixes: &mut Fixes) {
    rig.ok(Command::TakeControl);
    rig.ok(Command::Enable);
    let ok = run_until(rig, fixes, 10.0, |r| {
        r.state().mode == anguilla_ipc::vocabulary::Mode::Ready as u8
            && r.ctl.nav().is_some_and(|n| n.has_estimate())
    });
    assert!(ok, "ready with an estimate");
}

/// Runs periods (the fixes going on) until `done` holds or `seconds`
/// pass; whether `done` held.
pub fn run_until(
    rig: &mut Rig,
    fixes: &mut Fixes,
    seconds: f64,
    done: impl Fn(&Rig) -> bool,
) -> bool {
    let end = rig.time() + seconds;
    while rig.time() < end {
        rig.period();
        fixes.poll(rig);
        if done(rig) {
            return true;
        }
    }
    false
}

/// What a run along a line measured on the truth (the body's centroid
/// averaged over each gait period).
#[derive(Debug, Clone, Copy)]
pub struct LineFigures {
    /// The last time the cross-track error was 0.10 m or more (s from the
    /// path's start).
    pub last_far: f64,
    /// The cross-track error's RMS over the last `window` seconds (m).
    pub rms: f64,
    /// Its mean over them (m, positive left).
    pub mean: f64,
    /// The along-track speed over them (m/s).
    pub along_speed: f64,
    /// The estimated current's error at 60 s (m/s).
    pub current_error_60: f64,
    /// Its component across the line (m/s): what the guidance leans
    /// against.
    pub current_across_60: f64,
    /// Its component along the line (m/s): the same, on a straight swim,
    /// as an error of the model's speed, which no position or velocity
    /// over ground tells apart from the current.
    pub current_along_60: f64,
    /// The forward speed through the water the model predicts (m/s, the
    /// mean over the window).
    pub speed: f64,
    /// The nose's cross-track RMS over the window (m): off the path by
    /// half the body's length times the sine of the crab angle.
    pub nose_rms: f64,
    /// Its mean (m, positive left).
    pub nose_mean: f64,
    /// The estimated current's error at the run's end (m/s): what more
    /// time on the line gives.
    pub current_error_end: f64,
    /// The estimate's factor of the model's speed at the run's end.
    pub speed_scale: f64,
}

/// The straight-path case: the robot at the origin heading +x
/// (0°), the line x = 2 along +y (90°): 2.0 m off it, at −90° to it.
/// The water moves at `current` (m/s, earth frame; unknown to the
/// daemon), fixes from `fixes`; runs `seconds`, figures over the last
/// `window`.
pub fn line_run(
    cfg: &anguilla_daemon::config::Config,
    seed: u64,
    current: [f64; 2],
    mut fixes: Fixes,
    seconds: f64,
    window: f64,
) -> LineFigures {
    let mut rig = Rig::new(cfg, seed, [current[0], current[1], 0.0]);
    ready(&mut rig, &mut fixes);
    let (a, b) = ((2.0, -5.0), (2.0, 1000.0));
    follow(&mut rig, &[a, b], false, false);
    let per = (1e9 / rig.ctl.period_ns().as_nanos() as f64).round() as usize;
    let mut track = Track::new(per, cfg.model.body().length / 2.0);
    let start = rig.time();
    let mut f = LineFigures {
        last_far: 0.0,
        rms: 0.0,
        mean: 0.0,
        along_speed: 0.0,
        current_error_60: f64::NAN,
        current_across_60: f64::NAN,
        current_along_60: f64::NAN,
        speed: 0.0,
        current_error_end: f64::NAN,
        speed_scale: f64::NAN,
        nose_rms: f64::NAN,
        nose_mean: f64::NAN,
    };
    let (mut sq, mut sum, mut n, mut speed) = (0.0, 0.0, 0usize, 0.0);
    let (mut csq, mut csum) = (0.0, 0.0);
    let mut along0: Option<(f64, f64)> = None;
    let mut along1 = (0.0, 0.0);
    while rig.time() - start < seconds {
        rig.period();
        fixes.poll(&mut rig);
        let t = rig.time() - start;
        if f.current_error_60.is_nan() && t >= 60.0 {
            let nav = &rig.state().nav;
            let (ex, ey) = (
                f64::from(nav.current_x) - current[0],
                f64::from(nav.current_y) - current[1],
            );
            f.current_error_60 = ex.hypot(ey);
            // The line runs along +y.
            f.current_across_60 = ex;
            f.current_along_60 = ey;
        }
        if let Some(avg) = track.push(&rig) {
            // The figures are the centroid's; the nose's beside.
            let (e, s) = cross_track(avg.centroid, a, b);
            let (ec, _) = cross_track(avg.nose, a, b);
            if e.abs() >= 0.1 {
                f.last_far = t;
            }
            if t >= seconds - window {
                along0.get_or_insert((t, s));
                along1 = (t, s);
                sq += e * e;
                sum += e;
                csq += ec * ec;
                csum += ec;
                speed += rig.ctl.report().forward_speed;
                n += 1;
            }
        }
    }
    let nav = &rig.state().nav;
    f.current_error_end =
        (f64::from(nav.current_x) - current[0]).hypot(f64::from(nav.current_y) - current[1]);
    if let Some(n) = rig.ctl.nav() {
        f.speed_scale = n.plane().speed_scale();
    }
    let n = n.max(1) as f64;
    f.rms = (sq / n).sqrt();
    f.mean = sum / n;
    f.nose_rms = (csq / n).sqrt();
    f.nose_mean = csum / n;
    f.speed = speed / n;
    if let Some((t0, s0)) = along0 {
        f.along_speed = (along1.1 - s0) / (along1.0 - t0).max(1e-9);
    }
    f
}
