//! `anguilla run` and `anguilla config`: parse, load, hand over to the daemon.

use crate::output::{out, outln};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use anguilla_daemon::config::{Config, default_toml};
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
    /// `mem:NAME`. Overrides `bus.spec`. Without one, the daemon runs
    /// against the built-in simulated robot; real hardware is only driven
    /// when a bus is named.
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
}

/// `anguilla config ...`.
#[derive(clap::Subcommand, Debug)]
pub enum ConfigCmd {
    /// Print the whole default configuration, commented.
    Default,
    /// Check a configuration file and say what is wrong with it.
    Check {
        /// The file.
        file: PathBuf,
    },
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

pub fn run(args: RunArgs) -> anyhow::Result<()> {
    init_logging();
    let mut cfg = match &args.config {
        Some(path) => Config::load(path)?,
        None => Config::default(),
    };
    if let Some(b) = &args.bus {
        cfg.bus.spec = b.clone();
    }
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
    crate::signals::install();
    let stop = Arc::new(AtomicBool::new(false));
    let (bus, sim) = if cfg.bus.spec.is_empty() {
        let sensor = cfg.fit_builtin_sensor();
        let relaxed = cfg.relax_for_builtin();
        if !relaxed.is_empty() {
            tracing::info!(
                "simulated robot: it shares this machine's CPU with the daemon, so the \
                 timeouts left at their defaults are relaxed: {} (a real bus keeps the strict defaults)",
                relaxed.join(", ")
            );
        }
        let (bus, sim) = anguilla::builtin_sim::start_builtin(&cfg, sim_body)?;
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
    let status =
        Client::new(&prefix, "anguilla-run-status").context("reading the daemon's state")?;
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

pub fn config(cmd: ConfigCmd) -> anyhow::Result<()> {
    match cmd {
        ConfigCmd::Default => {
            out!("{}", default_toml())
        }
        ConfigCmd::Check { file } => {
            let cfg = Config::load(&file)?;
            let tls = !cfg.link.ca.is_empty();
            for e in cfg
                .link
                .listen
                .iter()
                .filter(|e| *e != anguilla_link::LOCAL)
            {
                anguilla_link::Endpoint::parse_form(e, tls)
                    .and_then(|ep| ep.listenable(cfg.link.insecure_loopback))
                    .map_err(|e| anyhow::anyhow!("{}: link.listen: {e}", file.display()))?;
            }
            let period = anguilla_daemon::control::period_ns(&cfg);
            outln!(
                "{}: valid; {} joints, control rate {:.1} Hz, bus {}",
                file.display(),
                cfg.robot.joints,
                1e9 / period.as_nanos() as f64,
                if cfg.bus.spec.is_empty() {
                    "built-in simulated robot"
                } else {
                    &cfg.bus.spec
                }
            )
        }
    }
}

/// `anguilla replay`'s exit status for a recording that is cut short but
/// matches as far as it goes.
pub const REPLAY_TRUNCATED: i32 = 3;

/// Arguments of `anguilla replay`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Exit status: 0 identical, 1 a difference (or an unreadable recording), \
    3 a recording cut short (no end line) whose periods all match."
)]
pub struct ReplayArgs {
    /// A session directory written by `anguilla run` with `recording.dir` set.
    dir: PathBuf,
}

/// Arguments of `anguilla export`.
#[derive(clap::Args, Debug)]
pub struct ExportArgs {
    /// A session directory written by `anguilla run` with `recording.dir` set.
    dir: PathBuf,
    /// Write the MCAP file here (default: DIR/session.mcap; an existing
    /// file is replaced).
    #[arg(long, value_name = "FILE", num_args = 0..=1, default_missing_value = "")]
    mcap: Option<PathBuf>,
    /// Instead of writing the MCAP file from state.bin, make DIR's own
    /// session.mcap complete: a daemon killed mid-recording leaves it
    /// without summary and index, which indexed readers refuse. Every
    /// message readable before the cut is kept, on every channel.
    #[arg(long)]
    repair: bool,
    /// Write a rosbag2 MCAP for ROS 2 tools instead (DIR/session.ros2.mcap,
    /// or --mcap FILE): the topics of `anguilla link`'s ROS 2 node
    /// (`[link] ros2-*` of the session's configuration: namespace, rates),
    /// from state.bin (docs/ros2.md).
    #[arg(long, conflicts_with = "repair")]
    ros2: bool,
}

/// A progress bar on standard error for work of `total` steps, when it is
/// a terminal (none in pipes, logs and CI); `None` otherwise.
fn progress_bar(what: &str, total: u64) -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal as _;
    if !std::io::stderr().is_terminal() || total < 2 * anguilla_daemon::replay::PROGRESS_EVERY {
        return None;
    }
    let bar = indicatif::ProgressBar::new(total);
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "{what} [{{bar:40}}] {{pos}}/{{len}} {{msg}} ({{elapsed}}, {{eta}} left)"
        ))
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    Some(bar)
}

/// A progress callback that drives a bar made on the first report.
fn progress(what: &'static str) -> (impl FnMut(u64, u64), impl FnOnce()) {
    let bar: std::rc::Rc<std::cell::RefCell<Option<indicatif::ProgressBar>>> = Default::default();
    let (b, done) = (bar.clone(), bar);
    let mut made = false;
    let report = move |n: u64, total: u64| {
        if !made {
            made = true;
            *b.borrow_mut() = progress_bar(what, total);
        }
        if let Some(bar) = b.borrow().as_ref() {
            bar.set_position(n);
        }
    };
    let finish = move || {
        if let Some(bar) = done.borrow_mut().take() {
            bar.finish_and_clear();
        }
    };
    (report, finish)
}

pub fn export(args: ExportArgs) -> anyhow::Result<()> {
    if args.repair {
        return repair(args);
    }
    if args.ros2 {
        return export_ros2(args);
    }
    let out = match &args.mcap {
        Some(p) if !p.as_os_str().is_empty() => p.clone(),
        _ => args.dir.join("session.mcap"),
    };
    let (mut report, finish) = progress("exporting");
    let done = anguilla_daemon::mcap_log::export_with(&args.dir, &out, &mut report);
    finish();
    let done = done.with_context(|| format!("exporting {}", args.dir.display()))?;
    outln!(
        "{}: {} snapshots{}",
        out.display(),
        done.snapshots,
        if done.partial_bytes > 0 {
            format!(
                " ({} bytes at the end of state.bin were not a whole snapshot: the recording was cut short)",
                done.partial_bytes
            )
        } else {
            String::new()
        }
    )?;
    Ok(())
}

/// `export --ros2`: a rosbag2 MCAP of the ROS 2 node's topics.
fn export_ros2(args: ExportArgs) -> anyhow::Result<()> {
    use anguilla_link::ros2::{LATCHED, TOPICS, bag};
    let out = match &args.mcap {
        Some(p) if !p.as_os_str().is_empty() => p.clone(),
        _ => args.dir.join("session.ros2.mcap"),
    };
    // The session directory's name holds the recorder's start (Unix s):
    // docs/data.md "Time".
    let name = args.dir.file_name().and_then(|n| n.to_str()).unwrap_or("");
    let start_s: u64 = name
        .strip_prefix("session-")
        .and_then(|t| t.parse().ok())
        .with_context(|| {
            format!(
                "{}: expected a session directory named session-<Unix time>, as `anguilla run` \
                 writes (its name dates the recording)",
                args.dir.display()
            )
        })?;
    let cfg = anguilla_daemon::config::Config::load(&args.dir.join("config.toml"))
        .with_context(|| format!("exporting {}", args.dir.display()))?;
    let l = &cfg.link;
    let settings = bag::BagSettings {
        namespace: l.ros2_namespace.clone(),
        rates: TOPICS.map(|(n, _)| l.ros2_rates.get(n).copied().unwrap_or(l.ros2_rate)),
        start_ns: start_s.saturating_mul(1_000_000_000),
        geometry: anguilla_link::ros2::state::Geometry {
            segments: anguilla_daemon::mcap_log::segments(&cfg),
            limits: [cfg.limits.angle, cfg.limits.velocity, cfg.limits.torque],
        },
    };
    let mut bag =
        bag::Bag::create(&out, settings).with_context(|| format!("creating {}", out.display()))?;
    let (_, n, partial) =
        anguilla_daemon::mcap_log::for_each_state(&args.dir, |_, _, s| bag.write(s))
            .with_context(|| format!("exporting {}", args.dir.display()))?;
    let counts = bag
        .finish()
        .with_context(|| format!("writing {}", out.display()))?;
    outln!(
        "{}: rosbag2 MCAP from {n} snapshots: {}{}",
        out.display(),
        TOPICS
            .iter()
            .chain(&LATCHED)
            .zip(counts)
            .map(|((t, _), c)| format!("{t} {c}"))
            .collect::<Vec<_>>()
            .join(", "),
        if partial > 0 {
            format!(
                " ({partial} bytes at the end of state.bin were not a whole snapshot: the recording was cut short)"
            )
        } else {
            String::new()
        }
    )?;
    Ok(())
}

/// `export --repair`: DIR/session.mcap made complete, in place (through a
/// temporary file renamed over it), or written to `--mcap FILE`.
fn repair(args: ExportArgs) -> anyhow::Result<()> {
    let input = args.dir.join("session.mcap");
    let out = match &args.mcap {
        Some(p) if !p.as_os_str().is_empty() => p.clone(),
        _ => args.dir.join("session.mcap.repairing"),
    };
    let done = anguilla_daemon::mcap_log::repair(&input, &out)
        .with_context(|| format!("repairing {}", input.display()))?;
    let written = match &args.mcap {
        Some(p) if !p.as_os_str().is_empty() => out,
        _ => {
            std::fs::rename(&out, &input)
                .with_context(|| format!("replacing {} by {}", input.display(), out.display()))?;
            input
        }
    };
    outln!(
        "{}: {} messages on {} channels, with summary and index{}",
        written.display(),
        done.messages,
        done.channels,
        match &done.cut {
            Some(why) => format!(" (the recording was cut there: {why})"),
            None => " (the file was already whole)".to_string(),
        }
    )?;
    Ok(())
}

pub fn replay(args: ReplayArgs) -> anyhow::Result<()> {
    let (mut progress, finish) = progress("replaying");
    let report = anguilla_daemon::replay::replay_with(&args.dir, &mut progress);
    finish();
    let report = report.with_context(|| format!("replaying {}", args.dir.display()))?;
    match (&report.mismatch, report.truncated_at) {
        (None, None) => outln!(
            "{}: identical: {} periods, {} frames replayed bit for bit",
            args.dir.display(),
            report.periods,
            report.frames
        ),
        (None, Some(line)) => {
            outln!(
                "{}: truncated at line {line} (period {}): the {} periods before it match bit \
                 for bit ({} frames); the recording has no end (the daemon was killed, or the \
                 disk filled; `anguilla export DIR --repair` makes its session.mcap whole)",
                args.dir.display(),
                report.periods + 1,
                report.periods,
                report.frames
            )?;
            // Distinct from a mismatch (1): what there is matches.
            std::process::exit(REPLAY_TRUNCATED)
        }
        (Some((period, what)), _) => anyhow::bail!(
            "{}: differs at period {period} after {} identical frames: {what}",
            args.dir.display(),
            report.frames
        ),
    }
}
