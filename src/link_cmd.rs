//! `anguilla link`: remote operation over Zenoh (docs/remote.md). Its own
//! process on the tether computer, an operator tool of the daemon like any
//! other (iceoryx2), bridging the daemon's state, commands and E-stop to
//! Zenoh (`anguilla_link::bridge`), so the real-time daemon never runs a
//! network stack. `anguilla link certs` makes the robot's small CA.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anguilla_link::{Bridge, Endpoint, LinkSettings, Tls};
use anyhow::Context as _;

use crate::teleop_cmd::PrefixArgs;

/// Arguments of `anguilla link`.
#[derive(clap::Args, Debug)]
#[command(
    args_conflicts_with_subcommands = true,
    after_help = "Operators reach the daemon with `anguilla teleop|joy|monitor|ctl --connect \
    ENDPOINT` (and --ca/--cert/--key for tls/). By default the link listens on 'local', a Unix \
    socket in /tmp/anguilla/PREFIX/link/ that only the link's user and the members of its group \
    reach (tools: --connect local). Any other address needs tls/ with mutual authentication; \
    plain tcp/ is accepted on loopback only, with --insecure-loopback. docs/remote.md has the \
    setup for a robot and two laptops."
)]
pub struct LinkArgs {
    #[command(subcommand)]
    cmd: Option<LinkCmd>,
    #[command(flatten)]
    at: PrefixArgs,
    /// Listen on this Zenoh endpoint (repeatable; overrides `[link] listen`):
    /// local (the default: the prefix's Unix socket, operators only),
    /// tls/0.0.0.0:7447, tcp/127.0.0.1:7447 (with --insecure-loopback).
    #[arg(long, value_name = "ENDPOINT")]
    listen: Vec<String>,
    /// Accept plain tcp/ on loopback, which every local user can reach
    /// (overrides `[link] insecure-loopback`).
    #[arg(long)]
    insecure_loopback: bool,
    /// The robot's CA certificate (PEM; overrides `[link] ca`).
    #[arg(long, value_name = "FILE")]
    ca: Option<PathBuf>,
    /// The robot's certificate (PEM; overrides `[link] cert`).
    #[arg(long, value_name = "FILE")]
    cert: Option<PathBuf>,
    /// The robot's private key (PEM; overrides `[link] key`).
    #[arg(long, value_name = "FILE")]
    key: Option<PathBuf>,
    /// Most states a second on the link (overrides `[link] state-rate`).
    #[arg(long, value_name = "HZ")]
    state_rate: Option<f64>,
    /// Stop after this many seconds (default: until Ctrl-C).
    #[arg(long, value_name = "SECONDS")]
    duration: Option<f64>,
}

/// `anguilla link` subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum LinkCmd {
    /// Make the robot's CA, the robot's certificate and one certificate per
    /// operator in DIR (never overwriting a file).
    Certs {
        /// Where to write them.
        dir: PathBuf,
        /// A name or address operators use to reach the robot (repeatable):
        /// robot.local, 192.168.1.10.
        #[arg(long = "robot-name", value_name = "NAME", required = true)]
        robot_names: Vec<String>,
        /// An operator to make a certificate for (repeatable).
        #[arg(long = "operator", value_name = "NAME")]
        operators: Vec<String>,
    },
}

/// Runs `anguilla link`.
pub fn run(args: LinkArgs) -> anyhow::Result<()> {
    if let Some(LinkCmd::Certs {
        dir,
        robot_names,
        operators,
    }) = &args.cmd
    {
        let made = anguilla_link::certs::make(dir, robot_names, operators)?;
        for f in &made.files {
            crate::output::write_fmt(format_args!("{}\n", f.display()))?;
        }
        return Ok(());
    }
    // The link's own lines (sessions opened and closed, refusals, a lost
    // client) and the connections Zenoh refused; before, nothing installed
    // a logger here and they went nowhere.
    init_link_logging();
    let whole = args.at.config()?;
    let prefix = args.at.prefix()?;
    let (cfg, l) = (&whole.daemon, &whole.link);
    let pick = |flag: &Option<PathBuf>, key: &str| {
        flag.clone()
            .or_else(|| (!key.is_empty()).then(|| PathBuf::from(key)))
    };
    let tls = match (
        pick(&args.ca, &l.ca),
        pick(&args.cert, &l.cert),
        pick(&args.key, &l.key),
    ) {
        (Some(ca), Some(cert), Some(key)) => Some(Tls { ca, cert, key }),
        (None, None, None) => None,
        _ => anyhow::bail!(
            "the CA, the certificate and the key go together (--ca, --cert, --key or [link] ca, \
             cert, key): give all three for TLS"
        ),
    };
    let texts = if args.listen.is_empty() {
        l.listen.clone()
    } else {
        args.listen.clone()
    };
    let listen = texts
        .iter()
        .map(|t| Endpoint::parse_at(t, &prefix, tls.as_ref()))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| anyhow::anyhow!("--listen {e}"))?;
    let insecure_loopback = args.insecure_loopback || l.insecure_loopback;
    for e in listen.iter().filter(|e| e.insecure()) {
        e.listenable(insecure_loopback)
            .map_err(|e| anyhow::anyhow!("--listen {e}"))?;
        eprintln!(
            "anguilla link: WARNING: listening on {} without authentication \
             (insecure-loopback): every local user can drive the robot",
            e.text
        );
    }
    if listen.iter().any(|e| e.unix) {
        // The socket Zenoh makes must be the group's (the directory, 0770,
        // keeps everyone else out).
        // SAFETY: umask has no preconditions.
        unsafe { libc::umask(0o007) };
    }
    if listen.contains(&Endpoint::local(&prefix)?) {
        anguilla_link::prepare_local(&prefix).map_err(|e| anyhow::anyhow!("--listen {e}"))?;
    }
    let kinds: Vec<&str> = listen
        .iter()
        .map(|e| match (e.tls, e.unix) {
            (true, _) => "TLS, mutual authentication",
            (false, true) => "Unix socket, the link's user and group only",
            (false, false) => "plain TCP on loopback, INSECURE",
        })
        .collect();
    let state_rate = args.state_rate.unwrap_or(l.state_rate);
    anyhow::ensure!(
        state_rate.is_finite() && (0.1..=1000.0).contains(&state_rate),
        "--state-rate {state_rate} is invalid (expected 0.1 ..= 1000 states a second)"
    );
    if let Some(d) = args.duration {
        anyhow::ensure!(
            d.is_finite() && d > 0.0,
            "--duration {d} is invalid (expected seconds > 0)"
        );
    }
    // cmd_vel's speeds become amplitudes through the model's steady speed
    // at the frequency it swims (once, here; nothing to compute per twist)
    let speeds = if l.ros2 {
        anguilla_daemon::speed::steady_speeds(cfg, l.ros2_frequency).with_context(|| {
            "the model's steady speeds, for ROS 2 cmd_vel ([model] and [gait] of the configuration)"
        })?
    } else {
        [0.0; anguilla_daemon::speed::N]
    };
    // Checked with the configuration: a udp: [sensor.usbl] source.
    let pose_to = (l.ros2 && l.ros2_pose)
        .then(|| whole.pose_fix_target())
        .transpose()?;
    let settings = LinkSettings {
        prefix: prefix.clone(),
        listen,
        tls,
        state_rate,
        max_clients: l.max_clients as usize,
        idle_timeout: Duration::from_secs_f64(l.idle_timeout),
        allow_command: l.inbound.iter().any(|n| n == "command"),
        allow_estop: l.inbound.iter().any(|n| n == "estop"),
        publish_state: l.outbound.iter().any(|n| n == "state"),
        ros2: l.ros2.then(|| anguilla_link::ros2::node::Ros2Settings {
            domain: l.ros2_domain,
            namespace: l.ros2_namespace.clone(),
            node: l.ros2_node.clone(),
            rates: anguilla_link::ros2::TOPICS
                .map(|(n, _)| l.ros2_rates.get(n).copied().unwrap_or(l.ros2_rate)),
            humble: l.ros2_distro == "humble",
            geometry: anguilla_link::ros2::state::Geometry {
                segments: anguilla_view::segments(cfg.robot.joints),
                limits: [cfg.limits.angle, cfg.limits.velocity, cfg.limits.torque],
            },
            allow_command: l.inbound.iter().any(|n| n == "command"),
            allow_estop: l.inbound.iter().any(|n| n == "estop"),
            speeds: anguilla_link::ros2::node::SpeedTable::new(speeds),
            max_speed: l.ros2_max_speed,
            frequency: l.ros2_frequency.min(cfg.gait.max_frequency),
            pose: pose_to.map(|to| anguilla_link::ros2::node::PoseSettings {
                to,
                frame: l.ros2_pose_frame.clone(),
                sigma: l.ros2_pose_sigma,
            }),
        }),
    };
    crate::signals::install();
    let start = Instant::now();
    let running = crate::signals::running_for(args.duration);
    // The link may start before the daemon.
    let mut bridge = crate::signals::open_when_up(
        "anguilla link",
        &running,
        || Bridge::open(settings.clone()),
        |e| matches!(e, anguilla_link::LinkError::Ipc(_)),
    )
    .with_context(|| format!("starting the link for prefix '{prefix}'"))?;
    eprintln!(
        "anguilla link: prefix '{prefix}' on {} ({}; state at most {state_rate} Hz; \
         inbound {:?}, outbound {:?})",
        settings
            .listen
            .iter()
            .map(|e| e.text.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        kinds.join("; "),
        l.inbound,
        l.outbound,
    );
    if let Some(n) = bridge.ros2() {
        let id = n.id();
        eprintln!(
            "anguilla link: ROS 2 node {}/{} on domain {} ({}; rmw_zenoh's wire; docs/ros2.md); \
             cmd_vel swims its linear.x through the model's steady speed at {} Hz, up to {:.3} m/s \
             (full amplitude{})",
            id.namespace.trim_end_matches('/'),
            id.name,
            id.domain,
            l.ros2_distro,
            n.settings().frequency,
            n.settings().speeds.max_speed().min(l.ros2_max_speed),
            if l.ros2_max_speed < n.settings().speeds.max_speed() {
                format!(
                    " swims {:.3} m/s; [link] ros2-max-speed caps it",
                    n.settings().speeds.max_speed()
                )
            } else {
                String::new()
            }
        );
        if let Some(p) = &n.settings().pose {
            eprintln!(
                "anguilla link: ROS 2 position fixes: pose_fix and odom_fix in frame {:?} go to                  the daemon's [sensor.usbl] at {}, aged by their stamps",
                p.frame, p.to
            );
        }
    }
    bridge.run(&|| !running())?;
    let st = bridge.stats();
    use std::sync::atomic::Ordering::Relaxed;
    let secs = start.elapsed().as_secs_f64().max(1e-9);
    eprintln!(
        "anguilla link: stopped after {secs:.1} s: {} states ({:.0} payload bytes/s), {} commands \
         forwarded, {} rejected, {} e-stops relayed",
        st.states.load(Relaxed),
        st.state_bytes.load(Relaxed) as f64 / secs,
        st.commands.load(Relaxed),
        st.rejected.load(Relaxed),
        st.estops.load(Relaxed),
    );
    if let Some(n) = bridge.ros2() {
        eprintln!(
            "anguilla link: ROS 2: {} messages published, {} twists sent as swims, {} superseded \
             by a newer one (latest wins, one swim per control period), {} dropped, {} not CDR, \
             {} beyond reach (clamped)",
            n.published,
            n.twists,
            n.superseded(),
            n.dropped,
            n.undecodable(),
            n.clamped,
        );
        if let Some(p) = n.pose_stats() {
            eprintln!(
                "anguilla link: ROS 2 position fixes: {} sent to the daemon, {} superseded by a                  newer one, {} refused, {} stale (older than 60 s), {} stamped ahead of this                  clock, {} failed to send",
                p.sent, p.superseded, p.refused, p.stale, p.ahead, p.failed
            );
        }
    }
    Ok(())
}

/// The link's log on stderr: its own lines at `ANGUILLA_LOG` (default
/// `info`), and Zenoh's warnings and errors through [`Refusals`] instead
/// of Zenoh's own words.
fn init_link_logging() {
    use std::io::IsTerminal;
    use tracing_subscriber::Layer as _;
    use tracing_subscriber::layer::SubscriberExt as _;
    use tracing_subscriber::util::SubscriberInitExt as _;
    let filter = tracing_subscriber::EnvFilter::try_from_env("ANGUILLA_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info,zenoh=off"));
    let terminal = std::io::stderr().is_terminal();
    let fmt = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_ansi(terminal)
        .with_target(false);
    // Under systemd, journald stamps every line itself.
    let fmt = if terminal {
        fmt.with_filter(filter).boxed()
    } else {
        fmt.without_time().with_filter(filter).boxed()
    };
    let refusals = Refusals::default().with_filter(tracing_subscriber::filter::filter_fn(|m| {
        m.target().starts_with("zenoh") && *m.level() <= tracing::Level::WARN
    }));
    let _ = tracing_subscriber::registry()
        .with(fmt)
        .with(refusals)
        .try_init();
}

/// Zenoh's warnings, told once: a TLS connection it refused (a client
/// certificate not signed by the robot's CA, none at all) says so in the
/// operator's words, without Zenoh's hint about open file limits that
/// follows every failed accept; the same line again within [`Refusals::EVERY`]
/// is counted instead of printed.
#[derive(Default)]
struct Refusals {
    last: std::sync::Mutex<Option<(String, std::time::Instant, u64)>>,
}

impl Refusals {
    const EVERY: std::time::Duration = std::time::Duration::from_secs(5);
}

/// Zenoh's message for an event.
#[derive(Default)]
struct Message(String);

impl tracing::field::Visit for Message {
    fn record_str(&mut self, field: &tracing::field::Field, value: &str) {
        if field.name() == "message" {
            self.0 = value.to_string();
        }
    }

    fn record_debug(&mut self, field: &tracing::field::Field, value: &dyn std::fmt::Debug) {
        if field.name() == "message" {
            self.0 = format!("{value:?}");
        }
    }
}

/// A Zenoh warning in the operator's words.
fn refusal_text(zenoh: &str) -> String {
    let text = zenoh
        .split(". Hint:")
        .next()
        .unwrap_or(zenoh)
        .trim()
        .to_string();
    if let Some(why) = text.strip_prefix("invalid peer certificate: ") {
        format!(
            "refused a TLS connection: the client's certificate is not valid for this robot \
             ({why}: not signed by its CA, or expired)"
        )
    } else if text.contains("peer sent no certificates") {
        "refused a TLS connection: the client sent no certificate (--cert and --key)".into()
    } else {
        format!("zenoh: {text}")
    }
}

impl<S: tracing::Subscriber> tracing_subscriber::Layer<S> for Refusals {
    fn on_event(&self, event: &tracing::Event<'_>, _: tracing_subscriber::layer::Context<'_, S>) {
        let mut m = Message::default();
        event.record(&mut m);
        let line = refusal_text(&m.0);
        let Ok(mut last) = self.last.lock() else {
            return;
        };
        match last.as_mut() {
            Some((l, at, n)) if *l == line && at.elapsed() < Self::EVERY => *n += 1,
            _ => {
                let again = match last.take() {
                    Some((_, _, n)) if n > 0 => format!(" (the line before came {n} more times)"),
                    _ => String::new(),
                };
                eprintln!("anguilla link: {line}{again}");
                *last = Some((line, std::time::Instant::now(), 0));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::refusal_text;

    #[test]
    fn zenoh_refusals_read_as_what_happened() {
        assert_eq!(
            refusal_text(
                "invalid peer certificate: BadSignature. Hint: increase the system open file limit."
            ),
            "refused a TLS connection: the client's certificate is not valid for this robot \
             (BadSignature: not signed by its CA, or expired)"
        );
        assert!(refusal_text("peer sent no certificates").contains("sent no certificate"));
        assert_eq!(refusal_text("something else"), "zenoh: something else");
    }
}
