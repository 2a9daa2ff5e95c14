//! The controller and the simulated robot (twelve vertebra nodes, the
//! swimming body and a head sensor) in lockstep on a manual clock: the
//! whole closed loop, deterministic and faster than real time. Used by the
//! daemon's `tests/autopilot.rs`, `tests/mcap.rs`, `tests/no_alloc.rs` and
//! `benches/autopilot.rs`.

use std::sync::Arc;
use std::time::Duration;

use anguilla_daemon::calibration::Leg;
use anguilla_daemon::config::Config;
use anguilla_daemon::control::Controller;
use anguilla_daemon::mcap_log::McapLog;
use anguilla_daemon::truth::GroundTruth;
use anguilla_drivers::mem::{MemBus, MemParticipant};
use anguilla_drivers::{Clock, ManualClock};
use anguilla_ipc::vocabulary::{Command, Mode, Nanos, SwimParams};
use anguilla_ipc::{CommandReply, CommandRequest, Envelope, StateSnapshot};
use anguilla_model::Current;
use anguilla_sim::robot::{RobotConfig, SimRobot, Truth};
use anguilla_sim::sensor::SensorConfig;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// The head sensor's node id in these rigs.
pub const SENSOR: u8 = 20;
/// The simulated sensor's depth at the model's origin (m).
pub const ORIGIN_DEPTH: f64 = 1.0;

/// A configuration with a head sensor on node [`SENSOR`].
pub fn config() -> Config {
    let mut cfg = Config::default();
    cfg.sensor.node = SENSOR;
    cfg.validate().expect("valid configuration");
    cfg
}

/// The rig.
pub struct Rig {
    clock: ManualClock,
    host: MemParticipant,
    /// The simulated robot.
    pub robot: SimRobot,
    /// The daemon's controller.
    pub ctl: Controller,
    /// "Real" vertebrae on the same bus ([`Rig::mixed`]): another
    /// simulated robot playing the nodes `robot` does not.
    pub real: Option<SimRobot>,
    period: Duration,
    seq: u32,
    last_keep_alive: Duration,
}

impl Rig {
    /// `cfg`'s controller and a robot with a typical sensor (noise, bias
    /// walk) seeded with `seed`, in the uniform `current` (m/s, earth frame).
    pub fn new(cfg: &Config, seed: u64, current: [f64; 3]) -> Self {
        Self::with_sensor(cfg, seed, current, |_| {})
    }

    /// [`Rig::new`] with the simulated sensor's settings changed by `tune`.
    pub fn with_sensor(
        cfg: &Config,
        seed: u64,
        current: [f64; 3],
        tune: impl FnOnce(&mut SensorConfig),
    ) -> Self {
        Self::with_robot(cfg, seed, current, tune, |_| {})
    }

    /// [`Rig::new`] on a simulated body of its own (`body`), not the one
    /// the daemon's `[model]` describes.
    pub fn with_body(cfg: &Config, seed: u64, body: anguilla_model::Body) -> Self {
        Self::with_robot(
            cfg,
            seed,
            [0.0; 3],
            |_| {},
            |r| {
                r.body = body;
                // open water: the calibration's gaits climb more than the
                // start's depth, and the model knows no surface
                r.surface = false;
            },
        )
    }

    /// [`Rig::with_sensor`] with the simulated robot's configuration then
    /// changed by `robot`.
    pub fn with_robot(
        cfg: &Config,
        seed: u64,
        current: [f64; 3],
        tune: impl FnOnce(&mut SensorConfig),
        robot: impl FnOnce(&mut RobotConfig),
    ) -> Self {
        let clock = ManualClock::new();
        let bus = MemBus::builder(&format!("lockstep-{seed}-{}", std::process::id()))
            .bitrate(cfg.bus.bitrate)
            .data_bitrate(cfg.bus.data_bitrate)
            .clock(Arc::new(clock.clone()))
            .capacity(1 << 14)
            .build();
        let host = bus.participant();
        let s = &cfg.sensor;
        // No sensor on the robot when the daemon has none configured.
        let sensor = (s.node != 0).then(|| {
            let mut sensor = SensorConfig {
                origin_depth: ORIGIN_DEPTH,
                ..SensorConfig::typical_in(s.node, s.rate_hz, s.water_density, s.surface_pressure)
            };
            tune(&mut sensor);
            sensor
        });
        // A tail IMU when the daemon has one configured.
        let tail = (s.tail_imu != 0).then(|| SensorConfig {
            origin_depth: ORIGIN_DEPTH,
            ..SensorConfig::typical_in(s.tail_imu, s.rate_hz, s.water_density, s.surface_pressure)
        });
        let mut rcfg = RobotConfig {
            node_ids: cfg.node_ids(),
            variant: cfg.bus.variant(),
            boot_time: Duration::from_millis(10),
            seed,
            head_sensor: sensor,
            tail_sensor: tail,
            body: cfg.model.body(),
            current: Current::steady(current).expect("a current within limits"),
            ..RobotConfig::with_joints(cfg.robot.joints)
        };
        robot(&mut rcfg);
        let robot =
            SimRobot::on_mem(rcfg, bus.participant(), Duration::ZERO).expect("simulated robot");
        let ctl = Controller::new(cfg, Nanos::ZERO).expect("controller");
        let period = Duration::from_nanos(ctl.period_ns().as_nanos());
        Self {
            clock,
            host,
            robot,
            ctl,
            real: None,
            period,
            seq: 0,
            last_keep_alive: Duration::ZERO,
        }
    }

    /// A mixed robot: the simulated robot plays every joint but those of
    /// node ids `real`, which it swims with as they move on the bus
    /// (`anguilla_sim::observed`); another simulated robot on the same
    /// bus plays them as real vertebrae would, its servos changed by
    /// `servo`: a whole body of its own that swims with the first's
    /// joints as they move on the bus, so the real joints are loaded as
    /// in the water.
    pub fn mixed(
        cfg: &Config,
        seed: u64,
        real: &[u8],
        servo: impl FnOnce(&mut anguilla_sim::actuator::ActuatorParams),
    ) -> Self {
        let mut rig = Self::with_robot(
            cfg,
            seed,
            [0.0; 3],
            |_| {},
            |r| {
                r.observed = real.to_vec();
            },
        );
        let mut actuator = anguilla_sim::actuator::ActuatorParams::default();
        servo(&mut actuator);
        let node_ids = cfg.node_ids();
        let rcfg = RobotConfig {
            observed: node_ids
                .iter()
                .copied()
                .filter(|id| !real.contains(id))
                .collect(),
            node_ids,
            variant: cfg.bus.variant(),
            boot_time: Duration::from_millis(10),
            seed: seed ^ 0x5EA1,
            actuator,
            body: cfg.model.body(),
            ..RobotConfig::with_joints(cfg.robot.joints)
        };
        let bus = rig.robot.mem_bus().expect("an in-memory bus").clone();
        rig.real = Some(
            SimRobot::on_mem(rcfg, bus.participant(), Duration::ZERO).expect("the real vertebrae"),
        );
        rig
    }

    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.clock.now().as_secs_f64()
    }

    /// The last snapshot.
    pub fn state(&self) -> &StateSnapshot {
        self.ctl.snapshot()
    }

    /// One operator command, answered.
    pub fn command(&mut self, cmd: Command) -> CommandReply {
        self.seq += 1;
        let now = Nanos::from_nanos(self.clock.now().as_nanos() as u64);
        self.ctl.command(
            now,
            &Envelope {
                origin: 1,
                node: 1,
                request: CommandRequest::new(cmd, self.seq),
            },
        )
    }

    /// A command that must be accepted.
    pub fn ok(&mut self, cmd: Command) {
        let r = self.command(cmd);
        assert_eq!(r.accepted, 1, "'{}' refused: {}", cmd.name(), r.reason());
    }

    /// One control period (the operator keeps control alive every 0.2 s).
    pub fn period(&mut self) {
        let now = self.advance();
        self.control(now);
    }

    /// The robot's half of a period: the clock moves on one period and the
    /// robot lives until then; returns the time.
    pub fn advance(&mut self) -> Nanos {
        self.clock.advance(self.period);
        let t = self.clock.now();
        if let Some(real) = &mut self.real {
            real.step_until(t);
        }
        self.robot.step_until(t);
        Nanos::from_nanos(t.as_nanos() as u64)
    }

    /// The robot's thread starved of the CPU for `seconds` (a loaded
    /// machine: CI's fuzzing beside the built-in robot): the controller's
    /// periods go on, the robot sends nothing, and catches up on the next
    /// [`Rig::period`] with a burst of everything it owes.
    pub fn starve_robot(&mut self, seconds: f64) {
        let end = self.time() + seconds;
        while self.time() < end {
            self.clock.advance(self.period);
            let now = Nanos::from_nanos(self.clock.now().as_nanos() as u64);
            self.control(now);
        }
    }

    /// The daemon's half: a keep-alive every 0.2 s, and the period.
    pub fn control(&mut self, now: Nanos) {
        let t = Duration::from_nanos(now.as_nanos());
        if t.saturating_sub(self.last_keep_alive) >= Duration::from_millis(200) {
            self.last_keep_alive = t;
            self.command(Command::KeepAlive);
        }
        self.ctl.run_period(now, &mut self.host);
    }

    /// Plays a scenario `text` whose times count from now (each line's
    /// first word is added to the current time).
    pub fn scenario_from_now(&mut self, text: &str) {
        let now = self.time();
        let shifted: String = text
            .lines()
            .map(|l| match l.split_once(' ') {
                Some((t, rest)) => format!("{} {rest}\n", now + t.parse::<f64>().expect("time")),
                None => format!("{l}\n"),
            })
            .collect();
        self.robot.load_scenario(&shifted).expect("scenario");
    }

    /// Runs `seconds`, calling `each` after every period.
    pub fn run(&mut self, seconds: f64, mut each: impl FnMut(&Self)) {
        let end = self.time() + seconds;
        while self.time() < end {
            self.period();
            each(self);
        }
    }

    /// Runs until `done` or `seconds`; whether `done` held.
    pub fn run_until(&mut self, seconds: f64, done: impl Fn(&Self) -> bool) -> bool {
        let end = self.time() + seconds;
        while self.time() < end {
            self.period();
            if done(self) {
                return true;
            }
        }
        false
    }

    /// Takes control, enables, and swims at full amplitude at `frequency`.
    pub fn swim(&mut self, frequency: f64) {
        self.swim_at(1.0, frequency);
    }

    /// Takes control, enables, and swims at `amplitude` (0–1) and
    /// `frequency` (Hz), straight.
    pub fn swim_at(&mut self, amplitude: f64, frequency: f64) {
        self.ok(Command::TakeControl);
        self.ok(Command::Enable);
        assert!(
            self.run_until(5.0, |r| r.state().mode == Mode::Ready as u8),
            "ready"
        );
        self.ok(Command::Swim(SwimParams {
            amplitude,
            frequency,
            turn: 0.0,
            pitch: 0.0,
        }));
    }

    /// The simulation's truth.
    pub fn truth(&self) -> Truth {
        self.robot.truth()
    }

    /// The simulation's truth as a recording's `/sim/truth` holds it.
    pub fn ground_truth(&self) -> GroundTruth {
        let t = self.robot.truth();
        GroundTruth {
            sim_time: t.time.as_secs_f64(),
            position: t.position,
            orientation: t.orientation,
            velocity: t.velocity,
            speed: t.forward_speed,
            heading: t.heading,
            depth: t.depth,
        }
    }

    /// Takes control, enables, swims `legs` (the calibration swim's, or
    /// any) and records them as `anguilla run` records a session's
    /// `session.mcap` at `path`: every tenth snapshot, and the ground
    /// truth every 50 ms.
    pub fn record_legs(
        &mut self,
        cfg: &Config,
        legs: &[Leg],
        path: &std::path::Path,
    ) -> std::io::Result<()> {
        let mut log = McapLog::create(path, cfg)?;
        self.ok(Command::TakeControl);
        self.ok(Command::Enable);
        assert!(
            self.run_until(5.0, |r| r.state().mode == Mode::Ready as u8),
            "ready"
        );
        let mut next_truth = 0u64;
        let mut failed = None;
        for leg in legs {
            self.ok(Command::Swim(leg.gait));
            self.run(leg.seconds, |r| {
                let s = r.state();
                let ns = s.time_ns;
                let mut w = || -> std::io::Result<()> {
                    if s.sequence % 10 == 0 {
                        log.write(s)?;
                    }
                    if ns >= next_truth {
                        next_truth = ns + 50_000_000;
                        log.write_truth(ns, &r.ground_truth())?;
                    }
                    Ok(())
                };
                if let Err(e) = w() {
                    failed.get_or_insert(e);
                }
            });
        }
        if let Some(e) = failed {
            return Err(e);
        }
        log.finish()
    }
}

/// The head's true attitude in the sensor's axes (x forward, y left, z up).
pub fn true_attitude(t: &Truth) -> UnitQuaternion<f64> {
    let [w, x, y, z] = t.orientation;
    let model = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
    model * anguilla_model::forward_turn()
}

/// The head's true heading (rad, counter-clockwise from x).
pub fn true_head_heading(t: &Truth) -> f64 {
    let f = true_attitude(t) * Vector3::x();
    f.y.atan2(f.x)
}

/// The nose's true depth (m).
pub fn true_depth(t: &Truth) -> f64 {
    ORIGIN_DEPTH - t.position[2]
}

/// The body's true heading: the head's, averaged (circularly) over the
/// last gait period, which removes the tail beat's swing of the head.
pub struct BodyHeading {
    ring: Vec<(f64, f64)>,
    next: usize,
}

impl BodyHeading {
    /// Averaging over `samples` periods of the control loop.
    pub fn new(samples: usize) -> Self {
        Self {
            ring: Vec::with_capacity(samples),
            next: 0,
        }
    }

    /// Adds the truth's head heading; returns the average (deg).
    pub fn push(&mut self, t: &Truth) -> f64 {
        let h = true_head_heading(t);
        let v = (h.cos(), h.sin());
        if self.ring.len() < self.ring.capacity() {
            self.ring.push(v);
        } else {
            self.ring[self.next] = v;
            self.next = (self.next + 1) % self.ring.len();
        }
        let (c, s) = self
            .ring
            .iter()
            .fold((0.0, 0.0), |(c, s), &(x, y)| (c + x, s + y));
        s.atan2(c).to_degrees().rem_euclid(360.0)
    }
}

/// A held depth step's figures, from the truth.
pub struct DepthStep {
    /// Time to 90 % of the step (s).
    pub reached: Option<f64>,
    /// Deepest beyond the target (m).
    pub overshoot: f64,
    /// Last time the depth was more than 5 cm off (s).
    pub last_outside: f64,
    /// Worst depth error after `late_after` (m).
    pub late: f64,
    /// Worst body heading error after `late_after` (deg).
    pub heading: f64,
    /// Largest estimated roll (deg).
    pub roll: f64,
}

/// Holds the heading estimated now and a depth `step` metres below the
/// true one, for `seconds`; errors count from `late_after` seconds.
pub fn depth_step(rig: &mut Rig, step: f64, seconds: f64, late_after: f64) -> DepthStep {
    let h0 = rig.state().nav.heading_deg as f64;
    let d0 = true_depth(&rig.truth());
    let target = d0 + step;
    rig.ok(Command::Hold(anguilla_ipc::Hold {
        heading: Some(h0),
        depth: Some(target),
    }));
    let per_period = (1e9 / rig.ctl.period_ns().as_nanos() as f64).round() as usize;
    let mut body = BodyHeading::new(per_period);
    let mut m = DepthStep {
        reached: None,
        overshoot: f64::NEG_INFINITY,
        last_outside: 0.0,
        late: 0.0,
        heading: 0.0,
        roll: 0.0,
    };
    let start = rig.time();
    rig.run(seconds, |r| {
        let t = r.truth();
        let (d, h, since) = (true_depth(&t), body.push(&t), r.time() - start);
        m.overshoot = m.overshoot.max(d - target);
        m.roll = m.roll.max((r.state().nav.roll_deg as f64).abs());
        if m.reached.is_none() && d >= d0 + 0.9 * step {
            m.reached = Some(since);
        }
        if (d - target).abs() > 0.05 {
            m.last_outside = since;
        }
        if since > late_after {
            m.late = m.late.max((d - target).abs());
            m.heading = m.heading.max(angle_diff_deg(h, h0).abs());
        }
    });
    m
}

/// `a − b` wrapped into (−180, 180] degrees.
pub fn angle_diff_deg(a: f64, b: f64) -> f64 {
    anguilla_daemon::autopilot::wrap((a - b).to_radians()).to_degrees()
}
