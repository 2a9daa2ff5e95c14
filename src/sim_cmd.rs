//! `anguilla sim`: the simulated robot as its own process, on a named bus or
//! behind an emulated SLCAN adapter on a pseudo-terminal.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anguilla_model::dynamics::NODES_RANGE;
use anguilla_model::{Current, MAX_CURRENT};
use anguilla_protocol::Family;
use anguilla_protocol::message::Variant;
use anguilla_sim::actuator::ActuatorParams;
use anguilla_sim::offbus::SimSensorConfig;
use anguilla_sim::sensor::SensorConfig;
use anguilla_sim::serve::{ScenarioText, Serve, TruthSink, Wire, serve};
use anguilla_sim::{RobotConfig, SimError, TICK_RANGE};
use anyhow::{Context, bail};
use clap::Args;

/// Options of `anguilla sim`.
#[derive(Args, Debug)]
#[command(after_help = "\
Examples:
  anguilla sim --slcan-pty                 # prints the device to open, e.g.
                                           # slcan:/dev/pts/5@1000000
  anguilla sim --slcan-pty --adapters 2 --joints 0
                                           # two adapters on one bus, no robot:
                                           # tools on either end talk to each other
  anguilla sim --bus socketcan:vcan0 --scenario faults.txt
  anguilla sim --bus socketcan:can0 --fd --joints 6
  anguilla sim --slcan-pty --truth truth.mcap
                                           # records the ground truth (/sim/truth)
  anguilla sim --slcan-pty --fd --data-bitrate 5000000
                                           # CAN FD behind the adapter: open it with
                                           # slcan:/dev/pts/5@1000000?fd=1, [bus] fd = true
  anguilla sim --bus socketcan:vcan0 --drive odrive --joints 4 --axis-ids 1:2,3:4,5:6,7:8

--drive chooses what the joints' drives speak (docs/drives.md): anguilla
vertebra nodes (one node per joint, ids 1..=N), or one bought drive per axis
(odrive: CANSimple axes, ids 0..=63; cia402: CANopen drives, ids 1..=127;
mit: MIT-mode actuators, ids 1..=127), by default pitch 2j+1 and yaw 2j+2
for joint j = 0 (head end), 1, ...; scenario lines 'node N' then name
joint N.

The robot runs in real time until Ctrl-C, printing a status line every second.
Scenario files (sim-backend/README.md) script faults with times, e.g.
  1.5 node 3 silent 0.5
  2.0 joint 4 yaw stuck
  3.0 bus drop 5          (bus faults: in-process bus only, so with --slcan-pty)
  4.0 water current 0 0.1 (the water flows sideways at 0.1 m/s; --current sets it at the start)")]
pub struct SimArgs {
    /// Bus to put the robot on: socketcan:IFACE, slcan:DEVICE@BITRATE or mem:NAME.
    #[arg(long, value_name = "SPEC", conflicts_with = "slcan_pty")]
    bus: Option<String>,
    /// Emulate an SLCAN USB adapter on a pseudo-terminal and run the robot
    /// behind it; prints the device path to open.
    #[arg(long)]
    slcan_pty: bool,
    /// Number of emulated SLCAN adapters on the same simulated bus, 1..=8
    /// (with --slcan-pty); each prints its own device path.
    #[arg(long, value_name = "N")]
    adapters: Option<usize>,
    /// Bit rate of the simulated wire behind the emulated adapter (bit/s).
    #[arg(long, default_value_t = 1_000_000, value_name = "BPS")]
    bitrate: u32,
    /// CAN FD data-phase bit rate of the simulated wire behind the
    /// emulated adapters (bit/s; with --fd and --slcan-pty): set it to the
    /// daemon's `[bus] data-bitrate` [default: the daemon's default,
    /// 5000000]. On --bus SPEC the interface has its own.
    #[arg(long, value_name = "BPS")]
    data_bitrate: Option<u32>,
    /// Fault scenario file (timed faults, see sim-backend/README.md).
    #[arg(long, value_name = "FILE")]
    scenario: Option<PathBuf>,
    /// Number of joints (nodes 1..=N), 1..=63; 0 with --slcan-pty: no
    /// robot, the adapters' bus alone.
    #[arg(long, default_value_t = 12, value_name = "N")]
    joints: usize,
    /// CAN FD nodes (setpoint groups) instead of classic CAN (anguilla
    /// drives only).
    #[arg(long)]
    fd: bool,
    /// What the joints' drives speak (docs/drives.md).
    #[arg(long, default_value = "anguilla", value_name = "FAMILY", value_parser = anguilla::family_arg::FamilyParser)]
    drive: Family,
    /// The drives' node ids of every joint, head end first, as PITCH:YAW
    /// pairs (e.g. 1:2,3:4); the families with a drive per axis (all but
    /// anguilla). Default 2j+1:2j+2.
    #[arg(long, value_name = "P:Y,...")]
    axis_ids: Option<String>,
    /// Seed of sensor noise and random faults.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Perfect servos that follow their setpoints exactly.
    #[arg(long)]
    ideal: bool,
    /// Physics step in seconds (0.0001..=0.02; default 0.002). A larger
    /// step, like fewer model nodes, makes the body cheaper to simulate on
    /// a slow machine (e.g. a CPU-emulated VM).
    #[arg(long, value_name = "SECONDS")]
    dt: Option<f64>,
    /// Space intervals of the body model (2..=100000; default 52).
    #[arg(long, value_name = "N")]
    model_nodes: Option<usize>,
    /// The water's uniform current at the start, `VX,VY[,VZ]` in m/s (earth
    /// frame: e1 is the robot's initial axis, its head towards -e1); each at
    /// most 5 m/s. A scenario's 'water current' lines change it.
    #[arg(long, value_name = "VX,VY[,VZ]")]
    current: Option<String>,
    /// A head sensor on node ID (1..=63, not a joint's): a simulated
    /// BNO08x-class IMU and pressure sensor at 100 Hz (anguilla drives
    /// only; protocol/README.md "The head sensor").
    #[arg(long, value_name = "ID")]
    head_sensor: Option<u8>,
    /// The bought drives' own watchdog (s, 0.001..=60): an ODrive axis's
    /// watchdog_timeout, an MIT drive's CAN timeout [default: 0.1 s for
    /// ODrive, 0.5 s for MIT]. A drive without a message this long stops.
    #[arg(long, value_name = "S")]
    drive_watchdog: Option<f64>,
    /// An IMU in the tail on node ID (1..=63, not a joint's nor the head
    /// sensor's): the same simulated sensor, measuring the tail section
    /// (the daemon's `[sensor] tail-imu`).
    #[arg(long, value_name = "ID")]
    tail_imu: Option<u8>,
    /// Vertebra nodes the simulator does not play (comma-separated ids of
    /// 1..=--joints; anguilla drives only): real vertebrae on the same
    /// bus answer for them, and the simulated body swims with their
    /// measured motion, heard in their feedback frames (docs/bench.md).
    #[arg(long, value_name = "IDS")]
    skip: Option<String>,
    /// A sensor off the bus beside the robot, sending what the body's
    /// truth gives to ADDRESS:PORT in UDP datagrams (the daemon's
    /// `[sensor.NAME] source = "udp:ADDRESS:PORT"`), each LATENCY s after
    /// it was measured (default: the kind's usual): `usbl` (1 Hz, σ 0.3 m
    /// per axis, 10 % of fixes lost; latency 0.3 s, under a fix's period)
    /// or `dvl` (velocity over ground, 5 Hz, σ 0.01 m/s, 5 % lost, none
    /// while the nose is shallower than 0.3 m; latency 0.05 s, under 0.2).
    /// Repeat for several (docs/autopilot.md, "Position").
    #[arg(
        long = "sensor",
        value_name = "NAME=ADDRESS:PORT[@LATENCY]",
        value_parser = SimSensorConfig::parse
    )]
    sensors: Vec<SimSensorConfig>,
    /// The body's ballast: its centre of mass this far below its axis (m,
    /// 0..=0.05; default 0.02, as the daemon's `[model] ballast`; 0: the
    /// paper's body, which rolls freely under pitch curvature).
    #[arg(long, value_name = "M")]
    ballast: Option<f64>,
    /// The simulated body's own coefficients, drag law, density and
    /// ballast (TOML; docs/calibration.md): a robot that is not the
    /// daemon's model. --ballast overrides its ballast.
    #[arg(long, value_name = "FILE")]
    body: Option<PathBuf>,
    /// Stop after this many seconds (default: run until Ctrl-C).
    #[arg(long, value_name = "SECONDS")]
    duration: Option<f64>,
    /// Record the simulation's ground truth into FILE, a new MCAP file
    /// (an existing one is refused): the channel /sim/truth that a session
    /// recorded against `anguilla run`'s built-in robot holds (pose,
    /// velocity, speed, heading, depth), 20 times a second, stamped with
    /// this machine's monotonic clock, the daemon's: it lines up with a
    /// session the daemon records here.
    #[arg(long, value_name = "FILE")]
    truth: Option<PathBuf>,
}

/// Runs `anguilla sim`.
pub fn run(args: &SimArgs) -> anyhow::Result<()> {
    if args.joints == 0 && !args.slcan_pty {
        bail!(
            "--joints 0: expected 1..=63 (0, no robot, only with --slcan-pty: the adapters' bus alone)"
        );
    }
    if args.joints > 63 {
        bail!(
            "--joints {}: expected 1..=63 (or 0 with --slcan-pty)",
            args.joints
        );
    }
    let adapters = match args.adapters {
        Some(_) if !args.slcan_pty => {
            bail!("--adapters: only with --slcan-pty (emulated adapters on one bus)")
        }
        Some(n) if !ADAPTERS_RANGE.contains(&n) => {
            bail!("--adapters {n}: expected {ADAPTERS_RANGE:?} emulated adapters")
        }
        Some(n) => n,
        None => 1,
    };
    if let Some(d) = args.duration
        && !(d > 0.0 && d <= 1e6)
    {
        bail!(
            "--duration {}: expected seconds, 0 < S <= 1e6",
            anguilla_daemon::config::fmt_number(d)
        );
    }
    if let Some(d) = args.data_bitrate {
        if !args.fd {
            bail!("--data-bitrate {d}: only with --fd (classic CAN has one bit rate, --bitrate)");
        }
        if !args.slcan_pty {
            bail!(
                "--data-bitrate {d}: the simulated wire's, behind --slcan-pty; on --bus SPEC the \
                 interface has its own (e.g. `ip link set can0 type can bitrate 1000000 dbitrate \
                 {d} fd on`)"
            );
        }
    }
    anguilla_protocol::budget::Bitrates {
        nominal: args.bitrate,
        data: data_bitrate(args),
    }
    .validate()
    .map_err(|e| match (e, args.data_bitrate) {
        (anguilla_protocol::budget::BudgetError::DataRate { .. }, Some(d)) => {
            anyhow::anyhow!("--data-bitrate {d}: {e}")
        }
        _ => anyhow::anyhow!("--bitrate: {e}"),
    })?;
    if args.bus.is_none() && !args.slcan_pty {
        bail!("give --bus SPEC (e.g. socketcan:vcan0) or --slcan-pty");
    }
    if let Some(dt) = args.dt
        && !TICK_RANGE.contains(&dt)
    {
        bail!("--dt {dt}: expected a physics step of {TICK_RANGE:?} seconds");
    }
    if let Some(n) = args.model_nodes
        && !NODES_RANGE.contains(&n)
    {
        bail!("--model-nodes {n}: expected {NODES_RANGE:?} space intervals");
    }
    let current = match &args.current {
        Some(text) => parse_current(text)?,
        None => Current::ZERO,
    };
    if args.fd && !args.drive.speaks_fd() {
        bail!(
            "--fd: {} drives speak classic CAN (CAN FD is for anguilla drives)",
            args.drive
        );
    }
    if args.joints == 0 {
        if args.scenario.is_some() {
            bail!("--scenario: needs a robot (--joints 1..=63), not the bus alone (--joints 0)");
        }
        if args.axis_ids.is_some() {
            bail!("--axis-ids: needs a robot (--joints 1..=63), not the bus alone (--joints 0)");
        }
        if args.current.is_some() {
            bail!("--current: needs a robot (--joints 1..=63), not the bus alone (--joints 0)");
        }
        if args.truth.is_some() {
            bail!("--truth: needs a robot (--joints 1..=63), not the bus alone (--joints 0)");
        }
        if !args.sensors.is_empty() {
            bail!("--sensor: needs a robot (--joints 1..=63), not the bus alone (--joints 0)");
        }
        let alone = Serve {
            robot: None,
            wire: wire(args, adapters),
            scenario: None,
            off_bus: Vec::new(),
            truth: None,
        };
        return serve_until_stopped(alone, args.duration);
    }
    let cfg = robot_config(args, current)?;
    let scenario = match &args.scenario {
        Some(p) => Some(
            std::fs::read_to_string(p)
                .with_context(|| format!("reading the scenario file {}", p.display()))?,
        ),
        None => None,
    };

    // Made before the robot starts: a file that is there is refused.
    let truth: Option<Box<dyn TruthSink>> = match &args.truth {
        Some(p) => Some(Box::new(TruthRecord {
            file: anguilla_daemon::truth::TruthFile::from_file(anguilla::user_file::create_new(p)?)
                .with_context(|| format!("--truth {}", p.display()))?,
            path: p.display().to_string(),
        })),
        None => None,
    };
    let serve = Serve {
        robot: Some(cfg),
        wire: wire(args, adapters),
        scenario: match (&args.scenario, scenario) {
            (Some(p), Some(text)) => Some(ScenarioText {
                name: p.display().to_string(),
                text,
            }),
            _ => None,
        },
        off_bus: args.sensors.clone(),
        truth,
    };
    serve_until_stopped(serve, args.duration)
}

/// Serves `s` until a stop signal or `duration` seconds, printing its
/// lines (a failing stdout ends them, never the simulation).
fn serve_until_stopped(s: Serve, duration: Option<f64>) -> anyhow::Result<()> {
    crate::signals::install();
    let mut out = crate::output::Status::default();
    let end = duration.map(|d| Instant::now() + Duration::from_secs_f64(d));
    let wait = |deadline: Instant| {
        let deadline = end.map_or(deadline, |e| e.min(deadline));
        let ns = deadline
            .saturating_duration_since(Instant::now())
            .as_nanos() as u64;
        crate::signals::sleep_until_ns(anguilla_daemon::rt::monotonic_ns() + ns)
            || end.is_some_and(|e| deadline >= e)
    };
    serve(s, &wait, &mut |line| out.line(format_args!("{line}")))?;
    Ok(())
}

/// `--truth FILE`: the ground truth into an MCAP file, stamped with this
/// machine's monotonic clock (the daemon's).
struct TruthRecord {
    file: anguilla_daemon::truth::TruthFile,
    path: String,
}

impl TruthSink for TruthRecord {
    fn name(&self) -> String {
        self.path.clone()
    }

    fn write(&mut self, t: &anguilla_sim::Truth) -> std::io::Result<()> {
        let t = anguilla::builtin_sim::ground_truth(t);
        self.file.write(anguilla_daemon::rt::monotonic_ns(), &t)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }

    fn finish(self: Box<Self>) -> std::io::Result<()> {
        self.file.finish()
    }
}

/// Where the robot goes: `--bus SPEC`, or `--slcan-pty`'s adapters.
fn wire(args: &SimArgs, adapters: usize) -> Wire {
    match &args.bus {
        Some(spec) if !args.slcan_pty => Wire::Bus(spec.clone()),
        _ => Wire::Adapters {
            count: adapters,
            bitrate: args.bitrate,
            data_bitrate: data_bitrate(args),
        },
    }
}

/// The simulated robot `args` describe, checked; its errors name the
/// option at fault.
fn robot_config(args: &SimArgs, current: Current) -> anyhow::Result<RobotConfig> {
    let axis_ids = match &args.axis_ids {
        Some(text) => {
            if !args.drive.drive_per_axis() {
                let per_axis: Vec<&str> = anguilla_protocol::Family::ALL
                    .into_iter()
                    .filter(|f| f.drive_per_axis())
                    .map(|f| f.name())
                    .collect();
                bail!(
                    "--axis-ids: only with --drive {} (a drive per axis; anguilla nodes are 1..=--joints)",
                    per_axis.join(", ")
                );
            }
            let ids = parse_axis_ids(text)?;
            if ids.len() != args.joints {
                bail!(
                    "--axis-ids {text}: {} pairs for {} joints (give one PITCH:YAW pair per joint, or --joints {})",
                    ids.len(),
                    args.joints,
                    ids.len()
                );
            }
            ids
        }
        None => Vec::new(),
    };
    let defaults = RobotConfig::with_joints(args.joints);
    let drive_watchdog = match args.drive_watchdog {
        None => None,
        Some(v) if v.is_finite() && (0.001..=60.0).contains(&v) => Some(Duration::from_secs_f64(v)),
        Some(v) => bail!("--drive-watchdog {v}: expected 0.001 ..= 60 s"),
    };
    let cfg = RobotConfig {
        drive: args.drive,
        drive_watchdog,
        axis_ids,
        variant: if args.fd {
            Variant::Fd
        } else {
            Variant::Classic
        },
        seed: args.seed,
        actuator: ActuatorParams {
            ideal: args.ideal,
            ..ActuatorParams::default()
        },
        tick: args.dt.map_or(defaults.tick, Duration::from_secs_f64),
        model_nodes: args.model_nodes.unwrap_or(defaults.model_nodes),
        current,
        head_sensor: args.head_sensor.map(SensorConfig::typical),
        tail_sensor: args.tail_imu.map(SensorConfig::typical),
        observed: match &args.skip {
            Some(text) => parse_skip(text)?,
            None => Vec::new(),
        },
        body: {
            let mut body = match &args.body {
                Some(path) => anguilla_daemon::config::BodyFile::load(path)
                    .map_err(|e| anyhow::anyhow!("--body {}: {e}", path.display()))?
                    .body(),
                None => defaults.body.clone(),
            };
            if let Some(b) = args.ballast {
                body.ballast = b;
            }
            body
        },
        ..defaults
    };
    if let Err(e) = cfg.validate() {
        match (&e, &args.axis_ids) {
            (
                SimError::Config {
                    field: "axis_ids",
                    reason,
                },
                Some(text),
            ) => {
                bail!("--axis-ids {text}: {reason}")
            }
            (
                SimError::Config {
                    field: "axis_ids",
                    reason,
                },
                None,
            ) => bail!(
                "--joints {}: {reason} with --drive {}'s default ids (give --axis-ids)",
                args.joints,
                args.drive
            ),
            (
                SimError::Config {
                    field: "observed",
                    reason,
                },
                _,
            ) => bail!(
                "--skip {}: {reason}",
                args.skip.as_deref().unwrap_or_default()
            ),
            (SimError::Config { field, reason }, _) if field.starts_with("tail_sensor") => {
                bail!("--tail-imu {}: {reason}", args.tail_imu.unwrap_or_default())
            }
            (SimError::Config { field, reason }, _) if field.starts_with("head_sensor") => {
                bail!(
                    "--head-sensor {}: {reason}",
                    args.head_sensor.unwrap_or_default()
                )
            }
            _ => return Err(e).context("the simulated robot's settings"),
        }
    }
    Ok(cfg)
}

/// `--skip`'s node ids, or what is wrong with them.
fn parse_skip(text: &str) -> anyhow::Result<Vec<u8>> {
    text.split(',')
        .map(|t| {
            t.trim().parse::<u8>().map_err(|_| {
                anyhow::anyhow!("--skip {text}: '{t}' is not a node id (expected ids like 1,2)")
            })
        })
        .collect()
}

/// The data-phase bit rate of the simulated wire: `--data-bitrate`, by
/// default the daemon's default `[bus] data-bitrate` (at least the nominal
/// rate); none for classic CAN.
fn data_bitrate(args: &SimArgs) -> Option<u32> {
    args.fd.then(|| {
        args.data_bitrate.unwrap_or_else(|| {
            anguilla_daemon::config::BusConfig::default()
                .data_bitrate
                .max(args.bitrate)
        })
    })
}

/// The most emulated adapters `--adapters` starts on one bus.
const ADAPTERS_RANGE: std::ops::RangeInclusive<usize> = 1..=8;

/// `--axis-ids`: comma-separated `PITCH:YAW` pairs of node ids (0..=255
/// here; the family's range is checked with the rest of the settings).
fn parse_axis_ids(text: &str) -> anyhow::Result<Vec<[u8; 2]>> {
    text.split(',')
        .enumerate()
        .map(|(j, pair)| {
            let bad = || {
                anyhow::anyhow!(
                    "--axis-ids {text}: joint {} is {pair:?}, expected PITCH:YAW node ids (e.g. 1:2)",
                    j + 1
                )
            };
            let (p, y) = pair.trim().split_once(':').ok_or_else(bad)?;
            let id = |s: &str| s.trim().parse::<u8>().map_err(|_| bad());
            Ok([id(p)?, id(y)?])
        })
        .collect()
}

/// `--current`: `VX,VY` or `VX,VY,VZ` (m/s, earth frame).
fn parse_current(text: &str) -> anyhow::Result<Current> {
    let bad = || {
        anyhow::anyhow!(
            "--current {text}: expected VX,VY or VX,VY,VZ in m/s (e.g. 0.1,0), each within ±{MAX_CURRENT}"
        )
    };
    let parts: Vec<&str> = text.split(',').collect();
    if !(2..=3).contains(&parts.len()) {
        return Err(bad());
    }
    let mut v = [0.0; 3];
    for (c, p) in v.iter_mut().zip(&parts) {
        *c = p.trim().parse::<f64>().map_err(|_| bad())?;
    }
    Current::steady(v).map_err(|_| bad())
}

#[cfg(test)]
mod tests {
    use super::{parse_axis_ids, parse_current};

    #[test]
    fn currents_are_two_or_three_components_and_bad_ones_are_named() {
        let c = parse_current("0.1, -0.05").unwrap();
        assert_eq!(
            c,
            anguilla_model::Current::steady([0.1, -0.05, 0.0]).unwrap()
        );
        let c = parse_current("0,0,0.02").unwrap();
        assert_eq!(
            c,
            anguilla_model::Current::steady([0.0, 0.0, 0.02]).unwrap()
        );
        for text in ["0.1", "1,2,3,4", "x,0", "0,9", "nan,0", ""] {
            let e = parse_current(text).unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("--current {text}: expected VX,VY")),
                "{e}"
            );
        }
    }

    #[test]
    fn axis_ids_are_pitch_yaw_pairs_and_bad_ones_are_named() {
        assert_eq!(
            parse_axis_ids("1:2, 3:4,62:63").unwrap(),
            vec![[1, 2], [3, 4], [62, 63]]
        );
        for (text, joint) in [("1:2,3", 2), ("x:2", 1), ("1:2,3:300", 2), ("", 1)] {
            let e = parse_axis_ids(text).unwrap_err().to_string();
            assert!(e.contains(&format!("joint {joint} is")), "{text}: {e}");
        }
    }
}
