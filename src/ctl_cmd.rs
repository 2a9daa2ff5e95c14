//! `anguilla ctl`: one operator command per call, for scripts. The session
//! logic is `anguilla_teleop::ctl`; this file parses arguments, prints and
//! turns the outcome into the exit status.

use std::io::Write;
use std::time::Duration;

use anguilla_ipc::{FaultSet, StateSnapshot, SwimParams};
use anguilla_teleop::ctl::{self, Ctl, CtlError};
use anguilla_teleop::json;
use anguilla_teleop::pad::autopilot_text;
use anguilla_teleop::view::{cause_words, mode_name, sensor_name};

use crate::teleop_cmd::DaemonArgs;

/// Arguments of `anguilla ctl`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Exit status: 0 done, 1 refused (the daemon's reason on stderr), \
    2 no daemon reachable (or a command line clap rejected)."
)]
pub struct CtlArgs {
    #[command(flatten)]
    daemon: DaemonArgs,
    #[command(subcommand)]
    cmd: CtlCmd,
}

/// What `anguilla ctl` does.
#[derive(clap::Subcommand, Debug)]
pub enum CtlCmd {
    /// Wait until the daemon is up (its state read), at most --timeout
    /// seconds: for scripts that start `anguilla run` in the background
    /// and then command it. Exits 2 if it is not up by then.
    Wait {
        /// Seconds to wait at most (0 < S <= 3600).
        #[arg(long, value_name = "S", default_value_t = 60.0)]
        timeout: f64,
    },
    /// Print one state snapshot (--json: exactly `monitor --json`'s line).
    Status {
        /// One JSON line instead of the summary.
        #[arg(long)]
        json: bool,
    },
    /// Emergency stop, by every path (the E-stop socket, then the command
    /// service); any client, never refused.
    Estop,
    /// Take control, enable the actuators, wait for ready, release.
    Enable,
    /// Take control, disable the actuators, wait for idle, release.
    Disable,
    /// Take control, clear a fault or an E-stop, wait for idle, release.
    Reset,
    /// Take control, stop a swim, wait until at rest, release.
    Stop,
    /// Take control and swim, resending within the command timeout, for
    /// --for seconds (until Ctrl-C without it); then stop, wait for ready and
    /// release. With --heading and/or --depth, the autopilot holds them for
    /// the swim (needs the daemon's head sensor; the swim's --turn or
    /// --pitch is then ignored).
    Swim {
        /// Amplitude, fraction of the configured maximum (0..=1); default
        /// 1 (with 1 Hz: the paper's gait F1).
        #[arg(long, default_value_t = 1.0)]
        amplitude: f64,
        /// Undulation frequency (Hz).
        #[arg(long, default_value_t = 1.0)]
        frequency: f64,
        /// Yaw turn curvature (1/m), positive left.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        turn: f64,
        /// Pitch curvature (1/m), positive dives.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        pitch: f64,
        /// Seconds to swim (0 < S <= 86400); without it, until Ctrl-C.
        #[arg(long = "for", value_name = "S")]
        duration: Option<f64>,
        /// Heading to hold (degrees, counter-clockwise seen from above: a
        /// left turn increases it; taken modulo 360).
        #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
        heading: Option<f64>,
        /// Depth to hold (metres below the surface, >= 0, at most the
        /// daemon's max-depth).
        #[arg(long, value_name = "M", allow_negative_numbers = true)]
        depth: Option<f64>,
    },
    /// Take control and follow the path in PATH_FILE (JSON,
    /// docs/path.schema.json; docs/autopilot.md, "Following a path"): the
    /// robot joins the line from its first waypoint to the second and
    /// follows each leg, integral line-of-sight guidance holding the
    /// heading through a current. Needs the daemon in ready, its head
    /// sensor and a position that is not lost. Prints the progress every
    /// second; done when the daemon reports the last waypoint reached (it
    /// then stops), an error when it stopped the path (the fix lost, the
    /// geofence) or the swim ended otherwise. A looped path runs until
    /// Ctrl-C.
    Follow {
        /// The path file.
        #[arg(value_name = "PATH_FILE")]
        path: std::path::PathBuf,
        /// Amplitude, fraction of the configured maximum (0..=1).
        #[arg(long, default_value_t = 1.0, conflicts_with = "speed")]
        amplitude: f64,
        /// Speed through the water (m/s) instead of --amplitude: the
        /// amplitude whose steady speed it is at --frequency, by the model
        /// of --config's body (the daemon's), corrected by the model speed
        /// factor the daemon's estimate has learnt.
        #[arg(long, value_name = "M/S")]
        speed: Option<f64>,
        /// Undulation frequency (Hz).
        #[arg(long, default_value_t = 1.0)]
        frequency: f64,
        /// After the last waypoint, back to the first, until Ctrl-C (as
        /// the file's "loop": true).
        #[arg(long = "loop")]
        looped: bool,
        /// The waypoints are in the robot's frame now (as the file's
        /// "frame": "here"): its position the origin, x ahead, y to its
        /// left.
        #[arg(long)]
        here: bool,
    },
    /// Take control and swim to X, Y (m, the estimate's frame: `ctl
    /// status` shows where the robot is) along the straight line from
    /// where it is, as `follow` does a path; done when the daemon reports
    /// it reached (within `[guidance] acceptance-radius`).
    Goto {
        /// x (m).
        #[arg(allow_negative_numbers = true)]
        x: f64,
        /// y (m).
        #[arg(allow_negative_numbers = true)]
        y: f64,
        /// The depth to hold on the way (m below the surface).
        #[arg(long, value_name = "M", allow_negative_numbers = true)]
        depth: Option<f64>,
        /// Amplitude, fraction of the configured maximum (0..=1).
        #[arg(long, default_value_t = 1.0, conflicts_with = "speed")]
        amplitude: f64,
        /// Speed through the water (m/s) instead of --amplitude (as
        /// `follow --speed`).
        #[arg(long, value_name = "M/S")]
        speed: Option<f64>,
        /// Undulation frequency (Hz).
        #[arg(long, default_value_t = 1.0)]
        frequency: f64,
    },
    /// Take control and swim the calibration swim (docs/calibration.md):
    /// a minute of forward gaits at three frequencies, glides, turns both
    /// ways, a dive and a climb, which `anguilla calibrate` fits the
    /// model's coefficients to (record it: `[recording] dir`); then stop,
    /// wait for ready and release. Prints each leg as it starts. The swim
    /// climbs up to about 3 m above its start: it is refused where the head
    /// sensor reads less than --min-depth.
    CalibrateSwim {
        /// The shallowest start (metres below the surface; 0: no check).
        #[arg(long, value_name = "M", allow_negative_numbers = true, default_value_t = anguilla_daemon::calibration::MIN_START_DEPTH)]
        min_depth: f64,
    },
}

/// `anguilla ctl`: exits with the documented status.
pub fn run(args: CtlArgs) -> ! {
    let code = match ctl(args) {
        Ok(()) => 0,
        Err(e) => {
            let _ = writeln!(std::io::stderr(), "anguilla ctl: {e}");
            e.exit_code()
        }
    };
    std::process::exit(code)
}

fn out(text: &str) -> Result<(), CtlError> {
    let mut o = std::io::stdout().lock();
    match o.write_all(text.as_bytes()).and_then(|()| o.flush()) {
        Ok(()) => Ok(()),
        // A closed pipe (`| head`) ends quietly.
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(CtlError::Refused(format!("writing to stdout: {e}"))),
    }
}

fn ctl(args: CtlArgs) -> Result<(), CtlError> {
    let prefix = args
        .daemon
        .prefix()
        .map_err(|e| CtlError::NoDaemon(crate::output::error_text(&e)))?;
    if let CtlCmd::Estop = args.cmd {
        let r = match args
            .daemon
            .remote()
            .map_err(|e| CtlError::NoDaemon(crate::output::error_text(&e)))?
        {
            None => ctl::estop(&prefix)?,
            Some((endpoint, tls)) => ctl::estop_by(
                &args.daemon.describe(&prefix),
                "the link's e-stop key",
                || crate::teleop_cmd::remote_estop(&prefix, &endpoint, tls.as_ref()),
                || crate::teleop_cmd::remote_session(&prefix, &endpoint, tls.as_ref(), true),
            )?,
        };
        let how = match (r.socket, r.command) {
            (true, true) => format!("on {} and as a command", r.path),
            (true, false) => format!("on {}", r.path),
            _ => "as a command".to_string(),
        };
        let confirmed = match r.confirmed {
            Some(true) => "; the daemon reports e-stop",
            Some(false) => "; the daemon's state does not show it yet",
            None => "; the state could not be read",
        };
        for n in &r.notes {
            let _ = writeln!(std::io::stderr(), "note: {n}");
        }
        return out(&format!("e-stop sent {how}{confirmed}\n"));
    }
    let hold = match &args.cmd {
        CtlCmd::Swim { heading, depth, .. } => ctl::hold_from_args(*heading, *depth)?,
        _ => anguilla_ipc::Hold::MANUAL,
    };
    if let CtlCmd::Swim {
        duration: Some(d), ..
    } = &args.cmd
    {
        // The daemon checks the gait; the duration is ours to check.
        if !(d.is_finite() && *d > 0.0 && *d <= 86_400.0) {
            let shown = if d.abs() >= 1e6 {
                format!("{d:e}")
            } else {
                format!("{d}")
            };
            return Err(CtlError::Refused(format!(
                "--for {shown} is invalid (expected seconds, 0 < S <= 86400)"
            )));
        }
    }
    // A path is read and checked before anything is sent.
    let path = match &args.cmd {
        CtlCmd::Follow {
            path, looped, here, ..
        } => {
            let text = std::fs::read_to_string(path).map_err(|e| {
                CtlError::Refused(format!("reading the path file {}: {e}", path.display()))
            })?;
            let mut p = anguilla_teleop::path::PathFile::parse(&text)
                .map_err(|e| CtlError::Refused(format!("{}: {e}", path.display())))?;
            p.looped |= *looped;
            if *here {
                p.frame = anguilla_teleop::path::PathFrame::Here;
            }
            if p.looped && p.waypoints.len() < 2 {
                return Err(CtlError::Refused(format!(
                    "{}: a looped path needs at least 2 waypoints",
                    path.display()
                )));
            }
            Some((path.clone(), p))
        }
        CtlCmd::Goto { x, y, depth, .. } => {
            if !(x.is_finite() && y.is_finite()) {
                return Err(CtlError::Refused(format!(
                    "goto {x} {y}: expected finite metres"
                )));
            }
            if let Some(d) = depth
                && !(d.is_finite() && *d >= 0.0)
            {
                return Err(CtlError::Refused(format!(
                    "--depth {d} is invalid (expected metres below the surface, >= 0)"
                )));
            }
            let w = anguilla_ipc::Waypoint {
                index: 0,
                x: *x,
                y: *y,
                depth: *depth,
            };
            let p = anguilla_teleop::path::PathFile {
                waypoints: vec![w],
                looped: false,
                lines: vec![],
                frame: anguilla_teleop::path::PathFrame::Estimate,
            };
            Some((std::path::PathBuf::new(), p))
        }
        _ => None,
    };
    // A speed asked for: the body's speed table at the frequency, by the
    // model of the daemon's configuration, before anything is sent.
    let speeds = match &args.cmd {
        CtlCmd::Follow {
            speed: Some(v),
            frequency,
            ..
        }
        | CtlCmd::Goto {
            speed: Some(v),
            frequency,
            ..
        } => Some(speed_table(&args.daemon, *v, *frequency)?),
        _ => None,
    };
    if let CtlCmd::CalibrateSwim { min_depth } = args.cmd
        && !(min_depth.is_finite() && min_depth >= 0.0)
    {
        return Err(CtlError::Refused(format!(
            "--min-depth {min_depth} is invalid (expected metres below the surface, >= 0)"
        )));
    }
    crate::signals::install();
    if let CtlCmd::Wait { timeout } = args.cmd {
        if !(timeout.is_finite() && timeout > 0.0 && timeout <= 3600.0) {
            return Err(CtlError::Refused(format!(
                "--timeout {timeout} is invalid (expected seconds, 0 < S <= 3600)"
            )));
        }
        let end = std::time::Instant::now() + std::time::Duration::from_secs_f64(timeout);
        // each try waits for a state (ctl's reply timeout) once open
        loop {
            let tried = args
                .daemon
                .open(&prefix, "anguilla-ctl", true)
                .map_err(|e| CtlError::NoDaemon(crate::output::error_text(&e)))
                .and_then(Ctl::over);
            match tried {
                Ok(c) => {
                    return out(&format!(
                        "the daemon is up: {}\n",
                        mode_name(c.state().mode)
                    ));
                }
                Err(e) if std::time::Instant::now() >= end => {
                    return Err(CtlError::NoDaemon(format!(
                        "not up within {timeout} s (ctl wait --timeout): {e}"
                    )));
                }
                Err(_) => std::thread::sleep(std::time::Duration::from_millis(200)),
            }
        }
    }
    let session = args
        .daemon
        .open(&prefix, "anguilla-ctl", true)
        .map_err(|e| CtlError::NoDaemon(crate::output::error_text(&e)))?;
    let mut c = Ctl::over(session)?;
    if let Some(p) = c.provenance_problem() {
        let _ = writeln!(std::io::stderr(), "warning: {p}");
    }
    let outcome = match args.cmd {
        CtlCmd::Status { json: true } => {
            return out(&format!("{}\n", json::snapshot_json(c.state())));
        }
        CtlCmd::Status { json: false } => return out(&summary(c.state(), c.holder_text())),
        CtlCmd::Estop | CtlCmd::Wait { .. } => unreachable!("handled above"),
        CtlCmd::Enable => c.enable()?,
        CtlCmd::Disable => c.disable()?,
        CtlCmd::Reset => c.reset()?,
        CtlCmd::Stop => c.stop()?,
        CtlCmd::CalibrateSwim { min_depth } => {
            use anguilla_daemon::calibration::{CLIMB, LEGS, duration};
            use anguilla_ipc::vocabulary::SensorHealth;
            let nav = c.state().nav;
            let health = SensorHealth::from_code(nav.sensor);
            let depth = f64::from(nav.depth_m);
            if min_depth == 0.0 {
                // told not to check
            } else if health == Some(SensorHealth::None) {
                let _ = out(&format!(
                    "calibration swim: no head sensor, no depth reading: the swim climbs about \
                     {CLIMB} m above its start; make sure there is more water than that above the robot\n"
                ));
            } else if health != Some(SensorHealth::Ok) {
                return Err(CtlError::Refused(format!(
                    "calibration swim: no depth reading (head sensor: {}) and the swim climbs \
                     about {CLIMB} m above its start (docs/calibration.md): wait for the sensor, \
                     or --min-depth 0 swims anyway",
                    sensor_name(nav.sensor)
                )));
            } else if depth < min_depth {
                return Err(CtlError::Refused(format!(
                    "calibration swim: the robot is {depth:.2} m deep and the swim climbs about \
                     {CLIMB} m above its start (docs/calibration.md): start it at least \
                     {min_depth} m deep (--min-depth 0 swims anyway)"
                )));
            } else {
                let _ = out(&format!(
                    "calibration swim: starting {depth:.2} m deep (it climbs about {CLIMB} m)\n"
                ));
            }
            let legs: Vec<(SwimParams, Duration)> = LEGS
                .iter()
                .map(|l| (l.gait, Duration::from_secs_f64(l.seconds)))
                .collect();
            let _ = out(&format!(
                "calibration swim: {} legs, {:.0} s\n",
                LEGS.len(),
                duration()
            ));
            let mut at = 0.0;
            c.swim_legs(
                &legs,
                &mut |i| {
                    let l = &LEGS[i];
                    let _ = out(&format!(
                        "{at:5.1} s  {} ({} s: amplitude {}, {} Hz, turn {:+}, pitch {:+})\n",
                        l.what,
                        l.seconds,
                        l.gait.amplitude,
                        l.gait.frequency,
                        l.gait.turn,
                        l.gait.pitch
                    ));
                    at += l.seconds;
                },
                &|| crate::signals::requested(),
            )?
        }
        CtlCmd::Follow {
            amplitude,
            speed,
            frequency,
            ..
        }
        | CtlCmd::Goto {
            amplitude,
            speed,
            frequency,
            ..
        } => {
            let (file, p) = path.expect("read above");
            let goto = file.as_os_str().is_empty();
            let amplitude = match speed {
                None => amplitude,
                Some(v) => {
                    let scale = c.state().nav.speed_scale;
                    let table = speeds.ok_or_else(|| {
                        CtlError::Refused("--speed: no speed table was made".into())
                    })?;
                    let (a, words) = amplitude_for_speed(&table, v, frequency, scale)?;
                    out(&format!("{words}\n"))?;
                    a
                }
            };
            let follow = anguilla_ipc::Follow {
                swim: SwimParams {
                    amplitude,
                    frequency,
                    turn: 0.0,
                    pitch: 0.0,
                },
                count: p.waypoints.len() as u32,
                looped: p.looped,
                from_here: goto,
                resume: false,
            };
            // In the estimate's frame, from the robot's pose now for a
            // path in the frame "here".
            let nav = &c.state().nav;
            let here = (nav.samples > 0).then(|| {
                (
                    f64::from(nav.x_m),
                    f64::from(nav.y_m),
                    f64::from(nav.heading_deg),
                )
            });
            let waypoints = p
                .placed(here)
                .map_err(|e| CtlError::Refused(format!("{}: {e}", file.display())))?;
            let r = c.follow(
                &waypoints,
                follow,
                &mut |s| {
                    let _ = out(&format!(
                        "{:6.1} s  {}\n",
                        s.time_ns as f64 * 1e-9,
                        ctl::guide_words(s)
                    ));
                },
                &|| crate::signals::requested(),
            );
            // A refusal naming a waypoint names its line in the file.
            match r {
                Err(CtlError::Refused(why)) if !goto => {
                    return Err(CtlError::Refused(match p.line_of(&why) {
                        Some(line) => format!("{}: line {line}: {why}", file.display()),
                        None => why,
                    }));
                }
                r => r?,
            }
        }
        CtlCmd::Swim {
            amplitude,
            frequency,
            turn,
            pitch,
            duration,
            ..
        } => {
            let p = SwimParams {
                amplitude,
                frequency,
                turn,
                pitch,
            };
            c.swim_holding(p, hold, duration.map(Duration::from_secs_f64), &|| {
                crate::signals::requested()
            })?
        }
    };
    out(&format!("done: {}\n", outcome.mode))
}

/// The speed table of `--speed v` at `frequency` (Hz): the steady speed
/// at each amplitude of the body the daemon's configuration (`--config`,
/// else the default: the built-in robot's) describes.
fn speed_table(
    daemon: &crate::teleop_cmd::DaemonArgs,
    v: f64,
    frequency: f64,
) -> Result<anguilla_model::SpeedTable, CtlError> {
    if !(v.is_finite() && v > 0.0) {
        return Err(CtlError::Refused(format!(
            "--speed {v} is invalid (expected metres a second through the water, > 0)"
        )));
    }
    if !(frequency.is_finite() && frequency > 0.0) {
        return Err(CtlError::Refused(format!(
            "--frequency {frequency} is invalid (expected Hz, > 0)"
        )));
    }
    let cfg = daemon.at.config().map_err(|e| {
        CtlError::Refused(format!("--speed needs the daemon's configuration: {e:#}"))
    })?;
    let speeds = anguilla_daemon::speed::steady_speeds(&cfg.daemon, frequency).map_err(|e| {
        CtlError::Refused(format!(
            "--speed: the model of this body does not swim: {e}"
        ))
    })?;
    Ok(anguilla_model::SpeedTable::new(speeds))
}

/// The amplitude that swims `v` m/s through the water at `frequency`:
/// the model's steady speed from `table`, divided by the factor the
/// daemon's estimate has learnt (`scale`, 1.04 when the body swims 4 %
/// faster than the model; ignored when not a sensible factor), and the
/// words that say so. Beyond the body's reach: refused.
fn amplitude_for_speed(
    table: &anguilla_model::SpeedTable,
    v: f64,
    frequency: f64,
    scale: f32,
) -> Result<(f64, String), CtlError> {
    let scale = f64::from(scale);
    let scale = if (0.5..=2.0).contains(&scale) {
        scale
    } else {
        1.0
    };
    let model = v / scale;
    let (a, reached) = table.amplitude_for(model);
    if !reached {
        return Err(CtlError::Refused(format!(
            "--speed {v} m/s is beyond this body at {frequency} Hz: its model swims {:.2} m/s at full amplitude{} (ask for less, or a higher --frequency)",
            table.max_speed() * scale,
            if scale == 1.0 {
                String::new()
            } else {
                format!(", times the learnt factor {scale:.3}")
            }
        )));
    }
    Ok((
        a,
        format!(
            "--speed {v} m/s: amplitude {a:.2} at {frequency} Hz (the model's steady speed {model:.2} m/s, times the learnt factor {scale:.3})"
        ),
    ))
}

/// The position's health in words, with the last fix's age.
fn position_words(n: &anguilla_ipc::NavSnapshot) -> String {
    let name = n
        .position_state()
        .map_or("unknown", anguilla_ipc::PositionHealth::name);
    match n.fix_age_s() {
        Some(age) => format!("{name}, last {age:.1} s ago"),
        None => name.to_string(),
    }
}

/// The human summary of `ctl status`.
fn summary(s: &StateSnapshot, who: Option<String>) -> String {
    let faults = FaultSet {
        kinds: s.fault_kinds,
        nodes: s.fault_nodes,
    };
    let holder = match (s.holder(), who) {
        (None, _) => "nobody".to_string(),
        (Some(_), Some(who)) => who,
        (Some(h), None) => format!("client {h:032x}"),
    };
    let l = &s.limits;
    let g = &s.gait_actual;
    let period = s.loop_stats.period_ns.max(1) as f64;
    let bus_state = anguilla_ipc::bus_state_name(s.bus.state);
    let n = &s.nav;
    let nav = if n.sensor == 0 {
        "no head sensor (heading and depth hold unavailable)".to_string()
    } else if n.samples == 0 {
        format!("sensor {}, no sample yet", sensor_name(n.sensor))
    } else {
        format!(
            "heading {:.1} deg, pitch {:+.1} deg, roll {:+.1} deg{}, depth {:.2} m ({:+.2} m/s, + down){}, x {:.2} m, y {:.2} m (+/- {:.2} m, {} fixes; {}), current {:+.3}, {:+.3} m/s (+/- {:.3}), model speed x{:.3}; sensor {}",
            n.heading_deg,
            n.pitch_deg,
            n.roll_deg,
            if n.roll_alarm != 0 {
                " (ROLL ALARM)"
            } else {
                ""
            },
            n.depth_m,
            n.depth_rate,
            if n.surfaced != 0 { " SURFACED" } else { "" },
            n.x_m,
            n.y_m,
            n.position_sigma_m,
            n.position_fixes,
            position_words(n),
            n.current_x,
            n.current_y,
            n.current_sigma,
            n.speed_scale,
            sensor_name(n.sensor)
        )
    };
    // The torque residual: the alarmed axes, or the largest residual.
    let alarms: Vec<String> = s
        .residual_alarms()
        .map(|(j, axis, r)| format!("joint {j} {axis} {r:+.2}"))
        .collect();
    let residual = if alarms.is_empty() {
        let n = (s.joint_count as usize).min(s.joints.len());
        let largest = s.joints[..n]
            .iter()
            .flat_map(|j| [j.pitch_torque_residual.abs(), j.yaw_torque_residual.abs()])
            .fold(0.0f32, f32::max);
        format!("no alarm (largest |residual| {largest:.2})")
    } else {
        format!("ALARM {}", alarms.join(", "))
    };
    // The path: its state, and where on it the robot is.
    let path = match s.guide.guide_state() {
        Some(anguilla_ipc::GuideState::Off) => "none".to_string(),
        Some(g) => format!("{g}: {}", ctl::guide_words(s)),
        None => format!("state {}", s.guide.state),
    };
    // Every sensor of the list, as its kind names its values.
    let mut sensors = String::new();
    for e in s.sensors.iter().filter(|e| e.kind != 0) {
        let kind = e
            .sensor_kind()
            .map_or_else(|| format!("kind {}", e.kind), |k| k.name().to_string());
        let values: Vec<String> = e
            .named_values()
            .map(|(name, unit, v)| format!("{name} {v:.2} {unit}"))
            .collect();
        sensors.push_str(&format!(
            "sensor    {kind} (node {}): {}, {} samples{}{}\n",
            e.id,
            sensor_name(e.health),
            e.samples,
            if values.is_empty() || e.samples == 0 {
                ""
            } else {
                "; "
            },
            if e.samples == 0 {
                String::new()
            } else {
                values.join(", ")
            }
        ));
    }
    format!(
        "mode      {} ({})\n\
         faults    {faults}\n\
         control   {holder}\n\
         gait      amplitude {:.2}, frequency {:.2} Hz, turn {:.2} /m, pitch {:.2} /m\n\
         head      {:.3} m/s, {:.3} rad/s (predicted)\n\
         nav       {nav}\n\
         {sensors}\
         autopilot {}\n\
         path      {path}\n\
         residual  {residual}\n\
         bus       {bus_state}; tx {}, rx {}, tx dropped {}, malformed {}\n\
         loop      {:.1} Hz; jitter p99 {:.0} us; overruns {}\n\
         refused   {} command(s); {} out-of-band e-stop(s); {} recording record(s) lost\n\
         limits    frequency <= {} Hz, |turn| <= {} /m, |pitch| <= {} /m, command timeout {} ms\n\
         daemon    pid {}\n",
        mode_name(s.mode),
        cause_words(s.cause),
        g.amplitude,
        g.frequency,
        g.turn,
        g.pitch,
        s.predicted_head_speed,
        s.predicted_turn_rate,
        autopilot_text(n),
        s.bus.tx_frames,
        s.bus.rx_frames,
        s.bus.tx_dropped,
        s.bus.malformed,
        1e9 / period,
        s.loop_stats.jitter_p99_ns as f64 / 1e3,
        s.loop_stats.overruns,
        s.refused_commands,
        s.socket_estops,
        s.records_lost,
        l.max_frequency,
        l.max_turn,
        l.max_pitch,
        l.command_timeout_ms,
        l.daemon_pid,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The amplitude of a speed: the model's steady speed divided by the
    /// learnt factor (ignored when it is not one: 0 without a head
    /// sensor), refused beyond full amplitude.
    #[test]
    fn a_speed_is_the_amplitude_whose_scaled_steady_speed_it_is() {
        let table = anguilla_model::SpeedTable::linear(0.6);
        let (a, words) = amplitude_for_speed(&table, 0.3, 1.0, 1.0).unwrap();
        assert!((a - 0.5).abs() < 1e-9, "{a}");
        assert!(words.contains("amplitude 0.50 at 1 Hz"), "{words}");
        // The body swims 20 % faster than its model: less amplitude.
        let (a, _) = amplitude_for_speed(&table, 0.3, 1.0, 1.2).unwrap();
        assert!((a - 0.25 / 0.6).abs() < 1e-6, "{a}");
        for nonsense in [0.0, f32::NAN, 10.0] {
            let (a, _) = amplitude_for_speed(&table, 0.3, 1.0, nonsense).unwrap();
            assert!((a - 0.5).abs() < 1e-9, "{nonsense}: {a}");
        }
        let Err(CtlError::Refused(why)) = amplitude_for_speed(&table, 0.7, 1.0, 1.0) else {
            panic!("0.7 m/s is beyond 0.6");
        };
        assert!(
            why.contains("beyond this body") && why.contains("0.60 m/s"),
            "{why}"
        );
    }
}
