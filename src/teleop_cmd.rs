//! `anguilla teleop`, `anguilla joy` and `anguilla monitor`: terminal and
//! device plumbing around the `anguilla-teleop` library.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anguilla::config::Config;
use anguilla_ipc::{Client, Session};
use anguilla_link::{Endpoint, Tls};
use anguilla_teleop::app::{Action, Intent, Limits};
use anguilla_teleop::joy::{Joy, JoyMapping};
use anguilla_teleop::keys;
use anguilla_teleop::operator::{Driver, Operator, QUIT_TIMEOUT};
use anguilla_teleop::pad::{EvdevPads, JoyNotice, JoySession};
use anguilla_teleop::session::{JsonPacer, MonitorSession, Paced, TeleopSession};
use anguilla_teleop::view;
use anyhow::Context;
use crossterm::event::{self, Event};

/// Which daemon on this computer: its configuration or its prefix.
#[derive(clap::Args, Debug)]
pub struct PrefixArgs {
    /// The daemon's configuration file: its `ipc.prefix` is used (the
    /// limits come from the daemon's state).
    #[arg(long, value_name = "FILE")]
    pub(crate) config: Option<PathBuf>,
    /// The daemon's iceoryx2 service prefix (overrides the configuration's;
    /// with --connect to a link but `local`, default: the one it serves).
    #[arg(long, value_name = "PREFIX")]
    prefix: Option<String>,
}

impl PrefixArgs {
    /// The configuration: --config's file (the whole file, so a tool that
    /// reads `[link]` or `[foxglove]` has them checked), else the default.
    pub fn config(&self) -> anyhow::Result<Config> {
        Ok(match &self.config {
            Some(p) => Config::load(p)?,
            None => Config::default(),
        })
    }

    /// The prefix: --prefix, else the configuration's, else the default.
    pub fn prefix(&self) -> anyhow::Result<String> {
        if let Some(p) = &self.prefix {
            anyhow::ensure!(
                anguilla_ipc::valid_prefix(p),
                "--prefix '{p}' is not valid (expected letters, digits, '-', '_' and '/')"
            );
            return Ok(p.clone());
        }
        Ok(self.config()?.daemon.ipc.prefix)
    }
}

/// Where to find the daemon (shared by the operator tools): on this
/// computer, or through a link with --connect.
#[derive(clap::Args, Debug)]
pub struct DaemonArgs {
    #[command(flatten)]
    pub(crate) at: PrefixArgs,
    /// Reach the daemon through its `anguilla link`, at this Zenoh
    /// endpoint: local (the link's Unix socket on this computer, for the
    /// link's user and group), tls/HOST:PORT with --ca, --cert and --key
    /// (another computer), or tcp/127.0.0.1:7447 (an insecure-loopback link).
    #[arg(long, value_name = "ENDPOINT")]
    connect: Option<String>,
    /// With --connect tls/...: the robot's CA certificate (PEM).
    #[arg(long, value_name = "FILE", requires = "connect")]
    ca: Option<PathBuf>,
    /// With --connect tls/...: this operator's certificate (PEM), from the robot's CA.
    #[arg(long, value_name = "FILE", requires = "connect")]
    cert: Option<PathBuf>,
    /// With --connect tls/...: this operator's private key (PEM).
    #[arg(long, value_name = "FILE", requires = "connect")]
    key: Option<PathBuf>,
    /// The prefix the link said it serves, once asked.
    #[arg(skip)]
    served: std::sync::OnceLock<String>,
}

impl DaemonArgs {
    /// The prefix: --prefix if given; else, with --connect to a link (but
    /// `local`, the configured prefix's own socket), the prefix that link
    /// says it serves; else the configuration's (see
    /// [`PrefixArgs::prefix`]).
    pub fn prefix(&self) -> anyhow::Result<String> {
        if self.at.prefix.is_some() || self.connect.is_none() {
            return self.at.prefix();
        }
        if let Some(p) = self.served.get() {
            return Ok(p.clone());
        }
        let configured = self.at.prefix()?;
        // `local` is the configured prefix's socket: nothing to ask (nor
        // to fail on while no link listens yet: `ctl --connect local
        // wait` waits for it).
        if self.connect.as_deref() == Some("local") {
            return Ok(configured);
        }
        let Some((endpoint, tls)) = self.remote()?.filter(|(e, _)| e.text != "local") else {
            return Ok(configured);
        };
        // A link that cannot be reached now is reported by the connection
        // itself (a viewer retries); the configured prefix stands until then.
        let Ok(Some(served)) = ask_prefix(&endpoint, tls.as_ref()) else {
            return Ok(configured);
        };
        if !anguilla_ipc::valid_prefix(&served) {
            return Ok(configured);
        }
        Ok(self.served.get_or_init(|| served).clone())
    }

    /// The link to reach, with --connect: its checked endpoint and TLS files.
    pub fn remote(&self) -> anyhow::Result<Option<(Endpoint, Option<Tls>)>> {
        let Some(e) = &self.connect else {
            return Ok(None);
        };
        if !cfg!(feature = "remote") {
            anyhow::bail!("--connect {e}: {NOT_REMOTE}");
        }
        let tls = match (&self.ca, &self.cert, &self.key) {
            (Some(ca), Some(cert), Some(key)) => Some(Tls {
                ca: ca.clone(),
                cert: cert.clone(),
                key: key.clone(),
            }),
            (None, None, None) => None,
            _ => anyhow::bail!("--ca, --cert and --key go together (TLS): give all three"),
        };
        let endpoint = Endpoint::parse_at(e, &self.at.prefix()?, tls.as_ref())
            .map_err(|e| anyhow::anyhow!("--connect {e}"))?;
        if endpoint.unix
            && let Some(why) = anguilla_link::local_access(&endpoint)
        {
            anyhow::bail!("--connect {}: {why}", endpoint.text);
        }
        Ok(Some((endpoint, tls)))
    }

    /// Where the tool reaches the daemon, for messages.
    pub fn describe(&self, prefix: &str) -> String {
        match &self.connect {
            Some(e) => format!("the daemon at prefix '{prefix}' through the link at {e}"),
            None => format!("the daemon at prefix '{prefix}'"),
        }
    }

    /// Opens a session with the daemon at `prefix`: local (iceoryx2,
    /// naming the node after `tool`), or through the link with --connect.
    /// `commands`: the tool sends commands (a remote session asks the link
    /// for its own client); a read-only tool only reads the state.
    pub fn open(
        &self,
        prefix: &str,
        tool: &str,
        commands: bool,
    ) -> anyhow::Result<Box<dyn Session>> {
        let s: Box<dyn Session> = match self.remote()? {
            None => match Client::new(prefix, &format!("{tool}-{}", std::process::id())) {
                Ok(c) => Box::new(c),
                // Only when the daemon's files are another user's
                // (`Foreign`): a daemon that is not running is not looked
                // for through a link.
                Err(direct @ anguilla_ipc::IpcError::Foreign(_)) => match local_link(prefix) {
                    // Not the daemon's user (its iceoryx2 files are its own),
                    // but the prefix's local link admits this user: its
                    // group's members use every tool without sudo or flags.
                    Some(endpoint) => {
                        let s =
                            remote_session(prefix, &endpoint, None, commands).map_err(|link| {
                                anyhow::anyhow!(
                                    "over iceoryx2: {direct}; through the local link at {}: {link}",
                                    endpoint.text
                                )
                            })?;
                        eprintln!(
                            "{tool}: through the local link ({}): the daemon's iceoryx2 files \
                             are closed to this user",
                            endpoint.text
                        );
                        s
                    }
                    None => return Err(direct.into()),
                },
                Err(direct) => return Err(direct.into()),
            },
            Some((endpoint, tls)) => remote_session(prefix, &endpoint, tls.as_ref(), commands)?,
        };
        Ok(s)
    }

    /// [`DaemonArgs::open`] as an [`Operator`].
    pub fn operator(&self, prefix: &str, tool: &str, commands: bool) -> anyhow::Result<Operator> {
        self.open(prefix, tool, commands)
            .map(Operator::over)
            .with_context(|| format!("connecting to {}", self.describe(prefix)))
    }
}

/// The local link of `prefix` when this build has remote operation and a
/// link listens there that admits this user (its user, or a member of its
/// group): where a tool without `--connect` goes when iceoryx2 is closed to
/// it.
fn local_link(prefix: &str) -> Option<Endpoint> {
    if !cfg!(feature = "remote") {
        return None;
    }
    let endpoint = Endpoint::local(prefix).ok()?;
    anguilla_link::local_access(&endpoint)
        .is_none()
        .then_some(endpoint)
}

/// Why `--connect` and `anguilla link` fail in a build without them.
pub const NOT_REMOTE: &str = "this anguilla was built without remote operation (Zenoh): build \
     it with `--features remote` (or `--all-features`, everything: cargo install --locked --path \
     . --all-features)";

/// A session through the link at `endpoint` (the `remote` feature).
#[cfg(feature = "remote")]
pub fn remote_session(
    prefix: &str,
    endpoint: &Endpoint,
    tls: Option<&Tls>,
    commands: bool,
) -> Result<Box<dyn Session>, anguilla_ipc::IpcError> {
    Ok(Box::new(anguilla_link::RemoteClient::connect(
        prefix, endpoint, tls, commands,
    )?))
}

/// Without the `remote` feature: [`NOT_REMOTE`].
#[cfg(not(feature = "remote"))]
pub fn remote_session(
    _prefix: &str,
    endpoint: &Endpoint,
    _tls: Option<&Tls>,
    _commands: bool,
) -> Result<Box<dyn Session>, anguilla_ipc::IpcError> {
    Err(anguilla_ipc::IpcError::Remote(format!(
        "--connect {}: {NOT_REMOTE}",
        endpoint.text
    )))
}

/// The prefix the link at `endpoint` serves (the `remote` feature).
#[cfg(feature = "remote")]
fn ask_prefix(
    endpoint: &Endpoint,
    tls: Option<&Tls>,
) -> Result<Option<String>, anguilla_ipc::IpcError> {
    anguilla_link::ask_prefix(endpoint, tls)
}

/// Without the `remote` feature there is no link to ask.
#[cfg(not(feature = "remote"))]
fn ask_prefix(
    _endpoint: &Endpoint,
    _tls: Option<&Tls>,
) -> Result<Option<String>, anguilla_ipc::IpcError> {
    Ok(None)
}

/// An E-stop on the link's E-stop key at `endpoint` (the `remote` feature).
#[cfg(feature = "remote")]
pub fn remote_estop(prefix: &str, endpoint: &Endpoint, tls: Option<&Tls>) -> Result<(), String> {
    anguilla_link::remote_estop(prefix, endpoint, tls).map_err(|e| e.to_string())
}

/// Without the `remote` feature: [`NOT_REMOTE`].
#[cfg(not(feature = "remote"))]
pub fn remote_estop(_prefix: &str, endpoint: &Endpoint, _tls: Option<&Tls>) -> Result<(), String> {
    Err(format!("--connect {}: {NOT_REMOTE}", endpoint.text))
}

/// How long a tool waits for the daemon's first state.
const FIRST_STATE: Duration = Duration::from_secs(2);

/// The daemon's limits, from its first state; warns on stderr when that
/// state does not come from the process serving the commands.
fn daemon_limits(op: &mut Operator, prefix: &str) -> anyhow::Result<Limits> {
    let s = op
        .wait_state(FIRST_STATE)?
        .copied()
        .with_context(|| format!("no state from the daemon at prefix '{prefix}' within 2 s"))?;
    if let Some(p) = op.provenance_problem() {
        eprintln!("warning: {p}");
    }
    Ok(Limits::from_snapshot(&s.limits))
}

/// Arguments of `anguilla teleop`.
#[derive(clap::Args, Debug)]
pub struct TeleopArgs {
    #[command(flatten)]
    daemon: DaemonArgs,
    /// A path (JSON, docs/path.schema.json) the `f` key follows, pauses
    /// and resumes (docs/autopilot.md, "Following a path").
    #[arg(long, value_name = "FILE")]
    path: Option<PathBuf>,
}

/// Arguments of `anguilla joy`.
#[derive(clap::Args, Debug)]
pub struct JoyArgs {
    #[command(flatten)]
    daemon: DaemonArgs,
    /// Gamepad mapping (TOML; see --print-mapping for the keys and defaults).
    #[arg(long, value_name = "FILE")]
    mapping: Option<PathBuf>,
    /// Print the default mapping and exit.
    #[arg(long)]
    print_mapping: bool,
    /// Use this event device (e.g. /dev/input/event5) instead of the first gamepad found.
    #[arg(long, value_name = "PATH")]
    device: Option<PathBuf>,
}

/// Arguments of `anguilla monitor`.
#[derive(clap::Args, Debug)]
pub struct MonitorArgs {
    #[command(flatten)]
    daemon: DaemonArgs,
    /// Stream the state as JSON lines on stdout instead of the terminal view.
    #[arg(long)]
    json: bool,
    /// With --json: at most this many lines per second (default: every state received).
    #[arg(long, value_name = "HZ")]
    rate: Option<f64>,
    /// With --json: stop after this many lines.
    #[arg(long, value_name = "N")]
    count: Option<u64>,
    /// Joint plotted (1 = nearest the head; default: the tail-most).
    #[arg(long, value_name = "N")]
    joint: Option<usize>,
    /// Seconds of history in the plots.
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0)]
    window: f64,
}

/// An error of a wait that a signal interrupted is the signal, not a failure.
fn interrupted<T>(r: Result<T, anguilla_ipc::IpcError>) -> anyhow::Result<Option<T>> {
    match r {
        Ok(v) => Ok(Some(v)),
        Err(_) if crate::signals::requested() => Ok(None),
        Err(e) => Err(e.into()),
    }
}

fn need_terminal(tool: &str, hint: &str) -> anyhow::Result<()> {
    if !(std::io::stdin().is_terminal() && std::io::stdout().is_terminal()) {
        anyhow::bail!("{tool} needs a terminal, and stdin or stdout is not one; {hint}");
    }
    Ok(())
}

/// `anguilla teleop`.
pub fn teleop(args: TeleopArgs) -> anyhow::Result<()> {
    // A bad path file is refused before anything is opened.
    let path = match &args.path {
        Some(file) => {
            let text = std::fs::read_to_string(file)
                .map_err(|e| anyhow::anyhow!("reading the path file {}: {e}", file.display()))?;
            Some(
                anguilla_teleop::path::PathFile::parse(&text)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?,
            )
        }
        None => None,
    };
    need_terminal(
        "anguilla teleop",
        "run it in a terminal (for scripts, `anguilla monitor --json` streams the state)",
    )?;
    let prefix = args.daemon.prefix()?;
    let mut op = args.daemon.operator(&prefix, "anguilla-teleop", true)?;
    let limits = daemon_limits(&mut op, &prefix)?;
    let mut driver = Driver::new(op, Intent::new(limits));
    driver.path = path;
    let mut session = TeleopSession::new(driver, &prefix);
    // SIGTERM (and SIGINT outside raw mode) ends the loop like `q`.
    crate::signals::install();
    let mut terminal = ratatui::init();
    let result = teleop_loop(&mut terminal, &mut session);
    // Whatever happened, stop the swim and release control before leaving.
    let quit = session.driver.quit(QUIT_TIMEOUT);
    ratatui::restore();
    result?;
    quit.context("stopping and releasing control on quit")?;
    Ok(())
}

fn teleop_loop(
    terminal: &mut ratatui::DefaultTerminal,
    session: &mut TeleopSession,
) -> anyhow::Result<()> {
    while !crate::signals::requested() {
        let next = session.pump(Instant::now())?;
        terminal.draw(|f| view::render(f, &session.view()))?;
        let wait = next
            .saturating_duration_since(Instant::now())
            .min(Duration::from_millis(50));
        if event::poll(wait)? {
            while {
                if let Event::Key(k) = event::read()?
                    && let Some(a) = keys::action_for(k)
                {
                    if a == Action::Quit {
                        return Ok(());
                    }
                    session.act(a)?;
                }
                event::poll(Duration::ZERO)?
            } {}
        }
    }
    Ok(())
}

/// `anguilla monitor`.
pub fn monitor(args: MonitorArgs) -> anyhow::Result<()> {
    let prefix = args.daemon.prefix()?;
    if let Some(r) = args.rate
        && !(r.is_finite() && r > 0.0)
    {
        anyhow::bail!("--rate {r} is invalid (expected lines per second > 0)");
    }
    if !(args.window.is_finite() && args.window > 0.0) {
        anyhow::bail!("--window {} is invalid (expected seconds > 0)", args.window);
    }
    if !args.json {
        need_terminal(
            "anguilla monitor",
            "use `anguilla monitor --json` to stream the state as JSON lines",
        )?;
    }
    // Read-only: this connection never sends a command.
    let mut op = args.daemon.operator(&prefix, "anguilla-monitor", false)?;
    if let Some(p) = op.provenance_problem() {
        eprintln!("warning: {p}");
    }
    if args.json {
        return monitor_json(&mut op, &args, &prefix);
    }
    let joint = args.joint.map(|j| j.saturating_sub(1));
    let mut session = MonitorSession::new(op, &prefix, args.window, joint);
    crate::signals::install();
    let mut terminal = ratatui::init();
    let result = (|| -> anyhow::Result<()> {
        let mut last_draw = Instant::now() - Duration::from_secs(1);
        while !crate::signals::requested() {
            if interrupted(session.poll(Duration::from_millis(20)))?.is_none() {
                return Ok(());
            }
            if last_draw.elapsed() >= Duration::from_millis(50) {
                last_draw = Instant::now();
                terminal.draw(|f| view::render(f, &session.view()))?;
            }
            while event::poll(Duration::ZERO)? {
                if let Event::Key(k) = event::read()?
                    && keys::action_for(k) == Some(Action::Quit)
                {
                    return Ok(());
                }
            }
        }
        Ok(())
    })();
    ratatui::restore();
    result
}

fn monitor_json(op: &mut Operator, args: &MonitorArgs, prefix: &str) -> anyhow::Result<()> {
    crate::signals::install();
    let mut pacer = JsonPacer::new(prefix, args.rate, Instant::now());
    let mut lines = 0u64;
    while !crate::signals::requested() && args.count.is_none_or(|c| lines < c) {
        let Some(s) = interrupted(
            op.wait_state(Duration::from_millis(100))
                .map(|s| s.copied()),
        )?
        else {
            break;
        };
        match pacer.offer(s.as_ref(), Instant::now()) {
            Paced::Skip => {}
            Paced::Silent(w) => eprintln!("{w}"),
            Paced::Line(l) => {
                // A closed pipe (`| head`) ends the stream quietly (main sees
                // to it); any other failure is an error naming stdout.
                crate::output::write_fmt(format_args!("{l}\n"))?;
                lines += 1;
            }
        }
    }
    Ok(())
}

/// `anguilla joy`.
pub fn joy(args: JoyArgs) -> anyhow::Result<()> {
    let prefix = args.daemon.prefix()?;
    // The mapping is checked against the daemon's limits; printing it needs
    // no daemon (then the default configuration's limits apply).
    let mut op = if args.print_mapping {
        None
    } else {
        Some(args.daemon.operator(&prefix, "anguilla-joy", true)?)
    };
    let limits = match op.as_mut() {
        Some(op) => daemon_limits(op, &prefix)?,
        None => Limits::default(),
    };
    let mapping = match &args.mapping {
        Some(p) => {
            let text =
                std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            JoyMapping::from_toml(&text, limits).with_context(|| p.display().to_string())?
        }
        None => JoyMapping::default(),
    };
    if args.print_mapping {
        return crate::output::write_fmt(format_args!("{}", mapping.to_toml()));
    }
    let op = op.context("connected above")?;
    // After iceoryx2 is set up, so these handlers are the ones in place.
    crate::signals::install();
    eprintln!(
        "anguilla joy: daemon prefix '{prefix}'; hold {:?} to drive, {:?} is E-stop, \
         {:?} / {:?} toggle heading / depth hold (Ctrl-C quits)",
        mapping.deadman, mapping.estop, mapping.heading_hold, mapping.depth_hold
    );
    let pads = EvdevPads::new(args.device.clone(), mapping);
    let mut session = JoySession::new(op, Joy::new(mapping, limits), pads);
    while !crate::signals::requested() {
        let step = session.step(|n| match n {
            JoyNotice::Waiting(why) => eprintln!(
                "anguilla joy: no gamepad found ({why}); waiting for one to be plugged in"
            ),
            JoyNotice::Connected(name) => eprintln!("anguilla joy: using {name}"),
            JoyNotice::Disconnected { stop_sent } => eprintln!(
                "anguilla joy: the gamepad disappeared ({}); waiting for it",
                if stop_sent {
                    "one stop sent"
                } else {
                    "the deadman was up: nothing sent, the daemon's command timeout is the backstop"
                }
            ),
            JoyNotice::Mode(m) => eprintln!("anguilla joy: mode {}", view::mode_name(m)),
            JoyNotice::Autopilot(a) => eprintln!("anguilla joy: autopilot {a}"),
            JoyNotice::Refused(r) => {
                eprintln!("anguilla joy: '{}' refused: {}", r.name(), r.reason)
            }
        });
        if interrupted(step)?.is_none() {
            break;
        }
    }
    session
        .quit(QUIT_TIMEOUT)
        .context("stopping and releasing control on quit")?;
    Ok(())
}
