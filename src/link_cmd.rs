//! `anguilla link`: remote operation over Zenoh (docs/remote.md). Its own
//! process on the tether computer, an operator tool of the daemon like any
//! other (iceoryx2), bridging the daemon's state, commands and E-stop to
//! Zenoh (`anguilla_link::bridge`), so the real-time daemon never runs a
//! network stack. `anguilla link certs` makes the robot's small CA. The
//! run is [`anguilla_link::run`]'s; here are its options, what it asks of
//! the process ([`Host`]: the daemon's configuration, the signals), the
//! log and the closing counts.

use std::path::PathBuf;

use anguilla_link::run::{Host, Robot, RunOptions};
use anguilla_link::{Bridge, LinkError};

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
    let cfg = &whole.daemon;
    let opts = RunOptions {
        prefix,
        config: whole.link.clone(),
        listen: args.listen,
        insecure_loopback: args.insecure_loopback,
        ca: args.ca,
        cert: args.cert,
        key: args.key,
        state_rate: args.state_rate,
        duration: args.duration,
        robot: Robot {
            joints: cfg.robot.joints,
            limits: [cfg.limits.angle, cfg.limits.velocity, cfg.limits.torque],
            max_frequency: cfg.gait.max_frequency,
        },
    };
    let r = anguilla_link::run::run(&opts, &Process { whole: &whole })?;
    let secs = r.seconds.max(1e-9);
    eprintln!(
        "anguilla link: stopped after {secs:.1} s: {} states ({:.0} payload bytes/s), {} commands \
         forwarded, {} rejected, {} e-stops relayed",
        r.states,
        r.state_bytes as f64 / secs,
        r.commands,
        r.rejected,
        r.estops,
    );
    if let Some(n) = &r.ros2 {
        eprintln!(
            "anguilla link: ROS 2: {} messages published, {} twists sent as swims, {} superseded \
             by a newer one (latest wins, one swim per control period), {} dropped, {} not CDR, \
             {} beyond reach (clamped)",
            n.published, n.twists, n.superseded, n.dropped, n.undecodable, n.clamped,
        );
        if let Some(p) = &n.pose {
            eprintln!(
                "anguilla link: ROS 2 position fixes: {} sent to the daemon, {} superseded by a \
                 newer one, {} refused, {} stale (older than 60 s), {} stamped ahead of this \
                 clock, {} failed to send",
                p.sent, p.superseded, p.refused, p.stale, p.ahead, p.failed
            );
        }
    }
    Ok(())
}

/// What the link asks of this process: the daemon's configuration's
/// steady speeds and position fixes' target, the stop signals, the wait
/// for the daemon.
struct Process<'a> {
    whole: &'a anguilla::config::Config,
}

impl Host for Process<'_> {
    fn steady_speeds(&self, frequency: f64) -> Result<[f64; anguilla_daemon::speed::N], String> {
        anguilla_daemon::speed::steady_speeds(&self.whole.daemon, frequency)
            .map_err(|e| crate::output::error_text(&anyhow::Error::new(e)))
    }

    fn pose_fix_target(&self) -> Result<std::net::SocketAddr, String> {
        self.whole
            .pose_fix_target()
            .map_err(|e| crate::output::error_text(&anyhow::Error::new(e)))
    }

    fn running(&self, duration: Option<f64>) -> Box<dyn Fn() -> bool> {
        crate::signals::install();
        Box::new(crate::signals::running_for(duration))
    }

    fn open_when_up(
        &self,
        running: &dyn Fn() -> bool,
        open: &mut dyn FnMut() -> Result<Bridge, LinkError>,
    ) -> Result<Bridge, LinkError> {
        crate::signals::open_when_up("anguilla link", running, open, |e| {
            matches!(e, LinkError::Ipc(_))
        })
    }
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
