//! The daemon's command line and entry, shared by `anguilla run` (the
//! developer's binary, every tool) and `anguillad` (the robot's service
//! binary: the daemon alone, no terminal UI, no network stack): parse,
//! load, hand over to the daemon, print status lines.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use anguilla_daemon::config::{BUS_BUILTIN, BUS_UNSET, Config};
use anguilla_daemon::run;
use anguilla_ipc::Client;
use anguilla_ipc::Mode;
use anyhow::Context;

/// Arguments of `anguilla run`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Signals: SIGINT, SIGTERM and SIGHUP each stop a swim smoothly (at most \
    3 s), disable the actuators and exit 0. There is no configuration reload: restart the daemon \
    to apply a new configuration. Status lines go to stdout; when it fails (a closed pipe, a full \
    disk) they stop and the daemon goes on."
)]
pub struct RunArgs {
    /// Configuration file (TOML); every key is optional (see `anguilla config default`).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Bus to drive, e.g. `socketcan:can0`, `slcan:/dev/ttyACM0@1000000`,
    /// `mem:NAME`, or `builtin` (the built-in simulated robot). Overrides
    /// `bus.spec`. Without one, the daemon runs against the built-in
    /// simulated robot; real hardware is only driven when a bus is named.
    #[arg(long, value_name = "SPEC")]
    bus: Option<String>,
    /// Stop (smoothly) after this many seconds.
    #[arg(long, value_name = "SECONDS")]
    duration: Option<f64>,
    /// No status line on stdout (logs still go to stderr).
    #[arg(long)]
    quiet: bool,
    /// The built-in simulated robot's own body (TOML: coefficients, drag
    /// law, density, ballast; docs/calibration.md) instead of the one
    /// `[model]` describes: a robot that is not the model.
    #[arg(long, value_name = "FILE")]
    sim_body: Option<PathBuf>,
    /// How deep the built-in simulated robot's nose starts (metres below
    /// the water's surface, > 0, at most `[autopilot] max-depth`; default
    /// 1). The calibration swim climbs up to about 3 m: start it 3.5 m deep or
    /// more (`ctl calibrate-swim`).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    sim_depth: Option<f64>,
    /// A fault scenario for the built-in simulated robot (a file of timed
    /// faults, seconds from the robot's start: node silences and reboots,
    /// joint snags and jams, bus faults, the water's current;
    /// sim-backend/README.md), e.g. `20 joint 7 yaw snag 0.5`. The
    /// recording's `/sim/truth` holds what the robot did.
    #[arg(long, value_name = "FILE")]
    scenario: Option<PathBuf>,
}

pub fn init_logging() {
    use std::io::IsTerminal;
    let filter = tracing_subscriber::EnvFilter::try_from_env("ANGUILLA_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    let terminal = std::io::stderr().is_terminal();
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(terminal)
        .with_target(false);
    // Under systemd, journald stamps every line itself.
    if terminal {
        builder.init();
    } else {
        builder.without_time().init();
    }
}

/// How often the simulated robot's ground truth is recorded (ns).
const TRUTH_PERIOD_NS: u64 = 50_000_000;

fn mode_name(m: u8) -> &'static str {
    Mode::from_code(m).map(Mode::name).unwrap_or("?")
}

/// A configuration the daemon cannot run: a file that does not load, or
/// a bus left unset. Its exit status is [`crate::EXIT_CONFIG`], which the
/// systemd unit does not restart on.
#[derive(Debug)]
pub struct Unrunnable(pub anyhow::Error);

impl std::fmt::Display for Unrunnable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&crate::output::error_text(&self.0))
    }
}

impl std::error::Error for Unrunnable {}

/// The daemon's configuration: the file (or the defaults), `--bus` over
/// it, `builtin` read as the built-in simulated robot, and a bus left
/// `unset` (the Debian package's file, until the operator names one)
/// refused.
pub fn load(args: &RunArgs) -> Result<Config, Unrunnable> {
    let mut cfg = match &args.config {
        Some(path) => Config::load(path).map_err(|e| Unrunnable(e.into()))?,
        None => Config::default(),
    };
    if let Some(b) = &args.bus {
        cfg.bus.spec = b.clone();
    }
    if cfg.bus.spec == BUS_BUILTIN {
        cfg.bus.spec.clear();
    }
    if cfg.bus.spec == BUS_UNSET {
        let file = args
            .config
            .as_ref()
            .map_or_else(|| "the configuration".into(), |p| p.display().to_string());
        return Err(Unrunnable(anyhow::anyhow!(
            "{file}: [bus] spec is \"{BUS_UNSET}\": the robot's bus is not set yet. Name it \
             (e.g. \"socketcan:can0\", or \"slcan:/dev/serial/by-id/<adapter>@1000000\"; every form in \
             drivers/README.md): `sudo anguilla config set-bus SPEC` writes it into {}, or \
             `--bus SPEC` for one run; `--bus {BUS_BUILTIN}` runs against the built-in simulated robot",
            anguilla_daemon::config::SYSTEM_FILE
        )));
    }
    Ok(cfg)
}

pub fn run(args: RunArgs) -> anyhow::Result<()> {
    init_logging();
    let mut cfg = load(&args)?;
    if let Some(d) = args.duration
        && !(d.is_finite() && d > 0.0)
    {
        anyhow::bail!("--duration {d} is invalid (expected a number of seconds > 0)");
    }
    let sim_body = match &args.sim_body {
        Some(_) if !cfg.bus.spec.is_empty() => {
            anyhow::bail!("--sim-body is for the built-in simulated robot; a bus was named")
        }
        Some(path) => Some(
            anguilla_daemon::config::BodyFile::load(path)
                .map_err(|e| anyhow::anyhow!("--sim-body {}: {e}", path.display()))?
                .body(),
        ),
        None => None,
    };
    let sim_depth = match args.sim_depth {
        Some(_) if !cfg.bus.spec.is_empty() => {
            anyhow::bail!("--sim-depth is for the built-in simulated robot; a bus was named")
        }
        Some(d) if !(d.is_finite() && d > 0.0 && d <= cfg.autopilot.max_depth) => anyhow::bail!(
            "--sim-depth {d} is invalid (expected metres below the surface, > 0 and at most \
             [autopilot] max-depth {})",
            cfg.autopilot.max_depth
        ),
        d => d,
    };
    let scenario = match &args.scenario {
        Some(_) if !cfg.bus.spec.is_empty() => anyhow::bail!(
            "--scenario is for the built-in simulated robot; a bus was named (a simulated robot \
             on a bus plays its own: `anguilla sim --bus SPEC --scenario FILE`)"
        ),
        Some(path) => Some(crate::builtin_sim::ScenarioFile {
            text: std::fs::read_to_string(path)
                .with_context(|| format!("--scenario {}: cannot read", path.display()))?,
            path: path.clone(),
        }),
        None => None,
    };
    // Root on the packaged layout runs the daemon as the service's user
    // (anguilla_ipc::service_user), before any thread starts.
    if let Some(note) =
        anguilla_ipc::service_user::adopt(anguilla_ipc::service_user::Keep::Realtime)?
    {
        tracing::info!("{note}");
    }
    crate::signals::install();
    // The loop below polls the stop flag, and the robot is driven while
    // this thread opens its state reader: a signal never ends it there.
    anguilla_ipc::guard::stop_is_polled();
    // Before any thread starts (the simulated robot's first).
    anguilla_daemon::rt::prepare(&run::rt_request(&cfg));
    let stop = Arc::new(AtomicBool::new(false));
    let (bus, sim) = if cfg.bus.spec.is_empty() {
        let anguilla_daemon::config::BuiltinFit { sensor, relaxed } = cfg.fit_builtin();
        if !relaxed.is_empty() {
            tracing::info!(
                "simulated robot: it shares this machine's CPU with the daemon, so the \
                 timeouts left at their defaults are relaxed: {} (a real bus keeps the strict defaults)",
                relaxed.join(", ")
            );
        }
        let (bus, sim) =
            crate::builtin_sim::start_builtin(&cfg, sim_body, sim_depth, scenario.as_ref())?;
        tracing::info!("no bus named: running against the built-in simulated robot");
        match (sensor, cfg.sensor.node) {
            (Some(id), _) => tracing::info!(
                "the simulated robot's head sensor is node {id} (heading and depth hold; \
                 [sensor] node chooses another id)"
            ),
            (None, 0) => tracing::info!(
                "the simulated robot has no head sensor ({} drives: heading and depth hold unavailable)",
                cfg.robot.drive
            ),
            (None, _) => {}
        }
        (bus, Some(sim))
    } else {
        let bus = anguilla_drivers::open(&cfg.bus.spec)
            .with_context(|| format!("opening bus '{}'", cfg.bus.spec))?;
        (bus, None)
    };
    let prefix = cfg.ipc.prefix.clone();
    let running = run::spawn(cfg, bus, stop.clone())?;
    let status = match Client::new(&prefix, "anguilla-run-status") {
        Ok(c) => c,
        Err(e) => {
            // The loop drives the robot already: stop it as a signal would
            // (a swim ramped down, the actuators disabled) before saying so.
            running.request_stop();
            let stopped = running.join();
            if let Some(sim) = sim {
                sim.stop();
            }
            let e = anyhow::Error::new(e).context("reading the daemon's state");
            return Err(match stopped {
                Ok(_) => e,
                Err(r) => e.context(format!("and stopping the control loop: {r}")),
            });
        }
    };
    let start = Instant::now();
    let mut last_print = Instant::now();
    let mut next_truth_ns = 0;
    // Status lines never touch the loop: a failing stdout only ends them.
    let mut out = crate::output::Status::default();
    let mut signal_logged = false;
    while !running.is_finished() {
        if let Some(sig) = crate::signals::received()
            && !signal_logged
        {
            signal_logged = true;
            tracing::info!(
                "{} received: stopping (a swim ramps down, the actuators are disabled, the \
                 recording is finished)",
                crate::signals::name(sig)
            );
        }
        if crate::signals::requested()
            || args
                .duration
                .is_some_and(|d| start.elapsed().as_secs_f64() >= d)
        {
            running.request_stop();
        }
        let state = status.wait_state(Duration::from_millis(100)).ok().flatten();
        // The simulated robot's truth beside the estimate, 20 times a
        // second, stamped with the state just published.
        if let (Some(s), Some(sim), Some(tx)) = (&state, &sim, running.ground_truth())
            && s.time_ns >= next_truth_ns
        {
            next_truth_ns = s.time_ns + TRUTH_PERIOD_NS;
            let _ = tx.try_send((s.time_ns, sim.ground_truth()));
        }
        if let Some(s) = state
            && !args.quiet
            && last_print.elapsed() >= Duration::from_secs(1)
        {
            last_print = Instant::now();
            let truth = sim.as_ref().map(|s| s.truth_line()).unwrap_or_default();
            out.line(format_args!(
                "t={:7.1}s mode={:<8} predicted speed {:+.3} m/s turn {:+.3} rad/s | loop {:.0} Hz jitter p99 {:.0} µs compute p99 {:.0} µs overruns {} | bus tx {} rx {} malformed {}{}{}{}",
                s.time_ns as f64 * 1e-9,
                mode_name(s.mode),
                s.predicted_head_speed + 0.0, // no "-0.000" at rest
                s.predicted_turn_rate + 0.0,
                1e9 / s.loop_stats.period_ns.max(1) as f64,
                s.loop_stats.jitter_p99_ns as f64 / 1e3,
                s.loop_stats.compute_p99_ns as f64 / 1e3,
                s.loop_stats.overruns,
                s.bus.tx_frames,
                s.bus.rx_frames,
                s.bus.malformed,
                if s.bus.state >= 2 {
                    format!(
                        " | BUS {}",
                        anguilla_ipc::bus_state_name(s.bus.state).to_uppercase()
                    )
                } else {
                    String::new()
                },
                if s.records_lost > 0 {
                    format!(" | RECORDING LOST {} records", s.records_lost)
                } else {
                    String::new()
                },
                truth,
            ));
        }
    }
    let report = running.join()?;
    if let Some(sim) = sim {
        sim.stop();
    }
    out.line(format_args!(
        "stopped in mode {}: {} periods, {} overruns (latest wake-up {:.0} µs, longest period {:.0} µs), last second's jitter p50/p99/max {:.0}/{:.0}/{:.0} µs, compute p99 {:.0} µs",
        report.final_mode,
        report.periods,
        report.overruns,
        report.worst_late_ns as f64 / 1e3,
        report.worst_compute_ns as f64 / 1e3,
        report.jitter.p50 as f64 / 1e3,
        report.jitter.p99 as f64 / 1e3,
        report.jitter.max as f64 / 1e3,
        report.compute.p99 as f64 / 1e3,
    ));
    if report.records_dropped > 0 {
        out.line(format_args!(
            "the recording lost {} records (the recorder fell behind or failed; replay says where it ends)",
            report.records_dropped
        ));
    }
    if report.states_dropped > 0 {
        out.line(format_args!(
            "the state thread fell behind: {} snapshots were not published (newer ones were)",
            report.states_dropped
        ));
    }
    Ok(())
}
