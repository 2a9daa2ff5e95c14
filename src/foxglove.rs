//! `anguilla foxglove`'s live view for Foxglove and Lichtblick (issue 17),
//! for the binary and for tests ([`run`]; the `foxglove` feature). Its own process, reading the daemon's state over iceoryx2 like any
//! operator tool (or through `anguilla link` with `--connect`), so the
//! real-time daemon never links a WebSocket stack. It serves the channels
//! of the session's MCAP file (`anguilla_view`) over the
//! Foxglove WebSocket protocol. Read-only unless `[foxglove] commands =
//! true`: then each Foxglove client that publishes on [`COMMAND_TOPIC`] is
//! its own operator session, under the daemon's authority and deadman
//! rules (`Operators`). The daemon is reached through [`Daemon`]: the
//! binary's `--prefix`, `--config` and `--connect`.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::mpsc::{Receiver, SyncSender};
use std::time::{Duration, Instant};

use anguilla_ipc::{Command, Session};
use anguilla_teleop::operator::Operator;
use foxglove::websocket::{Capability, Client, ClientChannel, ClientId, ServerListener};
use serde_json::json;

use anguilla_view::{Scene, TOPICS, schemas};
use anyhow::Context as _;

use crate::output::outln;

mod gate;

/// What the view serves (`anguilla foxglove`'s options).
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Listen on this ADDR:PORT.
    pub bind: String,
    /// At most this many states a second to the viewers.
    pub rate: f64,
    /// Stop after this many seconds (`None`: at a stop signal).
    pub duration: Option<f64>,
}

/// The daemon the view serves, as the command line names it.
pub trait Daemon {
    /// The whole configuration (its `[foxglove]` and the daemon's robot).
    fn config(&self) -> anyhow::Result<crate::config::Config>;
    /// The daemon's prefix.
    fn prefix(&self) -> anyhow::Result<String>;
    /// Whether the daemon is reached through a link (`--connect`): its
    /// E-stop then goes out of band through the link, not to the local
    /// E-stop socket.
    fn remote(&self) -> anyhow::Result<bool>;
    /// A session with the daemon at `prefix` as `tool` (`commands`: one
    /// that sends commands).
    fn open(&self, prefix: &str, tool: &str, commands: bool) -> anyhow::Result<Box<dyn Session>>;
    /// The view's own operator connection (its state).
    fn operator(&self, prefix: &str, tool: &str, commands: bool) -> anyhow::Result<Operator>;
}

/// What the view did, counted by its gate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Report {
    /// Viewers admitted.
    pub admitted: u64,
    /// Viewers refused at `[foxglove] max-clients`.
    pub refused: u64,
    /// Viewers closed for subscribing to nothing in time.
    pub idle_closed: u64,
}

/// Serves the view as `args` says of `daemon` until a stop signal or the
/// duration: the options are checked first, then the configuration read;
/// what the gate counted is returned once the server has stopped.
pub fn run(args: &Options, daemon: &dyn Daemon) -> anyhow::Result<Report> {
    let addr: SocketAddr = args.bind.parse().map_err(|_| {
        anyhow::anyhow!(
            "--bind {}: expected ADDR:PORT (e.g. 127.0.0.1:8765 or [::1]:8765)",
            args.bind
        )
    })?;
    anyhow::ensure!(
        args.rate.is_finite() && args.rate > 0.0,
        "--rate {} is invalid (expected states per second > 0)",
        args.rate
    );
    if let Some(d) = args.duration {
        anyhow::ensure!(
            d.is_finite() && d > 0.0,
            "--duration {d} is invalid (expected seconds > 0)"
        );
    }
    if !addr.ip().is_loopback() {
        eprintln!(
            "warning: --bind {addr}: not loopback; anyone who reaches this port sees the robot \
             (no authentication, no TLS)"
        );
    }
    let cfg = daemon.config()?;
    let prefix = daemon.prefix()?;
    let ctx = foxglove::Context::new();
    // The server listens on an ephemeral loopback port, behind the gate
    // (its connection limits: foxglove's server has none).
    let mut builder = foxglove::WebSocketServer::new()
        .name("anguilla")
        .bind("127.0.0.1", 0)
        .context(&ctx);
    let (tx, from_clients) = std::sync::mpsc::sync_channel(COMMAND_QUEUE);
    // Departures and E-stops never wait in the bounded queue.
    let (gone_tx, gone) = std::sync::mpsc::channel();
    let estop_wanted = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    if cfg.foxglove.commands {
        anyhow::ensure!(
            cfg.foxglove.insecure_commands,
            "[foxglove] commands = true: the Foxglove WebSocket protocol has no authentication, so \
             whoever reaches {addr} (on loopback: every local user) could drive the robot. Drive \
             with the operators' tools (teleop, joy, ctl; --connect local or tls/ through \
             `anguilla link`), or accept the risk with [foxglove] insecure-commands = true"
        );
        eprintln!(
            "anguilla foxglove: WARNING: commands accepted on {addr} without authentication \
             (insecure-commands): {}",
            if addr.ip().is_loopback() {
                "every local user may take control of the robot"
            } else {
                "anyone who reaches this port may take control of the robot"
            }
        );
        builder = builder
            .capabilities([Capability::ClientPublish])
            .supported_encodings(["json"])
            .listener(std::sync::Arc::new(Commands {
                tx,
                gone: std::sync::Mutex::new(gone_tx),
                estop_wanted: estop_wanted.clone(),
                estop_prefix: (!daemon.remote()?).then(|| prefix.clone()),
            }));
    }
    let server = builder
        .start_blocking()
        .context("starting the Foxglove server on loopback")?;
    let limits = gate::Limits {
        max_clients: cfg.foxglove.max_clients as usize,
        subscribe_timeout: (cfg.foxglove.subscribe_timeout > 0.0)
            .then(|| Duration::from_secs_f64(cfg.foxglove.subscribe_timeout)),
        read_timeout: (cfg.foxglove.read_timeout > 0.0)
            .then(|| Duration::from_secs_f64(cfg.foxglove.read_timeout)),
    };
    let inner = SocketAddr::from(([127, 0, 0, 1], server.port()));
    let gate =
        gate::Gate::start(addr, inner, limits).with_context(|| format!("serving on {addr}"))?;
    let mut channels = Vec::new();
    for (i, (name, data)) in schemas().into_iter().enumerate() {
        channels.push(
            ctx.channel_builder(TOPICS[i])
                .message_encoding("json")
                .schema(foxglove::Schema::new(name, "jsonschema", data))
                .build_raw()
                .with_context(|| format!("channel {}", TOPICS[i]))?,
        );
    }
    outln!(
        "anguilla foxglove: ws://{} serving the robot at prefix '{prefix}' (Ctrl-C stops)",
        SocketAddr::new(addr.ip(), gate.local_addr().port())
    )?;
    crate::signals::install();
    let running = crate::signals::running_for(args.duration);
    // The viewer may start before the daemon: it serves, and asks again.
    let mut op = crate::signals::open_when_up(
        "anguilla foxglove",
        &running,
        || daemon.operator(&prefix, "anguilla-foxglove", false),
        |_| true,
    )?;
    let replies = if cfg.foxglove.commands {
        Some(
            ctx.channel_builder(REPLY_TOPIC)
                .message_encoding("json")
                .schema(foxglove::Schema::new(
                    "anguilla.CommandReply",
                    "jsonschema",
                    serde_json::to_vec(&reply_schema())?,
                ))
                .build_raw()
                .with_context(|| format!("channel {REPLY_TOPIC}"))?,
        )
    } else {
        None
    };
    let mut operators = Operators {
        sessions: HashMap::new(),
        from_clients,
        gone,
        open: &|| daemon.open(&prefix, "anguilla-foxglove-client", true),
    };
    let mut scene = Scene::new(cfg.daemon.robot.joints);
    let every = Duration::from_secs_f64(1.0 / args.rate);
    let mut last = None::<Instant>;
    // With commands, a short wait: a command waits at most this long.
    let wait = Duration::from_millis(if replies.is_some() { 5 } else { 100 });
    while running() {
        if estop_wanted.swap(false, std::sync::atomic::Ordering::SeqCst) {
            // Through a link: its e-stop key, ahead of any queue.
            if let Err(e) = op.estop_out_of_band() {
                eprintln!("anguilla foxglove: e-stop: {e}");
            }
        }
        if let Some(r) = &replies {
            operators.pump(&mut |v| r.log(v.to_string().as_bytes()));
        }
        let Some(s) = op.wait_state(wait)?.copied() else {
            continue;
        };
        if last.is_some_and(|t| t.elapsed() < every) {
            continue;
        }
        last = Some(Instant::now());
        for (i, v) in scene.messages(&s) {
            channels[i].log(v.to_string().as_bytes());
        }
    }
    let c = gate.counts();
    let report = Report {
        admitted: c.admitted.load(std::sync::atomic::Ordering::SeqCst),
        refused: c.refused.load(std::sync::atomic::Ordering::SeqCst),
        idle_closed: c.idle_closed.load(std::sync::atomic::Ordering::SeqCst),
    };
    gate.stop();
    server.stop().wait_blocking();
    Ok(report)
}

/// The channel Foxglove clients publish operator commands on (JSON, see
/// `anguilla_teleop::json::command_from_json`), with `[foxglove] commands`.
pub const COMMAND_TOPIC: &str = "/anguilla/command";
/// Where each command's outcome is published: `{client, command,
/// accepted, reason}`.
pub const REPLY_TOPIC: &str = "/anguilla/command_reply";
/// Commands waiting for the main loop; beyond, a command is dropped (the
/// E-stop socket is written at once regardless).
const COMMAND_QUEUE: usize = 256;
/// Most Foxglove clients with an operator session at once.
const MAX_OPERATORS: usize = 8;

enum FromClient {
    Command(ClientId, Result<Command, String>),
}

/// The server's callbacks (on its own thread; they must not block): parse,
/// hand over, and write an E-stop to the daemon's socket at once.
struct Commands {
    tx: SyncSender<FromClient>,
    /// Clients that left (unbounded: one message per departure).
    gone: std::sync::Mutex<std::sync::mpsc::Sender<ClientId>>,
    /// An E-stop arrived and the daemon is reached through a link: the
    /// main loop sends it out of band at once.
    estop_wanted: std::sync::Arc<std::sync::atomic::AtomicBool>,
    /// The local daemon's prefix, for its E-stop socket (none through a link).
    estop_prefix: Option<String>,
}

impl ServerListener for Commands {
    fn on_message_data(&self, client: Client, channel: &ClientChannel, payload: &[u8]) {
        let parsed = if channel.topic == COMMAND_TOPIC {
            anguilla_teleop::json::command_from_json(payload)
        } else {
            Err(format!(
                "topic {} carries no commands (publish them on {COMMAND_TOPIC})",
                channel.topic
            ))
        };
        if let Ok(Command::EStop) = &parsed {
            match &self.estop_prefix {
                Some(p) => {
                    if let Err(e) = anguilla_ipc::estop::send(p) {
                        eprintln!("anguilla foxglove: e-stop socket: {e}");
                    }
                }
                None => self
                    .estop_wanted
                    .store(true, std::sync::atomic::Ordering::SeqCst),
            }
        }
        let _ = self.tx.try_send(FromClient::Command(client.id(), parsed));
    }

    fn on_client_unadvertise(&self, client: Client, channel: &ClientChannel) {
        if channel.topic == COMMAND_TOPIC
            && let Ok(g) = self.gone.lock()
        {
            let _ = g.send(client.id());
        }
    }
}

/// What [`REPLY_TOPIC`] says of one command; its schema is
/// [`reply_schema`].
fn reply(client: u32, command: &str, accepted: bool, reason: &str) -> serde_json::Value {
    json!({"client": client, "command": command, "accepted": accepted, "reason": reason})
}

/// The name [`reply`] gives a reply the session has no record of.
const UNNAMED: &str = "command";

/// [`REPLY_TOPIC`]'s JSON Schema (`anguilla.CommandReply`).
fn reply_schema() -> serde_json::Value {
    use anguilla_view::schema::{boolean, count, message, names, string};
    message(
        "anguilla.CommandReply",
        "The outcome of one command a Foxglove client published on /anguilla/command",
        vec![
            ("client", count("The Foxglove client's id on this server")),
            (
                "command",
                names(
                    &format!(
                        "The command's name; empty when the message was not a command, \
                         {UNNAMED} when the daemon answered one the view no longer tracks"
                    ),
                    Command::ALL.iter().map(Command::name).chain(["", UNNAMED]),
                ),
            ),
            ("accepted", boolean("True if the daemon accepted it")),
            ("reason", string("Why it was refused; empty when accepted")),
        ],
    )
}

/// The commands a session sent and awaits replies to: (sequence, name).
type Sent = Vec<(u32, &'static str)>;

/// One operator session per Foxglove client that publishes commands: each
/// is its own client for the daemon (its own authority; the deadman holds:
/// nothing is resent on its behalf), closed when it unadvertises or leaves.
struct Operators<'a> {
    sessions: HashMap<ClientId, (Box<dyn Session>, Sent)>,
    from_clients: Receiver<FromClient>,
    gone: Receiver<ClientId>,
    open: &'a dyn Fn() -> anyhow::Result<Box<dyn Session>>,
}

impl Operators<'_> {
    /// Forwards what arrived and publishes the outcomes with `publish`.
    fn pump(&mut self, publish: &mut dyn FnMut(serde_json::Value)) {
        while let Ok(id) = self.gone.try_recv() {
            self.sessions.remove(&id);
        }
        while let Ok(m) = self.from_clients.try_recv() {
            match m {
                FromClient::Command(id, Err(why)) => publish(reply(u32::from(id), "", false, &why)),
                FromClient::Command(id, Ok(cmd)) => {
                    if !self.sessions.contains_key(&id) {
                        if self.sessions.len() >= MAX_OPERATORS {
                            publish(reply(
                                u32::from(id),
                                cmd.name(),
                                false,
                                &format!("{MAX_OPERATORS} Foxglove clients operate already"),
                            ));
                            continue;
                        }
                        match (self.open)() {
                            Ok(s) => {
                                self.sessions.insert(id, (s, Vec::new()));
                            }
                            Err(e) => {
                                publish(reply(u32::from(id), cmd.name(), false, &format!("{e:#}")));
                                continue;
                            }
                        }
                    }
                    let Some((s, sent)) = self.sessions.get_mut(&id) else {
                        continue;
                    };
                    match s.send(cmd) {
                        Ok(seq) => {
                            if sent.len() >= 64 {
                                sent.remove(0);
                            }
                            sent.push((seq, cmd.name()));
                        }
                        Err(e) => publish(reply(u32::from(id), cmd.name(), false, &e.to_string())),
                    }
                }
            }
        }
        for (id, (s, sent)) in &mut self.sessions {
            let _ = s.replies(&mut |r| {
                let name = sent
                    .iter()
                    .position(|(q, _)| *q == r.sequence)
                    .map_or(UNNAMED, |i| sent.remove(i).1);
                publish(reply(u32::from(*id), name, r.accepted == 1, r.reason()));
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use anguilla_view::schema::{check, table};

    use super::*;

    /// Every reply the view can publish conforms to [`reply_schema`]: each
    /// command's, a message that was no command, an untracked reply.
    #[test]
    fn replies_conform_to_their_schema() {
        let schema = reply_schema();
        let id = 7;
        let names = Command::ALL.iter().map(Command::name).chain(["", UNNAMED]);
        for (i, name) in names.enumerate() {
            let r = reply(id, name, i % 2 == 0, "take control first");
            assert_eq!(check(&schema, &r), Ok(()), "{r}");
        }
        let e = check(&schema, &reply(id, "dance", false, "")).unwrap_err();
        assert!(e.starts_with("command: \"dance\" is not one of"), "{e}");
    }

    /// `docs/data.md` between `<!-- command_reply:begin -->` and its end
    /// is the reply's table (rewritten with ANGUILLA_BLESS=1).
    #[test]
    fn docs_data_md_has_the_reply_table() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/data.md");
        anguilla_testkit::generated_block(
            std::path::Path::new(path),
            "command_reply",
            &table(&reply_schema()),
        );
    }

    /// A daemon the view must not reach: the options are checked first.
    struct Unreached;

    impl Daemon for Unreached {
        fn config(&self) -> anyhow::Result<crate::config::Config> {
            panic!("read the configuration")
        }
        fn prefix(&self) -> anyhow::Result<String> {
            panic!("asked the prefix")
        }
        fn remote(&self) -> anyhow::Result<bool> {
            panic!("asked for a link")
        }
        fn open(&self, _: &str, _: &str, _: bool) -> anyhow::Result<Box<dyn Session>> {
            panic!("opened a session")
        }
        fn operator(&self, _: &str, _: &str, _: bool) -> anyhow::Result<Operator> {
            panic!("connected")
        }
    }

    /// [`run`] refuses a bind address that is none, a rate that is not a
    /// positive number and a duration that is not, each by its option's
    /// name, before it reads the configuration or reaches the daemon.
    #[test]
    fn run_refuses_bad_options_before_reaching_the_daemon() {
        let ok = Options {
            bind: "127.0.0.1:0".into(),
            rate: 30.0,
            duration: Some(1.0),
        };
        let refused = |o: Options| format!("{:#}", run(&o, &Unreached).unwrap_err());
        for rate in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(
                refused(Options { rate, ..ok.clone() }),
                format!("--rate {rate} is invalid (expected states per second > 0)")
            );
        }
        assert_eq!(
            refused(Options {
                bind: "localhost".into(),
                ..ok.clone()
            }),
            "--bind localhost: expected ADDR:PORT (e.g. 127.0.0.1:8765 or [::1]:8765)"
        );
        assert_eq!(
            refused(Options {
                duration: Some(0.0),
                ..ok
            }),
            "--duration 0 is invalid (expected seconds > 0)"
        );
    }
}
